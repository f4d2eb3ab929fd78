"""Closed-loop episodes on the model plant, their records, and the benchmark table (SPEC §5).

Every simulated episode goes through :func:`dexpush.simulate.simulate`, which runs the
controller's pure step and the model plant for a whole batch of trials in one jitted,
vmapped call. :func:`run_episode` is one trial (``dexpush run``); :func:`run_benchmark`
runs the §5 table, all conditions of a task and shape in one queue of lanes, and saves
every finished trial at once in its condition's file, so an interrupted run resumes
where it stopped. :func:`write_tables` turns the records into JSON, CSV and Markdown.

Re-running a trial: the outcome recorded for a seed is reproduced bit for bit by the same
command on any subset of seeds, or by ``dexpush run ... --seed S --lanes 32`` (the bench's
lane count; see :mod:`dexpush.simulate` for why the lane count matters).
"""

from __future__ import annotations

import csv
import json
import os
import sys
import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import jax.numpy as jnp
import numpy as np
from tqdm import tqdm

from dexpush.controller import ControllerSettings, PushingController
from dexpush.cost import Scene, collides
from dexpush.files import atomic_path, write_json_atomic
from dexpush.geometry import Shape
from dexpush.model import LAMBDA_TRUE, MODE_NAMES, Contour, contact_solution
from dexpush.plants import ModelPlant, PhysicsPlant
from dexpush.se2 import pose_error
from dexpush.sensing import Camera, SensorSettings
from dexpush.simulate import TrialResult, TrialSpec, simulate
from dexpush.tasks import MAX_STEPS, Task, get_task, initial_conditions, is_success

__all__ = ["ALL_METHODS", "BENCH_LANES",
           "METHODS", "PARAMS", "SHAPES", "Episode", "EpisodeRecord", "make_shape", "run_benchmark",
           "run_episode", "run_gcs_trial", "summarize", "write_tables"]

#: λ_pred of the two parameter scenarios (paper Sec. IV-B)
PARAMS = {"known": LAMBDA_TRUE, "unknown": (15.0, 0.0, 0.0)}
_SHAPE_MAKERS = {"rect": Shape.rectangle, "tee": Shape.tee, "ellipse": Shape.ellipse}
SHAPES = tuple(_SHAPE_MAKERS)
METHODS = ("mppi", "mppi-ukf")        #: the closed-loop MPPI methods the benchmark runs by default
ALL_METHODS = (*METHODS, "gcs")        #: plus the GCS plan-and-track baseline (Tasks I, II; dexpush.gcs)
CONTROL_PERIOD = 0.04
BENCH_LANES = 32   #: trials the benchmark advances together (one compiled program for every run)


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
    planning_ms_median: float     #: batched runs: wall time of one control step (UKF + MPPI + plant)
    planning_ms_max: float        #: amortized over the batch; sensed runs: the controller's time per command
    params_estimate: list[float] | None = None
    lanes: int = 1                #: lanes of the batch it ran in (needed to reproduce it exactly)
    plant: str = "model"          #: the world: model (C-GVMM, λ_true) or physics (MuJoCo)
    sensor: str = "exact"         #: what the controller saw (see dexpush.sensing)
    offline_plan_s: float | None = None   #: GCS: wall time of the offline plan (before the first step)
    replans: int | None = None            #: GCS: plans made during tracking


@dataclass
class Episode:
    """A finished episode: its record plus the sampled trajectory."""

    record: EpisodeRecord
    states: np.ndarray            #: (T+1, 5) true states
    modes: np.ndarray             #: (T,) contact mode at the start of each control step
    commands: np.ndarray          #: (T, 2)
    planning_ms: np.ndarray       #: (T,) wall time per control step (amortized, see EpisodeRecord)
    params: np.ndarray            #: (T, 3) λ_pred the controller planned with at each step
    goal: np.ndarray
    obstacles: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))

    def summary(self) -> dict:
        return asdict(self.record)


def _path_length(xy: np.ndarray) -> float:
    return float(np.sum(np.linalg.norm(np.diff(xy, axis=0), axis=-1)))


def _check_condition(params: str, method: str) -> None:
    if params not in PARAMS:
        raise ValueError(f"unknown params {params!r}; choose 'known' or 'unknown'")
    if method not in ALL_METHODS:
        raise ValueError(f"unknown method {method!r}; choose one of {', '.join(ALL_METHODS)}")


def _sensor_label(sensor: SensorSettings | None) -> str:
    if sensor is None or sensor.perfect:
        return "exact"
    rate = f"{sensor.rate_hz:g} Hz" if sensor.rate_hz else "every step"
    return (f"{rate}, noise {sensor.pos_std_m * 1e3:g} mm / {np.degrees(sensor.heading_std_rad):.2g}°, "
            f"latency {sensor.latency_s * 1e3:g} ms, drops {sensor.drop_prob:.0%}")


def trial_spec(params: str, method: str, seed: int) -> TrialSpec:
    """The :class:`TrialSpec` of one benchmark trial."""
    _check_condition(params, method)
    return TrialSpec(int(seed), PARAMS[params], method == "mppi-ukf")


def make_episode(task: Task, shape_name: str, shape: Shape, params: str, method: str, result: TrialResult,
                 lanes: int, scene: Scene | None = None, plant: str = "model",
                 sensor: SensorSettings | None = None) -> Episode:
    """The record (SPEC §5) and trajectory of a finished trial."""
    scene = scene or Scene.make(shape, task.goal, task.obstacles)
    X, U = result.states, result.commands
    if len(U):
        modes = np.asarray(contact_solution(Contour.of(shape), X[:-1], U, LAMBDA_TRUE).mode)
        hits = np.asarray(collides(jnp.asarray(X[1:], jnp.float32), scene))
    else:
        modes, hits = np.zeros(0, int), np.zeros(0, bool)
    in_contact = modes != MODE_NAMES.index("free")
    pos_err, head_err = pose_error(X[-1, :3], task.goal)
    ms = result.step_ms if len(result.step_ms) else np.zeros(1)
    record = EpisodeRecord(
        task=task.key, shape=shape_name, params=params, method=method, seed=result.spec.seed,
        success=bool(result.success), steps=len(U), time_s=round(len(U) * CONTROL_PERIOD, 3),
        object_path_m=round(_path_length(X[:, :2]), 4), pusher_path_m=round(_path_length(X[:, 3:]), 4),
        final_error_m=round(float(pos_err), 5), final_error_deg=round(float(head_err), 3),
        collisions=int(np.sum(hits)), contact_switches=int(np.sum(in_contact[1:] != in_contact[:-1])),
        planning_ms_median=round(float(np.median(ms)), 3), planning_ms_max=round(float(np.max(ms)), 3),
        params_estimate=[round(float(v), 5) for v in result.params[-1]] if method == "mppi-ukf" and len(U) else None,
        lanes=int(lanes), plant=plant, sensor=_sensor_label(sensor),
        offline_plan_s=round(float(result.plan_s[0]), 3) if result.plan_s else None,
        replans=len(result.plan_s) - 1 if result.plan_s else None)
    return Episode(record, X, modes, U, result.step_ms, result.params, np.asarray(task.goal),
                   np.asarray(task.obstacles).reshape(-1, 3))


PLANTS = ("model", "physics")


def make_plant(name: str, shape: Shape) -> object:
    """The world of an experiment: ``model`` (C-GVMM with λ_true) or ``physics`` (MuJoCo)."""
    if name == "model":
        return ModelPlant(shape)
    if name == "physics":
        return PhysicsPlant(shape)
    raise ValueError(f"unknown plant {name!r}; choose one of {', '.join(PLANTS)}")


def run_sensed_trial(task: Task, shape: Shape, spec: TrialSpec, plant: str = "physics",
                     sensor: SensorSettings | None = None, settings: ControllerSettings | None = None,
                     max_steps: int = MAX_STEPS, progress: bool = False) -> TrialResult:
    """One trial the way a robot runs it: a :class:`PushingController` fed by a
    :class:`dexpush.sensing.Camera` on a plant, stepped from Python at the control rate.

    The controller only sees frames; success is judged on the plant's true state. The
    recorded ``step_ms`` is the controller's own time per command (planning latency).
    """
    settings = settings or ControllerSettings()
    settings = replace(settings, estimate_params=spec.estimate)
    sensor = replace(sensor or SensorSettings(), seed=(sensor.seed if sensor else 0) * 1_000_003 + spec.seed)
    camera = Camera(make_plant(plant, shape), sensor)
    pose, pusher = initial_conditions(task, shape, spec.seed)
    frame = camera.reset(pose, pusher)
    ctrl = PushingController(shape, task.goal, params=spec.params, obstacles=task.obstacles, settings=settings,
                             seed=spec.seed)
    scene = ctrl.scene
    T = settings.mppi.control_period
    frame_period = 1.0 / sensor.rate_hz if sensor.rate_hz else T
    ctrl.act(frame, frame_period)      # compile outside the timed loop (estimate, predict, plan) ...
    ctrl.act(None, frame_period)
    ctrl.reset()                       # ... and start afresh
    states, commands, lam, ms = [camera.state], [], [], []
    success = bool(is_success(camera.state[:3], task.goal))
    bar = tqdm(total=max_steps, desc=f"task {task.key} {shape.name} ({plant})", unit="step", disable=not progress,
               leave=False)
    while not success and len(commands) < max_steps:
        t0 = time.perf_counter()
        u = ctrl.act(frame, frame_period)
        ms.append((time.perf_counter() - t0) * 1e3)
        lam.append(ctrl.params)
        frame = camera.step(u, T)
        commands.append(u)
        states.append(camera.state)
        success = bool(is_success(camera.state[:3], task.goal))
        bar.update(1)
        if len(task.obstacles) and bool(collides(jnp.asarray(camera.state, jnp.float32), scene)):
            success = False                  # touching the obstacle fails the trial (SPEC §5)
            break
    bar.close()
    return TrialResult(spec, success, np.asarray(states), np.asarray(commands).reshape(-1, 2),
                       np.asarray(lam).reshape(-1, 3), np.asarray(ms))


def run_gcs_trial(task: Task, shape: Shape, spec: TrialSpec, plant: str = "model", max_steps: int = MAX_STEPS,
                  progress: bool = False) -> TrialResult:
    """One trial of the GCS baseline: plan offline with λ_pred, track on the plant (λ_true).

    ``step_ms`` holds the wall time of every control step after the offline plan (replans
    included: they happen online); ``plan_s`` the wall time of the offline plan and of each
    replan (see :class:`dexpush.gcs.GCSTracker`). The trial ends early when the tracker
    gives up (no plan, or replans exhausted and the plan run out): the object would stay
    put for the remaining steps.
    """
    from dexpush.gcs import GCSTracker  # Drake loads only for this method

    if task.obstacles:
        raise ValueError(f"the GCS baseline has no obstacle support (task {task.key}); use tasks I or II")
    world = make_plant(plant, shape)
    pose, pusher = initial_conditions(task, shape, spec.seed)
    obs = world.reset(pose, pusher)
    tracker = GCSTracker(shape, task.goal, spec.params, control_period=CONTROL_PERIOD)
    states, commands, ms = [world.state], [], []
    success = bool(is_success(obs.object_pose, task.goal))
    if not success:
        tracker.plan(obs.object_pose, obs.pusher_xy)       # offline: before the clock starts
    bar = tqdm(total=max_steps, desc=f"task {task.key} {shape.name} (gcs)", unit="step", disable=not progress,
               leave=False)
    while not success and len(commands) < max_steps and not tracker.gave_up:
        t0 = time.perf_counter()
        u = tracker.command(obs.object_pose, obs.pusher_xy)
        ms.append((time.perf_counter() - t0) * 1e3)
        obs = world.step(u, CONTROL_PERIOD)
        commands.append(u)
        states.append(world.state)
        success = bool(is_success(obs.object_pose, task.goal))
        bar.update(1)
    bar.close()
    lam = np.tile(np.asarray(spec.params, dtype=np.float64), (len(commands), 1))
    return TrialResult(spec, success, np.asarray(states), np.asarray(commands).reshape(-1, 2), lam, np.asarray(ms),
                       tuple(tracker.planning_s))


def run_episode(task: str | Task = "I", shape: str | Shape = "rect", params: str = "known",
                method: str = "mppi", seed: int = 0, max_steps: int = MAX_STEPS,
                settings: ControllerSettings | None = None, progress: bool = False, lanes: int = 1,
                chunk: int = 25, plant: str = "model", sensor: SensorSettings | None = None) -> Episode:
    """Run one closed-loop trial (SPEC §5) and record it.

    On the model plant with a perfect sensor it runs in :func:`dexpush.simulate.simulate`
    (``lanes`` = :data:`BENCH_LANES` reproduces the benchmark's record of this seed
    exactly); on the physics plant, or with a realistic ``sensor``, in
    :func:`run_sensed_trial`.
    """
    task = get_task(task)
    shape_name = shape if isinstance(shape, str) else shape.name
    shape = make_shape(shape) if isinstance(shape, str) else shape
    spec = trial_spec(params, method, seed)
    if max_steps < 1:
        raise ValueError(f"max_steps must be >= 1, got {max_steps}")
    if plant not in PLANTS:
        raise ValueError(f"unknown plant {plant!r}; choose one of {', '.join(PLANTS)}")
    if method == "gcs":
        if sensor is not None and not sensor.perfect:
            raise ValueError("the GCS baseline runs with exact observations only (no --camera)")
        result = run_gcs_trial(task, shape, spec, plant, max_steps, progress)
        return make_episode(task, shape_name, shape, params, method, result, 1, plant=plant)
    if plant == "model" and (sensor is None or sensor.perfect):
        result = simulate(task, shape, [spec], settings, max_steps=max_steps, lanes=lanes, chunk=chunk,
                          progress=progress, desc=f"task {task.key} {shape_name}")[0]
        return make_episode(task, shape_name, shape, params, method, result, lanes)
    result = run_sensed_trial(task, shape, spec, plant, sensor, settings, max_steps, progress)
    return make_episode(task, shape_name, shape, params, method, result, 1, plant=plant,
                        sensor=sensor or SensorSettings())


# ---------------------------------------------------------------------------- the §5 table
CONDITION_KEYS = ("task", "shape", "params", "method")


def condition_name(task: str, shape: str, params: str, method: str) -> str:
    return f"{task}_{shape}_{params}_{method}"


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
    one task and shape share one queue of ``lanes`` (:func:`dexpush.simulate.simulate`);
    otherwise (``plant="physics"`` or a realistic ``sensor``) trials run one by one through
    :func:`run_sensed_trial`. ``workers`` > 1 runs the (task, shape) groups in that many
    processes (XLA runs a scanned loop on one thread, so a 2-core machine needs 2). With
    ``figures`` each condition's trajectories go to ``out/trajectories/<condition>.npz``
    and a figure ``out/figures/<condition>.png``. Returns the records in condition, then
    seed, order.
    """
    out = Path(out)
    task_keys = [get_task(t).key for t in tasks]
    for p in params:
        for m in methods:
            _check_condition(p, m)
    for sh in shapes:
        make_shape(sh)
    if plant not in PLANTS:
        raise ValueError(f"unknown plant {plant!r}; choose one of {', '.join(PLANTS)}")
    if workers < 1:
        raise ValueError(f"workers must be >= 1, got {workers}")
    if "gcs" in methods and sensor is not None and not sensor.perfect:
        raise ValueError("the GCS baseline runs with exact observations only; drop gcs or the camera options")
    skipped = [t for t in task_keys if get_task(t).obstacles] if "gcs" in methods else []
    if skipped and progress:
        print(f"gcs: no obstacle support, skipping task {', '.join(skipped)}", file=sys.stderr, flush=True)
    seeds = sorted({int(s) for s in seeds})
    groups = [(t, sh) for t in task_keys for sh in shapes]
    common = dict(params=tuple(params), methods=tuple(methods), seeds=tuple(seeds), max_steps=max_steps,
                  lanes=lanes, settings=settings, progress=progress, figures=figures, plant=plant, sensor=sensor)
    if workers == 1 or len(groups) == 1:
        for t, sh in groups:
            _run_group(out, t, sh, **common)
    else:
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        # one XLA thread per worker process: the workers are the parallelism
        saved = os.environ.get("XLA_FLAGS")
        os.environ["XLA_FLAGS"] = f"{saved or ''} --xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1"
        try:
            with ProcessPoolExecutor(min(workers, len(groups)), mp_context=multiprocessing.get_context("spawn")) as ex:
                futures = [ex.submit(_run_group, out, t, sh, **common, position=i % workers)
                           for i, (t, sh) in enumerate(groups)]
                for f in futures:
                    f.result()
        finally:
            if saved is None:
                os.environ.pop("XLA_FLAGS", None)
            else:
                os.environ["XLA_FLAGS"] = saved
    order = [condition_name(t, sh, p, m) for t in task_keys for sh in shapes for p in params
             for m in _methods_for(get_task(t), methods)]
    records = {name: _load_condition(out / "conditions" / f"{name}.json") for name in order}
    return [records[name][s] for name in order for s in seeds]


def _methods_for(task: Task, methods: Sequence[str]) -> tuple[str, ...]:
    """The methods that run on ``task``: GCS has no obstacle support (as in the paper)."""
    return tuple(m for m in methods if not (m == "gcs" and task.obstacles))


def _run_group(out: Path, task_key: str, shape_name: str, *, params: tuple[str, ...], methods: tuple[str, ...],
               seeds: tuple[int, ...], max_steps: int, lanes: int, settings: ControllerSettings | None,
               progress: bool, figures: bool, plant: str, sensor: SensorSettings | None, position: int = 0) -> None:
    """The conditions of one task and shape (see :func:`run_benchmark`)."""
    task, shape = get_task(task_key), make_shape(shape_name)
    scene = Scene.make(shape, task.goal, task.obstacles)
    batched = plant == "model" and (sensor is None or sensor.perfect)
    names = {(p, m): condition_name(task.key, shape_name, p, m) for p in params for m in _methods_for(task, methods)}
    records: dict[str, dict[int, dict]] = {}
    specs: list[tuple[TrialSpec, str, str]] = []
    for (p, m), name in names.items():
        records[name] = _load_condition(out / "conditions" / f"{name}.json")
        specs += [(trial_spec(p, m, s), p, m) for s in seeds if s not in records[name]]
    paths: dict[str, dict[int, np.ndarray]] = {name: {} for name in names.values()}
    owner = {id(spec): (p, m) for spec, p, m in specs}

    def save(result: TrialResult) -> None:
        p, m = owner[id(result.spec)]
        name = names[(p, m)]
        ep = make_episode(task, shape_name, shape, p, m, result, lanes if batched and m != "gcs" else 1, scene,
                          plant=plant, sensor=sensor)
        records[name][result.spec.seed] = ep.summary()
        write_json_atomic(out / "conditions" / f"{name}.json",
                          {"trials": [records[name][s] for s in sorted(records[name])]})
        paths[name][result.spec.seed] = result.states.astype(np.float32)

    desc = f"task {task.key} {shape_name}"
    planned = [spec for spec, _, m in specs if m == "gcs"]
    closed_loop = [spec for spec, _, m in specs if m != "gcs"]
    if closed_loop and batched:
        if progress:
            print(f"{desc}: {len(closed_loop)} trials in {lanes} lanes", file=sys.stderr, flush=True)
        simulate(task, shape, closed_loop, settings, max_steps=max_steps, lanes=lanes,
                 on_result=save, progress=progress, desc=desc)
    elif closed_loop:
        for spec in tqdm(closed_loop, desc=f"{desc} ({plant})", unit="trial", disable=not progress,
                         position=position, leave=False):
            save(run_sensed_trial(task, shape, spec, plant, sensor, settings, max_steps))
    for spec in tqdm(planned, desc=f"{desc} (gcs, {plant})", unit="trial", disable=not progress or not planned,
                     position=position, leave=False):
        save(run_gcs_trial(task, shape, spec, plant, max_steps))
    if figures:
        for name, new in paths.items():
            _save_trajectories(out, name, new, shape, task, records[name])


def _save_trajectories(out: Path, name: str, new: dict[int, np.ndarray], shape: Shape, task: Task,
                       recs: dict[int, dict]) -> None:
    """Merge new trajectories into the condition's npz and redraw its figure."""
    import matplotlib.pyplot as plt

    from dexpush.viz import plot_condition

    path = out / "trajectories" / f"{name}.npz"
    trajs: dict[int, np.ndarray] = {}
    if path.exists():
        with np.load(path) as data:
            trajs = {int(k.split("_")[1]): data[k] for k in data.files}
    trajs.update(new)
    if not trajs:
        return
    if new:
        with atomic_path(path) as tmp, open(tmp, "wb") as fh:
            np.savez_compressed(fh, **{f"seed_{s}": trajs[s] for s in sorted(trajs)})
    seeds = sorted(s for s in trajs if s in recs)
    ok = sum(recs[s]["success"] for s in seeds)
    fig = plot_condition(shape, [trajs[s] for s in seeds], [recs[s]["success"] for s in seeds], np.asarray(task.goal),
               np.asarray(task.obstacles).reshape(-1, 3),
               title=f"{name.replace('_', ' · ')}: {ok}/{len(seeds)} successes",
               path=out / "figures" / f"{name}.png")
    plt.close(fig)


def summarize(trials: list[dict]) -> dict:
    """Per-condition numbers of SPEC §5 from its trial records."""
    ok = [t for t in trials if t["success"]]

    def mean_std(key: str) -> list[float] | None:
        v = np.array([t[key] for t in ok], float)
        return [round(float(v.mean()), 4), round(float(v.std()), 4)] if len(v) else None

    plan = np.array([t["planning_ms_median"] for t in trials], float)
    offline = np.array([t["offline_plan_s"] for t in trials if t.get("offline_plan_s") is not None], float)
    replans = np.array([t["replans"] for t in trials if t.get("replans") is not None], float)
    return {"trials": len(trials), "successes": len(ok),
            "success_rate": round(len(ok) / len(trials), 4) if trials else None,
            "object_path_m": mean_std("object_path_m"), "pusher_path_m": mean_std("pusher_path_m"),
            "time_to_goal_s": mean_std("time_s"),
            "planning_ms_median": round(float(np.median(plan)), 3) if len(plan) else None,
            "planning_ms_max": round(float(max(t["planning_ms_max"] for t in trials)), 3) if trials else None,
            "offline_plan_s": [round(float(np.median(offline)), 3), round(float(offline.max()), 3)]
            if len(offline) else None,
            "replans_mean": round(float(replans.mean()), 2) if len(replans) else None}


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
    cols = list(dict.fromkeys(k for r in records for k in r))    # records written by older versions lack fields
    with atomic_path(files["csv"]) as tmp, open(tmp, "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=cols, restval="")
        writer.writeheader()
        for r in records:
            writer.writerow({k: json.dumps(v) if isinstance(v, list) else v for k, v in r.items()})

    def fmt(ms: list[float] | None) -> str:
        return f"{ms[0]:.3f} ± {ms[1]:.3f}" if ms else "–"

    lines = [f"Produced by `{meta.get('command', '')}` on {meta.get('date', '')} ({meta.get('machine', '')}).", "",
             "| task | shape | params | method | SR | object TL (m) | pusher TL (m) | time to goal (s) "
             "| planning ms per step (median / max) | offline plan s (median / max) | replans (mean) |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for s in summary:
        lines.append(f"| {s['task']} | {s['shape']} | {s['params']} | {s['method']} | "
                     f"{s['successes']}/{s['trials']} ({100 * s['success_rate']:.0f} %) | {fmt(s['object_path_m'])} | "
                     f"{fmt(s['pusher_path_m'])} | {fmt(s['time_to_goal_s'])} | "
                     f"{s['planning_ms_median']:.1f} / {s['planning_ms_max']:.0f} | "
                     + (f"{s['offline_plan_s'][0]:.1f} / {s['offline_plan_s'][1]:.1f} | {s['replans_mean']:.1f} |"
                        if s["offline_plan_s"] else "– | – |"))
    with atomic_path(files["markdown"]) as tmp:
        tmp.write_text("\n".join(lines) + "\n")
    return files
