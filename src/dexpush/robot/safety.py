"""The safety filter between the planner and the robot: the closest safe pusher velocity (a small QP).

Each control period the planner asks for a planar pusher velocity ``u`` (m/s) to be held for
``T`` seconds. The filter returns

    v* = argmin_v ‖v − u‖²   subject to   A v ≤ b                                   (QP)

where the rows of ``A v ≤ b`` are linear in v (docs/robot.md#the-safety-filter):

* **speed** |v| ≤ v_max, as the regular 16-gon inscribed in that disc;
* **acceleration** |v − v_prev| ≤ a_max·T, the inscribed 16-gon around the previous command;
* **workspace** (a convex polygon, e.g. the table's rectangle, that the pusher disc must stay in:
  each edge n·p ≤ o a row with d = o − n·p − ρ), the arm's **reach** (an annulus about the
  robot's base: beyond r_max the arm stretches to its joint limits, within r_min it folds to
  them), **keep-out discs** and **keep-out polygons** (obstacles, boxes and walls, grown by the pusher
  radius ρ and a margin; a polygon's normal n points from its nearest point to the pusher), each as
  a discrete-time barrier on the signed distance d to the boundary along its outward normal n:
  d(t+T) ≥ (1 − γ)·d(t), linearised as

      n·v ≥ −γ·d / T                                                               (barrier)

  so the pusher may approach a boundary at no more than γ·d/T and never crosses it; with
  ``γ = T / braking_s`` it slows over about ``braking_s`` seconds as it nears.

The QP has two unknowns, so it is solved exactly: when u is feasible it is returned unchanged
(the identity on safe commands); otherwise the optimum lies on one constraint line (the
projection of u onto it) or at a vertex where two meet, and the closest feasible candidate is
it. When the constraints admit no velocity (the previous command was fast towards a wall just
met, or the pusher is already inside a keep-out zone) the acceleration rows are dropped first
and the speed rows second (safety before smoothness); with nothing feasible the command is zero.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from dexpush.common.checks import check_nonnegative, check_positive
from dexpush.problem.regions import convex_polygon, nearest_on_outline, workspace_halfplanes

__all__ = ["FilterResult", "SafetySettings", "barrier_rate", "filter_velocity", "safe_velocity"]

_SIDES = 16
_COS = np.cos(np.pi / _SIDES)
_NORMALS = np.stack([np.cos(2 * np.pi * np.arange(_SIDES) / _SIDES), np.sin(2 * np.pi * np.arange(_SIDES) / _SIDES)], 1)


@dataclass(frozen=True)
class SafetySettings:
    """What the filter keeps the pusher within (metres, seconds, in the table frame).

    The defaults suit the paper's set-up: a planner at ≤ 0.1 m/s and a Franka that accelerates the
    tip at 2.5 m/s² at most while pushing (a fifth of its 13 m/s² limit, docs/robot.md).
    """

    v_max: float = 0.15                   #: speed limit of the pusher (m/s); the planner's v_max is below it
    a_max: float = 2.5                    #: change of the command per second (m/s²)
    #: the workspace the pusher disc stays in: a rectangle (x_min, y_min, x_max, y_max) or a convex polygon's
    #: corners ((x, y), ...), in m; None for no bounds
    workspace: tuple | None = None
    #: the arm's reach (base_x, base_y, r_min, r_max): the tip stays between r_min and r_max (m) from the
    #: base's vertical axis at (base_x, base_y) in the table frame; None: no such limit
    reach: tuple[float, float, float, float] | None = None
    keep_out_margin: float = 0.005        #: keep-out discs are obstacles grown by the pusher radius and this (m)
    braking_s: float = 0.3                #: the barrier's time constant: γ = T / braking_s (at most 1)

    @cached_property
    def workspace_rows(self) -> np.ndarray:
        """The workspace as half-plane rows [n_x, n_y, o] (n·p ≤ o inside; (0, 3) without one), derived once."""
        return np.zeros((0, 3)) if self.workspace is None else workspace_halfplanes(self.workspace)

    def __post_init__(self) -> None:
        for name in ("v_max", "a_max", "braking_s"):
            check_positive(name, getattr(self, name))
        check_nonnegative("keep_out_margin", self.keep_out_margin, "m")
        if self.workspace is not None:
            w = np.asarray(self.workspace, dtype=object)
            if w.shape == (4,):
                w = tuple(float(x) for x in self.workspace)
                if not all(np.isfinite(w)) or not (w[0] < w[2] and w[1] < w[3]):
                    raise ValueError(f"workspace is (x_min, y_min, x_max, y_max) in m with min < max, got "
                                     f"{self.workspace!r}")
            else:
                w = tuple((float(x), float(y)) for x, y in convex_polygon(self.workspace, "the filter's workspace"))
            object.__setattr__(self, "workspace", w)
        if self.reach is not None:
            r = tuple(float(x) for x in self.reach)
            if len(r) != 4 or not all(np.isfinite(r)) or not (0 <= r[2] < r[3]):
                raise ValueError(f"reach is (base_x, base_y, r_min, r_max) in m with 0 <= r_min < r_max, got "
                                 f"{self.reach!r}")
            object.__setattr__(self, "reach", r)


@dataclass(frozen=True)
class FilterResult:
    """The filtered command and why it differs: ``changed`` (v ≠ u), ``active`` (names of the constraints
    it lies on: speed, acceleration, workspace, reach, keep-out), ``relaxed`` (rows dropped because nothing
    satisfied them all: "acceleration", "acceleration+speed", "all" (stopped), or "")."""

    velocity: np.ndarray
    changed: bool
    active: tuple[str, ...]
    relaxed: str


def barrier_rate(T: float, s: SafetySettings) -> float:
    """γ of the barrier rows: T / ``braking_s``, at most 1."""
    return min(1.0, T / s.braking_s)


def _rows(p: np.ndarray, v_prev: np.ndarray, obstacles: np.ndarray, polygons: tuple[np.ndarray, ...], radius: float,
          T: float, s: SafetySettings) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """The constraint groups (name, A, b) of A v ≤ b."""
    gamma = barrier_rate(T, s)
    groups = [("speed", _NORMALS, np.full(_SIDES, s.v_max * _COS)),
              ("acceleration", _NORMALS, _NORMALS @ v_prev + s.a_max * T * _COS)]
    if s.workspace is not None:
        rows = s.workspace_rows
        d = rows[:, 2] - rows[:, :2] @ p - radius                             # the pusher disc's gap inside
        groups.append(("workspace", rows[:, :2], gamma * d / T))              # n·v ≤ γ d / T
    if s.reach is not None:
        bx, by, r_min, r_max = s.reach
        delta = p - (bx, by)
        dist = float(np.linalg.norm(delta))
        n = delta / dist if dist > 1e-9 else np.array([1.0, 0.0])
        groups.append(("reach", np.stack([n, -n]), gamma * np.array([r_max - dist, dist - r_min]) / T))
    if len(obstacles):
        c, r = obstacles[:, :2], obstacles[:, 2] + radius + s.keep_out_margin
        delta = p[None] - c
        dist = np.linalg.norm(delta, axis=1)
        n = np.where(dist[:, None] > 1e-9, delta / np.maximum(dist, 1e-9)[:, None], np.array([1.0, 0.0]))
        groups.append(("keep-out", -n, gamma * (dist - r) / T))               # −n·v ≤ γ d / T
    if polygons:
        near, inside = (np.array(v) for v in zip(*(nearest_on_outline(p, poly) for poly in polygons)))
        delta = p[None] - near
        dist = np.linalg.norm(delta, axis=1)
        n = np.where(dist[:, None] > 1e-9, delta / np.maximum(dist, 1e-9)[:, None], np.array([1.0, 0.0]))
        n = np.where(inside[:, None], -n, n)                                  # from inside: outward is away
        gap = np.where(inside, -dist, dist) - radius - s.keep_out_margin
        groups.append(("keep-out", -n, gamma * gap / T))
    merged: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    for name, A, b in groups:                                                 # discs' and polygons' rows: one group
        A0, b0 = merged.get(name, (np.zeros((0, 2)), np.zeros(0)))
        merged[name] = (np.concatenate([A0, A]), np.concatenate([b0, b]))
    return [(name, A, b) for name, (A, b) in merged.items()]


def _project(u: np.ndarray, A: np.ndarray, b: np.ndarray, tol: float = 1e-12) -> np.ndarray | None:
    """argmin ‖v − u‖² subject to A v ≤ b, exactly (two unknowns), or None when infeasible."""
    if np.all(A @ u <= b + tol):
        return u
    norms2 = np.sum(A * A, 1)
    cands = [u[None] - ((A @ u - b) / norms2)[:, None] * A]                  # onto each line
    i, j = np.triu_indices(len(b), 1)
    det = A[i, 0] * A[j, 1] - A[i, 1] * A[j, 0]
    ok = np.abs(det) > 1e-12
    i, j, det = i[ok], j[ok], det[ok]
    vx = (b[i] * A[j, 1] - b[j] * A[i, 1]) / det                               # where two lines meet
    vy = (A[i, 0] * b[j] - A[j, 0] * b[i]) / det
    cands.append(np.stack([vx, vy], 1))
    cands = np.concatenate(cands)
    feasible = np.all(cands @ A.T <= b[None] + 1e-9 * (1 + np.abs(b[None])), 1)
    if not feasible.any():
        return None
    cands = cands[feasible]
    return cands[np.argmin(np.sum((cands - u) ** 2, 1))]


def safe_velocity(u: object, pusher_xy: object, v_prev: object, control_period: float,
                  settings: SafetySettings, obstacles: object = (), pusher_radius: float = 0.0,
                  polygons: object = ()) -> FilterResult:
    """The closest velocity to ``u`` that keeps the pusher safe for the next ``control_period`` (QP above).

    Args:
        u: the planner's command (v_x, v_y), m/s.
        pusher_xy: where the pusher centre is now (m, table frame).
        v_prev: the command sent last period (m/s), for the acceleration limit.
        control_period: T, how long the command is held (s).
        settings: :class:`SafetySettings`.
        obstacles: discs (c_x, c_y, radius), (m, 3), in m; grown by ``pusher_radius`` and the margin.
        pusher_radius: ρ (m): the pusher disc stays inside the workspace and out of the keep-out zones.
        polygons: convex keep-out polygons (boxes, walls), each its corners (k, 2) in m; grown likewise.
    """
    u = np.asarray(u, dtype=np.float64).reshape(2)
    if not np.all(np.isfinite(u)):
        u = np.zeros(2)          # a non-finite request is treated as a request to stop
    p = np.asarray(pusher_xy, dtype=np.float64).reshape(2)
    vp = np.asarray(v_prev, dtype=np.float64).reshape(2)
    T = check_positive("control_period", control_period, "s")
    obs = np.asarray(obstacles, dtype=np.float64).reshape(-1, 3)
    return filter_velocity(u, p, vp, T, settings, obs, float(pusher_radius),
                           tuple(convex_polygon(q, "keep-out polygon") for q in polygons))


def filter_velocity(u: np.ndarray, p: np.ndarray, v_prev: np.ndarray, T: float, settings: SafetySettings,
                    obstacles: np.ndarray, pusher_radius: float, polygons: tuple[np.ndarray, ...],
                    extra: tuple[tuple[str, np.ndarray, np.ndarray], ...] = ()) -> FilterResult:
    """:func:`safe_velocity` on inputs already checked: float64 (2,) ``u`` (finite), ``p`` and ``v_prev``,
    ``T`` > 0, discs (m, 3) and ``polygons`` as :func:`dexpush.problem.regions.convex_polygon` returns them
    (counter-clockwise). A loop that filters every period checks its keep-out zones once and calls this.
    ``extra``: more groups (name, A, b) of rows A v ≤ b, kept like the keep-out rows (the object's barrier,
    :mod:`dexpush.robot.object_watch`)."""
    groups = _rows(p, v_prev, obstacles, polygons, pusher_radius, T, settings)
    groups += [(name, A, b) for name, A, b in extra if len(b)]
    by_name = {name: (A, b) for name, A, b in groups}
    tiers = [("", [g[0] for g in groups]),
             ("acceleration", [g[0] for g in groups if g[0] != "acceleration"]),
             ("acceleration+speed", [g[0] for g in groups if g[0] not in ("acceleration", "speed")])]
    for relaxed, names in tiers:
        if not names:
            continue
        A = np.concatenate([by_name[n][0] for n in names])
        b = np.concatenate([by_name[n][1] for n in names])
        v = _project(u, A, b)
        if v is not None:
            if relaxed == "acceleration+speed":      # never faster than the limit: shrink along the safe direction
                speed = float(np.linalg.norm(v))
                v = v * min(1.0, settings.v_max * _COS / speed) if speed > 0 else v
            active = tuple(n for n in names if np.any(np.abs(by_name[n][0] @ v - by_name[n][1]) <= 1e-9 + 1e-9
                                                      * np.abs(by_name[n][1])))
            return FilterResult(v, bool(np.any(v != u)), active, relaxed)
    return FilterResult(np.zeros(2), bool(np.any(u != 0)), (), "all")
