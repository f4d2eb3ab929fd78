"""The kernel of a footprint: a reference point from which the whole pusher-inflated contour is
visible (a star-shaped contour about it), for Shape.polygon(..., reference=None)."""

from __future__ import annotations

import numpy as np

from dexpush.model.polygons import as_polygon, inside_polygon
from dexpush.model.radial_table import radial_table_polygons

__all__ = ["kernel_centre", "kernel_point"]


def kernel_centre(poly: np.ndarray) -> np.ndarray | None:
    """The deepest point (Chebyshev centre) of a counter-clockwise polygon's kernel, the
    intersection of its edges' inner half-planes, by a small LP; None when the kernel has no
    interior (the polygon is not star-shaped about any point)."""
    from scipy.optimize import linprog

    a, d = poly, np.roll(poly, -1, axis=0) - poly
    n = np.stack([-d[:, 1], d[:, 0]], -1) / np.linalg.norm(d, axis=-1, keepdims=True)   # inward normals
    # maximise r subject to n_i·(p − a_i) ≥ r for every edge
    res = linprog(c=[0.0, 0.0, -1.0], A_ub=np.concatenate([-n, np.ones((len(n), 1))], -1),
                  b_ub=-np.sum(n * a, -1), bounds=[(None, None), (None, None), (0.0, None)], method="highs")
    scale = float(np.max(np.ptp(poly, axis=0)))
    return res.x[:2] if res.status == 0 and res.x[2] > 1e-9 * scale else None


def kernel_point(polys: tuple[np.ndarray, ...] | list[np.ndarray], rho: float, grid: int = 41,
                 tries: int = 400, table_size: int = 2048) -> np.ndarray:
    """A reference point about which the ρ-inflated union of ``polys`` is star-shaped.

    Candidates are the footprint's area centroid, then the deepest kernel point of each
    polygon (:func:`kernel_centre`) and the cell centres of a ``grid`` × ``grid`` lattice over
    its bounding box that lie inside it, nearest the centroid first (a reference near the
    centroid keeps the centre of friction p_bf near zero for an even support pressure). A
    kernel point of a polygon is a kernel point of its ρ-inflation too. The first candidate
    whose rays pass :func:`radial_table_polygons` on 256 azimuths, and then on the
    ``table_size`` azimuths the shape's table will use, is returned; raises ``ValueError``
    when none of the first ``tries`` does.
    """
    polys = [np.asarray(p, dtype=np.float64) for p in polys]
    pts = np.concatenate(polys)
    lo, hi = pts.min(0), pts.max(0)
    cells = (np.arange(grid) + 0.5) / grid                 # cell centres: no lattice point on the bounding box
    xs, ys = np.meshgrid(lo[0] + cells * (hi[0] - lo[0]), lo[1] + cells * (hi[1] - lo[1]))
    lattice = np.stack([xs.ravel(), ys.ravel()], -1)
    inside = np.zeros(len(lattice), dtype=bool)
    for poly in polys:
        inside |= inside_polygon(lattice, poly)
    lattice = lattice[inside]
    if not len(lattice):
        raise ValueError("the shape is too thin to find a reference point inside it; give `reference` yourself")
    centroid = lattice.mean(0)                     # the area centroid of the union, to the lattice's resolution
    centres = [c for c in (kernel_centre(as_polygon(p)) for p in polys) if c is not None]
    rest = np.concatenate([np.reshape(centres, (-1, 2)), lattice])
    candidates = np.concatenate([centroid[None], rest[np.argsort(np.linalg.norm(rest - centroid, axis=-1),
                                                                 kind="stable")]])
    for c in candidates[:tries]:
        moved = tuple(p - c for p in polys)
        if not any(inside_polygon(np.zeros((1, 2)), p)[0] for p in moved):
            continue
        try:
            if all(np.all(np.isfinite(R) & np.isfinite(dR))
                   for R, dR in (radial_table_polygons(moved, rho, n) for n in (256, table_size))):
                return c
        except ValueError:
            continue
    raise ValueError(
        f"no point inside the shape (tried its centroid, its pieces' kernels and {min(tries, len(candidates))} "
        "points) sees "
        "its whole pusher-inflated contour: the shape is not star-shaped about any point we tried. Split the "
        "object into star-shaped pieces, or give `reference` yourself.")
