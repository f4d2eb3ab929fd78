"""The robot side without a robot: the watchdog, the robot plant's clock and deadlines, and the driver
settings' frames, with a fake driver (a point that follows its command for ``command_hold_s``)."""

from __future__ import annotations

import threading
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from dexpush.robot.driver import DriverSettings, PusherDriver, RobotPlant
from dexpush.robot.watchdog import Watchdog


class FakeDriver:
    """A pusher that moves at the commanded velocity until its hold runs out; the clock is the wall clock."""

    def __init__(self, hold_s: float = 0.15) -> None:
        self.settings = DriverSettings(command_hold_s=hold_s)
        self._lock = threading.Lock()
        self._t0 = time.monotonic()
        self._p, self._v, self._until, self._at = np.zeros(2), np.zeros(2), 0.0, 0.0
        self.stops = 0

    def _advance(self) -> None:
        now = self.time()
        moving = min(now, self._until) - self._at
        if moving > 0:
            self._p = self._p + self._v * moving
        self._at = now

    def time(self) -> float:
        return time.monotonic() - self._t0

    def move_to(self, xy: object) -> None:
        with self._lock:
            self._advance()
            self._p, self._v = np.asarray(xy, float), np.zeros(2)

    def send(self, velocity: object) -> None:
        with self._lock:
            self._advance()
            self._v, self._until = np.asarray(velocity, float), self.time() + self.settings.command_hold_s

    def stop(self) -> None:
        with self._lock:
            self._advance()
            self._until = self._at
            self.stops += 1

    def moving(self) -> bool:
        with self._lock:
            return self.time() < self._until and bool(np.any(self._v))

    def tip(self) -> np.ndarray:
        with self._lock:
            self._advance()
            return np.array([*self._p, 0.004])

    def recover(self) -> bool:
        return True

    def close(self) -> None:
        self.stop()


class StillObject:
    def __init__(self) -> None:
        self.pose = np.zeros(3)

    def object_pose(self) -> np.ndarray:
        return self.pose

    def place(self, pose: object) -> None:
        self.pose = np.asarray(pose, float)


def test_the_fake_is_a_driver() -> None:
    assert isinstance(FakeDriver(), PusherDriver)


def test_the_watchdog_stops_within_a_tenth_of_a_second_of_its_deadline_and_rearms() -> None:
    stopped: list[float] = []
    with Watchdog(0.2, lambda: stopped.append(time.monotonic())) as dog:
        assert not stopped                     # not armed before the first feed
        t0 = time.monotonic()
        dog.feed()
        time.sleep(0.45)
        assert len(stopped) == 1 and 0.2 <= stopped[0] - t0 <= 0.3
        time.sleep(0.3)
        assert len(stopped) == 1               # once per silence
        for _ in range(10):                    # fed: no stop
            dog.feed()
            time.sleep(0.05)
        assert len(stopped) == 1
        time.sleep(0.35)
        assert len(stopped) == 2 and dog.trips == 2
        dog.feed()
        dog.pause()
        time.sleep(0.35)
        assert len(stopped) == 2               # paused: nothing to watch


def test_a_stop_that_raises_does_not_kill_the_watchdog() -> None:
    calls = []

    def bad_stop() -> None:
        calls.append(1)
        raise ConnectionError("robot gone")

    with Watchdog(0.05, bad_stop) as dog:
        dog.feed()
        time.sleep(0.15)
        dog.feed()
        time.sleep(0.15)
    assert len(calls) == 2 and "ConnectionError: robot gone" in dog.errors[0]


def test_a_start_the_arm_cannot_reach_is_a_start_error() -> None:
    """A motion to the episode's start that the robot refuses is a :class:`StartError` (nothing pushed yet), which
    the benchmark tells apart from a robot that stops mid-episode."""
    from dexpush.robot.driver import RobotError, StartError

    class Refusing(FakeDriver):
        def move_to(self, xy: object) -> None:
            raise RobotError("moving the pusher to [-0.1, 0.0] m failed: Motion planner failed with error code -111")

    with RobotPlant(Refusing(), StillObject(), watchdog_s=None) as plant:
        with pytest.raises(StartError, match="error code -111"):
            plant.reset((0.0, 0.0, 0.0), (-0.1, 0.0))


def test_the_plant_steps_on_the_robot_clock_and_counts_missed_deadlines() -> None:
    driver = FakeDriver()
    with RobotPlant(driver, StillObject(), watchdog_s=None) as plant:
        obs = plant.reset((0.0, 0.0, 0.0), (-0.1, 0.0))
        assert obs.time == 0.0 and np.allclose(obs.pusher_xy, (-0.1, 0.0))
        dt = 0.04
        for k in range(5):
            obs = plant.step((0.05, 0.0), dt)
            assert obs.time >= (k + 1) * dt - 1e-9
        assert plant.late_steps == 0
        time.sleep(0.1)                        # the planner overran its deadline
        plant.step((0.05, 0.0), dt)
        assert plant.late_steps == 1
        assert obs.pusher_xy[0] > -0.1
    assert driver.stops >= 1                   # closing stops the robot


def test_a_hung_loop_is_stopped_by_the_watchdog() -> None:
    driver = FakeDriver(hold_s=2.0)            # a long hold: only the watchdog can stop it in time
    with RobotPlant(driver, StillObject(), watchdog_s=0.1) as plant:
        plant.reset((0.0, 0.0, 0.0), (-0.1, 0.0))
        plant.step((0.05, 0.0), 0.04)
        t0 = time.monotonic()
        while driver.moving() and time.monotonic() - t0 < 1.0:
            time.sleep(0.005)
        assert not driver.moving() and time.monotonic() - t0 < 0.2
        assert plant.watchdog_stops == 1


def test_the_table_frame_round_trips_and_faces_the_task() -> None:
    s = DriverSettings(table_origin=(0.5, 0.1), table_yaw=0.7)
    p = np.array([[0.1, -0.2], [0.3, 0.05]])
    assert np.allclose(s.to_table(s.to_base(p)), p)
    f = DriverSettings().facing((0.0, 0.0), (0.6, 0.3))
    a, b = f.to_base((0.0, 0.0)), f.to_base((0.6, 0.3))
    mid = (a + b) / 2
    assert abs(mid[1]) < 1e-9 and 0.45 < mid[0] < 0.6
    assert abs(a[0] - b[0]) < 1e-9             # start to goal runs across the robot's front
    r_min, r_max = f.reach                     # the path's middle as far inside r_min as its ends inside r_max
    assert np.isclose(mid[0] - r_min, r_max - np.linalg.norm(a)) and np.isclose(np.linalg.norm(a), np.linalg.norm(b))
    spot = DriverSettings().facing((0.1, 0.1), (0.1, 0.1))
    assert np.allclose(spot.to_base((0.1, 0.1)), ((r_min + r_max) / 2, 0.0))
    bx, by, r0, r1 = f.reach_in_table()
    assert np.allclose(f.to_base((bx, by)), 0.0) and (r0, r1) == f.reach


@pytest.mark.parametrize("bad", [dict(dynamics_factor=1.5), dict(command_hold_s=0), dict(reach=(0.8, 0.3)),
                                 dict(tip_height=-0.01)])
def test_bad_driver_settings_are_refused(bad: dict) -> None:
    with pytest.raises(ValueError):
        DriverSettings(**bad)


@pytest.mark.parametrize("key", ["I", "II", "III", "IV"])
@pytest.mark.parametrize("shape_name", ["rect", "tee", "ellipse"])
def test_every_task_fits_the_arm_and_starts_within_its_reach(key: str, shape_name: str) -> None:
    """On the robot the planner knows the arm: the object and the pusher stay in the task's area, the object
    where the pusher can get round it, the pusher within the reach; each start fits, its pusher moved round
    the object when the task's azimuth is out of reach."""
    from dexpush.experiments.registry import make_shape
    from dexpush.experiments.robot_trial import (
        RobotSettings,
        reachable_pusher_start,
        robot_area,
        robot_problem,
        task_centre,
    )
    from dexpush.experiments.scenarios import get_task
    from dexpush.problem.regions import point_gap

    task, shape, robot = get_task(key), make_shape(shape_name), RobotSettings()
    for seed in (0, 7, 13, 29):
        problem = task.problem(shape, seed=seed)
        pose, pusher = task.trial_start(shape, seed)
        goal = np.asarray(problem.goal[:2])
        driver = robot.driver.facing(pose[:2], goal, task_centre(problem, robot, pose))
        area, reach, keep_out = robot_area(problem, robot, driver, pose, pusher)
        bounded = robot_problem(problem, area, reach, keep_out)
        start = reachable_pusher_start(shape, pose, pusher, reach, keep_out)
        bounded.check_start(pose, start)                  # raises when the start touches or leaves the area
        assert point_gap(start, np.asarray(reach)) <= -shape.pusher_radius + 1e-9
        r_min, r_max = driver.reach
        (bx, by, r_object, r_pusher), = keep_out            # the keep-out disc is the reach's inner circle
        assert np.allclose(driver.to_base((bx, by)), 0.0) and r_pusher == r_min + robot.reach_margin
        assert r_object <= r_min + robot.object_inset(shape.pusher_radius)
        assert np.hypot(*(start - (bx, by))) >= r_pusher + shape.pusher_radius - 1e-9
        r = np.linalg.norm(driver.to_base(np.asarray(reach)), axis=1)     # the pusher's area: in the outer circle
        assert np.all(r <= r_max - robot.reach_margin + 1e-9)
        assert bounded.guide is not None                  # the way round the base


@pytest.mark.parametrize("shape_name", ["rect", "tee", "ellipse"])
def test_a_disc_task_is_placed_with_one_wide_way_round_its_obstacle(shape_name: str) -> None:
    """Task III on the arm: the disc lies against one edge of the reach's band, and the way past it on the
    other side is wider than with the band's middle on the task (facing's default) and than the object across
    its way; the start and goal still fit; and the object's area
    (:func:`robot_area`: the task's default box within the reach) leaves that way as wide as the placement
    reckons it (a box 0.25 m round the task had cut it to 21 cm, where the placement saw 31)."""
    from dexpush.experiments.registry import make_shape
    from dexpush.experiments.robot_trial import RobotSettings, robot_area, task_centre
    from dexpush.experiments.scenarios import get_task
    from dexpush.problem.regions import workspace_halfplanes

    shape, robot = make_shape(shape_name), RobotSettings()
    r_min, r_max = robot.driver.reach
    inset = robot.reach_margin + 2 * shape.pusher_radius + robot.object_room
    task = get_task("III")
    for seed in (0, 7, 13, 29):
        problem = task.problem(shape, seed=seed)
        pose = task.trial_start(shape, seed)[0]
        goal = np.asarray(problem.goal[:2])

        def widest_way(driver: DriverSettings, problem: object = problem) -> float:
            cx, cy, r = problem.obstacles[0]
            rho = float(np.linalg.norm(driver.to_base((cx, cy))))
            return max(r_max - inset - rho - r, rho - r - r_min - inset)

        placed = robot.driver.facing(pose[:2], goal, task_centre(problem, robot, pose))
        default = robot.driver.facing(pose[:2], goal)
        assert widest_way(placed) > widest_way(default) + 0.02
        along = (goal - pose[:2]) / np.linalg.norm(goal - pose[:2])
        width = np.ptp(np.concatenate(shape.footprint_world(pose)) @ np.array([-along[1], along[0]]))
        assert widest_way(placed) > width + 0.02          # the object as it starts, across its way, passes
        ends = np.concatenate([*shape.footprint_world(pose), *shape.footprint_world(problem.goal)])
        assert np.all(np.linalg.norm(placed.to_base(ends), axis=1) <= r_max - inset + 1e-9)
        # outward from the base through the disc: the area's edge lies no nearer than the outer circle
        held = robot_area(problem, robot, placed, pose, task.trial_start(shape, seed)[1])[0]
        area = workspace_halfplanes(np.asarray(held))
        cx, cy, r = problem.obstacles[0]
        out = np.array([cx, cy]) - placed.reach_in_table()[:2]
        out /= np.linalg.norm(out)
        ahead = area[:, :2] @ out > 1e-9
        edge = np.min((area[ahead, 2] - area[ahead, :2] @ (cx, cy)) / (area[ahead, :2] @ out))
        assert edge - r >= r_max - inset - np.linalg.norm(placed.to_base((cx, cy))) - r - 1e-6


@pytest.mark.parametrize("shape_name", ["rect", "tee", "ellipse"])
def test_a_walled_task_is_placed_where_its_straight_way_has_the_most_room(shape_name: str) -> None:
    """Task IV (four walls round its area) on the arm: ``task_centre`` puts it where the straight way has
    the most room in the band: no less than at the band's middle (facing's default) or at any other distance
    from the base, to within half the placement's 5-mm step (the room moves no faster than the base); the T's way,
    which does not fit at the middle, fits there (docs/robot.md#task-ivs-place-on-the-arm)."""
    from dexpush.experiments.arm_room import way_room
    from dexpush.experiments.registry import make_shape
    from dexpush.experiments.robot_trial import RobotSettings, placed_driver
    from dexpush.experiments.scenarios import get_task

    task, shape, robot = get_task("IV"), make_shape(shape_name), RobotSettings()
    r_min, r_max = robot.driver.reach
    for seed in (0, 3, 13):
        problem = task.problem(shape, seed=seed)
        pose = task.trial_start(shape, seed)[0]
        goal = np.asarray(problem.goal[:2])
        room = way_room(problem, robot, placed_driver(problem, robot, pose), pose)
        middle = way_room(problem, robot, robot.driver.facing(pose[:2], goal), pose)
        others = [way_room(problem, robot, robot.driver.facing(pose[:2], goal, (c, 0.0)), pose)
                  for c in np.linspace(r_min + 0.0025, r_max - 0.0025, 40)]
        assert room >= max(middle, *others) - 0.0025 - 1e-9
        if shape_name == "tee":
            assert middle < 0 < room


def test_a_task_out_of_reach_is_refused_in_one_line() -> None:
    from dexpush.experiments.registry import make_shape
    from dexpush.experiments.robot_trial import RobotSettings, robot_area
    from dexpush.experiments.scenarios import get_task

    task, shape = get_task("I"), make_shape("rect")
    far = DriverSettings(table_origin=(3.0, 0.0))
    with pytest.raises(ValueError, match="reach"):
        robot_area(task.problem(shape), RobotSettings(), far, (0.0, 0.0, 0.0), (-0.15, 0.0))
    on_base = DriverSettings(table_origin=(0.0, 0.0), reach=(0.05, 0.8))     # the start over the base
    with pytest.raises(ValueError, match="over the arm's base"):
        robot_area(task.problem(shape), RobotSettings(), on_base, (0.0, 0.0, 0.0), (-0.15, 0.0))


def test_the_straight_ways_room_is_the_footprints_least_clearance_to_the_arms_band() -> None:
    """``way_room``: an object that stays put at the band's middle has as much room as its corners leave to the
    circle and to the line; narrowing the reach by δ takes at most δ of the room; the T's long push does not
    fit the FR3's band in a straight line where the box's does (docs/robot.md#the-arms-problem-without-the-arm)."""
    from dexpush.experiments.arm_room import way_room
    from dexpush.experiments.registry import make_shape
    from dexpush.experiments.robot_trial import RobotSettings, placed_driver
    from dexpush.experiments.scenarios import get_task
    from dexpush.problem.problem import Problem

    robot, shape = RobotSettings(), make_shape("rect")
    driver = DriverSettings(table_origin=(0.55, 0.0))             # the base at (−0.55, 0) in the table frame
    r_min, r_max = driver.reach
    inset = robot.reach_margin + 2 * shape.pusher_radius + robot.object_room
    corners = np.concatenate(shape.footprint_world((0.0, 0.0, 0.0))) + np.array([0.55, 0.0])   # from the base
    expected = min(r_max - inset - np.linalg.norm(corners, axis=1).max(), corners[:, 0].min() - r_min - inset)
    problem = Problem(shape, goal=(0.0, 0.0, 0.0))
    assert np.isclose(way_room(problem, robot, driver, (0.0, 0.0, 0.0)), expected)
    for key, name in (("I", "tee"), ("I", "rect"), ("II", "tee")):
        task, shape = get_task(key), make_shape(name)
        problem = task.problem(shape, seed=3)
        pose = task.trial_start(shape, 3)[0]
        placed = placed_driver(problem, robot, pose)
        room = way_room(problem, robot, placed, pose)
        less = way_room(problem, robot, replace(placed, reach=(r_min, r_max - 0.03)), pose)
        assert less <= room + 1e-9 and room - less <= 0.03 + 1e-9
        if key == "I":                            # straight, across the middle of the reach (facing's default)
            middle = robot.driver.facing(pose[:2], problem.goal[:2])
            assert (way_room(problem, robot, middle, pose) < 0) == (name == "tee")
    task, shape = get_task("I"), make_shape("tee")            # no distance from the base gives the T's way room
    problem = task.problem(shape, seed=3)
    pose = task.trial_start(shape, 3)[0]
    rooms = [way_room(problem, robot, robot.driver.facing(pose[:2], problem.goal[:2], (c, 0.0)), pose)
             for c in np.arange(r_min, r_max, 0.005)]
    assert -0.02 < max(rooms) < 0


@pytest.mark.parametrize(("key", "shape_name"), [("I", "tee"), ("I", "rect"), ("I", "ellipse"), ("II", "tee")])
def test_a_way_across_the_front_is_placed_where_it_fits_bent_round_the_base(key: str, shape_name: str) -> None:
    """With the reach's inner circle as the band's bound, ``task_centre`` places a task with no obstacles where a
    way bent round the base has the most room: the T's long push, which no straight way fits, gets 2 cm or more
    with a bend of 5 cm or more; the bend never takes room from a way that is straight in the open (a turn on
    the spot), and it leaves the ends where they are (bend 0 at start and goal)."""
    from dexpush.experiments.arm_room import BENDS_M, way_room
    from dexpush.experiments.registry import make_shape
    from dexpush.experiments.robot_trial import RobotSettings, placed_driver, task_centre
    from dexpush.experiments.scenarios import get_task

    task, shape, robot = get_task(key), make_shape(shape_name), RobotSettings()
    for seed in (0, 13, 1000):
        problem = task.problem(shape, seed=seed)
        pose = task.trial_start(shape, seed)[0]
        c, _ = task_centre(problem, robot, pose)
        assert robot.driver.reach[0] < c < robot.driver.reach[1]
        placed = placed_driver(problem, robot, pose)
        rooms = np.array([way_room(problem, robot, placed, pose, bend=b) for b in BENDS_M])
        assert rooms.max() >= 0.02
        if key == "I":
            assert BENDS_M[rooms.argmax()] >= 0.05                     # the way bends round the base
            far = way_room(problem, robot, placed, pose, poses=2, bend=0.2)
            assert np.isclose(far, way_room(problem, robot, placed, pose, poses=2))     # the ends stay put
        if key == "I" and shape_name == "tee":
            assert rooms[0] < 0                                          # straight, the T does not fit


def test_the_guidance_figure_draws_the_arms_bounds(tmp_path) -> None:
    """``plot_guidance`` of a problem on the arm draws the object's polygon and the base's keep-out disc (dashed,
    one legend entry), as docs/make_robot_figures.py shows them."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from dexpush.experiments.registry import make_shape
    from dexpush.experiments.robot_trial import RobotSettings, place_on_arm
    from dexpush.experiments.scenarios import get_task
    from dexpush.viz import plot_guidance

    shape = make_shape("rect")
    placed = place_on_arm(get_task("III"), shape, RobotSettings(), 0)
    fig = plot_guidance(shape, placed.problem, np.array([[*placed.pose, *placed.pusher]]), title="t",
                        path=tmp_path / "g.png")
    ax = fig.axes[0]
    dashed = [p for p in ax.patches if p.get_linestyle() == "--" and not p.get_fill()]
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    plt.close(fig)
    assert len(dashed) >= 3 and labels.count("object's bound") == 1    # the polygon, the disc, the goal
    assert (tmp_path / "g.png").stat().st_size > 10_000


def test_the_endgame_figure_draws_both_bounds_and_the_pushers_path_from_its_first_step(tmp_path) -> None:
    """``plot_endgame`` draws the object's and the pusher's bounds dashed (one legend entry each) and the pusher's
    path from step ``first`` on; a ``first`` past the end keeps the last step."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from dexpush.experiments.registry import make_shape
    from dexpush.experiments.robot_trial import RobotSettings, place_on_arm
    from dexpush.experiments.scenarios import get_task
    from dexpush.viz import plot_endgame

    shape = make_shape("tee")
    placed = place_on_arm(get_task("II"), shape, RobotSettings(), 0)
    goal = np.asarray(placed.problem.goal, dtype=float)
    step = 0.01 * np.arange(10)[:, None] * np.array([1.0, 0.0, 0.0])
    states = np.hstack([goal + step, goal[:2] + step[:, :2] - [0.1, 0.0]])      # the pusher 10 cm behind
    for first, points in ((4, 6), (99, 1)):
        fig = plot_endgame(shape, placed.problem, states, first, title="t", path=tmp_path / f"e{first}.png")
        ax = fig.axes[0]
        dashed = [p for p in ax.patches if p.get_linestyle() == "--" and not p.get_fill()]
        labels = [t.get_text() for t in ax.get_legend().get_texts()]
        assert len(dashed) == 2 and labels.count("object's bound") == labels.count("pusher's bound") == 1
        assert len(ax.collections[0].get_offsets()) == points
        plt.close(fig)
        assert (tmp_path / f"e{first}.png").stat().st_size > 10_000


def test_the_robot_benchmark_goes_on_past_an_episode_the_robot_cannot_start(tmp_path, monkeypatch, capsys) -> None:
    """An episode whose start the arm cannot reach (a move its motion planner refuses) is not recorded: the
    benchmark says so in one line, runs the rest, and ends with an error naming the episodes a re-run retries.
    A robot that stops mid-episode ends the benchmark with a one-line error."""
    import importlib.util
    import sys

    from dexpush.robot.driver import RobotError, StartError

    spec = importlib.util.spec_from_file_location("robot_sim", Path(__file__).resolve().parents[1] / "benchmarks"
                                                  / "robot_sim.py")
    robot_sim = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(robot_sim)
    calls = []

    def refused(task, shape, **kw):
        calls.append(kw["seed"])
        raise StartError("moving the pusher to [-0.15, 0.0] m failed: Motion planner failed with error code -111")

    monkeypatch.setattr(robot_sim, "run_robot_episode", refused)
    argv = ["robot_sim.py", "--out", str(tmp_path), "--tasks", "I", "--shapes", "rect", "--seeds", "0,1"]
    monkeypatch.setattr(sys, "argv", argv)
    with pytest.raises(SystemExit, match=r"2 episode\(s\) could not start .*\(I rect 0, I rect 1\).*again"):
        robot_sim.main()
    err = capsys.readouterr().err
    assert calls == [0, 1] and "I rect seed 1: the robot could not start, not recorded: moving the pusher" in err
    assert not (tmp_path / "records.jsonl").exists()

    def reflex(task, shape, **kw):
        raise RobotError("the Franka refused a velocity command twice: cartesian_reflex")

    monkeypatch.setattr(robot_sim, "run_robot_episode", reflex)
    with pytest.raises(SystemExit, match=r"^error: I rect seed 0: the robot stopped the episode: .*cartesian_reflex"):
        robot_sim.main()


def test_the_robot_benchmarks_object_watch_needs_the_filter_and_a_folder_of_its_own(tmp_path, monkeypatch) -> None:
    """``robot_sim.py --object-watch`` without the arm needs ``--with-filter`` (the watch is the filter's), and a
    folder holding episodes without the watch, or of another method, refuses a run with it
    (docs/robot.md#the-objects-clearance)."""
    import importlib.util
    import json
    import sys

    spec = importlib.util.spec_from_file_location("robot_sim", Path(__file__).resolve().parents[1] / "benchmarks"
                                                  / "robot_sim.py")
    robot_sim = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(robot_sim)
    argv = ["robot_sim.py", "--out", str(tmp_path), "--tasks", "III", "--seeds", "0", "--without-arm"]
    monkeypatch.setattr(sys, "argv", [*argv, "--object-watch"])
    with pytest.raises(SystemExit, match=r"^error: --object-watch is the filter's: with --without-arm give --with"):
        robot_sim.main()
    record = {"plant": "physics", "filtered": True, "reach": [0.36, 0.8], "bent_way_room_m": 0.01,
              "workspace_margin": 0.4, "object_watch": False, "endgame_push": True, "task": "III", "shape": "rect",
              "seed": 0, "method": "mppi-ukf"}
    (tmp_path / "records.jsonl").write_text(json.dumps(record) + "\n")
    assert robot_sim.setup_of(record)["object watch"] == "off"
    assert robot_sim.setup_of({**record, "object_watch": True})["object watch"] == "on"
    # libfranka's filter is the arm's: records on it without the key ran with its 100-Hz default
    assert robot_sim.setup_of(record)["libfranka cutoff"] is None
    assert robot_sim.setup_of({**record, "plant": "franka-sim"})["libfranka cutoff"] == 100.0
    arm_record = {**record, "plant": "franka-sim", "cutoff_frequency": 1000.0}
    assert robot_sim.setup_of(arm_record)["libfranka cutoff"] == 1000.0
    # records before the endgame push hold no key for it: they ran without it
    assert robot_sim.setup_of({k: v for k, v in record.items() if k != "endgame_push"})["endgame push"] == "off"
    before = [*argv, "--with-filter", "--no-obstacles-under-start"]     # the record is from before the default
    monkeypatch.setattr(sys, "argv", [*before, "--object-watch", "--no-endgame-push"])
    with pytest.raises(SystemExit, match=r"holds episodes with another endgame push and object watch than this run's"):
        robot_sim.main()
    monkeypatch.setattr(sys, "argv", [*before, "--object-watch"])
    with pytest.raises(SystemExit, match=r"holds episodes with another object watch than this run's"):
        robot_sim.main()
    assert robot_sim.setup_of(record)["obstacles under start"] == "off"
    monkeypatch.setattr(sys, "argv", [*argv, "--with-filter"])          # today's default: on
    with pytest.raises(SystemExit, match=r"holds episodes with another obstacles under start than this run's"):
        robot_sim.main()
    monkeypatch.setattr(sys, "argv", [*before, "--method", "mppi"])    # MPPI from the prior alone
    with pytest.raises(SystemExit, match=r"holds episodes with another method than this run's \(method mppi\)"):
        robot_sim.main()


def test_the_repeat_comparison_names_the_seeds_that_change_outcome_and_how_far_the_time_moves(tmp_path) -> None:
    """``benchmarks/robot_repeat.py`` pairs two runs' records seed by seed: the seeds whose outcome changes, the time
    moved on the seeds both runs succeed on, and, for the arm's records, the commanded stream's largest jerk and
    acceleration and the reflex-level milliseconds; folders without a record, or with no seed in common, are
    one-line errors."""
    import json
    import subprocess
    import sys

    script = Path(__file__).resolve().parents[1] / "benchmarks" / "robot_repeat.py"
    runs = {"a": [(0, True, 20.0), (1, False, 60.0), (2, True, 30.0), (3, True, 10.0)],
            "b": [(0, True, 25.5), (1, True, 31.0), (2, False, 60.0), (3, True, 10.5)]}
    for name, rows in runs.items():
        (tmp_path / name).mkdir()
        (tmp_path / name / "records.jsonl").write_text("".join(
            json.dumps({"task": "III", "shape": "tee", "seed": s, "success": ok, "time_s": t}) + "\n"
            for s, ok, t in rows) + json.dumps({"task": "II", "shape": "tee", "seed": 0, "success": True,
                                                 "time_s": 1.0}) + "\n")
    run = subprocess.run([sys.executable, str(script), str(tmp_path / "a"), str(tmp_path / "b"), "--task", "III",
                          "--shape", "tee"], capture_output=True, text=True, timeout=60)
    assert run.returncode == 0, run.stderr
    out = json.loads(run.stdout.splitlines()[-1])
    assert out["seeds"] == 4 and out["successes"] == [3, 3] and out["changed_outcome"] == [1, 2]
    assert out["both_succeed"] == 2 and out["time_moved_s"] == {"mean": 3.0, "min": 0.5, "max": 5.5}
    assert "max_commanded_jerk" not in out                 # records without the arm's report
    for name, jerks in {"a": [4000.0, 5000.0, 6000.0, 7000.0], "b": [3000.0, 3500.0, 3600.0, 3700.0]}.items():
        rows = [json.loads(line) for line in (tmp_path / name / "records.jsonl").read_text().splitlines()]
        (tmp_path / name / "records.jsonl").write_text("".join(json.dumps({**r, "robot": {
            "max_commanded_jerk": j, "max_commanded_acceleration": j / 1000, "reflex_limit_steps": int(j > 6500)}})
            + "\n" for r, j in zip(rows, [*jerks, 1.0], strict=True)))
    run = subprocess.run([sys.executable, str(script), str(tmp_path / "a"), str(tmp_path / "b"), "--task", "III",
                          "--shape", "tee"], capture_output=True, text=True, timeout=60)
    out = json.loads(run.stdout.splitlines()[-1])
    assert out["max_commanded_jerk"] == {"median": [5500.0, 3550.0], "max": [7000.0, 3700.0]}
    assert out["max_commanded_acceleration"]["max"] == [7.0, 3.7] and out["reflex_limit_steps"] == [1, 0]
    for args in ((tmp_path / "a", tmp_path / "nothing", "--task", "III"),      # no records.jsonl
                 (tmp_path / "a", tmp_path / "b", "--task", "IV")):            # no seed in common
        bad = subprocess.run([sys.executable, str(script), *map(str, args), "--shape", "tee"], capture_output=True,
                             text=True, timeout=60)
        assert bad.returncode != 0 and "Traceback" not in bad.stderr
        assert "error: no" in bad.stderr.strip().splitlines()[-1]


def test_the_trace_prediction_replays_the_commands_through_the_model(tmp_path, monkeypatch, capsys) -> None:
    """``benchmarks/trace_prediction.py`` on a trace the model itself made: with the planner's λ the predicted gap
    and heading are the true ones; with another λ they differ; bad inputs are one-line errors."""
    import importlib.util
    import sys

    import jax.numpy as jnp

    from dexpush.experiments.registry import make_shape
    from dexpush.model.cgvmm import Contour, replay

    shape = make_shape("rect")
    x0 = np.array([0.0, 0.0, 0.0, -0.1 - shape.pusher_radius, 0.02])   # pushed off-centre: it turns
    u = np.tile([0.05, 0.0], (12, 1))
    lam = np.array([15.0, 0.0, 0.0])
    states = np.concatenate([x0[None], np.asarray(replay(Contour.of(shape), jnp.asarray(x0, jnp.float32),
                                                         jnp.asarray(u, jnp.float32), 0.04,
                                                         jnp.asarray(lam, jnp.float32)))])
    trace = tmp_path / "III_rect_7.npz"
    np.savez(trace, states=states, commands=u, params=np.tile(lam, (12, 1)), obstacles=np.array([[0.2, 0.0, 0.05]]))
    spec = importlib.util.spec_from_file_location("trace_prediction", Path(__file__).resolve().parents[1]
                                                  / "benchmarks" / "trace_prediction.py")
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    monkeypatch.setattr(sys, "argv", ["trace_prediction.py", str(trace), "--from", "2", "--steps", "5",
                                      "--params", "40,0,0.03"])
    script.main()
    rows = [line.split(" | ") for line in capsys.readouterr().out.splitlines()[2:]]
    assert [r[0] for r in rows] == ["3", "4", "5", "6", "7"]
    assert all(abs(float(r[1]) - float(r[2])) < 0.02 and abs(float(r[4]) - float(r[5])) < 0.05 for r in rows)
    assert abs(float(rows[-1][5]) - float(rows[-1][6])) > 0.5          # another λ turns it otherwise
    for argv, message in ((["--from", "12"], "--from must be a step in 0..11"),
                          (["--from", "0", "--params", "1,2"], "expected λ as 3 comma-separated numbers")):
        monkeypatch.setattr(sys, "argv", ["trace_prediction.py", str(trace), *argv])
        with pytest.raises(SystemExit, match=message if "--from" in message else None):
            script.main()
    (tmp_path / "bad.npz").write_text("no")
    monkeypatch.setattr(sys, "argv", ["trace_prediction.py", str(tmp_path / "bad.npz"), "--from", "0"])
    with pytest.raises(SystemExit, match="not an episode's arrays"):
        script.main()


def test_the_robot_benchmarks_tables_show_the_least_clearance_of_each_row(tmp_path) -> None:
    """``robot_sim.py``'s tables give each row's least object–obstacle clearance in mm, a touch's depth negative, and
    "–" for a row without obstacles; the arm's table the median of the episodes' median planning times."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("robot_sim", Path(__file__).resolve().parents[1] / "benchmarks"
                                                  / "robot_sim.py")
    robot_sim = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(robot_sim)
    arm = {"tracking_error_mm_median": 0.3, "tracking_error_mm_p99": 3.0, "reflex_limit_steps": 0,
           "joint_limit_steps": 0, "workspace_exits": 0, "speed_limit_exceeded": 0, "late_steps": 0,
           "real_time_factor": 1.0, "max_commanded_acceleration": 4.0, "max_commanded_jerk": 4000.0}

    def record(task: str, clearance: float | None, collisions: int = 0) -> dict:
        return {"task": task, "shape": "rect", "success": True, "time_s": 20.0, "collisions": collisions,
                "clearance_m": clearance, "final_error_m": 0.01, "planning_ms_median": 7.0, "robot": arm}

    records = [record("I", None), record("III", 0.0145), record("III", -0.0003, collisions=1)]
    for table in (robot_sim.table, robot_sim.arm_free_table):
        lines = table(records).splitlines()
        column = [c.strip() for c in lines[0].split("|")].index("least clearance (mm)")
        cells = {line.split("|")[1].strip(): line.split("|")[column].strip() for line in lines[2:]}
        assert cells == {"I": "–", "III": "-0.3"}
    header = [c.strip() for c in robot_sim.table(records).splitlines()[0].split("|")]
    assert robot_sim.table(records).splitlines()[2].split("|")[header.index("planning (ms, median)")].strip() == "7.0"
