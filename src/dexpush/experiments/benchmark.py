"""The paper's benchmark (Sec. IV-B; docs/conventions.md#benchmark-tasks): every condition's trials,
resumably, and their figures.

:func:`run_benchmark` runs the trials of every condition (task × shape × params × method).
On the model plant with exact observations, the MPPI trials of all conditions of one task
and shape share one queue of lanes in the batched simulator
(:func:`dexpush.experiments.simulate.simulate`); everything else (the physics plant, a camera model,
the GCS baseline) runs trial by trial through :func:`dexpush.experiments.runner.run_loop`. Every
finished trial is saved at once in its condition's file, so an interrupted run resumes
where it stopped. :func:`dexpush.experiments.tables.write_tables` turns the records into JSON, CSV
and Markdown.

Re-running a trial: the outcome recorded for a seed is reproduced bit for bit by the same
command on any subset of seeds, or by ``dexpush run ... --seed S --lanes 16`` (the bench's
lane count; see :mod:`dexpush.experiments.simulate` for why the lane count matters).
"""

from __future__ import annotations

import importlib.metadata
import json
import os
import sys
import threading
import time
from collections.abc import Sequence
from dataclasses import asdict
from functools import partial
from pathlib import Path

import numpy as np

from dexpush.common.files import atomic_path, write_json_atomic
from dexpush.common.progress import progress_bar
from dexpush.control.controller import ControllerSettings
from dexpush.experiments.methods import get_method, method_names
from dexpush.experiments.records import CONDITION_KEYS, Condition, condition_name, make_episode
from dexpush.experiments.registry import PARAMS, PLANTS, SHAPES, check_condition, make_shape, world_sensor
from dexpush.experiments.runner import batched, run_trial, trial_spec
from dexpush.experiments.scenarios import MAX_STEPS, Task, get_task
from dexpush.experiments.simulate import TrialResult, TrialSpec, simulate
from dexpush.model.shape import Shape
from dexpush.world.sensing import SensorSettings

__all__ = ["BENCH_LANES", "exit_with_parent", "folder_records", "run_benchmark", "run_settings"]

BENCH_LANES = 16   #: trials the benchmark advances together (one compiled program for every run)


def _load_condition(path: Path) -> dict[int, dict]:
    if not path.exists():
        return {}
    try:
        return {int(r["seed"]): r for r in json.loads(path.read_text())["trials"]}
    except (json.JSONDecodeError, KeyError, TypeError) as exc:
        raise ValueError(f"{path}: not a dexpush condition file ({exc}); delete it to start over") from exc


def run_benchmark(out: str | os.PathLike, tasks: Sequence[str], shapes: Sequence[str], params: Sequence[str],
                  methods: Sequence[str], seeds: Sequence[int], max_steps: int = MAX_STEPS,
                  lanes: int = BENCH_LANES, settings: ControllerSettings | None = None,
                  progress: bool = True, figures: bool = True, workers: int = 1, plant: str = "model",
                  sensor: SensorSettings | None = None) -> list[dict]:
    """Run the trials of every condition (task × shape × params × method), resumably.

    Each condition has its file ``out/conditions/<task>_<shape>_<params>_<method>.json``,
    rewritten atomically as each of its trials ends; trials already recorded there are
    not run again. On the model plant with an exact sensor the trials of all conditions of
    one task and shape share one queue of ``lanes`` (:func:`dexpush.experiments.simulate.simulate`);
    otherwise (``plant="physics"`` or a realistic ``sensor``) trials run one by one through
    :func:`dexpush.experiments.runner.run_trial`. ``workers`` > 1 runs the (task, shape) groups in that
    many processes (XLA runs a scanned loop on one thread, so a 2-core machine needs 2). With
    ``figures`` each condition's trajectories go to ``out/trajectories/<condition>.npz`` (each
    as its trial ends, so a resumed run keeps them) and a figure
    ``out/figures/<condition>.png``. ``out/settings.json`` records the plant, sensor,
    controller settings, ``max_steps`` and ``lanes``; a run with other settings into the same
    folder is refused with a ``ValueError`` that names the differences. Returns the records
    in condition, then seed, order.
    """
    out = Path(out)
    task_keys = [get_task(t).key for t in tasks]
    for p in params:
        for m in methods:
            check_condition(p, m)
    for sh in shapes:
        make_shape(sh)
    if plant not in PLANTS:
        raise ValueError(f"unknown plant {plant!r}; choose one of {', '.join(PLANTS)}")
    if workers < 1:
        raise ValueError(f"workers must be >= 1, got {workers}")
    exact = sensor is None or sensor.perfect
    for m in map(get_method, methods):
        if not exact and not m.cameras:
            raise ValueError(f"the {m.name} method runs with exact observations only; drop {m.name} or the camera "
                             "options")
        skipped = [t for t in task_keys if get_task(t).obstacles] if not m.obstacles else []
        if skipped and progress:
            print(f"{m.name}: no obstacle support, skipping task {', '.join(skipped)}", file=sys.stderr, flush=True)
    seeds = sorted({int(s) for s in seeds})
    _claim_folder(out, run_settings(plant, sensor, settings, max_steps, lanes), progress)
    groups = sorted(((t, sh) for t in task_keys for sh in shapes), key=_expected_cost, reverse=True)
    common = dict(params=tuple(params), methods=tuple(methods), seeds=tuple(seeds), max_steps=max_steps,
                  lanes=lanes, settings=settings, progress=progress, figures=figures, plant=plant, sensor=sensor)
    if workers == 1 or len(groups) == 1:
        for t, sh in groups:
            _run_group(out, t, sh, **common)
    else:
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        # one XLA thread per worker process (dexpush.common.xla_options): the workers are the parallelism
        saved = os.environ.get("NPROC")
        os.environ["NPROC"] = "1"
        try:
            with ProcessPoolExecutor(min(workers, len(groups)), mp_context=multiprocessing.get_context("spawn"),
                                     initializer=exit_with_parent, initargs=(os.getpid(),)) as ex:
                futures = [ex.submit(_run_group, out, t, sh, **common, position=i % workers)
                           for i, (t, sh) in enumerate(groups)]
                for f in futures:
                    f.result()
        finally:
            if saved is None:
                os.environ.pop("NPROC", None)
            else:
                os.environ["NPROC"] = saved
    order = [condition_name(t, sh, p, m) for t in task_keys for sh in shapes for p in params
             for m in _methods_for(get_task(t), methods)]
    records = {name: _load_condition(out / "conditions" / f"{name}.json") for name in order}
    return [records[name][s] for name in order for s in seeds]


def _expected_cost(group: tuple[str, str]) -> tuple[int, int]:
    """A sort key for running the longest (task, shape) groups first, so that with several
    workers no core idles while one runs the last long group (longest-processing-time-first
    scheduling). Ranked by what made groups long in the committed table
    (docs/benchmark.md#against-the-targets): shapes with concave corners first (the two-contact
    solve makes their steps 2–3× dearer), then tasks with obstacles (their trials run longest)."""
    task_key, shape_name = group
    return len(make_shape(shape_name).corners), len(get_task(task_key).obstacles)


def exit_with_parent(parent: int, poll_s: float = 1.0) -> None:
    """Worker-pool initializer: end this worker once the process that started it is gone.

    Ctrl-C reaches the whole process group, but a benchmark process that is killed (``kill
    PID``) leaves its spawned workers orphaned, and they would run on for up to an hour,
    writing records made with whatever code they imported into the folder. A daemon thread
    polls the parent's pid and exits the worker when it changes.
    """
    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(poll_s)
        os._exit(1)

    threading.Thread(target=watch, daemon=True, name="exit-with-parent").start()


def folder_records(out: str | os.PathLike) -> list[dict]:
    """Every trial recorded in ``out/conditions/``, in task, shape, params, method, seed order."""
    rank = {k: i for i, k in enumerate(("I", "II", "III", *SHAPES, *PARAMS, *method_names()))}
    records = [r for path in sorted(Path(out, "conditions").glob("*.json")) for r in _load_condition(path).values()]
    return sorted(records, key=lambda r: (*(rank.get(r[k], len(rank)) for k in CONDITION_KEYS), r["seed"]))


def run_settings(plant: str, sensor: SensorSettings | None, settings: ControllerSettings | None, max_steps: int,
                 lanes: int) -> dict:
    """Everything besides the condition and the seed that decides a trial's outcome (JSON-friendly)."""
    sensor = sensor if sensor is not None and not sensor.perfect else None
    return json.loads(json.dumps({"plant": plant, "sensor": asdict(sensor) if sensor else "exact",
                                  "controller": asdict(settings or ControllerSettings()), "max_steps": int(max_steps),
                                  "lanes": int(lanes)}))


#: controller options that are on by default but were added after results folders were started:
#: the value that a folder without the key was made with (the option did not exist, so it was off)
BEFORE_THEY_EXISTED = {"stall_after_s": None, "endgame_temperature": None, "prediction_margin_gain": 0.0,
                       "weights": {"detour": False, "C_margin": None}, "mppi": {"update": "clipped"}}


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


def _claim_folder(out: Path, wanted: dict, progress: bool) -> None:
    """Record the settings in ``out/settings.json``, or refuse a folder whose records were made with others.

    A folder from before settings were recorded (records but no settings.json) is adopted as is.
    """
    path = out / "settings.json"
    try:
        version = importlib.metadata.version("dexpush")
    except importlib.metadata.PackageNotFoundError:  # pragma: no cover (running from a source tree)
        version = "unknown"
    if path.exists():
        saved = json.loads(path.read_text())
        # a setting added after the folder was started is taken at the value that reproduces what the
        # folder's records were made with: off for an option that is on by default now, else its default
        defaults = run_settings(wanted["plant"], None, None, wanted["max_steps"], wanted["lanes"])["controller"]
        before = _with_defaults(saved.get("settings"), {"controller": BEFORE_THEY_EXISTED})
        diff = _differences(_with_defaults(before, {"controller": defaults}), wanted)
        if diff:
            raise ValueError(f"{out} holds results made with other settings ({'; '.join(diff[:3])}"
                             f"{'; …' if len(diff) > 3 else ''}); choose another --out, or delete it to start over")
        if saved.get("version") != version and progress:
            print(f"note: {out} was started by dexpush {saved.get('version')}, this is {version}", file=sys.stderr)
        return
    write_json_atomic(path, {"settings": wanted, "version": version})


def _methods_for(task: Task, methods: Sequence[str]) -> tuple[str, ...]:
    """The methods that run on ``task``: those without obstacle support skip tasks with obstacles (GCS, as
    in the paper)."""
    return tuple(m for m in methods if get_method(m).obstacles or not task.obstacles)


def _run_group(out: Path, task_key: str, shape_name: str, *, params: tuple[str, ...], methods: tuple[str, ...],
               seeds: tuple[int, ...], max_steps: int, lanes: int, settings: ControllerSettings | None,
               progress: bool, figures: bool, plant: str, sensor: SensorSettings | None, position: int = 0) -> None:
    """The conditions of one task and shape (see :func:`run_benchmark`)."""
    task, shape = get_task(task_key), make_shape(shape_name)
    settings = settings or ControllerSettings()
    problem = task.problem(shape, settings.weights)
    names = {(p, m): condition_name(task.key, shape_name, p, m) for p in params for m in _methods_for(task, methods)}
    records: dict[str, dict[int, dict]] = {}
    specs: list[tuple[TrialSpec, str, str]] = []
    for (p, m), name in names.items():
        records[name] = _load_condition(out / "conditions" / f"{name}.json")
        specs += [(trial_spec(p, m, s), p, m) for s in seeds if s not in records[name]]
    owner = {id(spec): (p, m) for spec, p, m in specs}

    def save(result: TrialResult) -> None:
        p, m = owner[id(result.spec)]
        name = names[(p, m)]
        ep = make_episode(problem, Condition(task.key, shape_name, p, m), result,
                          lanes if batched(plant, m, sensor) else 1, plant=plant,
                          sensor=world_sensor(plant, sensor, result.spec.seed),
                          control_period=settings.mppi.control_period)
        records[name][result.spec.seed] = ep.summary()
        if figures:   # the trajectory first: a trial whose record exists never lacks its trajectory
            _store_trajectory(out, name, result.spec.seed, result.states.astype(np.float32))
        write_json_atomic(out / "conditions" / f"{name}.json",
                          {"trials": [records[name][s] for s in sorted(records[name])]})

    desc = f"task {task.key} {shape_name}"
    starts = partial(task.trial_start, shape)
    queued = [spec for spec, _, m in specs if batched(plant, m, sensor)]
    one_by_one = [(spec, m) for spec, _, m in specs if not batched(plant, m, sensor)]
    if queued:
        if progress:
            print(f"{desc}: {len(queued)} trials in {lanes} lanes", file=sys.stderr, flush=True)
        simulate(problem, queued, settings, starts=starts, max_steps=max_steps, lanes=lanes,
                 on_result=save, progress=progress, desc=desc)
    bar = progress_bar(len(one_by_one), f"{desc} ({plant})", "trial", progress and bool(one_by_one), position)
    for spec, m in one_by_one:
        save(run_trial(problem, starts, spec, m, plant, sensor, settings, max_steps, desc=desc))
        bar.update(1)
    bar.close()
    if figures:
        for name in names.values():
            _draw_condition(out, name, shape, task, records[name])


def _load_trajectories(path: Path) -> dict[int, np.ndarray]:
    if not path.exists():
        return {}
    with np.load(path) as data:
        return {int(k.split("_")[1]): data[k] for k in data.files}


def _store_trajectory(out: Path, name: str, seed: int, states: np.ndarray) -> None:
    """Add one trial's states to the condition's npz (rewritten atomically), as soon as it ends."""
    path = out / "trajectories" / f"{name}.npz"
    trajs = _load_trajectories(path)
    trajs[seed] = states
    with atomic_path(path) as tmp, open(tmp, "wb") as fh:
        np.savez_compressed(fh, **{f"seed_{s}": trajs[s] for s in sorted(trajs)})


def _draw_condition(out: Path, name: str, shape: Shape, task: Task, recs: dict[int, dict]) -> None:
    """The condition's figure: every recorded trial's object path."""
    import matplotlib.pyplot as plt

    from dexpush.viz import plot_condition

    trajs = _load_trajectories(out / "trajectories" / f"{name}.npz")
    if not trajs:
        return
    seeds = sorted(s for s in trajs if s in recs)
    ok = sum(recs[s]["success"] for s in seeds)
    first = recs[seeds[0]] if seeds else {}
    fig = plot_condition(shape, [trajs[s] for s in seeds], [recs[s]["success"] for s in seeds], np.asarray(task.goal),
               np.asarray(task.obstacles).reshape(-1, 3),
               title=f"{name.replace('_', ' · ')} · {first.get('plant', 'model')} plant · camera: "
                     f"{first.get('sensor', 'exact')}: {ok}/{len(seeds)} successes",
               path=out / "figures" / f"{name}.png")
    plt.close(fig)
