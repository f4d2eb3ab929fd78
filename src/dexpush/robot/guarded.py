"""A controller behind the robot's guards (:class:`GuardedController`): one glitched frame never
reaches the planner (:class:`FrameGuard`), and every command passes the safety filter
(:func:`dexpush.robot.safety.safe_velocity`). It is itself a
:class:`dexpush.common.interfaces.Controller`, so any loop that runs a controller runs it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from dexpush.common.checks import check_positive
from dexpush.common.interfaces import Controller, Observation
from dexpush.common.se2 import wrap_angle
from dexpush.problem.regions import convex_polygon
from dexpush.robot.object_watch import ObjectWatch
from dexpush.robot.safety import SafetySettings, barrier_rate, filter_velocity

__all__ = ["FrameGuard", "GuardedController"]


@dataclass
class FrameGuard:
    """Holds back a frame whose object pose jumped further than the object can move since the last
    accepted frame: ``jump_m + speed_m_s·Δt`` in position or ``jump_rad + spin_rad_s·Δt`` in angle.

    A held-back frame is not given to the planner (it plans from its prediction, as for a dropped
    frame). If the next frame agrees with the held-back one (within ``jump_m`` / ``jump_rad``) the
    object really moved (it was knocked): that frame is accepted and the guard follows it.
    """

    jump_m: float = 0.015          #: position jump beyond what the object's motion explains (m)
    jump_rad: float = 0.15         #: angle jump beyond the object's rotation (rad)
    speed_m_s: float = 0.2         #: the fastest the object moves when pushed (m/s)
    spin_rad_s: float = 2.0        #: the fastest it turns (rad/s)

    def __post_init__(self) -> None:
        for name in ("jump_m", "jump_rad", "speed_m_s", "spin_rad_s"):
            check_positive(name, getattr(self, name))
        self.held = 0
        self._last: Observation | None = None
        self._pending: Observation | None = None

    def _close(self, a: Observation, b: Observation, slack: bool) -> bool:
        dt = abs(float(b.time) - float(a.time)) if slack else 0.0
        qa, qb = np.asarray(a.object_pose, float), np.asarray(b.object_pose, float)
        d = float(np.hypot(*(qb[:2] - qa[:2])))
        dth = abs(float(wrap_angle(qb[2] - qa[2])))
        return d <= self.jump_m + self.speed_m_s * dt and dth <= self.jump_rad + self.spin_rad_s * dt

    def __call__(self, frame: Observation | None) -> Observation | None:
        """``frame`` if it is plausible (or confirms a jump), else None (counted in :attr:`held`)."""
        if frame is None:
            return None
        if self._last is None or self._close(self._last, frame, slack=True):
            self._last, self._pending = frame, None
            return frame
        if self._pending is not None and self._close(self._pending, frame, slack=True):
            self._last, self._pending = frame, None
            return frame
        self._pending = frame
        self.held += 1
        return None


class GuardedController:
    """``controller`` behind a :class:`FrameGuard` and the safety filter.

    Args:
        controller: any :class:`dexpush.common.interfaces.Controller`.
        control_period: T (s), how long each command is held.
        safety: :class:`dexpush.robot.safety.SafetySettings`.
        obstacles: discs (c_x, c_y, r) the pusher keeps out of (grown by the pusher radius and the margin).
        pusher_radius: ρ (m).
        polygons: convex polygons (boxes, walls; each its corners) the pusher keeps out of, grown likewise.
        guard: a :class:`FrameGuard` (None: frames pass as they come).
        position: where the pusher is now (a robot's measured tip); default: the newest frame's
            pusher position, carried forward by the commands sent since.
        frame_timeout_s: with no frame for this long (s) the command is zero until frames return
            (the robot brakes within its own limits; the planner keeps predicting).
        watch: an :class:`dexpush.robot.object_watch.ObjectWatch` that slows the pusher when the accepted frames
            show the object closing on an obstacle (None: the filter guards the pusher only). It reads the frames'
            times on the plant's clock, which starts at the first period (``Observation.time``), and stamps the
            k-th command (k − 1)·T.

    Counters: ``filtered`` (commands the filter changed), ``relaxed`` (periods in which it had to drop
    the acceleration or speed rows), ``stopped`` (periods in which no velocity was safe: it sent zero),
    ``blind`` (periods stopped for want of frames) and ``guard.held`` (frames held back).
    """

    def __init__(self, controller: Controller, control_period: float, safety: SafetySettings | None = None,
                 obstacles: object = (), pusher_radius: float = 0.0, guard: FrameGuard | None = None,
                 position: Callable[[], np.ndarray] | None = None, frame_timeout_s: float = 0.5,
                 polygons: object = (), watch: ObjectWatch | None = None) -> None:
        self.controller = controller
        self.watch = watch
        self.control_period = check_positive("control_period", control_period, "s")
        self.safety = safety or SafetySettings()
        self.obstacles = np.asarray(obstacles, dtype=np.float64).reshape(-1, 3)
        self.pusher_radius = float(pusher_radius)
        self.polygons = tuple(convex_polygon(p, f"keep-out polygon {i}") for i, p in enumerate(polygons))
        self.guard = guard
        self._position = position
        self.frame_timeout_s = check_positive("frame_timeout_s", frame_timeout_s, "s")
        self.filtered = self.relaxed = self.stopped = self.blind = 0
        self.limited_by: dict[str, int] = {}      #: per constraint, the periods a changed command lay on it
        self.periods = 0
        self.on_act: Callable[[int], object] | None = None   #: called with the period's number before each act
        self._since_frame = 0.0
        self._v = np.zeros(2)
        self._p: np.ndarray | None = None

    def __getattr__(self, name: str) -> object:       # params, gave_up, counters: the wrapped controller's
        if name == "controller":
            raise AttributeError(name)
        return getattr(self.controller, name)

    def reset(self, object_pose: object | None = None, pusher_xy: object | None = None) -> None:
        self.controller.reset(object_pose, pusher_xy)
        self._v = np.zeros(2)
        self._since_frame = 0.0
        self.periods = 0
        self._p = None if pusher_xy is None else np.asarray(pusher_xy, dtype=np.float64).reshape(2)
        if self.watch is not None:
            self.watch.reset()
        if self.guard is not None and object_pose is not None and pusher_xy is not None:
            self.guard(Observation(np.asarray(object_pose, float), np.asarray(pusher_xy, float), 0.0))

    def hold(self) -> None:
        """The robot was sent zero outside :meth:`act` (a caller's stop): the filter's previous command is zero."""
        self._v = np.zeros(2)

    def act(self, frame: Observation | None, frame_period: float | None = None) -> np.ndarray:
        self.periods += 1
        now = (self.periods - 1) * self.control_period      # on the plant's clock, which starts at the first period
        if self.on_act is not None:
            self.on_act(self.periods)
        if frame is not None:
            self._p = np.asarray(frame.pusher_xy, dtype=np.float64).reshape(2)
            self._since_frame = 0.0
        else:
            self._since_frame += self.control_period
        seen = self.guard(frame) if self.guard is not None else frame
        if seen is not None and self.watch is not None:
            self.watch.see(seen.object_pose, seen.time)
        u = np.asarray(self.controller.act(seen, frame_period), dtype=np.float64)
        p = self._position() if self._position is not None else self._p
        if p is None:
            raise ValueError("GuardedController needs the pusher's position: reset it with one or give a frame")
        if self._since_frame >= self.frame_timeout_s - 1e-9:
            self.blind += 1
            self._v = np.zeros(2)
        else:
            u = u if np.all(np.isfinite(u)) else np.zeros(2)       # a non-finite request is a request to stop
            p = np.asarray(p, dtype=np.float64).reshape(2)
            extra = () if self.watch is None else (
                ("object", *self.watch.rows(p, self.control_period,
                                            barrier_rate(self.control_period, self.safety), now=now)),)
            result = filter_velocity(u.reshape(2), p, self._v, self.control_period, self.safety, self.obstacles,
                                     self.pusher_radius, self.polygons, extra)
            self.filtered += result.changed
            if result.changed:
                for name in result.active:
                    self.limited_by[name] = self.limited_by.get(name, 0) + 1
            self.relaxed += result.relaxed not in ("", "all")
            self.stopped += result.relaxed == "all"
            self._v = result.velocity
        if self.watch is not None:
            self.watch.sent(self._v, now)
        if self._position is None:
            self._p = p + self._v * self.control_period
        return self._v.copy()
