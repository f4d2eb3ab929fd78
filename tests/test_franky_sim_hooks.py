"""The checks of the simulated robot's command stream (:mod:`dexpush.robot.franky_sim_hooks`): the commanded
acceleration and jerk on the commands' own clock."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from dexpush.robot.franky_sim_hooks import FRANKA_LIMITS, Checks


def _twist(vx: float, vy: float = 0.0) -> np.ndarray:
    return np.array([vx, vy, 0.0])


@settings(max_examples=25, deadline=None)
@given(acc=st.floats(-5.0, 5.0), acc_y=st.floats(-2.0, 2.0), start=st.integers(1, 10_000))
def test_a_constant_acceleration_is_measured_exactly_and_has_no_jerk(acc: float, acc_y: float, start: int) -> None:
    checks = Checks()
    for k in range(20):
        t = (start + k) * 1e-3
        checks.command("cartesian_velocity", _twist(acc * k * 1e-3, acc_y * k * 1e-3), t)
    assert np.allclose(checks.a, [acc, acc_y, 0], atol=1e-6)
    assert checks.max_j < 1e-3 and checks.missed == 0
    assert np.isclose(checks.max_a, np.hypot(acc, acc_y), rtol=1e-5, atol=1e-6)
    assert checks.over == int(np.hypot(acc, acc_y) > FRANKA_LIMITS["acceleration"])


def test_a_step_is_a_jerk_over_the_limit_and_a_gap_starts_a_new_motion() -> None:
    checks = Checks()
    for k, v in enumerate([0.0, 0.0, 0.0, 0.01]):
        checks.command("cartesian_velocity", _twist(v), (1 + k) * 1e-3)
    assert np.isclose(checks.max_a, 10.0) and np.isclose(checks.max_j, 10.0 / 1e-3)
    assert checks.over == 1                                         # the jerk; 10 m/s² is within 13
    assert checks.max_j_at == 4e-3                                  # at the step's command
    checks.command("cartesian_velocity", _twist(0.5), 1.0)          # 1 s later: a new motion
    assert checks.a is None
    checks.command("cartesian_velocity", _twist(0.5), 1.003)        # two ticks missed
    assert checks.missed == 2
