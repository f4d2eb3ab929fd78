"""The Franka driver's retry (:class:`dexpush.robot.franky_driver.FrankyDriver`), against a stand-in for
franky-control that fails a motion's first plan and, like franky 2.0, refuses to start a motion object twice."""

from __future__ import annotations

import threading
import types

import pytest

from dexpush.robot.driver import DriverSettings, RobotError
from dexpush.robot.franky_driver import FrankyDriver


class _Motion:
    def __init__(self, *args: object, **kwargs: object) -> None:
        self.started = False


class _Robot:
    """Fails the first ``fails`` moves as franky's planner does (code -111) and any motion started before."""

    def __init__(self, fails: int) -> None:
        self.fails, self.moves, self.cutoffs, self.has_errors = fails, [], [], False
        pose = types.SimpleNamespace(translation=[0.5, 0.0, 0.2], quaternion=[1.0, 0.0, 0.0, 0.0])
        self.current_cartesian_state = types.SimpleNamespace(pose=types.SimpleNamespace(end_effector_pose=pose))
        self.state = types.SimpleNamespace(time=types.SimpleNamespace(to_sec=lambda: 12.345))    # the robot's clock

    def move(self, motion: _Motion, asynchronous: bool = False, cutoff_frequency: float = 100.0) -> None:
        if motion.started:
            raise RuntimeError("This motion object has already been started before.")
        motion.started = True
        if self.fails:
            self.fails -= 1
            raise RuntimeError("Motion planner failed with error code -111")
        self.moves.append(motion)
        self.cutoffs.append(cutoff_frequency)

    def join_motion(self, timeout: float | None = None) -> None:
        pass


_FRANKY = types.SimpleNamespace(CartesianVelocityMotion=_Motion, RobotVelocity=lambda t: t, Twist=lambda a, b: (a, b),
                                Duration=lambda ms: ms, CartesianMotion=_Motion, Affine=lambda p, q: (p, q))


def _driver(fails: int, settings: DriverSettings | None = None) -> FrankyDriver:
    driver = object.__new__(FrankyDriver)
    driver._f, driver.settings, driver._lock = _FRANKY, settings or DriverSettings(), threading.RLock()
    driver.robot, driver.sent, driver.retries, driver.stops, driver.errors = _Robot(fails), 0, 0, 0, []
    driver.retry_times = []
    return driver


def test_a_failed_plan_is_retried_with_a_new_motion() -> None:
    driver = _driver(fails=1)
    driver.send([0.02, 0.0])
    assert driver.sent == 1 and driver.retries == 1 and len(driver.robot.moves) == 1
    assert "-111" in driver.errors[0] and driver.retry_times == [12.345]    # what and when, for the record


def test_a_retry_whose_clock_cannot_be_read_is_still_counted() -> None:
    driver = _driver(fails=1)
    del driver.robot.state
    driver.send([0.02, 0.0])
    assert driver.retries == 1 and len(driver.retry_times) == 1 and driver.retry_times[0] != driver.retry_times[0]


def test_a_command_failing_twice_is_a_robot_error_and_a_stop_never_raises() -> None:
    driver = _driver(fails=2)
    with pytest.raises(RobotError, match="refused a velocity command twice"):
        driver.send([0.02, 0.0])
    driver.robot.fails = 2
    driver.stop()
    assert driver.stops == 1 and len(driver.errors) >= 3


def test_the_velocity_stream_goes_through_the_configured_filter() -> None:
    driver = _driver(fails=1, settings=DriverSettings(cutoff_frequency=1000.0))
    driver.send([0.02, 0.0])
    driver.stop()
    assert driver.robot.cutoffs == [1000.0, 1000.0]
    for bad in (0.0, -5.0, 1500.0):
        with pytest.raises(ValueError, match="cutoff_frequency"):
            DriverSettings(cutoff_frequency=bad)


def test_an_episodes_record_says_what_the_robot_refused_and_when() -> None:
    import numpy as np

    from dexpush.experiments.robot_trial import robot_report
    from dexpush.robot.safety import SafetySettings

    driver = _driver(fails=1)
    driver.send([0.02, 0.0])
    plant = types.SimpleNamespace(driver=driver, late_steps=0, watchdog_stops=0)
    episode = types.SimpleNamespace(states=np.zeros((3, 5)), commands=np.zeros((2, 2)))
    out = robot_report(episode, plant, None, None, 0.04, SafetySettings())
    assert out["driver_retries"] == 1 and out["driver_retry_s"] == [12.345]
    assert out["driver_errors"] == ["RuntimeError: Motion planner failed with error code -111"]
    driver.retries, driver.errors = 0, []
    assert "driver_errors" not in robot_report(episode, plant, None, None, 0.04, SafetySettings())
