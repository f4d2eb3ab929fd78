"""Closed-loop episodes on a plant, their records, and the benchmark table (SPEC §5).

:func:`run_episode` is one trial: a plant, a :class:`PushingController`, the task's start
and goal, up to N_max control steps at 0.04 s. It returns an :class:`Episode` with the
trajectory (for plots) and the per-trial record (for tables). :func:`run_condition` runs
the trials of one condition (task × shape × params × method), resumable from its file;
:func:`write_tables` turns all records into JSON, CSV and Markdown. Trials run one after
another (the batched, vmapped runner of issue 4 is not built yet).
"""

from __future__ import annotations

import csv
import json
import os
import time
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import jax.numpy as jnp
import numpy as np
from tqdm import tqdm

from dexpush.controller import ControllerSettings, PushingController
from dexpush.cost import collides
from dexpush.files import atomic_path, write_json_atomic
from dexpush.geometry import Shape
from dexpush.model import LAMBDA_TRUE, MODE_NAMES, Contour, contact_solution
from dexpush.plants import ModelPlant
from dexpush.tasks import MAX_STEPS, Task, get_task, initial_conditions, is_success, pose_error

__all__ = ["METHODS", "PARAMS", "SHAPES", "Episode", "EpisodeRecord", "make_shape", "run_condition", "run_episode",
           "summarize", "write_tables"]

#: λ_pred of the two parameter scenarios (paper Sec. IV-B)
PARAMS = {"known": LAMBDA_TRUE, "unknown": (15.0, 0.0, 0.0)}
_SHAPE_MAKERS = {"rect": Shape.rectangle, "tee": Shape.tee, "ellipse": Shape.ellipse}
SHAPES = tuple(_SHAPE_MAKERS)
METHODS = ("mppi", "mppi-ukf")
CONTROL_PERIOD = 0.04


def make_shape(name: str) -> Shape:
    """The standard shapes of SPEC §2.1 by name."""
    if name not in _SHAPE_MAKERS:
        raise ValueError(f"unknown shape {name!r}; choose one of {', '.join(SHAPES)}")
    return _SHAPE_MAKERS[name]()


@dataclass
class EpisodeRecord:
    """The per-trial record of SPEC §5 (JSON-friendly)."""

    task: str
    shape: str
    params: str
    method: str
    seed: int
    success: bool
    steps: int                    #: control steps taken (to success, or N_max)
    time_s: float                 #: simulated time (steps × 0.04 s)
    object_path_m: float
    pusher_path_m: float
    final_error_m: float
    final_error_deg: float
    collisions: int               #: control steps that ended in collision with an obstacle
    contact_switches: int         #: contact on/off transitions
    planning_ms_median: float
    planning_ms_max: float
    params_estimate: list[float] | None = None


@dataclass
class Episode:
    """A finished episode: its record plus the sampled trajectory."""

    record: EpisodeRecord
    states: np.ndarray            #: (T+1, 5) true states
    modes: np.ndarray             #: (T,) contact mode at the start of each control step
    commands: np.ndarray          #: (T, 2)
    planning_ms: np.ndarray       #: (T,)
    params: np.ndarray            #: (T, 3) λ_pred the controller planned with at each step
    goal: np.ndarray
    obstacles: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))

    def summary(self) -> dict:
        return asdict(self.record)


def _path_length(xy: np.ndarray) -> float:
    return float(np.sum(np.linalg.norm(np.diff(xy, axis=0), axis=-1)))


def run_episode(task: str | Task = "I", shape: str | Shape = "rect", params: str = "known",
                method: str = "mppi", seed: int = 0, max_steps: int = MAX_STEPS,
                settings: ControllerSettings | None = None, progress: bool = False) -> Episode:
    """Run one closed-loop trial on the model plant (SPEC §5) and record it."""
    task = get_task(task)
    shape_name = shape if isinstance(shape, str) else shape.name
    shape = make_shape(shape) if isinstance(shape, str) else shape
    if params not in PARAMS:
        raise ValueError(f"unknown params {params!r}; choose 'known' or 'unknown'")
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}; choose one of {', '.join(METHODS)}")
    if max_steps < 1:
        raise ValueError(f"max_steps must be >= 1, got {max_steps}")
    pose, pusher = initial_conditions(task, shape, seed)
    plant = ModelPlant(shape, params=LAMBDA_TRUE)
    obs = plant.reset(pose, pusher)
    settings = settings or ControllerSettings()
    settings = replace(settings, estimate_params=(method == "mppi-ukf"))
    ctrl = PushingController(shape, task.goal, params=PARAMS[params], obstacles=task.obstacles,
                             settings=settings, seed=seed)
    scene = ctrl.scene
    contour = Contour.of(shape)

    states, commands, plan_ms, lam = [obs.state], [], [], []
    success = bool(is_success(obs.object_pose, task.goal))
    bar = tqdm(total=max_steps, desc=f"task {task.key} {shape_name}", unit="step", disable=not progress,
               leave=False)
    while not success and len(commands) < max_steps:
        t0 = time.perf_counter()
        u = ctrl.command(obs.object_pose, obs.pusher_xy)
        plan_ms.append((time.perf_counter() - t0) * 1e3)
        lam.append(ctrl.params)
        obs = plant.step(u, CONTROL_PERIOD)
        commands.append(u)
        states.append(obs.state)
        success = bool(is_success(obs.object_pose, task.goal))
        bar.update(1)
    bar.close()

    X = np.asarray(states)
    U = np.asarray(commands).reshape(-1, 2)
    modes = np.asarray(contact_solution(contour, X[:-1], U, LAMBDA_TRUE).mode) if len(U) else np.zeros(0, int)
    in_contact = modes != MODE_NAMES.index("free")
    hits = np.asarray(collides(jnp.asarray(X[1:]), scene)) if len(U) else np.zeros(0, bool)
    pos_err, head_err = pose_error(X[-1, :3], task.goal)
    ms = np.asarray(plan_ms) if plan_ms else np.zeros(1)
    record = EpisodeRecord(
        task=task.key, shape=shape_name, params=params, method=method, seed=int(seed), success=success,
        steps=len(U), time_s=round(len(U) * CONTROL_PERIOD, 3),
        object_path_m=round(_path_length(X[:, :2]), 4), pusher_path_m=round(_path_length(X[:, 3:]), 4),
        final_error_m=round(float(pos_err), 5), final_error_deg=round(float(head_err), 3),
        collisions=int(np.sum(hits)), contact_switches=int(np.sum(in_contact[1:] != in_contact[:-1])),
        planning_ms_median=round(float(np.median(ms)), 3), planning_ms_max=round(float(np.max(ms)), 3),
        params_estimate=[round(float(v), 5) for v in ctrl.params] if method == "mppi-ukf" else None)
    return Episode(record, X, modes, U, ms, np.asarray(lam).reshape(-1, 3), np.asarray(task.goal),
                   np.asarray(task.obstacles).reshape(-1, 3))


# ---------------------------------------------------------------------------- the §5 table
CONDITION_KEYS = ("task", "shape", "params", "method")


def condition_name(task: str, shape: str, params: str, method: str) -> str:
    return f"{task}_{shape}_{params}_{method}"


def run_condition(path: str | os.PathLike, task: str, shape: str, params: str, method: str,
                  seeds: list[int], max_steps: int = MAX_STEPS, progress: bool = True) -> list[dict]:
    """Run the trials of one condition, resuming from ``path`` (one JSON file per condition).

    The file is rewritten atomically after every trial, so an interrupted run loses at most
    the trial in progress; trials already recorded for a seed are not run again.
    """
    path = Path(path)
    done: dict[int, dict] = {}
    if path.exists():
        try:
            done = {int(r["seed"]): r for r in json.loads(path.read_text())["trials"]}
        except (json.JSONDecodeError, KeyError, TypeError) as exc:
            raise ValueError(f"{path}: not a dexpush condition file ({exc}); delete it to start over") from exc
    todo = [s for s in seeds if s not in done]
    shape_obj = make_shape(shape)
    bar = tqdm(todo, desc=condition_name(task, shape, params, method), unit="trial", disable=not progress,
               leave=False)
    for seed in bar:
        ep = run_episode(task, shape_obj, params=params, method=method, seed=seed, max_steps=max_steps)
        done[seed] = ep.summary()
        write_json_atomic(path, {"trials": [done[s] for s in sorted(done)]})
    return [done[s] for s in seeds]


def summarize(trials: list[dict]) -> dict:
    """Per-condition numbers of SPEC §5 from its trial records."""
    ok = [t for t in trials if t["success"]]

    def mean_std(key: str) -> list[float] | None:
        v = np.array([t[key] for t in ok], float)
        return [round(float(v.mean()), 4), round(float(v.std()), 4)] if len(v) else None

    plan = np.array([t["planning_ms_median"] for t in trials], float)
    return {"trials": len(trials), "successes": len(ok),
            "success_rate": round(len(ok) / len(trials), 4) if trials else None,
            "object_path_m": mean_std("object_path_m"), "pusher_path_m": mean_std("pusher_path_m"),
            "time_to_goal_s": mean_std("time_s"),
            "planning_ms_median": round(float(np.median(plan)), 3) if len(plan) else None,
            "planning_ms_max": round(float(max(t["planning_ms_max"] for t in trials)), 3) if trials else None}


def write_tables(out: str | os.PathLike, records: list[dict], meta: dict) -> dict[str, str]:
    """benchmark.json (trials + per-condition summary), benchmark.csv and benchmark.md."""
    out = Path(out)
    groups: dict[tuple, list[dict]] = {}
    for r in records:
        groups.setdefault(tuple(r[k] for k in CONDITION_KEYS), []).append(r)
    summary = [dict(zip(CONDITION_KEYS, key)) | summarize(trials) for key, trials in groups.items()]
    files = {"json": str(out / "benchmark.json"), "csv": str(out / "benchmark.csv"),
             "markdown": str(out / "benchmark.md")}
    write_json_atomic(files["json"], {"meta": meta, "summary": summary, "trials": records})
    cols = list(records[0].keys()) if records else []
    with atomic_path(files["csv"]) as tmp, open(tmp, "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=cols)
        writer.writeheader()
        for r in records:
            writer.writerow({k: json.dumps(v) if isinstance(v, list) else v for k, v in r.items()})

    def fmt(ms: list[float] | None) -> str:
        return f"{ms[0]:.3f} ± {ms[1]:.3f}" if ms else "–"

    lines = [f"Produced by `{meta.get('command', '')}` on {meta.get('date', '')} ({meta.get('machine', '')}).", "",
             "| task | shape | params | method | SR | object TL (m) | pusher TL (m) | time to goal (s) "
             "| planning ms (median / max) |", "|---|---|---|---|---|---|---|---|---|"]
    for s in summary:
        lines.append(f"| {s['task']} | {s['shape']} | {s['params']} | {s['method']} | "
                     f"{s['successes']}/{s['trials']} ({100 * s['success_rate']:.0f} %) | {fmt(s['object_path_m'])} | "
                     f"{fmt(s['pusher_path_m'])} | {fmt(s['time_to_goal_s'])} | "
                     f"{s['planning_ms_median']:.1f} / {s['planning_ms_max']:.0f} |")
    for task in sorted({s["task"] for s in summary} & {"I", "II"}):
        for shape in sorted({s["shape"] for s in summary}):
            lines.append(f"| {task} | {shape} | – | gcs | not implemented | | | | |")
    with atomic_path(files["markdown"]) as tmp:
        tmp.write_text("\n".join(lines) + "\n")
    return files
