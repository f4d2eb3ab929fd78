"""A benchmark's results folder: its format and what it promises.

    out/settings.json                    the settings every record was made with (:func:`claim_folder`)
    out/conditions/<condition>.json      one record per trial, rewritten atomically as each trial ends
    out/trajectories/<condition>.npz     each trial's true states (seed_<s>), likewise
    out/figures/<condition>.png          every recorded trial's object path
    out/benchmark.{json,csv,md}          the tables (:mod:`dexpush.experiments.tables`)

A folder is resumable: a run into it with the same settings runs only the trials it lacks, and
one with other settings is refused with the differences named. A settings.json written by an
older dexpush, whose controller settings were one flat table, is read in today's groups."""

from __future__ import annotations

import importlib.metadata
import json
import os
import sys
import zipfile
from dataclasses import asdict
from pathlib import Path

import numpy as np

from dexpush.common.files import atomic_path, write_json_atomic
from dexpush.common.interfaces import Sensor
from dexpush.common.settings import upgrade_flat
from dexpush.control.controller import ControllerSettings
from dexpush.control.estimator import UKFSettings
from dexpush.experiments.methods import method_names
from dexpush.experiments.records import CONDITION_KEYS
from dexpush.experiments.registry import PARAMS, SHAPES
from dexpush.experiments.scenarios import Task
from dexpush.model.shape import Shape

__all__ = [
    "ABSENT_MEANS",
    "FLAT_DIAGNOSTICS",
    "claim_folder",
    "draw_condition",
    "folder_records",
    "load_condition",
    "load_trajectories",
    "run_settings",
    "saved_settings",
    "store_trajectory",
    "upgrade_record",
]


#: the fields a record of an older dexpush carried for what is now its method's ``diagnostics``
FLAT_DIAGNOSTICS = ("offline_plan_s", "replans", "rejected_frames", "estimator_resets", "estimator_updates",
                    "gated_windows", "stall_resets", "params_estimate")


def upgrade_record(record: dict) -> dict:
    """A record in today's layout: an older record's method fields moved into ``diagnostics`` (those it had)."""
    if "diagnostics" in record:
        return record
    out = {k: v for k, v in record.items() if k not in FLAT_DIAGNOSTICS}
    out["diagnostics"] = {k: record[k] for k in FLAT_DIAGNOSTICS if record.get(k) is not None}
    return out


def load_condition(path: Path) -> dict[int, dict]:
    """A condition file's records by seed, in today's layout ({} when there is none)."""
    if not path.exists():
        return {}
    try:
        return {int(r["seed"]): upgrade_record(r) for r in json.loads(path.read_text())["trials"]}
    except (json.JSONDecodeError, KeyError, TypeError) as exc:
        raise ValueError(f"{path}: not a dexpush condition file ({exc}); delete it to start over") from exc


def folder_records(out: str | os.PathLike) -> list[dict]:
    """Every trial recorded in ``out/conditions/``, in task, shape, params, method, seed order."""
    rank = {k: i for i, k in enumerate(("I", "II", "III", *SHAPES, *PARAMS, *method_names()))}
    records = [r for path in sorted(Path(out, "conditions").glob("*.json")) for r in load_condition(path).values()]
    return sorted(records, key=lambda r: (*(rank.get(r[k], len(rank)) for k in CONDITION_KEYS), r["seed"]))


def run_settings(plant: str, sensor: Sensor | None, settings: ControllerSettings | None, max_steps: int,
                 lanes: int) -> dict:
    """Everything besides the condition and the seed that decides a trial's outcome (JSON-friendly)."""
    sensor = sensor if sensor is not None and not sensor.perfect else None
    return json.loads(json.dumps({"plant": plant, "sensor": asdict(sensor) if sensor else "exact",
                                  "controller": asdict(settings or ControllerSettings()), "max_steps": int(max_steps),
                                  "lanes": int(lanes)}))


#: what a settings.json of an older dexpush lacks, read as the values its records were made with: each
#: of these options was off in the versions without it
ABSENT_MEANS = {"obstacles_under_start": False, "stall": {"after_s": None}, "endgame": {"temperature": None},
                "prediction_margin": {"gain": 0.0},
                "weights": {"detour": False, "C_margin": None, "guidance": False, "guidance_goal_heading": False},
                "mppi": {"update": "clipped", "spread_cap": None},
                "push_plan": {"enabled": False, "endgame": {"enabled": False}}}


def _with_defaults(saved: object, defaults: dict) -> object:
    """``saved`` with the keys it lacks filled in from ``defaults`` (recursively, dicts only)."""
    if not isinstance(saved, dict):
        return saved
    out = dict(saved)
    for k, v in defaults.items():
        if k not in out:
            out[k] = v
        elif isinstance(v, dict):
            out[k] = _with_defaults(out[k], v)
    return out


def _differences(a: object, b: object, prefix: str = "") -> list[str]:
    if isinstance(a, dict) and isinstance(b, dict):
        return [d for k in sorted(set(a) | set(b)) for d in _differences(a.get(k), b.get(k), f"{prefix}{k}.")]
    return [] if a == b else [f"{prefix.rstrip('.')}: {a!r} there, {b!r} now"]


def saved_settings(path: Path, defaults: dict) -> dict:
    """The run settings in ``path`` (a settings.json) in today's layout: the controller's old flat keys
    moved into their groups, keys it lacks at :data:`ABSENT_MEANS` and then ``defaults``."""
    try:
        saved = json.loads(path.read_text())
    except (OSError, json.JSONDecodeError) as exc:
        raise ValueError(f"{path}: not a dexpush settings file ({exc}); delete the folder to start over") from exc
    settings = saved.get("settings") if isinstance(saved, dict) else None
    if not isinstance(settings, dict) or not isinstance(settings.get("controller", {}), dict):
        raise ValueError(f"{path}: not a dexpush settings file (no settings table); delete the folder to start over")
    controller = upgrade_flat(ControllerSettings, settings.get("controller", {}), str(path), warn=False)
    if isinstance(controller.get("ukf"), dict):
        controller["ukf"] = upgrade_flat(UKFSettings, controller["ukf"], str(path), warn=False)
    settings = {**settings, "controller": _with_defaults(controller, ABSENT_MEANS)}
    return _with_defaults(settings, {"controller": defaults})


def claim_folder(out: Path, wanted: dict, progress: bool) -> None:
    """Record the settings in ``out/settings.json``, or refuse a folder whose records were made with others.

    A folder from before settings were recorded (records but no settings.json) is adopted as is.
    """
    path = out / "settings.json"
    try:
        version = importlib.metadata.version("dexpush")
    except importlib.metadata.PackageNotFoundError:  # pragma: no cover (running from a source tree)
        version = "unknown"
    if path.exists():
        defaults = run_settings(wanted["plant"], None, None, wanted["max_steps"], wanted["lanes"])["controller"]
        diff = _differences(saved_settings(path, defaults), wanted)
        if diff:
            raise ValueError(f"{out} holds results made with other settings ({'; '.join(diff[:3])}"
                             f"{'; …' if len(diff) > 3 else ''}); choose another --out, or delete it to start over")
        saved_version = json.loads(path.read_text()).get("version")
        if saved_version != version and progress:
            print(f"dexpush: note: {out} was started by dexpush {saved_version}, this is {version}", file=sys.stderr)
        return
    write_json_atomic(path, {"settings": wanted, "version": version})


def load_trajectories(path: Path) -> dict[int, np.ndarray]:
    """The trajectories in a condition's npz by seed ({} when there is none)."""
    if not path.exists():
        return {}
    try:
        with np.load(path) as data:
            return {int(k.split("_")[1]): data[k] for k in data.files}
    except (OSError, ValueError, EOFError, zipfile.BadZipFile, IndexError) as exc:
        raise ValueError(f"{path}: damaged ({exc}); delete it to go on (the trials' records stay, their "
                         "trajectories and figure are lost)") from exc


def store_trajectory(out: Path, name: str, seed: int, states: np.ndarray) -> None:
    """Add one trial's states to the condition's npz (rewritten atomically), as soon as it ends."""
    path = out / "trajectories" / f"{name}.npz"
    trajs = load_trajectories(path)
    trajs[seed] = states
    with atomic_path(path) as tmp, open(tmp, "wb") as fh:
        np.savez_compressed(fh, **{f"seed_{s}": trajs[s] for s in sorted(trajs)})


def draw_condition(out: Path, name: str, shape: Shape, task: Task, recs: dict[int, dict]) -> None:
    """The condition's figure: every recorded trial's object path."""
    import matplotlib.pyplot as plt

    from dexpush.viz import plot_condition, plot_layouts

    trajs = load_trajectories(out / "trajectories" / f"{name}.npz")
    if not trajs:
        return
    seeds = sorted(s for s in trajs if s in recs)
    ok = sum(recs[s]["success"] for s in seeds)
    first = recs[seeds[0]] if seeds else {}
    title = (f"{name.replace('_', ' · ')} · {first.get('plant', 'model')} plant · camera: "
             f"{first.get('sensor', 'exact')}: {ok}/{len(seeds)} successes")
    if task.varies_by_seed:
        fig = plot_layouts(shape, [(task.problem(shape, seed=s), trajs[s], recs[s]["success"]) for s in seeds],
                           title=title, path=out / "figures" / f"{name}.png")
    else:
        problem = task.problem(shape)
        fig = plot_condition(shape, [trajs[s] for s in seeds], [recs[s]["success"] for s in seeds],
                             np.asarray(problem.goal), np.asarray(problem.obstacles).reshape(-1, 3), title=title,
                             path=out / "figures" / f"{name}.png", polygons=problem.polygons,
                             workspace=problem.workspace, region=problem.region_rows)
    plt.close(fig)
