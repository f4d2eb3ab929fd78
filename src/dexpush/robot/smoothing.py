"""Commands a robot can follow: the planner's steps interpolated within acceleration and jerk limits.

The planner issues a planar velocity every control period T (25 Hz); a robot's own loop runs at
100 Hz to 1 kHz and aborts on a discontinuous command (libfranka's reflexes). Between the two,
:class:`CommandSmoother` turns the planner's latest command, a step, into a stream at the robot's
rate dt whose velocity v and acceleration a obey

    ‖a‖ ≤ a_max,    ‖a(t + dt) − a(t)‖ ≤ j_max·dt,    v(t + dt) = v(t) + a(t + dt)·dt.

Each axis follows its target on its own, within a_max/√2 and j_max/√2 (so the vector's norms stay
within the bounds). Per axis, in the direction of the error e = target − v, each step
(:func:`smooth_step`) takes the largest acceleration a' reachable within the jerk bound such that

    a'·dt + b(a') ≤ e,    b(a') = dt · Σ_{i ≥ 1} max(a' − i·j·dt, 0),

b being the velocity still gained while a' is ramped down to zero at the jerk bound (the exact
discrete braking sum): the stream never overshoots a target it can still stop for, and lands on
it exactly (a last step whose acceleration can then drop to zero within the jerk bound). A zero
target brakes to rest the same way: this is how a smoothed stream stops softly.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from dexpush.common.checks import check_positive, checked_vector

__all__ = ["CommandSmoother", "SmoothingSettings", "smooth_step"]


@dataclass(frozen=True)
class SmoothingSettings:
    """The limits of the smoothed stream (m/s², m/s³). The defaults: the safety filter's 2.5 m/s²
    (a fifth of a Franka's 13 m/s²) and a jerk that reaches it in 10 ms (a Franka allows 6500 m/s³)."""

    a_max: float = 2.5       #: acceleration bound (m/s²)
    j_max: float = 250.0     #: jerk bound (m/s³)

    def __post_init__(self) -> None:
        check_positive("a_max", self.a_max, "m/s²")
        check_positive("j_max", self.j_max, "m/s³")


def _braking(a: float, da: float, dt: float) -> float:
    """The velocity change (signed) after this step while acceleration ``a`` ramps to zero by ``da`` a step."""
    m = abs(a)
    n = math.floor(m / da)
    return math.copysign(dt * (n * m - da * n * (n + 1) / 2), a)


def _axis(v: float, a: float, target: float, dt: float, a_max: float, j_max: float) -> tuple[float, float]:
    """One axis's step (the module docstring): the new velocity and acceleration."""
    e, da = target - v, j_max * dt
    if abs(e / dt - a) <= da and abs(e / dt) <= min(a_max, da):
        return target, e / dt                         # land on the target
    s = 1.0 if e > 0 or (e == 0 and a < 0) else -1.0
    e, a = s * e, s * a                                # work where the error is positive
    lo, hi = max(a - da, -a_max), min(a + da, a_max)

    def gained(x: float) -> float:
        return x * dt + _braking(x, da, dt)

    if gained(hi) <= e:
        x = hi
    elif gained(lo) > e:                               # it cannot stop in time: brake as hard as allowed
        x = lo
    else:
        for _ in range(40):                            # gained() increases with x: bisect for the largest
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if gained(mid) <= e else (lo, mid)
        x = lo
    return v + s * x * dt, s * x


def smooth_step(v: np.ndarray, a: np.ndarray, target: np.ndarray, dt: float, a_max: float,
                j_max: float) -> tuple[np.ndarray, np.ndarray]:
    """One step of dt (s) towards ``target`` from velocity ``v`` and acceleration ``a`` (2-vectors; the
    module docstring's law); returns the new (v, a)."""
    a_axis, j_axis = a_max / math.sqrt(2), j_max / math.sqrt(2)
    steps = [_axis(float(v[i]), float(a[i]), float(target[i]), dt, a_axis, j_axis) for i in range(2)]
    return np.array([steps[0][0], steps[1][0]]), np.array([steps[0][1], steps[1][1]])


class CommandSmoother:
    """A velocity stream at period ``dt`` (s) that follows the latest target within ``settings``' limits.

    ``step(target)`` advances one period and returns the velocity to send; ``reset(v)`` starts from
    ``v`` at rest acceleration (e.g. the robot's measured velocity). A non-finite target is refused
    with a ``ValueError`` (the caller sends zero instead).
    """

    def __init__(self, dt: float, settings: SmoothingSettings | None = None) -> None:
        self.dt = check_positive("dt", dt, "s")
        self.settings = settings or SmoothingSettings()
        self.reset()

    def reset(self, velocity: object = (0.0, 0.0)) -> None:
        self.velocity = checked_vector("velocity", velocity, 2).astype(np.float64)
        self.acceleration = np.zeros(2)

    def step(self, target: object) -> np.ndarray:
        t = checked_vector("target", target, 2).astype(np.float64)
        s = self.settings
        self.velocity, self.acceleration = smooth_step(self.velocity, self.acceleration, t, self.dt, s.a_max, s.j_max)
        return self.velocity.copy()
