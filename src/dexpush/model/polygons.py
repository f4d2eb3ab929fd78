"""Polygon basics in numpy: a footprint's corners checked and cleaned (:func:`as_polygon`), its
convex hull, and containment and distance tests (the radial table, the kernel search and the
convex pieces build on these).

Everything here runs once per shape, at construction, in float64; nothing is traced by JAX.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "MAX_CORNERS",
    "MAX_SHAPE_M",
    "as_polygon",
    "circumscribed",
    "convex_hull",
    "cross2",
    "distance_to_polygons",
    "inside_polygon",
    "is_convex",
    "union_distance",
]

#: the largest coordinate (m) a footprint's corner may have: a pushed object fits on a table
MAX_SHAPE_M = 10.0
#: the most corners a shape's polygons may have together: each costs the contour table a ray test
#: and each of the planner's obstacle tests an edge (docs/reliability.md)
MAX_CORNERS = 1024


def as_polygon(vertices: object, name: str = "vertices") -> np.ndarray:
    """Corners as a counter-clockwise (n, 2) float64 array: repeated corners merged, a closing
    corner dropped; degenerate or self-intersecting polygons are refused with the reason, and so
    are booleans, corners beyond ±:data:`MAX_SHAPE_M` and more than :data:`MAX_CORNERS` corners."""
    try:
        raw = np.asarray(vertices)
        if raw.dtype.kind not in "iuf" or _holds_bool(vertices):
            raise TypeError
        v = raw.astype(np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be an (n, 2) array of polygon corners (numbers, metres), got {vertices!r}") \
            from exc
    if v.ndim != 2 or v.shape[1] != 2:
        raise ValueError(f"{name} must be an (n, 2) array of polygon corners, got shape {v.shape}")
    if not np.all(np.isfinite(v)):
        raise ValueError(f"{name} contains NaN or infinite coordinates")
    if np.any(np.abs(v) > MAX_SHAPE_M):
        raise ValueError(f"{name} has a corner {np.max(np.abs(v)):.3g} m from the origin; corners must lie within "
                         f"±{MAX_SHAPE_M:g} m (lengths are in metres)")
    if len(v) > MAX_CORNERS:
        raise ValueError(f"{name} has {len(v)} corners; a shape may have at most {MAX_CORNERS} (simplify the outline)")
    scale = max(float(np.ptp(v[:, 0])) if len(v) else 0.0, float(np.ptp(v[:, 1])) if len(v) else 0.0, 1e-300)
    # merge repeated corners (consecutive, and a closing corner equal to the first)
    keep = np.linalg.norm(v - np.roll(v, 1, axis=0), axis=-1) > 1e-12 * scale
    v = v[keep] if len(v) > 1 and np.any(keep) else v[:1]
    if v.shape[0] < 3:
        raise ValueError(f"{name}: a polygon needs at least 3 distinct corners, got {v.shape[0]}")
    crossing = _self_intersection(v)
    if crossing is not None:
        i, j = crossing
        raise ValueError(f"{name} is self-intersecting: its edge from corner {i} and its edge from corner {j} "
                         "cross. List the corners in order around the boundary (a simple polygon).")
    area2 = np.sum(v[:, 0] * np.roll(v[:, 1], -1) - np.roll(v[:, 0], -1) * v[:, 1])
    if abs(area2) < 1e-9 * scale**2:
        raise ValueError(f"{name}: degenerate polygon (zero area; are the corners collinear?)")
    if area2 < 0:  # make counter-clockwise
        v = v[::-1].copy()
    return v


def _holds_bool(value: object) -> bool:
    """Whether a nested list or tuple holds a boolean (numpy would take True as 1 m)."""
    if isinstance(value, bool | np.bool_):
        return True
    return isinstance(value, list | tuple) and any(_holds_bool(v) for v in value)


def _self_intersection(v: np.ndarray) -> tuple[int, int] | None:
    """The first pair of non-adjacent edges (by start corner) that properly cross, or None."""
    a, b = v, np.roll(v, -1, axis=0)
    n = len(v)
    d = b - a

    def cross(p: np.ndarray, q: np.ndarray) -> np.ndarray:
        return p[..., 0] * q[..., 1] - p[..., 1] * q[..., 0]

    for i in range(n):                   # one row of the pair matrix at a time: O(n) memory
        j = np.arange(i + 2, n if i > 0 else n - 1)
        if not len(j):
            continue
        o1 = cross(d[i], a[j] - a[i])
        o2 = cross(d[i], b[j] - a[i])
        o3 = cross(d[j], a[i] - a[j])
        o4 = cross(d[j], b[i] - a[j])
        hit = (o1 * o2 < 0) & (o3 * o4 < 0)
        if np.any(hit):
            return i, int(j[np.argmax(hit)])
    return None


def convex_hull(points: np.ndarray) -> np.ndarray:
    """The convex hull's corners (k, 2), counter-clockwise (Andrew's monotone chain)."""
    pts = np.unique(np.asarray(points, dtype=np.float64).reshape(-1, 2), axis=0)

    def chain(seq: np.ndarray) -> list[np.ndarray]:
        out: list[np.ndarray] = []
        for q in seq:
            while len(out) >= 2 and cross2(out[-1] - out[-2], q - out[-2]) <= 0:
                out.pop()
            out.append(q)
        return out[:-1]

    return np.asarray(chain(pts) + chain(pts[::-1]))


def is_convex(polygon: np.ndarray) -> bool:
    """Whether a counter-clockwise polygon (n, 2) is convex (collinear corners allowed)."""
    e = np.roll(polygon, -1, axis=0) - polygon
    cross = e[:, 0] * np.roll(e, -1, axis=0)[:, 1] - e[:, 1] * np.roll(e, -1, axis=0)[:, 0]
    return bool(np.all(cross > -1e-12))


def _segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distance from points p (..., 2) to segments a→b (E, 2); returns (dist (..., E), nearest (..., E, 2))."""
    ab = b - a
    ap = p[..., None, :] - a
    t = np.clip(np.sum(ap * ab, -1) / np.sum(ab * ab, -1), 0.0, 1.0)
    nearest = a + t[..., None] * ab
    return np.linalg.norm(p[..., None, :] - nearest, axis=-1), nearest


def inside_polygon(p: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Even-odd point-in-polygon test for points p (..., 2) and one polygon v (n, 2)."""
    x, y = p[..., 0:1], p[..., 1:2]
    x0, y0 = v[:, 0], v[:, 1]
    x1, y1 = np.roll(x0, -1), np.roll(y0, -1)
    crosses = (y0 > y) != (y1 > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        xi = x0 + (y - y0) * (x1 - x0) / (y1 - y0)
    return np.sum(crosses & (x < xi), axis=-1) % 2 == 1


def union_distance(p: np.ndarray, polys: tuple[np.ndarray, ...],
                    a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distance from points to the union of polygons (0 inside) and the nearest boundary point."""
    dist, nearest = _segment_distance(p, a, b)
    k = np.argmin(dist, axis=-1)
    d = np.take_along_axis(dist, k[..., None], -1)[..., 0]
    near = np.take_along_axis(nearest, k[..., None, None], -2)[..., 0, :]
    inside = np.zeros(p.shape[:-1], dtype=bool)
    for poly in polys:
        inside |= inside_polygon(p, poly)
    return np.where(inside, 0.0, d), near


def distance_to_polygons(points: np.ndarray, polygons: tuple[np.ndarray, ...] | list[np.ndarray]) -> np.ndarray:
    """Distance (m) from points (..., 2) to the union of ``polygons``; 0 inside any of them."""
    a = np.concatenate(polygons)
    b = np.concatenate([np.roll(poly, -1, axis=0) for poly in polygons])
    return union_distance(np.asarray(points, dtype=np.float64), tuple(polygons), a, b)[0]


def cross2(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """The z component of p × q for 2-vectors (..., 2)."""
    return p[..., 0] * q[..., 1] - p[..., 1] * q[..., 0]


def circumscribed(polygon: np.ndarray, edges: int) -> np.ndarray:
    """A convex polygon of ``edges`` sides that contains the convex ``polygon``: its sides are the
    support lines nᵢ·x = h(nᵢ) = max_v nᵢ·v for the outward normals nᵢ at the angles 2πi/edges, its
    corners their neighbours' intersections (for the 10 × 6 cm ellipse and 32 sides, every corner lies
    within 0.8 mm of the footprint: ``tests/test_outline.py``)."""
    ang = 2 * np.pi * np.arange(edges) / edges
    n = np.stack([np.cos(ang), np.sin(ang)], -1)
    h = np.max(n @ np.asarray(polygon, np.float64).T, axis=1)
    n2, h2 = np.roll(n, -1, axis=0), np.roll(h, -1)
    det = n[:, 0] * n2[:, 1] - n[:, 1] * n2[:, 0]
    x = (h * n2[:, 1] - h2 * n[:, 1]) / det
    y = (n[:, 0] * h2 - n2[:, 0] * h) / det
    return np.stack([x, y], -1)
