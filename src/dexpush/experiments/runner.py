"""Closed-loop episodes: one loop for any plant and any controller, and episodes by name.

:func:`run_loop` is *the* episode loop. It takes any :class:`dexpush.common.interfaces.Plant`
(the model plant, the MuJoCo plant, your own simulator or robot driver) and any
:class:`dexpush.common.interfaces.Controller` (MPPI, MPPI+UKF, the GCS tracker, your own), seen
through an optional :class:`dexpush.world.sensing.Camera` model, and runs it at the control
rate from Python, the way a robot runs:

    frame = camera.reset(object_pose, pusher_xy)
    controller.reset(frame.object_pose, frame.pusher_xy)   # compile / plan before the clock
    repeat:  command = controller.act(frame, frame_period);  frame = camera.step(command, T)

The controller only sees frames; success and obstacle contact are judged on the plant's
true state. Many trials of MPPI on the model plant with exact observations are better run
batched (:func:`dexpush.experiments.simulate.simulate`: one compiled, vmapped step for a whole batch);
:func:`run_trial` picks that path on its own for named model-plant trials.

:func:`run_episode` is one benchmark trial by names (``dexpush run``).
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Callable
from dataclasses import replace

import numpy as np

from dexpush.common.checks import check_params, checked_vector
from dexpush.common.interfaces import CONTROL_PERIOD_S, Controller, Plant, Sensor, check_plant
from dexpush.common.progress import progress_bar
from dexpush.control.controller import ControllerSettings
from dexpush.experiments.methods import Method, get_method
from dexpush.experiments.records import Condition, Episode, make_episode
from dexpush.experiments.registry import PARAMS, PLANTS, check_condition, make_plant, make_shape, world_sensor
from dexpush.experiments.scenarios import MAX_STEPS, Task, get_task
from dexpush.experiments.simulate import ESTIMATOR_COUNTERS, Starts, TrialResult, TrialSpec, simulate
from dexpush.model.shape import Shape
from dexpush.problem.problem import Problem
from dexpush.world.sensing import SensorSettings

__all__ = ["batched", "plant_name", "run_episode", "run_loop", "run_trial", "trial_spec"]


def _problem_and_start(problem: Problem | Task, args: tuple, object_pose: object,
                       pusher_xy: object) -> tuple[Problem, object, object]:
    """``(problem, object_pose, pusher_xy)`` from run_loop's arguments; the older form
    ``(task, shape, object_pose, pusher_xy)`` is read with a ``DeprecationWarning``."""
    if isinstance(problem, Task) and args and isinstance(args[0], Shape):
        warnings.warn("run_loop(plant, controller, task, shape, pose, pusher) is deprecated: pass a Problem, "
                      "run_loop(plant, controller, task.problem(shape), pose, pusher)", DeprecationWarning,
                      stacklevel=3)
        problem, args = problem.problem(args[0]), args[1:]
    if not isinstance(problem, Problem):
        raise TypeError(f"run_loop(plant, controller, problem, object_pose, pusher_xy): problem is a dexpush Problem, "
                        f"got {type(problem).__name__}")
    given = (*args, *(v for v in (object_pose, pusher_xy) if v is not None))
    if len(given) != 2 or len(args) > 2 or (len(args) == 1 and object_pose is not None):
        raise TypeError("run_loop(plant, controller, problem, object_pose, pusher_xy) takes one start: an object "
                        "pose and a pusher position")
    return problem, given[0], given[1]


def run_loop(plant: Plant, controller: Controller, problem: Problem, *args: object, object_pose: object = None,
             pusher_xy: object = None, sensor: Sensor | None = None, control_period: float = CONTROL_PERIOD_S,
             max_steps: int = MAX_STEPS, spec: TrialSpec | None = None, progress: bool = False,
             desc: str = "episode") -> TrialResult:
    """Run ``controller`` on ``plant`` from the start ``object_pose``, ``pusher_xy`` until success,
    N_max steps, an obstacle touch, or the controller gives up (see the module docstring).

    Called as ``run_loop(plant, controller, problem, object_pose, pusher_xy, ...)``.

    Args:
        plant: the world (any :class:`dexpush.common.interfaces.Plant`).
        controller: any :class:`dexpush.common.interfaces.Controller`.
        problem: the :class:`dexpush.problem.problem.Problem`: its success test (8 mm and 3° on the
            true pose, docs/conventions.md#benchmark-tasks) and obstacles judge the trial.
        object_pose, pusher_xy: the start.
        sensor: what the controller sees (default: the exact state every control period).
        control_period: T (s), how long each command is held.
        max_steps: N_max.
        spec: recorded in the result (seed, λ_pred, estimate flag); default seed 0.
        progress: a progress bar on stderr.

    Returns:
        a :class:`dexpush.experiments.simulate.TrialResult`: true states, commands, the controller's
        λ per step (NaN when it has none), its wall time per ``act`` (ms), and the plan
        times of a planning controller.
    """
    problem, object_pose, pusher_xy = _problem_and_start(problem, args, object_pose, pusher_xy)
    if max_steps < 1:
        raise ValueError(f"max_steps must be >= 1, got {max_steps}")
    if not (np.isfinite(control_period) and control_period > 0):
        raise ValueError(f"control_period must be > 0 (s), got {control_period!r}")
    sensor = sensor or SensorSettings()
    camera = sensor.camera(plant, problem.obstacles)
    frame = camera.reset(object_pose, pusher_xy)
    frame_period = 1.0 / sensor.rate_hz if sensor.rate_hz else control_period
    controller.reset(frame.object_pose, frame.pusher_xy)     # slow preparation happens before the clock
    x = camera.state                                          # the true state, checked once per step
    states, commands, lam, ms, events = [x], [], [], [], []
    counts = planner_counts(controller)
    success = bool(problem.success(x[:3]))
    bar = progress_bar(max_steps, desc, "step", progress)
    while not success and len(commands) < max_steps and not getattr(controller, "gave_up", False):
        t0 = time.perf_counter()
        u = np.asarray(controller.act(frame, frame_period), dtype=np.float64)
        ms.append((time.perf_counter() - t0) * 1e3)
        lam.append(np.asarray(getattr(controller, "params", np.full(3, np.nan)), dtype=np.float64))
        if counts is not None:
            events.append(counts())
        frame = camera.step(u, control_period)
        x = camera.state
        commands.append(u)
        states.append(x)
        success = bool(problem.success(x[:3]))
        bar.update(1)
        if problem.has_obstacles and bool(problem.collides(x)):
            success = False          # touching the obstacle fails the trial (conventions.md#benchmark-tasks)
            break
    bar.close()
    return TrialResult(spec or TrialSpec(0), success, np.asarray(states), np.asarray(commands).reshape(-1, 2),
                       np.asarray(lam).reshape(-1, 3), np.asarray(ms),
                       tuple(getattr(controller, "planning_s", ())),
                       *(getattr(controller, name, None) for name in ESTIMATOR_COUNTERS),
                       stall_resets=getattr(controller, "stall_resets", None),
                       push_plans=getattr(controller, "push_plans", None),
                       frames=None if sensor.perfect else camera.counts(),
                       events=np.asarray(events, dtype=np.int32).reshape(-1, 2) if counts is not None else None)


def planner_counts(controller: Controller) -> Callable[[], tuple[int, int]] | None:
    """A reader of ``controller``'s stall restarts and push plans so far (0 for a count it keeps without a
    plan, such as push plans switched off), or None for a controller that counts neither."""
    if getattr(controller, "stall_resets", None) is None:
        return None
    return lambda: (int(controller.stall_resets), int(getattr(controller, "push_plans", None) or 0))


def plant_name(plant: str | Plant) -> str:
    """How a record names the plant: its registry name, or the class name of a plant object."""
    return plant if isinstance(plant, str) else type(plant).__name__


def trial_spec(params: str | object, method: str | Method, seed: int) -> TrialSpec:
    """The :class:`TrialSpec` of one trial; ``params`` is a scenario name (``known``,
    ``unknown``) or the λ_pred = [β, x_bf, y_bf] the controller starts from."""
    method = get_method(method)
    if isinstance(params, str):
        check_condition(params, method)
        lam = PARAMS[params]
    else:
        vec = checked_vector("params", params, 3)
        check_params(vec)
        lam = tuple(float(v) for v in vec)
    return TrialSpec(int(seed), lam, method.estimates)


def batched(plant: str | Plant, method: str | Method, sensor: Sensor | None) -> bool:
    """Whether a trial runs in the batched simulator: a batched method on the model plant, exact observations."""
    return plant == "model" and get_method(method).batched and (sensor is None or sensor.perfect)


def run_trial(problem: Problem, starts: Starts, spec: TrialSpec, method: str | Method,
              plant: str | Plant = "model", sensor: Sensor | None = None,
              settings: ControllerSettings | None = None, max_steps: int = MAX_STEPS, progress: bool = False,
              lanes: int = 1, chunk: int = 25, desc: str = "episode") -> TrialResult:
    """One trial of ``problem`` from ``starts(spec.seed)``: batched on the model plant with exact
    observations (``lanes``, ``chunk``: see :func:`dexpush.experiments.simulate.simulate`), otherwise
    through :func:`run_loop`.

    ``plant`` is a name from :data:`dexpush.experiments.registry.PLANTS` or a plant object. A
    realistic ``sensor`` is reseeded per trial (its seed × 1,000,003 + the trial seed);
    ``physics-random`` builds world ``spec.seed`` with its own camera (``sensor`` is unused).
    """
    method = get_method(method)
    settings = settings or ControllerSettings()
    method.check(problem, sensor is None or sensor.perfect)
    if batched(plant, method, sensor):
        return simulate(problem, [spec], settings, starts=starts, max_steps=max_steps, lanes=lanes, chunk=chunk,
                        progress=progress, desc=desc)[0]
    if sensor is not None:
        sensor = replace(sensor, seed=sensor.seed * 1_000_003 + spec.seed)
    sensor = world_sensor(plant, sensor, spec.seed)
    world = (make_plant(plant, problem.shape, spec.seed, problem.table) if isinstance(plant, str)
             else check_plant(plant))
    controller = method.controller(problem, spec.params, spec.seed, settings)
    pose, pusher = starts(spec.seed)
    return run_loop(world, controller, problem, pose, pusher, sensor=sensor,
                    control_period=settings.mppi.control_period, max_steps=max_steps, spec=spec, progress=progress,
                    desc=f"{desc} ({method.name}, {plant_name(plant)})")


def run_episode(task: str | Task = "I", shape: str | Shape = "rect", params: str | object = "known",
                method: str | Method = "mppi", seed: int = 0, max_steps: int = MAX_STEPS,
                settings: ControllerSettings | None = None, progress: bool = False, lanes: int = 1,
                chunk: int = 25, plant: str | Plant = "model", sensor: Sensor | None = None) -> Episode:
    """Run one closed-loop trial (docs/conventions.md#benchmark-tasks) and record it.

    ``params`` is ``"known"``, ``"unknown"`` or a λ_pred = [β, x_bf, y_bf] to start from
    (recorded as ``custom``); ``method`` a name from :data:`dexpush.experiments.methods.METHODS`
    or a :class:`dexpush.experiments.methods.Method`.

    ``plant`` is ``"model"``, ``"physics"`` or any :class:`dexpush.common.interfaces.Plant`
    object (your own simulator or robot). On the model plant with exact observations and
    a batched method the trial runs in the batched simulator (``lanes`` =
    :data:`dexpush.experiments.benchmark.BENCH_LANES` reproduces the benchmark's record of this seed
    exactly); otherwise in :func:`run_loop`.
    """
    task = get_task(task)
    shape_name = shape if isinstance(shape, str) else shape.name
    shape = make_shape(shape) if isinstance(shape, str) else shape
    method = get_method(method)
    spec = trial_spec(params, method, seed)
    if max_steps < 1:
        raise ValueError(f"max_steps must be >= 1, got {max_steps}")
    if isinstance(plant, str) and plant not in PLANTS:
        raise ValueError(f"unknown plant {plant!r}; choose one of {', '.join(PLANTS)}")
    settings = settings or ControllerSettings()
    problem = task.problem(shape, settings.weights, seed=seed)
    problem.check_start(*task.trial_start(shape, seed), what=f"the start of seed {seed}")
    result = run_trial(problem, lambda s: task.trial_start(shape, s), spec, method, plant, sensor, settings, max_steps,
                       progress, lanes, chunk, desc=f"task {task.key} {shape.name}")
    condition = Condition(task.key, shape_name, params if isinstance(params, str) else "custom", method.name)
    return make_episode(problem, condition, result, lanes if batched(plant, method, sensor) else 1,
                        plant=plant_name(plant), sensor=world_sensor(plant, sensor, seed),
                        control_period=settings.mppi.control_period, method=method)
