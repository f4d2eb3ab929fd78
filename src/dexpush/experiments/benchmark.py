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

import os
import signal
import sys
import threading
import time
from collections.abc import Sequence
from functools import partial
from pathlib import Path

import numpy as np

from dexpush.common.files import write_json_atomic
from dexpush.common.interfaces import Sensor
from dexpush.common.progress import progress_bar
from dexpush.control.controller import ControllerSettings
from dexpush.experiments.cluster import ENGINES, run_on_ray
from dexpush.experiments.methods import get_method
from dexpush.experiments.records import Condition, condition_name, make_episode
from dexpush.experiments.registry import PLANTS, check_condition, make_shape, world_sensor
from dexpush.experiments.results_folder import (
    claim_folder,
    draw_condition,
    load_condition,
    run_settings,
    store_trajectory,
)
from dexpush.experiments.runner import batched, run_trial, trial_spec
from dexpush.experiments.scenarios import MAX_STEPS, Task, get_task
from dexpush.experiments.simulate import TrialResult, TrialSpec, simulate
from dexpush.problem.problem import Problem

__all__ = ["BENCH_LANES", "exit_with_parent", "run_benchmark"]

BENCH_LANES = 16   #: trials the benchmark advances together (one compiled program for every run)


def run_benchmark(out: str | os.PathLike, tasks: Sequence[str], shapes: Sequence[str], params: Sequence[str],
                  methods: Sequence[str], seeds: Sequence[int], max_steps: int = MAX_STEPS,
                  lanes: int = BENCH_LANES, settings: ControllerSettings | None = None,
                  progress: bool = True, figures: bool = True, workers: int = 1, plant: str = "model",
                  sensor: Sensor | None = None, engine: str = "local", address: str | None = None) -> list[dict]:
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
    folder is refused with a ``ValueError`` that names the differences. ``engine="ray"`` runs the
    groups as tasks on Ray instead (:mod:`dexpush.experiments.cluster`: a local instance of
    ``workers`` CPUs on 127.0.0.1, or the cluster at ``address``), with the same records. Returns
    the records in condition, then seed, order.
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
    if engine not in ENGINES:
        raise ValueError(f"unknown engine {engine!r}; choose one of {', '.join(ENGINES)}")
    if address is not None and engine != "ray":
        raise ValueError("a cluster address is for engine='ray'")
    exact = sensor is None or sensor.perfect
    for m in map(get_method, methods):
        m.check_sensing(exact)
        skipped = [t for t in task_keys if get_task(t).has_obstacles] if not m.obstacles else []
        if skipped and progress:
            print(f"{m.name}: no obstacle support, skipping task {', '.join(skipped)}", file=sys.stderr, flush=True)
    seeds = sorted({int(s) for s in seeds})
    claim_folder(out, run_settings(plant, sensor, settings, max_steps, lanes), progress)
    groups = sorted(((t, sh) for t in task_keys for sh in shapes), key=_expected_cost, reverse=True)
    common = dict(params=tuple(params), methods=tuple(methods), seeds=tuple(seeds), max_steps=max_steps,
                  lanes=lanes, settings=settings, progress=progress, figures=figures, plant=plant, sensor=sensor)
    if engine == "ray":
        calls = [((out, t, sh), {**common, "position": i % workers}) for i, (t, sh) in enumerate(groups)]
        run_on_ray(_run_group, calls, workers=workers, address=address)
    elif workers == 1 or len(groups) == 1:
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
                # the workers start (on submit) with Ctrl-C ignored, until their initializer makes it end them
                # quietly: a Ctrl-C while one still imports would otherwise print its traceback
                main = threading.current_thread() is threading.main_thread()
                previous = signal.signal(signal.SIGINT, signal.SIG_IGN) if main else None
                try:
                    futures = [ex.submit(_run_group, out, t, sh, **common, position=i % workers)
                               for i, (t, sh) in enumerate(groups)]
                finally:
                    if main:
                        signal.signal(signal.SIGINT, previous)
                try:
                    for f in futures:
                        f.result()
                except KeyboardInterrupt:
                    # a worker that was still importing ignored the Ctrl-C: end it rather than wait for its group
                    for process in list((getattr(ex, "_processes", None) or {}).values()):
                        process.terminate()
                    raise
        finally:
            if saved is None:
                os.environ.pop("NPROC", None)
            else:
                os.environ["NPROC"] = saved
    order = [condition_name(t, sh, p, m) for t in task_keys for sh in shapes for p in params
             for m in _methods_for(get_task(t), methods)]
    records = {name: load_condition(out / "conditions" / f"{name}.json") for name in order}
    return [records[name][s] for name in order for s in seeds]


def _expected_cost(group: tuple[str, str]) -> tuple[int, int]:
    """A sort key for running the longest (task, shape) groups first, so that with several
    workers no core idles while one runs the last long group (longest-processing-time-first
    scheduling). Ranked by what made groups long in the committed table
    (docs/benchmark.md#against-the-targets): shapes with concave corners first (the two-contact
    solve makes their steps 2–3× dearer), then tasks with obstacles (their trials run longest)."""
    task_key, shape_name = group
    task = get_task(task_key)
    return len(make_shape(shape_name).corners), len(task.obstacles) + len(task.polygons) + 3 * task.varies_by_seed


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

    # Ctrl-C reaches the workers too: they end at once and quietly (every file is written atomically),
    # and the parent says how to resume
    signal.signal(signal.SIGINT, lambda *_: os._exit(130))

    threading.Thread(target=watch, daemon=True, name="exit-with-parent").start()


def _methods_for(task: Task, methods: Sequence[str]) -> tuple[str, ...]:
    """The methods that run on ``task``: those without obstacle support skip tasks with obstacles (GCS, as
    in the paper)."""
    return tuple(m for m in methods if get_method(m).obstacles or not task.has_obstacles)


def _run_group(out: Path, task_key: str, shape_name: str, *, params: tuple[str, ...], methods: tuple[str, ...],
               seeds: tuple[int, ...], max_steps: int, lanes: int, settings: ControllerSettings | None,
               progress: bool, figures: bool, plant: str, sensor: Sensor | None, position: int = 0) -> None:
    """The conditions of one task and shape (see :func:`run_benchmark`)."""
    task, shape = get_task(task_key), make_shape(shape_name)
    settings = settings or ControllerSettings()
    problems: dict[int, Problem] = {}

    def problem_of(seed: int) -> Problem:
        """The trial's problem: the task's one, or seed ``seed``'s layout (the clutter family)."""
        key = seed if task.varies_by_seed else -1
        if key not in problems:
            problems[key] = task.problem(shape, settings.weights, seed=seed if task.varies_by_seed else None)
        return problems[key]

    names = {(p, m): condition_name(task.key, shape_name, p, m) for p in params for m in _methods_for(task, methods)}
    records: dict[str, dict[int, dict]] = {}
    specs: list[tuple[TrialSpec, str, str]] = []
    for (p, m), name in names.items():
        records[name] = load_condition(out / "conditions" / f"{name}.json")
        specs += [(trial_spec(p, m, s), p, m) for s in seeds if s not in records[name]]
    owner = {id(spec): (p, m) for spec, p, m in specs}
    # with one layout per seed, each seed's conditions share a batch as wide as there are of them (the same
    # width for every seed, so one compiled program)
    width = min(lanes, sum(batched(plant, m, sensor) for _, m in names)) if task.varies_by_seed else lanes

    def save(result: TrialResult) -> None:
        p, m = owner[id(result.spec)]
        name = names[(p, m)]
        ep = make_episode(problem_of(result.spec.seed), Condition(task.key, shape_name, p, m), result,
                          width if batched(plant, m, sensor) else 1, plant=plant,
                          sensor=world_sensor(plant, sensor, result.spec.seed),
                          control_period=settings.mppi.control_period)
        records[name][result.spec.seed] = ep.summary()
        if figures:   # the trajectory first: a trial whose record exists never lacks its trajectory
            store_trajectory(out, name, result.spec.seed, result.states.astype(np.float32))
        write_json_atomic(out / "conditions" / f"{name}.json",
                          {"trials": [records[name][s] for s in sorted(records[name])]})

    desc = f"task {task.key} {shape_name}"
    starts = partial(task.trial_start, shape)
    queued = [spec for spec, _, m in specs if batched(plant, m, sensor)]
    one_by_one = [(spec, m) for spec, _, m in specs if not batched(plant, m, sensor)]
    if queued and not task.varies_by_seed:
        if progress:
            print(f"{desc}: {len(queued)} trials in {lanes} lanes", file=sys.stderr, flush=True)
        simulate(problem_of(0), queued, settings, starts=starts, max_steps=max_steps, lanes=lanes,
                 on_result=save, progress=progress, desc=desc)
    elif queued:
        bar = progress_bar(len(queued), desc, "trial", progress, position)
        for seed in sorted({spec.seed for spec in queued}):
            simulate(problem_of(seed), [q for q in queued if q.seed == seed], settings, starts=starts,
                     max_steps=max_steps, lanes=width, on_result=save, desc=desc)
            bar.update(sum(q.seed == seed for q in queued))
        bar.close()
    bar = progress_bar(len(one_by_one), f"{desc} ({plant})", "trial", progress and bool(one_by_one), position)
    for spec, m in one_by_one:
        save(run_trial(problem_of(spec.seed), starts, spec, m, plant, sensor, settings, max_steps, desc=desc))
        bar.update(1)
    bar.close()
    if figures:
        for name in names.values():
            draw_condition(out, name, shape, task, records[name])


