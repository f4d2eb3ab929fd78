"""The command smoother (dexpush.robot.smoothing): within its acceleration and jerk bounds, always; on the
target, soon; at rest after a zero target; bad targets refused."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from dexpush.robot.smoothing import CommandSmoother, SmoothingSettings

speed = st.floats(-0.2, 0.2, allow_nan=False)


@settings(max_examples=40, deadline=None)
@given(targets=st.lists(st.tuples(speed, speed), min_size=1, max_size=8),
       a_max=st.floats(0.5, 10.0), j_max=st.floats(20.0, 2000.0), dt=st.sampled_from([0.001, 0.004, 0.01]))
def test_the_stream_stays_within_its_limits(targets, a_max, j_max, dt):
    s = CommandSmoother(dt, SmoothingSettings(a_max, j_max))
    v_prev, a_prev = s.velocity.copy(), s.acceleration.copy()
    for target in targets:                        # a new step every 40 ms, as a 25 Hz planner sends them
        for _ in range(round(0.04 / dt)):
            v = s.step(target)
            a = s.acceleration
            assert np.all(np.isfinite(v))
            assert np.hypot(*a) <= a_max * (1 + 1e-9)
            assert np.hypot(*(a - a_prev)) <= j_max * dt * (1 + 1e-9) + 1e-12
            np.testing.assert_allclose(v - v_prev, a * dt, atol=1e-12)
            v_prev, a_prev = v, a.copy()


@settings(max_examples=40, deadline=None)
@given(start=st.tuples(speed, speed), target=st.tuples(speed, speed), a_max=st.floats(0.5, 10.0),
       j_max=st.floats(20.0, 2000.0))
def test_a_target_it_can_stop_for_is_never_overshot(start, target, a_max, j_max):
    dt = 0.004
    s = CommandSmoother(dt, SmoothingSettings(a_max, j_max))
    s.reset(start)
    e0 = np.subtract(target, start)
    for _ in range(2000):
        v = s.step(target)
        assert np.all((np.subtract(target, v) * np.sign(e0)) >= -1e-12)


@settings(max_examples=40, deadline=None)
@given(target=st.tuples(speed, speed), a_max=st.floats(0.5, 10.0), j_max=st.floats(20.0, 2000.0))
def test_a_constant_target_is_reached_and_held(target, a_max, j_max):
    dt = 0.001
    s = CommandSmoother(dt, SmoothingSettings(a_max, j_max))
    e = float(np.hypot(*target))
    # a ramp up and down at the jerk bound, a cruise at the acceleration bound, on an axis that has a
    # 1/√2 share of each: never longer than this (plus a few steps)
    bound = np.sqrt(2) * (e / a_max + 2 * a_max / j_max + 2 * np.sqrt(e / j_max)) + 10 * dt
    for _ in range(int(bound / dt) + 1):
        s.step(target)
    np.testing.assert_allclose(s.velocity, target, atol=1e-12)
    for _ in range(50):
        np.testing.assert_allclose(s.step(target), target, atol=1e-12)
    assert np.hypot(*s.acceleration) <= 1e-9


def test_a_zero_target_brings_the_stream_to_rest_softly():
    s = CommandSmoother(0.001)
    for _ in range(200):
        s.step([0.1, 0.0])
    assert np.isclose(s.velocity[0], 0.1)
    vs = np.array([s.step([0.0, 0.0]) for _ in range(200)])
    assert np.all(np.diff(vs[:, 0]) <= 1e-12)         # it brakes monotonically, never reverses
    assert np.all(vs[:, 0] >= -1e-12)                  # nor overshoots
    np.testing.assert_allclose(vs[-1], 0.0, atol=1e-12)
    assert vs[0, 0] > 0.1 - 250.0 * 0.001**2           # no jump: the first step slows by a jerk-bounded bit


@pytest.mark.parametrize("bad", [[np.nan, 0.0], [0.0, np.inf], [1.0]])
def test_a_bad_target_is_refused(bad):
    s = CommandSmoother(0.001)
    with pytest.raises(ValueError, match="target"):
        s.step(bad)


@pytest.mark.parametrize("kwargs", [{"a_max": 0}, {"j_max": -1.0}, {"a_max": float("nan")}])
def test_settings_are_checked(kwargs):
    with pytest.raises(ValueError):
        SmoothingSettings(**kwargs)
