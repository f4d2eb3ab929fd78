"""The obstacle and workspace kinds beyond discs, as convex polygons in the world frame (numpy).

* a **box** (:func:`box`): a rectangle of width × height about a centre, turned by a yaw;
* a **wall** (:func:`wall`): a segment with a thickness, i.e. the rectangle swept by it;
* a **convex polygon** (:func:`convex_polygon`): any convex corners, counter-clockwise after checking;
* a **workspace** (:func:`workspace_halfplanes`): a convex polygon (the table, a tray, a bin's floor)
  that the object's footprint and the pusher must stay inside.

A union of obstacles is simply several of them. Each polygon is also written as half-planes
n·p ≤ o (outward unit normals n), the form the cost's separating-axis gaps and the workspace
test use (:mod:`dexpush.problem.obstacles`). :func:`footprint_reach`, how far a turned footprint reaches
along a direction, serves the workspace gaps and the goal regions (numpy or jnp).
"""

from __future__ import annotations

import functools
from typing import Any

import numpy as np

from dexpush.common.checks import check_positive, checked_vector
from dexpush.model.polygons import as_polygon, is_convex

__all__ = ["MAX_POLYGON_CORNERS", "UNROLL_CORNERS", "box", "clip_convex", "convex_polygon", "footprint_reach",
           "halfplane_corners", "halfplanes", "nearest_on_outline", "point_gap", "wall", "workspace_halfplanes"]

#: the most corners an obstacle polygon or a workspace may have (each costs every rollout step a few
#: multiply-adds per footprint corner)
MAX_POLYGON_CORNERS = 16


def convex_polygon(vertices: object, name: str = "polygon") -> np.ndarray:
    """Corners (n, 2) float64 of a convex polygon, counter-clockwise; a ``ValueError`` names ``name``
    for anything else (fewer than 3 corners, zero area, a concave or self-intersecting outline, more than
    :data:`MAX_POLYGON_CORNERS` corners)."""
    try:
        v = as_polygon(vertices, name)
    except ValueError as exc:
        raise ValueError(f"{name}: {exc}") from None
    if len(v) > MAX_POLYGON_CORNERS:
        raise ValueError(f"{name} has {len(v)} corners; at most {MAX_POLYGON_CORNERS} are allowed")
    if not is_convex(v):
        raise ValueError(f"{name} must be convex (split a concave one into convex pieces), got corners {v.tolist()}")
    edges = np.roll(v, -1, axis=0) - v
    if np.min(np.hypot(edges[:, 0], edges[:, 1])) < 1e-4:
        raise ValueError(f"{name} has an edge shorter than 0.1 mm: {v.tolist()}")
    return v


def box(centre_x: float, centre_y: float, width: float, height: float, yaw: float = 0.0) -> np.ndarray:
    """The corners (4, 2) of a ``width × height`` rectangle about (centre_x, centre_y), turned by ``yaw`` (rad)."""
    cx, cy, yaw = checked_vector("box centre and yaw", (centre_x, centre_y, yaw), 3)
    w = check_positive("box width", width, "m") / 2
    h = check_positive("box height", height, "m") / 2
    c, s = np.cos(yaw), np.sin(yaw)
    local = np.array([[-w, -h], [w, -h], [w, h], [-w, h]])
    return local @ np.array([[c, s], [-s, c]]) + np.array([cx, cy])


def wall(x0: float, y0: float, x1: float, y1: float, thickness: float) -> np.ndarray:
    """The corners (4, 2) of the wall from (x0, y0) to (x1, y1): the segment swept ``thickness``/2 to
    each side (its ends are square, flush with the end points)."""
    p0, p1 = checked_vector("wall start", (x0, y0), 2), checked_vector("wall end", (x1, y1), 2)
    t = check_positive("wall thickness", thickness, "m") / 2
    d = p1 - p0
    length = float(np.hypot(*d))
    if length < 1e-4:
        raise ValueError(f"a wall needs two distinct end points, got ({x0}, {y0}) and ({x1}, {y1})")
    n = np.array([-d[1], d[0]]) / length * t
    return np.array([p0 - n, p1 - n, p1 + n, p0 + n])


def halfplanes(vertices: np.ndarray) -> np.ndarray:
    """A counter-clockwise convex polygon as rows [n_x, n_y, o]: the polygon is {p : n·p ≤ o for every row},
    n the outward unit normal of each edge."""
    v = np.asarray(vertices, dtype=np.float64)
    e = np.roll(v, -1, axis=0) - v
    n = np.stack([e[:, 1], -e[:, 0]], -1) / np.hypot(e[:, 0], e[:, 1])[:, None]
    return np.concatenate([n, np.sum(n * v, -1, keepdims=True)], -1)


def workspace_halfplanes(vertices: object) -> np.ndarray:
    """The workspace (a rectangle (x_lo, y_lo, x_hi, y_hi) or a convex polygon's corners) as
    :func:`halfplanes` rows; a clear ``ValueError`` for anything else."""
    arr = np.asarray(vertices, dtype=object)
    if arr.shape == (4,):
        lo_x, lo_y, hi_x, hi_y = checked_vector("workspace (x_lo, y_lo, x_hi, y_hi)", vertices, 4)
        if hi_x - lo_x < 1e-3 or hi_y - lo_y < 1e-3:
            raise ValueError(f"workspace (x_lo, y_lo, x_hi, y_hi) must have x_hi > x_lo and y_hi > y_lo, "
                             f"got {tuple(float(v) for v in vertices)}")
        vertices = [[lo_x, lo_y], [hi_x, lo_y], [hi_x, hi_y], [lo_x, hi_y]]
    return halfplanes(convex_polygon(vertices, "workspace"))


#: footprints with at most this many corners have their reach unrolled into elementwise code (the cost's, in
#: every rollout step, where XLA fuses it); more (the judge's ellipse) are reduced as arrays
UNROLL_CORNERS = 32


def footprint_reach(s: Any, c: Any, nx: Any, ny: Any, corners: Any, xp: Any = np) -> Any:
    """max_i m·v_i over the footprint's corners v_i (C, 2) in {B}, m = R(θ)ᵀ n the direction n seen from the
    body at heading θ (s, c = sin θ, cos θ): how far the footprint reaches along n past its reference point.
    Unrolled over at most :data:`UNROLL_CORNERS` corners, reduced as an array over more."""
    mx, my = c * nx + s * ny, -s * nx + c * ny                    # the direction in {B}
    if corners.shape[0] > UNROLL_CORNERS:
        return xp.max(mx[..., None] * corners[:, 0] + my[..., None] * corners[:, 1], -1)
    return functools.reduce(xp.maximum, [mx * corners[e, 0] + my * corners[e, 1]
                                         for e in range(corners.shape[0])])


def halfplane_corners(bounds: np.ndarray) -> np.ndarray:
    """The corners of a convex polygon from its :func:`halfplanes` rows (each corner where a row's line meets
    the next's)."""
    n, o = bounds[:, :2], bounds[:, 2]
    n1, o1 = np.roll(n, -1, axis=0), np.roll(o, -1)
    det = n[:, 0] * n1[:, 1] - n[:, 1] * n1[:, 0]
    return np.stack([(o * n1[:, 1] - o1 * n[:, 1]) / det, (n[:, 0] * o1 - n1[:, 0] * o) / det], -1)


def nearest_on_outline(points: np.ndarray, polygon: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For points (..., 2) and a counter-clockwise convex polygon: the nearest point of its outline (..., 2)
    and whether each point lies inside (...,)."""
    p = np.asarray(points, dtype=np.float64)[..., None, :]
    a = np.asarray(polygon, dtype=np.float64)
    e = np.roll(a, -1, axis=0) - a
    t = np.clip(np.sum((p - a) * e, -1) / np.sum(e * e, -1), 0.0, 1.0)
    q = a + t[..., None] * e                                     # the nearest point of each edge
    k = np.argmin(np.sum((p - q) ** 2, -1), -1)
    nearest = np.take_along_axis(q, k[..., None, None], -2)[..., 0, :]
    inside = np.all((e[:, 0] * (p[..., 1] - a[:, 1]) - e[:, 1] * (p[..., 0] - a[:, 0])) >= 0, -1)
    return nearest, inside


def point_gap(points: np.ndarray, polygon: np.ndarray) -> np.ndarray:
    """Signed distance (m) from points (..., 2) to a convex polygon: positive outside (exact), negative
    inside (minus the distance to the nearest edge)."""
    nearest, inside = nearest_on_outline(points, polygon)
    d = np.hypot(*np.moveaxis(np.asarray(points, dtype=np.float64) - nearest, -1, 0))
    return np.where(inside, -d, d)


def clip_convex(vertices: object, rows: object) -> np.ndarray:
    """The corners (n, 2) of the convex polygon ``vertices`` cut by the half-planes ``rows`` [n_x, n_y, o]
    (n·p ≤ o kept), counter-clockwise, corners closer than 0.1 mm to the next merged; (0, 2) when nothing is
    left (Sutherland–Hodgman, one half-plane at a time)."""
    poly = np.asarray(vertices, dtype=np.float64).reshape(-1, 2)
    for nx, ny, o in np.asarray(rows, dtype=np.float64).reshape(-1, 3):
        if len(poly) == 0:
            break
        side = poly @ (nx, ny) - o                          # > 0: outside
        nxt, side_nxt = np.roll(poly, -1, axis=0), np.roll(side, -1)
        out = []
        for p, q, a, b in zip(poly, nxt, side, side_nxt):
            if a <= 0:
                out.append(p)
            if (a < 0 < b) or (b < 0 < a):                   # the edge crosses the line: keep the crossing
                out.append(p + (q - p) * (a / (a - b)))
        poly = np.asarray(out, dtype=np.float64).reshape(-1, 2)
    if len(poly):
        keep = np.hypot(*(np.roll(poly, -1, axis=0) - poly).T) >= 1e-4
        poly = poly[keep]
    return poly if len(poly) >= 3 else np.zeros((0, 2))
