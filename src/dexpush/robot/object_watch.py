"""The object's clearance in the safety filter (:class:`ObjectWatch`): rows that slow the pusher when the frames
show the pushed object closing on an obstacle.

The filter's keep-out rows (:mod:`dexpush.robot.safety`) guard the pusher; the planner keeps the object a margin
from the obstacles, but only as far as its model predicts the object's motion. Where the model is wrong (a box
turning its corner into a disc as it is pushed past it), the object can reach an obstacle with the pusher clear
of everything. The watch measures what the model cannot be trusted for, from the frames alone:

* the object's gap g_i to each obstacle i (its footprint's distance to the disc or polygon, 0 on a touch), in
  every frame, and the gap now, g_i + min(J_i·v_last, 0)·(t − t_frame), carried over the frame's age (at most
  ``window_s``) at the last command's rate (J_i below);
* the gap's rate ġ_i, the least-squares slope of the frames of the last ``window_s`` seconds;
* the pusher's mean commanded velocity ṗ over the same window, and the gap's rate per unit of pusher velocity
  along it, learnt into a vector J_i one direction at a time: J_i ← J_i + β (min(ġ_i, 0)/|ṗ| − J_i·p̂) p̂ with
  p̂ = ṗ/|ṗ|, when |ṗ| ≥ ``moving_m_s`` and every command of the window pushed along p̂ at half that speed or
  more (a steady push, not a turn or a return that mixes pushes). The model is one-sided, ġ_i = min(J_i·ṗ, 0)
  (quasi-static pushing: the object moves in proportion to the pusher's speed and is never pulled), so β = 1
  when the frames show more closing than it predicts, β = ``release`` when less (a noisy frame releases a push
  slowly), and β = 0 when both say none (the pusher drawing back from a push learnt to close tells nothing of
  the push).

For each obstacle within ``watch_m`` for which a push has been seen to close the gap (J_i ≠ 0), while the pusher
is within ``contact_m`` of the footprint, the filter gets the row

    J_i · v ≥ −γ · (g_i − keep_m) / T                                            (object barrier)

the same discrete-time barrier as the pusher's keep-out rows (γ = T / braking_s): the object may close at no
more than γ (g − keep)/T, so it slows as it nears ``keep_m`` and never crosses it while the learnt rate holds.
A push in a direction not yet seen to close the gap, or the pusher leaving, is not limited
(docs/robot.md#the-objects-clearance).
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass
from typing import Any

import numpy as np

from dexpush.common.checks import check_nonnegative, check_positive
from dexpush.model.polygons import distance_to_polygons
from dexpush.model.shape import Shape

__all__ = ["ObjectWatch", "ObjectWatchSettings", "object_gaps"]


@dataclass(frozen=True)
class ObjectWatchSettings:
    """When the watch limits the pusher (metres, seconds)."""

    watch_m: float = 0.02        #: rows only for obstacles the object is nearer than this (twice the planner's margin)
    keep_m: float = 0.002        #: the gap the barrier keeps the object from an obstacle
    window_s: float = 0.4        #: the frames the gap's rate is fitted over (6 frames at 15 Hz: 4 mm/s for 1 mm noise)
    contact_m: float = 0.01      #: the pusher is pushing when its disc is within this of the footprint
    moving_m_s: float = 0.02     #: the rates are learnt from a window in which the pusher moved this fast (m/s)
    release: float = 0.3         #: a rate that says less closing than learnt moves J this fraction of the way

    def __post_init__(self) -> None:
        for name, unit in (("watch_m", "m"), ("window_s", "s"), ("contact_m", "m"), ("moving_m_s", "m/s")):
            check_positive(name, getattr(self, name), unit)
        if not 0 < self.release <= 1:
            raise ValueError(f"release must be in (0, 1], got {self.release!r}")
        check_nonnegative("keep_m", self.keep_m, "m")
        if self.keep_m >= self.watch_m:
            raise ValueError(f"keep_m must be below watch_m, got keep_m={self.keep_m:g}, watch_m={self.watch_m:g}")


def object_gaps(footprint: list[np.ndarray], obstacles: np.ndarray, polygons: tuple[np.ndarray, ...]) -> np.ndarray:
    """The gap (m) between the placed ``footprint`` (its polygons, world) and each disc (c_x, c_y, r) of
    ``obstacles`` and then each convex polygon of ``polygons``; 0 or less on a touch. For a polygon the gap is the
    least distance of either's corners to the other (exact for disjoint polygons; an overlap puts a corner inside,
    gap 0, unless their edges cross with no corner inside, which a gap watched from outside never reaches)."""
    gaps = [distance_to_polygons(obstacles[:, :2], footprint) - obstacles[:, 2]] if len(obstacles) else []
    corners = np.concatenate(footprint)
    for poly in polygons:
        gaps.append(np.array([min(distance_to_polygons(poly, footprint).min(),
                                  distance_to_polygons(corners, (poly,)).min())]))
    return np.concatenate(gaps) if gaps else np.zeros(0)


class ObjectWatch:
    """The object's gaps to the obstacles, frame by frame, and the filter's rows that keep it off them (above).

    Args:
        shape: the object (its footprint and the pusher's radius ρ).
        obstacles: discs (c_x, c_y, r), (m, 3), m.
        polygons: convex polygons (boxes, walls), each its corners.
        settings: :class:`ObjectWatchSettings`.

    Feed it every accepted frame (:meth:`see`) and every command sent (:meth:`sent`); :meth:`rows` gives the
    filter's rows for the next command.
    """

    def __init__(self, shape: Shape, obstacles: np.ndarray, polygons: tuple[np.ndarray, ...],
                 settings: ObjectWatchSettings | None = None) -> None:
        self.shape = shape
        self.obstacles = np.asarray(obstacles, dtype=np.float64).reshape(-1, 3)
        self.polygons = tuple(np.asarray(p, dtype=np.float64) for p in polygons)
        self.settings = settings or ObjectWatchSettings()
        self.reset()

    @property
    def active(self) -> bool:
        """Whether there is anything to watch (any obstacle)."""
        return len(self.obstacles) + len(self.polygons) > 0

    def reset(self) -> None:
        self._frames: deque[tuple[float, np.ndarray]] = deque()
        self._commands: deque[tuple[float, np.ndarray]] = deque()
        self._footprint: list[np.ndarray] | None = None                      #: the newest frame's, placed
        self.J = np.zeros((len(self.obstacles) + len(self.polygons), 2))    #: ġ per unit of pusher velocity
        self.gaps = np.full(len(self.J), np.inf)                              #: the newest frame's gaps (m)

    def sent(self, velocity: object, time: float) -> None:
        """Record the command sent at ``time`` (s, the frames' clock), held until the next."""
        if self.active:
            self._commands.append((float(time), np.asarray(velocity, dtype=np.float64).reshape(2)))
            while len(self._commands) > 1 and self._commands[1][0] < float(time) - 2 * self.settings.window_s:
                self._commands.popleft()

    def see(self, object_pose: object, time: float) -> None:
        """Record a frame's object pose (x, y, θ) captured at ``time`` (s) and, when the pusher moved fast enough
        over the window, learn the gaps' rates per unit of its velocity along that velocity."""
        if not self.active:
            return
        self._footprint = self.shape.footprint_world(np.asarray(object_pose, dtype=np.float64).reshape(3))
        self.gaps = object_gaps(self._footprint, self.obstacles, self.polygons)
        t1 = float(time)
        self._frames.append((t1, self.gaps))
        while self._frames and self._frames[0][0] < t1 - self.settings.window_s - 1e-9:
            self._frames.popleft()
        if len(self._frames) < 2:
            return
        t = np.array([f[0] for f in self._frames])
        if np.ptp(t) <= 0:
            return
        g = np.stack([f[1] for f in self._frames])
        dt = t - t.mean()
        rate = dt @ (g - g.mean(0)) / (dt @ dt)
        pdot, steady = self._mean_command(float(t[0]), t1)
        speed = float(np.linalg.norm(pdot))
        if speed >= self.settings.moving_m_s and steady(pdot / speed) >= speed / 2:
            d = pdot / speed
            along = np.minimum(rate, 0.0) / speed                            # pushing never pulls the object
            now = self.J @ d
            step = np.where(along < np.minimum(now, 0.0), 1.0,                # closing faster than J says: at once
                            np.where(now < 0.0, self.settings.release, 0.0))  # slower: slowly; J·p̂ ≥ 0 says 0 too
            self.J += (step * (along - now))[:, None] * d[None]

    def _mean_command(self, t0: float, t1: float) -> tuple[np.ndarray, Any]:
        """The pusher's mean commanded velocity over [t0, t1] (each command held until the next), and a function
        of a direction: the least speed along it of the commands in that time (a steady push: at least half the
        mean's)."""
        total, out, held = 0.0, np.zeros(2), []
        cmds = list(self._commands)
        for k, (tk, v) in enumerate(cmds):
            end = cmds[k + 1][0] if k + 1 < len(cmds) else max(t1, tk)
            overlap = min(end, t1) - max(tk, t0)
            if overlap > 0:
                out += overlap * v
                total += overlap
                held.append(v)
        along = np.array(held).reshape(-1, 2)
        return (out / total if total > 0 else out), lambda d: float((along @ d).min()) if len(along) else 0.0

    def rows(self, pusher_xy: np.ndarray, T: float, gamma: float,
             now: float | None = None) -> tuple[np.ndarray, np.ndarray]:
        """The object barrier's rows A v ≤ b ((k, 2), (k,)) for the next command, sent at time ``now`` (s, the
        frames' clock; None: the newest frame's time) with the pusher at ``pusher_xy``; none while the pusher is
        away from the footprint, or for an obstacle beyond ``watch_m`` or that no push has been seen to close."""
        none = (np.zeros((0, 2)), np.zeros(0))
        if self._footprint is None or not self._frames:
            return none
        s = self.settings
        reach = distance_to_polygons(np.asarray(pusher_xy, dtype=np.float64), self._footprint)
        if float(reach) > self.shape.pusher_radius + s.contact_m:
            return none
        age = 0.0 if now is None else float(np.clip(now - self._frames[-1][0], 0.0, s.window_s))
        v_last = self._commands[-1][1] if self._commands else np.zeros(2)
        g = self.gaps + np.minimum(self.J @ v_last, 0.0) * age                # the gap now, carried over the age
        closing = (g < s.watch_m) & np.any(self.J != 0.0, axis=1)
        return -self.J[closing], gamma * (g[closing] - s.keep_m) / T           # −J·v ≤ γ (g − keep) / T
