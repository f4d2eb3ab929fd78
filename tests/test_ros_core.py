"""The ROS 2 node's rules without ROS (dexpush.ros.core): bad poses and goals rejected and logged once,
frame times that keep a frame's age, the pusher where it was at the object's stamp, zero when stale,
reached or reset, a goal replaced mid-run with the estimate carried over, and the watchdog's zero."""

import math
import sys
from dataclasses import replace

import numpy as np
import pytest

from dexpush.experiments.registry import make_shape
from dexpush.experiments.scenarios import TASKS
from dexpush.problem.scene_file import Layout
from dexpush.ros.core import NodeCore, NodeSettings, yaw_of

T = 0.04


class Clock:
    def __init__(self, t: float = 1000.0) -> None:
        self.t = t

    def __call__(self) -> float:
        return self.t


class Recording:
    """A controller that records what it is given and pushes at a constant velocity."""

    def __init__(self, params) -> None:
        self.params = np.asarray(params, float)
        self.frames, self.resets = [], []
        self.stall_resets = 0

    def reset(self, object_pose=None, pusher_xy=None):
        self.resets.append((object_pose, pusher_xy))

    def act(self, frame, frame_period=None):
        self.frames.append(frame)
        return np.array([0.01, 0.0])

    def set_params(self, params):
        self.params = np.asarray(params, float)


class RecordingMethod:
    """Makes a :class:`Recording` controller per problem (the node's ``controller_for``)."""

    def __init__(self) -> None:
        self.made: list[Recording] = []

    def __call__(self, problem):
        self.made.append(Recording((15.0, 0.0, 0.0)))
        return self.made[-1]


def layout(task):
    return Layout(task.obstacles, task.polygons, task.workspace)


@pytest.fixture
def rig():
    clock, logs, method = Clock(), [], RecordingMethod()
    core = NodeCore(make_shape("rect"), layout(TASKS["I"]), method, node=NodeSettings(guard=None), log=logs.append,
                    clock=clock)
    return core, clock, logs, method


def feed(core, clock, pose, pusher, age=0.03):
    """An object and a pusher pose captured ``age`` s ago, arriving now."""
    stamp = clock.t - age
    assert core.pusher_pose(*pusher, stamp, "world", clock.t)
    assert core.object_pose(*pose, stamp, "world", clock.t)


def test_bad_poses_are_rejected_counted_and_logged_once(rig):
    core, clock, logs, _ = rig
    now = clock.t
    assert not core.object_pose(math.nan, 0.0, 0.0, now, "world", now)
    assert not core.object_pose(0.0, 0.0, 0.0, now, "camera", now)
    assert not core.object_pose(0.0, 0.0, 0.0, now + 1.0, "world", now)       # from the future
    assert not core.object_pose(0.0, 0.0, 0.0, now - 10.0, "world", now)      # 10 s old
    assert not core.pusher_pose(0.0, math.inf, now, "world", now)
    assert core.object_pose(0.0, 0.0, 0.0, now - 0.01, "world", now)
    assert not core.object_pose(0.0, 0.0, 0.0, now - 0.02, "world", now)      # older than the newest
    assert not core.object_pose(math.nan, 0.0, 0.0, now, "world", now)        # a second NaN: counted, not logged
    assert core.rejected == {"object_nan": 2, "object_frame": 1, "object_future": 1, "object_old": 1,
                             "pusher_nan": 1, "object_order": 1}
    assert len([m for m in logs if "rejected" in m]) == 6
    assert all("\n" not in m for m in logs)


def test_goals_that_cannot_be_reached_are_refused(rig):
    core, clock, logs, _ = rig
    assert not core.set_goal((0.6, 0.3, math.nan))
    assert not core.set_goal((0.6, 0.3, 0.0), frame_id="map")
    walled = NodeCore(make_shape("rect"), Layout(workspace=(-0.2, -0.2, 0.5, 0.5)), RecordingMethod(),
                      node=NodeSettings(guard=None), log=logs.append, clock=clock)
    assert not walled.set_goal((0.6, 0.3, 0.0))                                  # outside the workspace
    disc = NodeCore(make_shape("rect"), layout(TASKS["III"]), RecordingMethod(), node=NodeSettings(guard=None),
                    log=logs.append, clock=clock)
    assert not disc.set_goal((0.3, 0.0, 0.0))                                    # on the disc
    assert walled.rejected == {"goal_refused": 1} and disc.rejected == {"goal_refused": 1}
    assert any("workspace" in m for m in logs) and any("obstacle" in m for m in logs)
    assert walled.tick().mode == "idle" and disc.tick().mode == "idle"


def test_frames_keep_their_age_on_the_controllers_clock_however_the_ticks_jitter(rig):
    core, clock, _, method = rig
    assert core.set_goal((0.6, 0.3, 0.0))
    assert core.tick().mode == "waiting"                       # a goal, but no pose yet
    rng = np.random.default_rng(0)
    ages = []
    for k in range(12):
        age = float(rng.uniform(0.03, 0.05))
        feed(core, clock, (0.01 * k, 0.0, 0.0), (-0.1 + 0.01 * k, 0.0), age)
        ages.append(age)
        tick = core.tick()
        assert tick.mode == "pushing" and tick.received == clock.t
        clock.t += T + float(rng.uniform(-0.005, 0.005))       # jittered periods
    frames = method.made[-1].frames
    assert frames[0].time == 0.0                                # the episode's first frame
    for k in range(1, 12):                                      # clock k·T at act k: the age is kept exactly
        assert frames[k].time == pytest.approx(k * T - ages[k], abs=1e-9)


def test_the_pusher_is_taken_where_it_was_at_the_objects_stamp(rig):
    core, clock, _, method = rig
    core.set_goal((0.6, 0.3, 0.0))
    t = clock.t
    core.pusher_pose(0.0, 0.0, t - 0.05, "world", t)
    core.pusher_pose(0.1, 0.2, t - 0.01, "world", t)
    core.object_pose(0.3, 0.0, 0.0, t - 0.02, "world", t)      # between the two pusher poses
    core.tick()
    np.testing.assert_allclose(method.made[-1].resets[0][1], [0.075, 0.15])
    clock.t = t + 0.45
    core.object_pose(0.3, 0.0, 0.0, t + 0.25, "world", clock.t)    # 0.2 s from the newest pusher pose, and
    core.pusher_pose(0.1, 0.2, t + 0.45, "world", clock.t)         # the two around it 0.46 s apart
    assert core.tick().received is None                         # no pusher pose near it: no frame
    assert core.rejected.get("unpaired") == 1


def test_stale_poses_reached_goals_and_resets_stop_the_pusher(rig):
    core, clock, _, _ = rig
    core.set_goal((0.6, 0.3, 0.0))
    feed(core, clock, (0.3, 0.0, 0.0), (0.2, 0.0))
    assert np.any(core.tick().command != 0)
    clock.t += 0.6                                              # poses stop coming
    tick = core.tick()
    assert tick.mode == "stale" and np.all(tick.command == 0)
    feed(core, clock, (0.3, 0.0, 0.0), (0.2, 0.0))
    assert core.tick().mode == "pushing"                        # they resume
    clock.t += T
    feed(core, clock, (0.6 + 0.003, 0.3, math.radians(1.0)), (0.45, 0.3))   # within half the tolerance
    tick = core.tick()
    assert tick.mode == "reached" and np.all(tick.command == 0) and core.status()["success"]
    clock.t += T
    feed(core, clock, (0.5, 0.3, 0.0), (0.4, 0.3))
    assert core.tick().mode == "reached"                        # it stays stopped until a new goal
    core.reset()
    tick = core.tick()
    assert tick.mode == "idle" and np.all(tick.command == 0) and core.status()["goal"] is None


def test_a_new_goal_mid_run_replans_from_the_current_frame_with_the_estimate_kept(rig):
    core, clock, _, method = rig
    core.set_goal((0.6, 0.3, 0.0))
    feed(core, clock, (0.3, 0.0, 0.0), (0.2, 0.0))
    core.tick()
    method.made[-1].params = np.array([22.0, 0.01, -0.01])     # what the first controller estimated
    assert core.set_goal((0.5, -0.2, 1.0))
    clock.t += T
    feed(core, clock, (0.31, 0.0, 0.0), (0.21, 0.0))
    assert core.tick().mode == "pushing"
    second = method.made[-1]
    assert len(method.made) == 2 and second.resets[0][0][0] == 0.31
    np.testing.assert_allclose(second.params, [22.0, 0.01, -0.01])
    assert core.status()["goal"] == [0.5, -0.2, 1.0]
    core.reset()                                                # a reset forgets the estimate
    core.set_goal((0.6, 0.3, 0.0))
    clock.t += T
    feed(core, clock, (0.32, 0.0, 0.0), (0.22, 0.0))
    core.tick()
    np.testing.assert_allclose(method.made[-1].params, [15.0, 0.0, 0.0])


def test_the_stream_sends_zero_when_no_command_was_made_for_the_watchdogs_time(rig):
    core, clock, _, _ = rig
    core.set_goal((0.6, 0.3, 0.0))
    feed(core, clock, (0.3, 0.0, 0.0), (0.2, 0.0))
    u = core.tick().command
    target, tripped = core.stream_target(clock.t + 0.05)
    assert not tripped and np.array_equal(target, u)
    target, tripped = core.stream_target(clock.t + 0.15)
    assert tripped and np.all(target == 0)


def test_every_command_passes_the_safety_filter():
    clock = Clock()
    core = NodeCore(make_shape("rect"), layout(TASKS["I"]), RecordingMethod(), log=lambda m: None, clock=clock,
                    node=NodeSettings(guard=None, safety=replace(NodeSettings().safety, v_max=0.005)))
    core.set_goal((0.6, 0.3, 0.0))
    feed(core, clock, (0.3, 0.0, 0.0), (0.2, 0.0))
    assert np.hypot(*core.tick().command) <= 0.005 + 1e-9       # the stub asks for 0.01 m/s


@pytest.mark.parametrize("kwargs", [{"trigger": "sometimes"}, {"world_frame": ""}, {"stale_s": 0.0},
                                    {"reach_fraction": 1.5}])
def test_settings_are_checked(kwargs):
    with pytest.raises(ValueError):
        NodeSettings(**kwargs)


def test_yaw_of_a_quaternion():
    for th in (-3.0, -0.5, 0.0, 1.2, 3.1):
        assert yaw_of(0.0, 0.0, math.sin(th / 2), math.cos(th / 2)) == pytest.approx(th)


def test_the_ros_command_says_how_to_get_rclpy_when_it_is_missing(monkeypatch, capsys):
    from dexpush.cli.main import main

    monkeypatch.setitem(sys.modules, "rclpy", None)           # import rclpy raises ImportError
    assert main(["ros", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "pip install 'dexpush[ros]'" in err and len(err.strip().splitlines()) == 1
