"""A simple polygon cut into convex pieces (for the MuJoCo plant's collision prisms and the GCS
baseline's regions)."""

from __future__ import annotations

import numpy as np

from dexpush.model.polygons import cross2, is_convex

__all__ = ["convex_pieces"]


def _without_collinear(v: np.ndarray) -> np.ndarray:
    e0, e1 = v - np.roll(v, 1, axis=0), np.roll(v, -1, axis=0) - v
    scale = float(np.max(np.ptp(v, axis=0)))
    return v[np.abs(cross2(e0, e1)) > 1e-12 * scale**2]


def convex_pieces(polygon: np.ndarray) -> list[np.ndarray]:
    """A simple counter-clockwise polygon split into convex counter-clockwise pieces.

    Ear-clipping triangulation, then Hertel–Mehlhorn: drop every diagonal whose two sides
    merge into a convex piece (at most four times the fewest possible pieces; an L or a U
    gives two or three). A convex polygon comes back whole.
    """
    v = _without_collinear(np.asarray(polygon, dtype=np.float64))
    if is_convex(v):
        return [v]
    idx, tris = list(range(len(v))), []
    while len(idx) > 3:
        for k in range(len(idx)):
            i0, i1, i2 = idx[k - 1], idx[k], idx[(k + 1) % len(idx)]
            a, b, c = v[i0], v[i1], v[i2]
            if cross2(b - a, c - b) <= 0:
                continue                                  # reflex (or flat) corner: not an ear
            others = v[[j for j in idx if j not in (i0, i1, i2)]]
            inside = ((cross2(b - a, others - a) >= 0) & (cross2(c - b, others - b) >= 0)
                      & (cross2(a - c, others - c) >= 0))
            if not np.any(inside):
                tris.append([i0, i1, i2])
                idx.pop(k)
                break
        else:
            raise ValueError("could not split the polygon into convex pieces (is it simple?)")
    pieces = [*tris, idx]
    merged = True
    while merged:
        merged = False
        for p in range(len(pieces)):
            for q in range(p + 1, len(pieces)):
                joined = _join(pieces[p], pieces[q])
                if joined is not None and is_convex(v[joined]):
                    pieces[p] = joined
                    del pieces[q]
                    merged = True
                    break
            if merged:
                break
    return [v[p] for p in pieces]


def _join(p: list[int], q: list[int]) -> list[int] | None:
    """Two counter-clockwise index cycles sharing an edge (i→j in p, j→i in q) as one cycle."""
    for k in range(len(p)):
        i, j = p[k], p[(k + 1) % len(p)]
        for m in range(len(q)):
            if q[m] == j and q[(m + 1) % len(q)] == i:
                # p: ... i | j ...  ;  q: ... j | i ...  → p up to i, then q after i round to j, then p from j
                tail = [q[(m + 2 + r) % len(q)] for r in range(len(q) - 2)]
                return [*p[:k + 1], *tail, *p[k + 1:]]
    return None
