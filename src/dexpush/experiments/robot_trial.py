"""One pushing episode on a Franka (:func:`run_robot_episode`): the simulated FR3 of franky-sim on a
loopback address, or a real robot at its FCI address, driven through franky-control, with the
planner behind the frame guard and the safety filter and the robot behind its watchdog
(docs/robot.md). The episode is recorded as ``dexpush run`` records one.
"""

from __future__ import annotations

from contextlib import ExitStack
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from dexpush.common.checks import check_nonnegative, check_positive
from dexpush.common.se2 import rotate
from dexpush.control.controller import ControllerSettings
from dexpush.experiments.arm_room import bent_way_room, room_record, way_room
from dexpush.experiments.methods import Method, get_method
from dexpush.experiments.records import Condition, Episode, make_episode
from dexpush.experiments.runner import run_trial, trial_spec
from dexpush.experiments.scenarios import MAX_STEPS, Task
from dexpush.model.polygons import distance_to_polygons
from dexpush.model.shape import Shape
from dexpush.problem.problem import Problem
from dexpush.problem.regions import MAX_POLYGON_CORNERS, clip_convex, halfplane_corners, workspace_halfplanes
from dexpush.problem.weights import CostWeights
from dexpush.robot.driver import DriverSettings, RobotPlant
from dexpush.robot.guarded import FrameGuard, GuardedController
from dexpush.robot.object_watch import ObjectWatch, ObjectWatchSettings
from dexpush.robot.safety import SafetySettings

__all__ = ["EXIT_TOLERANCE_M", "ArmPlacement", "Guarded", "RobotSettings", "arm_problem", "arm_safety", "place_on_arm",
           "placed_driver", "reachable_pusher_start", "robot_area", "robot_problem", "robot_sensor", "run_arm_problem",
           "run_robot_episode", "task_centre", "task_workspace"]

#: a tip beyond the workspace by more than this (m) counts as a workspace exit (the arm's tracking
#: error at the boundary, well under a millimetre, does not)
EXIT_TOLERANCE_M = 0.002


@dataclass(frozen=True)
class RobotSettings:
    """The robot side of an episode (the ``[robot]`` table of a configuration file).

    ``driver.table_origin`` and ``table_yaw`` place the table frame in the robot's base frame; for
    the simulated robot they are chosen per episode (:meth:`DriverSettings.facing`: the task in
    front of the robot) unless ``place_task`` is False. The planner keeps the pusher within the task's
    area (its workspace, or the box around start and goal grown by ``workspace_margin``, within
    ``safety.workspace``) and ``reach_margin`` inside the arm's reach, the filter's workspace; and the
    object a pusher's width and ``object_room`` further in (:func:`robot_area`).
    """

    safety: SafetySettings = field(default_factory=SafetySettings)
    driver: DriverSettings = field(default_factory=DriverSettings)
    guard: FrameGuard | None = field(default_factory=FrameGuard)   #: None: frames reach the planner as they come
    #: the filter's rows that slow the pusher when the frames show the object closing on an obstacle, e.g.
    #: ``ObjectWatchSettings()``; None (the default): the filter guards the pusher only. Off because it measured
    #: worse than none (docs/robot.md#the-objects-clearance)
    object_watch: ObjectWatchSettings | None = None
    frame_timeout_s: float = 0.5          #: no frame for this long: the pusher stops until frames return (s)
    watchdog_s: float = 0.15              #: no command for this long (wall time): the watchdog stops the robot (s)
    deadline_s: float = 0.02              #: the planner's deadline after each tick (s): half a 25 Hz period
    #: the default workspace around start and goal (m): grown by this, the box lies beyond the arm's outer circle
    #: along Task III's way past its disc (docs/robot.md#the-tasks-area-round-the-disc)
    workspace_margin: float = 0.40
    reach_margin: float = 0.02            #: the planner keeps the pusher this far inside the arm's reach (m)
    object_room: float = 0.01             #: ... and the object's footprint a pusher's width and this further (m)
    place_task: bool = True               #: the simulated robot: place the table frame for the task

    def object_inset(self, pusher_radius: float) -> float:
        """How far inside the arm's reach the object's footprint stays (m): ``reach_margin``, a pusher's width
        (2 × ``pusher_radius``) and ``object_room``, so the pusher can get round the object."""
        return self.reach_margin + 2 * pusher_radius + self.object_room

    def __post_init__(self) -> None:
        for name in ("frame_timeout_s", "watchdog_s", "deadline_s"):
            check_positive(name, getattr(self, name))
        check_nonnegative("workspace_margin", self.workspace_margin, "m")
        check_nonnegative("reach_margin", self.reach_margin, "m")
        check_nonnegative("object_room", self.object_room, "m")


def task_workspace(points: object, margin: float) -> tuple[float, float, float, float]:
    """The box (x_min, y_min, x_max, y_max) around ``points`` (table frame, m) grown by ``margin``."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    lo, hi = p.min(0) - margin, p.max(0) + margin
    return float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1])


class Guarded(Method):
    """``method``'s controller behind the frame guard and the safety filter (:class:`GuardedController`);
    records under the inner method's name. ``make`` builds the wrapper from the inner controller."""

    def __init__(self, method: Method, make: Any) -> None:
        self.inner = method
        self._make = make
        for name in ("name", "description", "obstacles", "cameras", "estimates", "default"):
            setattr(self, name, getattr(method, name))
        self.batched = False
        self.last: GuardedController | None = None

    def controller(self, problem: Any, params: object, seed: int = 0,
                   settings: ControllerSettings | None = None) -> GuardedController:
        self.last = self._make(self.inner.controller(problem, params, seed, settings))
        return self.last

    def diagnostics(self, result: Any) -> dict[str, Any]:
        return self.inner.diagnostics(result)


def run_robot_episode(task: Task, shape: Shape, *, params: str | object = "unknown", method: str | Method = "mppi-ukf",
                      seed: int = 0, settings: ControllerSettings | None = None, sensor: Any = None,
                      robot: RobotSettings | None = None, address: str | None = None, sim: Any = None,
                      max_steps: int = MAX_STEPS, progress: bool = False, on_step: Any = None,
                      world: Any = None, driver: Any = None) -> tuple[Episode, dict]:
    """One episode of ``task`` with ``shape`` on a Franka, and what the robot side saw.

    Args:
        task: the goal, obstacles and start distribution (``seed`` draws the start).
        shape, params, method, seed, settings, sensor, max_steps, progress: as for
            :func:`dexpush.experiments.runner.run_episode`; ``sensor`` sees the robot plant: the
            noise-model camera (:class:`dexpush.world.sensing.SensorSettings`) or, on the simulated robot,
            rendered images of its world (:class:`dexpush.world.rendered_camera.RenderSettings`:
            :class:`dexpush.robot.robot_camera.RobotCamera`).
        robot: :class:`RobotSettings`.
        address: a real robot's FCI address (then the object's pose comes from ``sim``, which must
            be a :class:`dexpush.robot.driver.PoseSource`: your tracker); None: the simulated robot.
        sim: the simulator's settings (:class:`dexpush.robot.franka_sim.SimSettings`) or, with
            ``address``, the pose source.
        on_step: called with ``(period, plant, simulator or None, guarded controller)`` before each
            control period's ``act`` (fault injection).
        world, driver: a simulated robot already running (a started
            :class:`dexpush.robot.franka_sim.FrankaSim`) and a driver connected to it, for an episode that is
            one step of a longer script (docs/goal_regions.md#the-demonstration-on-the-franka): the episode
            uses them as they are (their frames, the object where it lies) and leaves them running.

    Returns:
        the :class:`dexpush.experiments.records.Episode` and a dict of the robot side: the
        simulator's checks (reflex-level limit violations, joint-limit steps, real-time factor), the
        filter's and guard's counters, late steps, watchdog trips, the pusher tip's tracking error.
    """
    from dexpush.robot.franky_driver import FrankyDriver

    robot = robot or RobotSettings()
    settings = settings or ControllerSettings()
    method = get_method(method)
    task_problem = task.problem(shape, settings.weights, seed=seed)
    pose, pusher = task.trial_start(shape, seed)
    if address is not None or world is not None:   # a real object is where it is: the pusher starts where the
        source = sim if world is None else world    # task puts it relative to the object
        pose, pusher = _start_at(np.asarray(source.object_pose(), dtype=np.float64), pose, pusher)
    if world is not None:
        driver_settings = world.settings.driver
    elif robot.place_task and address is None:
        driver_settings = placed_driver(task_problem, robot, pose)
    else:
        driver_settings = robot.driver
    problem, pusher = arm_problem(task_problem, robot, driver_settings, pose, pusher)
    safety = arm_safety(problem, robot, driver_settings)
    T = settings.mppi.control_period
    with ExitStack() as stack:
        if world is not None:
            poses, address, realtime = world, world.address, False
        elif address is None:
            from dexpush.robot.franka_sim import FrankaSim, SimSettings
            from dexpush.robot.tabletop import Tabletop

            sim_settings = replace(sim or SimSettings(), driver=driver_settings)
            if problem.table is not None and sim_settings.tabletop is None:     # an overhang's table has edges
                sim_settings = replace(sim_settings, tabletop=Tabletop(table=problem.table))
            world = stack.enter_context(FrankaSim(shape, problem.obstacles, sim_settings, problem.polygons))
            poses, address, realtime = world, world.address, False
        else:
            world, poses, realtime = None, sim, True
        if world is not None:
            sensor = robot_sensor(sensor, world, (pose[:2] + np.asarray(problem.goal[:2])) / 2)
        if driver is None:
            driver = FrankyDriver(address, driver_settings, realtime=realtime)
            stack.callback(driver.close)
        plant = stack.enter_context(RobotPlant(driver, poses, deadline_s=robot.deadline_s, watchdog_s=robot.watchdog_s))
        def make(controller: Any) -> GuardedController:
            g = guarded_controller(controller, problem, robot, safety, T, position=lambda: driver.tip()[:2])
            if on_step is not None:
                g.on_act = lambda k: on_step(k, plant, world, g)
            return g

        guarded = Guarded(method, make)
        spec = trial_spec(params, method, seed)
        result = run_trial(problem, lambda _: (pose, pusher), spec, guarded, plant, sensor, settings, max_steps,
                           progress, desc=f"robot task {task.key} {shape.name}")
        plant.close()                 # stopped before the record is made (the watchdog has nothing to watch)
        condition = Condition(task.key, shape.name, params if isinstance(params, str) else "custom", method.name)
        episode = make_episode(problem, condition, result, 1, plant="franka-sim" if world is not None else "franka",
                               sensor=sensor, control_period=T, method=method)
        report = robot_report(episode, plant, guarded.last, world, T, safety, shape.pusher_radius)
        report.update(room_record(task_problem, robot, driver_settings, pose))
    return episode, report


def placed_driver(problem: Problem, robot: RobotSettings, pose: object) -> DriverSettings:
    """``robot.driver`` with the table frame placed for an episode of ``problem`` that starts at ``pose``: the
    task across the robot's front (:meth:`DriverSettings.facing`, at :func:`task_centre`)."""
    return robot.driver.facing(np.asarray(pose)[:2], np.asarray(problem.goal[:2]), task_centre(problem, robot, pose))


@dataclass(frozen=True)
class ArmPlacement:
    """An episode of a task placed on the simulated arm (:func:`place_on_arm`)."""

    task_problem: Problem      #: the task's own problem
    driver: DriverSettings     #: the driver with the table frame placed for the episode (:func:`placed_driver`)
    problem: Problem           #: the problem the planner solves on the arm (:func:`arm_problem`)
    pose: np.ndarray           #: the object's start (x, y, θ)
    pusher: np.ndarray         #: the pusher's start, where the arm reaches (:func:`reachable_pusher_start`)


def place_on_arm(task: Task, shape: Shape, robot: RobotSettings, seed: int,
                 weights: CostWeights | None = None) -> ArmPlacement:
    """The episode ``seed`` of ``task`` with ``shape`` placed across the simulated arm's front and bounded by
    its reach, as :func:`run_robot_episode` and :func:`run_arm_problem` place it."""
    task_problem = task.problem(shape, weights, seed=seed)
    pose, pusher = task.trial_start(shape, seed)
    driver = placed_driver(task_problem, robot, pose)
    problem, pusher = arm_problem(task_problem, robot, driver, pose, pusher)
    return ArmPlacement(task_problem, driver, problem, np.asarray(pose, dtype=np.float64), pusher)


def arm_problem(problem: Problem, robot: RobotSettings, driver: DriverSettings, pose: object,
                pusher: object) -> tuple[Problem, np.ndarray]:
    """The problem the planner solves on the arm, and the pusher's start: ``problem`` bounded by the arm's
    reach (:func:`robot_area`, :func:`robot_problem`) for an episode that starts with the object at ``pose``
    and the pusher at ``pusher``, which moves to where the arm reaches (:func:`reachable_pusher_start`)."""
    area, reach, keep_out = robot_area(problem, robot, driver, pose, pusher)
    return (robot_problem(problem, area, reach, keep_out),
            reachable_pusher_start(problem.shape, np.asarray(pose, dtype=np.float64), np.asarray(pusher), reach,
                                   keep_out))


def arm_safety(problem: Problem, robot: RobotSettings, driver: DriverSettings) -> SafetySettings:
    """The safety filter's settings on the arm for ``problem`` (:func:`arm_problem`'s): ``robot.safety`` with the
    pusher's bound as its workspace, and the arm's reach (``driver``'s) unless ``robot.safety`` sets one."""
    safety = replace(robot.safety, workspace=problem.pusher_workspace)
    return safety if safety.reach is not None else replace(safety, reach=driver.reach_in_table())


def guarded_controller(controller: Any, problem: Problem, robot: RobotSettings, safety: SafetySettings,
                       control_period: float, position: Any = None) -> GuardedController:
    """``controller`` behind a fresh copy of ``robot``'s frame guard and the safety filter ``safety``, kept off
    ``problem``'s obstacles, with the object's watch (``robot.object_watch``); ``position`` reads the pusher tip
    (None: carried from the frames)."""
    guard = None if robot.guard is None else replace(robot.guard)
    watch = (None if robot.object_watch is None else
             ObjectWatch(problem.shape, problem.obstacles, problem.polygons, robot.object_watch))
    return GuardedController(controller, control_period, safety, problem.obstacles, problem.shape.pusher_radius,
                             guard, position=position, frame_timeout_s=robot.frame_timeout_s,
                             polygons=problem.polygons, watch=watch)


def run_arm_problem(task: Task, shape: Shape, *, params: str | object = "unknown", method: str | Method = "mppi-ukf",
                    seed: int = 0, settings: ControllerSettings | None = None, sensor: Any = None,
                    robot: RobotSettings | None = None, plant: str = "physics", max_steps: int = MAX_STEPS,
                    filtered: bool = False, progress: bool = False,
                    placed: ArmPlacement | None = None) -> tuple[Episode, dict]:
    """One episode of the problem the planner solves on the simulated robot (placed and bounded as
    :func:`run_robot_episode` places and bounds it; ``placed``: that placement, :func:`place_on_arm` of the same
    task, shape, robot, seed and weights, where the caller has it) on ``plant`` without the arm: the pusher moves as
    commanded, with no robot clock, and with no frame guard or safety filter unless ``filtered`` (then the
    robot's own, :class:`GuardedController` with :func:`arm_safety`, the pusher's position carried from the
    frames). What fails here is the planner's in the arm's band; what fails only on the robot is the arm's
    (docs/robot.md#the-arms-problem-without-the-arm).

    Returns:
        the :class:`dexpush.experiments.records.Episode` and the way's room
        (:func:`dexpush.experiments.arm_room.room_record`).
    """
    robot = robot or RobotSettings()
    settings = settings or ControllerSettings()
    method = get_method(method)
    placed = placed or place_on_arm(task, shape, robot, seed, settings.weights)
    problem, driver, pose, pusher = placed.problem, placed.driver, placed.pose, placed.pusher
    runs = method
    if filtered:
        safety, T = arm_safety(problem, robot, driver), settings.mppi.control_period
        runs = Guarded(method, lambda c: guarded_controller(c, problem, robot, safety, T))
    result = run_trial(problem, lambda _: (pose, pusher), trial_spec(params, method, seed), runs, plant, sensor,
                       settings, max_steps, progress, desc=f"task {task.key} {shape.name} in the arm's band")
    condition = Condition(task.key, shape.name, params if isinstance(params, str) else "custom", method.name)
    episode = make_episode(problem, condition, result, 1, plant=plant, sensor=sensor,
                           control_period=settings.mppi.control_period, method=method)
    return episode, room_record(placed.task_problem, robot, driver, pose)


def robot_area(problem: Problem, robot: RobotSettings, driver: DriverSettings, pose: object,
               pusher: object) -> tuple[tuple, tuple, tuple]:
    """Where the object may go on the robot and where the pusher may go (each its corners, table frame), and the
    keep-out disc round the arm's base (:attr:`Problem.keep_out`), for an episode that starts with the object
    at ``pose`` and the pusher at ``pusher``.

    The area: the task's workspace (or, without one, the box round start, pusher and goal grown by
    ``robot.workspace_margin``), within ``robot.safety``'s workspace where one is given. The pusher's: that
    within the arm's outer reach, ``robot.reach_margin`` inside it (:meth:`DriverSettings.reach_halfplanes`),
    and ``robot.reach_margin`` beyond its inner circle (the keep-out disc's r_p). The object's footprint
    stays a pusher's width and ``robot.object_room`` further inside (:meth:`RobotSettings.object_inset`), where
    the pusher can get round it (an object pushed where the pusher cannot follow cannot be pushed back; its
    outer lines touch the circle, where the pusher's are inscribed in theirs), each bound eased as far as the
    start's and the goal's footprints need to lie clear of the cost's margin (``obstacle_margin_m``) by 5 mm.
    The band is the annulus itself: a way across the robot's front may bend round the base, where a line
    across the inner circle would make it a chord (docs/robot.md#the-band-is-an-annulus). With an overhang goal
    the object's area reaches past that edge (its footprint crosses it there; the pusher stays on the table).
    """
    pose = np.asarray(pose, dtype=np.float64)
    goal = np.asarray(problem.goal, dtype=np.float64)
    points = [pose[:2], np.asarray(pusher, dtype=np.float64), goal[:2]]
    area = np.asarray(problem.workspace if problem.workspace is not None
                      else _box_corners(task_workspace(points, robot.workspace_margin)))
    if robot.safety.workspace is not None:
        area = clip_convex(area, robot.safety.workspace_rows)
    free = area                              # the object's: past an overhang's edge too (the footprint crosses it)
    goal_rows = problem.region_rows
    if goal_rows is not None and goal_rows.edge:
        lines = workspace_halfplanes(area)
        lines[np.all(np.isclose(lines, goal_rows.keep[:1, :3]), axis=1), 2] += 2 * problem.shape.bounding_radius
        free = halfplane_corners(lines)
    ends = np.concatenate([*problem.shape.footprint_world(pose), *problem.shape.footprint_world(goal)])
    inset = robot.object_inset(problem.shape.pusher_radius)
    ease = problem.weights.obstacle_margin_m + 0.005      # a start or goal never inside the cost's margin
    for sides in (16, 12, 8):                 # the reach's polygon with as many sides as a workspace may have
        reach = clip_convex(area, driver.reach_halfplanes(robot.reach_margin, sides))
        held = driver.reach_halfplanes(inset, sides, inscribed=False)
        held[:, 2] = np.maximum(held[:, 2], np.max(ends @ held[:, :2].T, 0) + ease)
        held = clip_convex(free, held)
        if max(len(reach), len(held)) <= MAX_POLYGON_CORNERS:
            break
    if len(held) < 3 or len(reach) < 3:
        raise ValueError("the task lies outside the arm's reach and the workspace: nothing is left to push in "
                         "(move the task or the table frame)")
    bx, by, r_min, _ = driver.reach_in_table()
    nearest = _nearest_footprint(np.array([bx, by]), problem.shape, (pose, goal))
    if nearest <= ease:
        raise ValueError("the start or the goal lies over the arm's base, inside its reach: move the task or the "
                         "table frame")
    keep_out = ((bx, by, min(r_min + inset, nearest - ease), r_min + robot.reach_margin),)
    return tuple(map(tuple, held.tolist())), tuple(map(tuple, reach.tolist())), keep_out


def _nearest_footprint(point: np.ndarray, shape: Shape, poses: tuple) -> float:
    """The least distance (m) from ``point`` to ``shape``'s footprint at any of ``poses`` (0 inside one)."""
    return min(float(distance_to_polygons(point, shape.footprint_world(p))) for p in poses)


def robot_sensor(sensor: Any, world: Any, middle: object) -> Any:
    """``sensor`` for the simulated robot ``world``: rendered images of that world around the task's ``middle``
    when ``sensor`` renders (:class:`dexpush.robot.robot_camera.RobotRenderSettings`), else as it is."""
    from dexpush.world.rendered_camera import RenderSettings

    if not isinstance(sensor, RenderSettings):
        return sensor
    from dexpush.robot.robot_camera import RobotRenderSettings

    fields = {f: getattr(sensor, f) for f in RenderSettings.__dataclass_fields__}
    return RobotRenderSettings(**fields, world=world, middle=tuple(float(v) for v in middle))


def task_centre(problem: Problem, robot: RobotSettings, pose: object,
                step: float = 0.005) -> tuple[float, float] | None:
    """Where :meth:`DriverSettings.facing` puts the task's middle for an episode that starts at ``pose``, on the
    base's x axis at a distance c from it (``step`` apart).

    With no obstacles, c gives the way the most room in the annulus :func:`robot_area` bounds the object by: the
    largest :func:`dexpush.experiments.arm_room.way_room` over ways that bend round the base by 0–20 cm
    (:func:`~dexpush.experiments.arm_room.bent_way_room`). A long push across the front fits the FR3's band only
    bent (docs/robot.md#the-band-is-an-annulus). With walls or a workspace of its own (Task IV), whose bounds
    leave no room for a bend, c gives the straight way the most room (docs/robot.md#task-ivs-place-on-the-arm).

    With discs alone, c is chosen among those at which the start's and the goal's footprints lie within that
    annulus where the narrower of the ways past each obstacle is widest: for each disc the wider of its two
    gaps, outward to the annulus's outer circle and inward to its inner one, and of those the smallest,
    maximised over c. The arm's annulus is wide enough for a detour on one side only; the obstacle then lies
    against the other.
    """
    r_min, r_max = robot.driver.reach
    walled = bool(problem.polygons) or problem.workspace is not None
    if walled or not problem.obstacles:
        start, goal = np.asarray(pose)[:2], np.asarray(problem.goal)[:2]

        def room(c: float) -> float:
            driver = robot.driver.facing(start, goal, (c, 0.0))
            return way_room(problem, robot, driver, pose) if walled else bent_way_room(problem, robot, driver, pose)[0]

        return max((room(float(c)), round(float(c), 4)) for c in np.arange(r_min, r_max, step))[1], 0.0
    pose = np.asarray(pose, dtype=np.float64)
    goal = np.asarray(problem.goal, dtype=np.float64)
    ends = np.concatenate([*problem.shape.footprint_world(pose), *problem.shape.footprint_world(goal)])
    discs = np.asarray(problem.obstacles, dtype=np.float64)
    inset = robot.object_inset(problem.shape.pusher_radius)
    best, best_gap = None, -np.inf
    for c in np.arange(r_min, r_max, step):
        bx, by, _, _ = robot.driver.facing(pose[:2], goal[:2], (float(c), 0.0)).reach_in_table()
        base = np.array([bx, by])
        nearest = _nearest_footprint(base, problem.shape, (pose, goal))
        if nearest < r_min + inset or np.max(np.linalg.norm(ends - base, axis=1)) > r_max - inset:
            continue
        outward = r_max - inset - np.linalg.norm(discs[:, :2] - base, axis=1) - discs[:, 2]
        inward = np.linalg.norm(discs[:, :2] - base, axis=1) - discs[:, 2] - (r_min + inset)
        gap = float(np.min(np.maximum(outward, inward)))
        if gap > best_gap + 1e-9:
            best, best_gap = (round(float(c), 4), 0.0), gap
    return best


def robot_problem(problem: Problem, area: tuple, reach: tuple, keep_out: tuple = ()) -> Problem:
    """``problem`` with the object within ``area`` and the pusher within ``reach``, both out of the ``keep_out``
    disc (:func:`robot_area`), and within the task's own workspace where it has one. The keep-out disc builds
    a cost-to-go (:mod:`dexpush.problem.guidance`) whose way bends round the base within ``area``
    (docs/robot.md#the-band-is-an-annulus)."""
    return replace(problem, object_workspace=area, pusher_workspace=reach, keep_out=tuple(keep_out))


def reachable_pusher_start(shape: Shape, pose: np.ndarray, pusher: np.ndarray, reach: tuple,
                           keep_out: tuple = ()) -> np.ndarray:
    """The task's pusher start when the pusher disc lies inside ``reach`` (corners) and out of the ``keep_out``
    discs (their r_p); otherwise the same distance outside the object's inflated contour at the azimuth nearest
    the task's that does (scanned in 1° steps)."""
    rows = workspace_halfplanes(reach)
    discs = np.asarray(keep_out, dtype=np.float64).reshape(-1, 4)

    def gap(p: np.ndarray) -> float:
        out = np.linalg.norm(p - discs[:, :2], axis=1) - discs[:, 3] if len(discs) else np.full(1, np.inf)
        return min(float(np.min(rows[:, 2] - rows[:, :2] @ p)), float(out.min())) - shape.pusher_radius

    if gap(pusher) >= 0:
        return pusher
    local = rotate(np.asarray(pusher, dtype=np.float64) - pose[:2], -pose[2])
    phi0 = float(np.arctan2(local[1], local[0]))
    clearance = float(np.linalg.norm(local) - np.linalg.norm(shape.contour(np.array(phi0))[0]))
    for step in np.radians(np.arange(1, 181)):
        for phi in (phi0 + step, phi0 - step):
            r = np.asarray(shape.contour(np.array(phi))[0], dtype=np.float64)
            p = pose[:2] + rotate(r * (1.0 + clearance / np.linalg.norm(r)), pose[2])
            if gap(p) >= 0:
                return p
    return pusher


def _box_corners(box: tuple[float, float, float, float]) -> np.ndarray:
    x0, y0, x1, y1 = box
    return np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]])


def _start_at(pose: np.ndarray, task_pose: np.ndarray, task_pusher: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The start from the object's pose ``pose``: the pusher where the task's start puts it relative to the object."""
    local = rotate(np.asarray(task_pusher) - task_pose[:2], -task_pose[2])
    return pose, pose[:2] + rotate(local, pose[2])


def tracking_error(states: np.ndarray, commands: np.ndarray, control_period: float) -> np.ndarray:
    """Per control period, how far the pusher tip ended from where its command would have taken it (m):
    |p_{k+1} − (p_k + u_k·T)|."""
    p = np.asarray(states, dtype=np.float64)[:, 3:5]
    u = np.asarray(commands, dtype=np.float64).reshape(-1, 2)
    n = min(len(u), len(p) - 1)
    return np.linalg.norm(p[1:n + 1] - (p[:n] + u[:n] * control_period), axis=1)


def robot_report(episode: Episode, plant: RobotPlant, guarded: GuardedController | None, world: Any,
                 control_period: float, safety: SafetySettings, pusher_radius: float = 0.0) -> dict:
    """The robot side of a finished episode (see :func:`run_robot_episode`)."""
    states, commands = episode.states, episode.commands
    err = tracking_error(states, commands, control_period)
    tips = states[:, 3:5]
    rows = safety.workspace_rows        # the pusher disc beyond the workspace's edges (m)
    beyond = np.max(tips @ rows[:, :2].T - rows[:, 2] + pusher_radius, 1) if len(rows) else np.zeros(len(tips))
    speed = np.linalg.norm(commands, axis=1) if len(commands) else np.zeros(1)
    out = {"late_steps": plant.late_steps, "watchdog_stops": plant.watchdog_stops,
           "tracking_error_mm_median": round(float(np.median(err)) * 1e3, 3) if len(err) else None,
           "tracking_error_mm_p99": round(float(np.percentile(err, 99)) * 1e3, 3) if len(err) else None,
           "workspace_exits": int(np.sum(beyond > EXIT_TOLERANCE_M)),
           "workspace_overshoot_mm": round(max(float(beyond.max()), 0.0) * 1e3, 3),
           "speed_limit_exceeded": int(np.sum(speed > safety.v_max + 1e-9)),
           "driver_retries": getattr(plant.driver, "retries", 0)}
    if out["driver_retries"]:     # what the robot said and when (its clock), to set beside the stream's maxima
        out["driver_retry_s"] = [round(float(t), 3) for t in getattr(plant.driver, "retry_times", [])]
        out["driver_errors"] = sorted({str(e)[:160] for e in getattr(plant.driver, "errors", [])})[:3]
    if guarded is not None:
        out.update({"filtered": guarded.filtered, "relaxed": guarded.relaxed, "stopped": guarded.stopped,
                    "blind_steps": guarded.blind, "frames_held": guarded.guard.held if guarded.guard else 0,
                    "limited_by": dict(sorted(guarded.limited_by.items()))})
    if world is not None:
        r = world.report()
        out.update({"reflex_limit_steps": r.over_limits, "max_commanded_acceleration": round(r.max_acceleration, 3),
                    "max_commanded_jerk": round(r.max_jerk, 1), "max_commanded_jerk_at_s": round(r.max_jerk_at_s, 3),
                    "joint_limit_steps": r.joint_limit_steps,
                    "missed_commands": r.missed_commands, "real_time_factor": round(r.real_time_factor, 3),
                    "sim_s": round(r.sim_s, 3)})
    return out
