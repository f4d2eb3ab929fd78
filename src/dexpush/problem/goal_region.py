"""Goals that are sets of poses (docs/goal_regions.md): the object's footprint overhanging the table's edge
(:class:`Overhang`), its edge within a distance of a wall (:class:`AtWall`), or a pose with a tolerance per axis
(:class:`PoseBox`).

Every region is written as two kinds of half-plane rows on the object's pose q = (p, θ), with
R = R(θ), the footprint's corners v_i and a point c of the object (its centre of mass for the first two
kinds, the reference point for a pose box), all in {B}:

    reach row (n, o):  max_i n·(p + R v_i) ≥ o      the footprint reaches the line n·x = o
    keep row (n, o):   n·(p + R c) ≤ o              the point c stays on the inner side of the line

and, where the region has a heading, |θ − θ_g| below the problem's heading tolerance. The success test
is these rows as written (:func:`in_region`); the cost (:func:`region_distance_sq`) aims a little inside
them, each row moved inward by its aim δ (the fourth column), so that noise at the goal does not flip the
test; inside the aimed region the goal distance is zero and MPPI stops wherever it got there first.

* :class:`Overhang`: a reach row on a workspace edge (n its outward normal, o = its offset + d: the
  footprint passes the edge by at least d) and a keep row on the same edge (the centre of mass on the
  table); the cost aims at d + :data:`AIM_M` and the centre of mass ``keep_m`` inside. The footprint may
  cross that edge (the pusher may not); the centre of mass crossing it is a drop (:func:`dropped`).
* :class:`AtWall`: a reach row on the face of a wall (or box) obstacle facing a direction, o = its
  offset − e (the footprint comes within e of the face; the obstacle's own cost keeps it off), and keep
  rows that hold the centre of mass in front of the face, between its ends.
* :class:`PoseBox`: keep rows on the reference point, ±tolerance along the goal's own axes, aimed at half
  of them; the heading as in the paper's test (the problem's ``tolerance_deg``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from dexpush.common.checks import check_nonnegative, check_positive, checked_vector
from dexpush.common.se2 import rotate, wrap_angle
from dexpush.model.shape import Shape
from dexpush.problem.regions import footprint_reach, halfplane_corners, halfplanes

__all__ = ["AIM_M", "FIT_WEIGHT", "REGION_SYNTAX", "AtWall", "GoalRegion", "Overhang", "PoseBox", "RegionRows",
           "direction", "dropped", "footprint_centroid", "in_region", "parse_region", "region_distance_sq",
           "region_error"]

#: how far (m) past the success test's line the cost aims a reach row
AIM_M = 0.005
#: the weight of a heading that cannot meet an overhang's two rows (:func:`region_distance_sq`)
FIT_WEIGHT = 10.0

_DIRECTIONS = {"+x": 0.0, "x": 0.0, "-x": 180.0, "+y": 90.0, "y": 90.0, "-y": -90.0}


def direction(value: str | float) -> np.ndarray:
    """A unit direction from ``+x``, ``-x``, ``+y``, ``-y`` or an angle in degrees (from +x, counter-clockwise)."""
    if isinstance(value, str):
        key = value.strip().lower()
        if key in _DIRECTIONS:
            deg = _DIRECTIONS[key]
        else:
            try:
                deg = float(key.removesuffix("deg"))
            except ValueError:
                raise ValueError(f"a direction is +x, -x, +y, -y or an angle in degrees, got {value!r}") from None
    else:
        deg = float(value)
    if not np.isfinite(deg):
        raise ValueError(f"a direction must be finite, got {value!r}")
    return np.array([np.cos(np.radians(deg)), np.sin(np.radians(deg))])


class RegionRows(NamedTuple):
    """A region as arrays (float64, world frame): ``reach`` (G, 4) and ``keep`` (K, 4) rows [n_x, n_y, o, δ]
    (the module docstring), the ``point`` c (2,) in {B} the keep rows hold, and whether the heading counts."""

    reach: np.ndarray
    keep: np.ndarray
    point: np.ndarray
    heading: bool
    #: whether keep row 0 is a table edge: the centre of mass past it is a drop (:func:`dropped`)
    edge: bool = False

    def shifted(self, origin: np.ndarray) -> RegionRows:
        """The same rows seen from ``origin`` (x, y, ...): n·x ≤ o becomes n·(x − origin) ≤ o − n·origin."""
        def move(rows: np.ndarray) -> np.ndarray:
            return np.c_[rows[:, :2], rows[:, 2] - rows[:, :2] @ origin[:2], rows[:, 3]]
        return self._replace(reach=move(self.reach), keep=move(self.keep))


@dataclass(frozen=True)
class Overhang:
    """The footprint passes the workspace edge that faces ``edge`` (``+x``, ``-y``, an angle in degrees: the
    edge whose outward normal is nearest it, within 45°) by at least ``depth_m``, with the centre of mass
    still on the table; the cost aims at ``depth_m`` + :data:`AIM_M` and the centre of mass ``keep_m`` inside
    the edge. ``heading`` (rad): the heading too, within the problem's tolerance; None: any heading."""

    edge: str | float
    depth_m: float
    keep_m: float = 0.02
    heading: float | None = None

    def __post_init__(self) -> None:
        direction(self.edge)
        check_positive("overhang depth", self.depth_m, "m")
        check_nonnegative("overhang keep_m", self.keep_m, "m")
        if self.heading is not None:
            checked_vector("overhang heading", (self.heading,), 1)

    def rows(self, shape: Shape, workspace: np.ndarray | None, polygons: tuple = (),
             margin_m: float = 0.0) -> RegionRows:
        """The rows of this region (``workspace``: the problem's half-planes, or None)."""
        if workspace is None:
            raise ValueError("an overhang goal needs a workspace: the table whose edge the object overhangs")
        k = _facing_row(workspace, direction(self.edge), f"no workspace edge faces {self.edge!r}")
        n, o = workspace[k, :2], workspace[k, 2]
        com = footprint_centroid(shape)
        reach = _most_reach(shape, n, com, self.heading)
        need = self.depth_m + AIM_M + self.keep_m
        if reach < need:
            raise ValueError(f"the overhang depth {self.depth_m * 1e3:.0f} mm is more than the object allows: "
                             f"{shape.name} reaches at most {reach * 1e3:.0f} mm past its centre of mass, and the "
                             f"goal needs {need * 1e3:.0f} (depth + {AIM_M * 1e3:.0f} mm aim + keep_m "
                             f"{self.keep_m * 1e3:.0f} mm)")
        return RegionRows(np.array([[*n, o + self.depth_m, -AIM_M]]), np.array([[*n, o, self.keep_m]]), com,
                          self.heading is not None, edge=True)

    def nominal(self, shape: Shape, rows: RegionRows, workspace: np.ndarray | None,
                margin_m: float = 0.0) -> np.ndarray:
        """A pose in the region's aimed part (the controller's frame origin and the plots' goal marker), from this
        region's :meth:`rows`."""
        n = rows.reach[0, :2]
        theta = _best_heading(shape, n, rows.point) if self.heading is None else float(self.heading)
        mid = _edge_midpoint(workspace, n)
        v = _rotated(shape, theta)
        com = rotate(rows.point, theta)
        # the centre of mass between keep_m inside the edge and where the overhang is depth + aim
        far = float(np.max(v @ n) - com @ n) - self.depth_m + rows.reach[0, 3]
        depth = 0.5 * (self.keep_m + far)
        return np.array([*(mid - n * depth - com), theta])


@dataclass(frozen=True)
class AtWall:
    """The footprint within ``within_m`` of the face of obstacle polygon ``wall`` (an index into the problem's
    polygons: a wall or a box) that faces ``face`` (``+x``, ``-y``, an angle in degrees), its centre of mass in
    front of that face; the obstacle's own cost keeps the footprint off it. ``heading`` as for :class:`Overhang`."""

    wall: int
    within_m: float
    face: str | float
    heading: float | None = None

    def __post_init__(self) -> None:
        if isinstance(self.wall, bool) or not isinstance(self.wall, int | np.integer) or self.wall < 0:
            raise ValueError(f"the wall of an at-wall goal is an index into the obstacle polygons, got {self.wall!r}")
        direction(self.face)
        check_positive("at-wall distance", self.within_m, "m")
        if self.heading is not None:
            checked_vector("at-wall heading", (self.heading,), 1)

    def rows(self, shape: Shape, workspace: np.ndarray | None, polygons: tuple = (),
             margin_m: float = 0.0) -> RegionRows:
        """The rows of this region; ``margin_m`` is the planner's obstacle margin, which the footprint keeps
        from the face: the cost aims between it and ``within_m``."""
        if self.within_m < margin_m + 2 * AIM_M:
            raise ValueError(f"an at-wall distance of {self.within_m * 1e3:.0f} mm leaves no room: the planner keeps "
                             f"{margin_m * 1e3:.0f} mm from obstacles (obstacle_margin_m), so give at least "
                             f"{(margin_m + 2 * AIM_M) * 1e3:.0f} mm")
        if self.wall >= len(polygons):
            raise ValueError(f"the at-wall goal names polygon {self.wall}, but the problem has {len(polygons)} "
                             "polygon obstacles (boxes, walls)")
        corners = np.asarray(polygons[self.wall], np.float64)
        planes = halfplanes(corners)
        k = _facing_row(planes, direction(self.face), f"no face of polygon {self.wall} faces {self.face!r}")
        n, o = planes[k, :2], planes[k, 2]
        a, b = corners[k], corners[(k + 1) % len(corners)]
        t = (b - a) / np.hypot(*(b - a))
        com = footprint_centroid(shape)
        # reach: the footprint's point nearest the face, seen along −n, comes within e of it
        # aimed at a gap halfway between the planner's margin and within_m
        reach = np.array([[*-n, -o - self.within_m, -(self.within_m - margin_m) / 2]])
        keep = np.array([[*-n, -o, 0.0], [*-t, -t @ a, 0.0], [*t, t @ b, 0.0]])
        return RegionRows(reach, keep, com, self.heading is not None)

    def nominal(self, shape: Shape, rows: RegionRows, workspace: np.ndarray | None,
                margin_m: float = 0.0) -> np.ndarray:
        """A pose in the region's aimed part (from this region's :meth:`rows`, ``margin_m`` as there): the centre
        of mass in front of the face's middle."""
        n, t = -rows.reach[0, :2], -rows.keep[1, :2]       # the face's outward normal, and along it
        a, b = -rows.keep[1, 2], rows.keep[2, 2]           # the face's ends along t
        theta = 0.0 if self.heading is None else float(self.heading)
        v, com = _rotated(shape, theta), rotate(rows.point, theta)
        gap = 0.5 * (self.within_m + margin_m)
        p = n * (-rows.keep[0, 2] + gap + float(np.max(v @ -n))) + t * (0.5 * (a + b) - t @ com)
        return np.array([*p, theta])


@dataclass(frozen=True)
class PoseBox:
    """The pose ``goal`` (x, y, θ) within ``x_m`` along the goal's own x axis and ``y_m`` along its y axis (the
    heading within the problem's ``tolerance_deg``); the cost aims within half of each."""

    goal: tuple[float, float, float]
    x_m: float
    y_m: float

    def __post_init__(self) -> None:
        checked_vector("pose-box goal", self.goal, 3)
        check_positive("pose-box x tolerance", self.x_m, "m")
        check_positive("pose-box y tolerance", self.y_m, "m")

    def rows(self, shape: Shape, workspace: np.ndarray | None, polygons: tuple = (),
             margin_m: float = 0.0) -> RegionRows:
        """The rows of this region (four keep rows on the reference point)."""
        g = np.asarray(self.goal, np.float64)
        u = np.array([np.cos(g[2]), np.sin(g[2])])
        w = np.array([-u[1], u[0]])
        keep = np.array([[*u, u @ g[:2] + self.x_m, self.x_m / 2], [*-u, -u @ g[:2] + self.x_m, self.x_m / 2],
                         [*w, w @ g[:2] + self.y_m, self.y_m / 2], [*-w, -w @ g[:2] + self.y_m, self.y_m / 2]])
        return RegionRows(np.zeros((0, 4)), keep, np.zeros(2), True)

    def nominal(self, shape: Shape, rows: RegionRows, workspace: np.ndarray | None,
                margin_m: float = 0.0) -> np.ndarray:
        """The pose itself."""
        return np.asarray(self.goal, np.float64)


#: what a problem's ``region`` may be
GoalRegion = Overhang | AtWall | PoseBox

#: the text forms :func:`parse_region` reads (``--goal-region``, ``[run] goal_region``)
REGION_SYNTAX = "overhang:EDGE,DEPTH[,KEEP] | wall:INDEX,FACE,WITHIN | box:X,Y,THETA,TOL_X,TOL_Y"


def parse_region(text: str) -> GoalRegion:
    """A goal region from its text form (:data:`REGION_SYNTAX`; lengths in m, EDGE and FACE ``+x``, ``-y`` or
    degrees, THETA in rad or e.g. ``30deg``), e.g. ``overhang:+x,0.06``; a one-line ``ValueError`` otherwise."""
    kind, _, rest = str(text).partition(":")
    parts = [t.strip() for t in rest.split(",")] if rest.strip() else []

    def number(t: str, angle: bool = False) -> float:
        try:
            v = np.radians(float(t[:-3])) if angle and t.endswith("deg") else float(t)
        except ValueError:
            raise ValueError(f"goal region {text!r}: {t!r} is not a number ({REGION_SYNTAX})") from None
        if not np.isfinite(v):
            raise ValueError(f"goal region {text!r}: numbers must be finite")
        return float(v)

    kind = kind.strip().lower()
    if kind == "overhang" and len(parts) in (2, 3):
        return Overhang(parts[0], *(number(t) for t in parts[1:]))
    if kind == "wall" and len(parts) == 3:
        if not parts[0].isdigit():
            raise ValueError(f"goal region {text!r}: the wall is an index into the polygon obstacles, got {parts[0]!r}")
        return AtWall(int(parts[0]), number(parts[2]), parts[1])
    if kind == "box" and len(parts) == 5:
        x, y, theta, tx, ty = number(parts[0]), number(parts[1]), number(parts[2], True), *map(number, parts[3:])
        return PoseBox((x, y, theta), tx, ty)
    raise ValueError(f"goal region {text!r}: expected {REGION_SYNTAX}")


# ---------------------------------------------------------------------------- tests and costs (numpy or jnp)
def _support(xb: Any, yb: Any, s: Any, c: Any, n: Any, corners: Any, xp: Any) -> Any:
    """max_i n·(p + R v_i) over the corners (C, 2) in {B}, for poses (...,)."""
    return n[0] * xb + n[1] * yb + footprint_reach(s, c, n[0], n[1], corners, xp)


def _point(xb: Any, yb: Any, s: Any, c: Any, point: Any) -> tuple[Any, Any]:
    return xb + c * point[0] - s * point[1], yb + s * point[0] + c * point[1]


def region_distance_sq(xb: Any, yb: Any, th: Any, reach: Any, keep: Any, point: Any, corners: Any,
                       xp: Any) -> Any:
    """The squared position distance of poses (...,) to the aimed region, zero inside it:

        Σ_g max(s_g, 0)² + Σ_k max(e_k, 0)² + w · Σ_(g,k) ∥ max(s_g + e_k, 0)²

    with s_g = o_g − δ_g − max_i n_g·(p + R v_i) the reach row's shortfall and e_k = n_k·(p + R c) − (o_k − δ_k)
    the keep row's excess (each row moved inward by its aim δ: the squared distance to the region where one row
    is not met). The last sum runs over the reach and keep rows on one line (n_g = n_k: an overhang's edge);
    s_g + e_k does not depend on p: it is how much farther the footprint must reach past its point c than it
    does at heading θ, so the headings that cannot meet both rows cost everywhere (weighted
    :data:`FIT_WEIGHT`), and the object is turned on the way rather than at the edge, where the pusher cannot
    get behind it."""
    s, c = xp.sin(th), xp.cos(th)
    total = xp.zeros_like(xb)
    px, py = _point(xb, yb, s, c, point)
    over = [keep[k, 0] * px + keep[k, 1] * py - (keep[k, 2] - keep[k, 3]) for k in range(keep.shape[0])]
    for e in over:
        total = total + xp.maximum(e, 0.0) ** 2
    for g in range(reach.shape[0]):
        short = reach[g, 2] - reach[g, 3] - _support(xb, yb, s, c, reach[g], corners, xp)
        total = total + xp.maximum(short, 0.0) ** 2
        for k, e in enumerate(over):
            same_line = (reach[g, 0] * keep[k, 0] + reach[g, 1] * keep[k, 1]) > 0.999
            total = total + xp.where(same_line, FIT_WEIGHT * xp.maximum(short + e, 0.0) ** 2, 0.0)
    return total


def region_error(pose: Any, reach: Any, keep: Any, point: Any, corners: Any, xp: Any = np) -> Any:
    """How far (m) poses (..., 3) are from the region as the success test reads it: the largest amount by
    which a row is not met; zero or less inside."""
    xb, yb, th = pose[..., 0], pose[..., 1], pose[..., 2]
    s, c = xp.sin(th), xp.cos(th)
    worst = xp.full(xp.shape(xb), -xp.inf)
    for g in range(reach.shape[0]):
        worst = xp.maximum(worst, reach[g, 2] - _support(xb, yb, s, c, reach[g], corners, xp))
    px, py = _point(xb, yb, s, c, point)
    for k in range(keep.shape[0]):
        worst = xp.maximum(worst, keep[k, 0] * px + keep[k, 1] * py - keep[k, 2])
    return worst


def in_region(pose: Any, goal: Any, reach: Any, keep: Any, point: Any, corners: Any, heading: Any,
              heading_deg: float, xp: Any = np) -> Any:
    """Whether poses (..., 3) meet every row, and (where ``heading`` is 1) head within ``heading_deg`` of the
    goal's θ."""
    inside = region_error(pose, reach, keep, point, corners, xp) <= 0
    turned = xp.abs(wrap_angle(pose[..., 2] - goal[2], xp)) * heading
    return inside & (turned < np.radians(heading_deg))


def dropped(pose: Any, rows: RegionRows | None, xp: Any = np) -> Any:
    """Whether the centre of mass of poses (..., 3) is past an overhang's edge (the object falls); False for
    other regions."""
    if rows is None or not rows.edge:
        return xp.zeros(xp.shape(pose[..., 0]), bool)
    th = pose[..., 2]
    px, py = _point(pose[..., 0], pose[..., 1], xp.sin(th), xp.cos(th), rows.point)
    return rows.keep[0, 0] * px + rows.keep[0, 1] * py > rows.keep[0, 2]


# ---------------------------------------------------------------------------- geometry helpers (numpy)
def footprint_centroid(shape: Shape) -> np.ndarray:
    """The area centroid (2,) of the footprint in {B}: the centre of mass of a uniform object (pieces that
    overlap count twice)."""
    area, moment = 0.0, np.zeros(2)
    for p in shape.polygons:
        q = np.roll(p, -1, axis=0)
        cross = p[:, 0] * q[:, 1] - q[:, 0] * p[:, 1]
        a = 0.5 * np.sum(cross)
        area += a
        moment += np.sum((p + q) * cross[:, None], 0) / 6.0
    return moment / area


def _rotated(shape: Shape, theta: float) -> np.ndarray:
    """The footprint's corners (all polygons') turned by θ about the reference point."""
    return rotate(np.concatenate(shape.polygons), theta)


def _reach_past(shape: Shape, n: np.ndarray, com: np.ndarray, angles: object) -> np.ndarray:
    """How far (m) the footprint reaches past its centre of mass ``com`` along n, at each heading of ``angles``."""
    return np.array([float(np.max(_rotated(shape, a) @ n) - rotate(com, a) @ n) for a in np.atleast_1d(angles)])


def _most_reach(shape: Shape, n: np.ndarray, com: np.ndarray, heading: float | None) -> float:
    """:func:`_reach_past` at ``heading``, or the most over headings (every 1°)."""
    return float(np.max(_reach_past(shape, n, com, np.radians(np.arange(360)) if heading is None else heading)))


def _best_heading(shape: Shape, n: np.ndarray, com: np.ndarray) -> float:
    """The heading (every 1° of a half turn) at which the footprint reaches farthest past ``com`` along n."""
    angles = np.radians(np.arange(180))
    return float(angles[int(np.argmax(_reach_past(shape, n, com, angles)))])


def _facing_row(rows: np.ndarray, d: np.ndarray, error: str) -> int:
    """The row whose outward normal is nearest the direction d (less than 45° from it), else a ``ValueError``."""
    k = int(np.argmax(rows[:, :2] @ d))
    if rows[k, :2] @ d < np.cos(np.radians(45.0)) + 1e-9:
        raise ValueError(error)
    return k


def _edge_midpoint(workspace: np.ndarray, n: np.ndarray) -> np.ndarray:
    """The midpoint of the workspace edge with outward normal n (rows [n_x, n_y, o], counter-clockwise)."""
    corners = halfplane_corners(workspace)
    k = int(np.argmax(workspace[:, :2] @ n))
    return 0.5 * (corners[k - 1] + corners[k])
