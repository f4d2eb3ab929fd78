"""Where the pusher can be: the faces it pushes on and the convex collision-free regions between them.

All of it lives in the object's body frame {B}. A :class:`Face` is a usable straight piece of
the footprint's outer boundary (one contact vertex of the graph per face); a :class:`Region`
is a convex set of pusher centres clear of the object (one per face, in front of it). Free
motions chain regions along :func:`region_route` in the graph :func:`region_graph` of
overlapping regions.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np

from dexpush.gcs.settings import PlanningError
from dexpush.model.shape import Shape, distance_to_polygons, is_convex

__all__ = ["Face", "Region", "contact_faces", "free_regions", "region_graph", "region_route"]


@dataclass(frozen=True)
class Face:
    """A straight piece of the footprint's outer boundary, seen from the pusher.

    The pusher centre touching the face at σ is ``q(σ) = a + σ·d + ρ·n_out``; ``n̂ = −n_out``
    (inward normal) and ``t̂ = d/|d|`` (counter-clockwise tangent) are the C-GVMM's contact
    frame on this face.
    """

    index: int
    a: np.ndarray          #: start corner (counter-clockwise), {B}
    d: np.ndarray          #: b − a
    n_out: np.ndarray      #: outward unit normal
    sigma_lo: float        #: usable contact range along the face
    sigma_hi: float
    polygon: int           #: the convex piece the face belongs to

    @property
    def tangent(self) -> np.ndarray:
        return self.d / np.linalg.norm(self.d)

    def pusher_point(self, sigma: object, rho: float) -> np.ndarray:
        """q(σ) for numeric σ of any shape (→ (..., 2)) or one symbolic σ (→ (2,) of expressions)."""
        if isinstance(sigma, int | float | np.ndarray | np.floating):
            s = np.asarray(sigma, dtype=np.float64)[..., None]
            return self.a + s * self.d + rho * self.n_out
        return np.array([self.a[i] + sigma * self.d[i] + rho * self.n_out[i] for i in range(2)])


def contact_faces(shape: Shape, sigma_margin: float = 0.005, samples: int = 801) -> list[Face]:
    """The faces a point pusher can push on: the outer boundary of the union of convex pieces.

    Each edge of each piece is kept where the pusher disc touching it does not overlap
    another piece (so an edge covered by another piece is dropped and a concave corner
    shortens both faces by ρ); every such interval of at least 1 cm, shrunk by
    ``sigma_margin`` at both ends, is a face.
    """
    polys = shape.polygons
    if not all(is_convex(p) for p in polys):
        raise PlanningError(
            f"the GCS planner needs the footprint as a union of convex pieces; shape {shape.name!r} "
            "has a non-convex piece (build it with Shape.union of convex polygons)")
    rho = shape.pusher_radius
    faces: list[Face] = []
    s = np.linspace(0.0, 1.0, samples)
    for pi, poly in enumerate(polys):
        for ei in range(len(poly)):
            a, b = poly[ei], poly[(ei + 1) % len(poly)]
            d = b - a
            length = float(np.linalg.norm(d))
            n_out = np.array([d[1], -d[0]]) / length
            q = a + s[:, None] * d + rho * n_out
            ok = np.ones(samples, dtype=bool)
            for pj, other in enumerate(polys):
                if pj != pi:
                    ok &= distance_to_polygons(q, [other]) >= rho - 1e-9
            # every run of usable samples is a face (a piece's edge can be split by another piece)
            runs, start = [], None
            for i, flag in enumerate(np.append(ok, False)):
                if flag and start is None:
                    start = i
                elif not flag and start is not None:
                    runs.append((start, i - 1))
                    start = None
            for i0, i1 in runs:
                lo, hi = s[i0] + sigma_margin / length, s[i1] - sigma_margin / length
                if hi - lo >= 0.01 / length:
                    faces.append(Face(len(faces), a.copy(), d.copy(), n_out, float(lo), float(hi), pi))
    if not faces:
        raise PlanningError(f"shape {shape.name!r} has no face a pusher can touch")
    return faces


@dataclass(frozen=True)
class Region:
    """A convex collision-free region for the pusher centre in {B}: ``A·p ≤ b``."""

    A: np.ndarray
    b: np.ndarray

    def contains(self, p: np.ndarray, tol: float = 1e-9) -> bool:
        return bool(np.all(self.A @ p <= self.b + tol))


def free_regions(shape: Shape, faces: list[Face], offset: float) -> list[Region]:
    """One convex region per face where the pusher centre keeps ``offset`` from the object.

    Region f is the half-plane ``n_out·p ≥ n_out·a + offset`` in front of face f, cut, for
    every other convex piece, by the half-plane of that piece which best clears face f's
    contact points, and by a box around the object.
    """
    polys = shape.polygons
    reach = shape.bounding_radius + 0.25
    regions = []
    for f in faces:
        rows = [(-f.n_out, -(f.n_out @ f.a + offset))]
        pts = f.pusher_point(np.linspace(f.sigma_lo, f.sigma_hi, 21), shape.pusher_radius)
        for pj, other in enumerate(polys):
            if pj == f.polygon:
                continue
            best = None
            for ei in range(len(other)):
                a, b = other[ei], other[(ei + 1) % len(other)]
                n = np.array([b[1] - a[1], a[0] - b[0]]) / np.linalg.norm(b - a)
                clearance = float(np.min((pts - a) @ n))
                if best is None or clearance > best[0]:
                    best = (clearance, n, a)
            _, n, a = best
            rows.append((-n, -(n @ a + offset)))
        for axis in range(2):
            e = np.eye(2)[axis]
            rows += [(e, reach), (-e, reach)]
        regions.append(Region(np.array([r[0] for r in rows]), np.array([r[1] for r in rows])))
    return regions


def _chebyshev_radius(A: np.ndarray, b: np.ndarray) -> float:
    """Radius of the largest disc inside ``A·p ≤ b`` (LP; ≤ 0 when empty)."""
    from scipy.optimize import linprog

    norms = np.linalg.norm(A, axis=1)
    res = linprog(c=[0, 0, -1], A_ub=np.hstack([A, norms[:, None]]), b_ub=b,
                  bounds=[(None, None), (None, None), (None, 1.0)], method="highs")
    return float(-res.fun) if res.status == 0 else -1.0


def region_graph(regions: list[Region], min_overlap: float = 1e-3) -> list[list[int]]:
    """Adjacency lists of the regions: i and j are neighbours when their overlap holds a disc of
    radius ``min_overlap`` (m), so a free motion can pass from one to the other."""
    adj: list[list[int]] = [[] for _ in regions]
    for i in range(len(regions)):
        for j in range(i + 1, len(regions)):
            A = np.vstack([regions[i].A, regions[j].A])
            b = np.concatenate([regions[i].b, regions[j].b])
            if _chebyshev_radius(A, b) > min_overlap:
                adj[i].append(j)
                adj[j].append(i)
    return adj


def region_route(adj: list[list[int]], start: int, goal: int) -> list[int] | None:
    """Fewest-hops chain of regions from ``start`` to ``goal`` (BFS)."""
    prev = {start: -1}
    queue = deque([start])
    while queue:
        i = queue.popleft()
        if i == goal:
            path = [i]
            while prev[path[-1]] >= 0:
                path.append(prev[path[-1]])
            return path[::-1]
        for j in adj[i]:
            if j not in prev:
                prev[j] = i
                queue.append(j)
    return None
