"""The GCS pushing planner: the paper's offline baseline (Graesdal et al., RSS 2024, ref. [26]).

Planar pushing is planned as a shortest path in a Graph of Convex Sets (Drake's
``GraphOfConvexSets``), then rounded to a feasible plan with a local nonlinear solve.

Graph
    * **Contact vertices**, one per face f of the footprint's outer boundary (a T has 8).
      The pusher sticks to the face at a contact point ``q(σ) = a + σ·d + ρ·n_out``
      (σ ∈ [σ_lo, σ_hi], constant in the mode) for ``N`` knots. Between knots k and k+1 it
      applies a contact impulse ``f_k = c_n·n̂ + c_f·t̂`` inside the (shrunk) friction cone
      ``|c_f| ≤ μ'·c_n``. Quasi-static dynamics with the same ellipsoidal limit surface as
      the C-GVMM (eq. 5): the body twist over the step is ``δ_k = M(λ)·[f_k; τ_k]`` with
      ``M = A_bf·L̃·A_bfᵀ`` and the moment ``τ_k = q(σ) × f_k``. The pose update is
      ``θ_{k+1} = θ_k + δθ_k``, ``p_{k+1} = p_k + R(θ_k)·(δx, δy)`` (first order; the
      rounding uses the exact SE(2) exponential). Poses are written with
      ``(c_k, s_k) = (cos θ_k, sin θ_k)`` and ``c_k² + s_k² = 1``.
    * **Free vertices**: contact-free pusher motion with the object at rest, one vertex
      per ordered pair of faces (and one per face from the start). The pusher's body-frame
      knots pass through a fixed chain of convex collision-free regions (one per face: the
      half-plane in front of the face, cut by a half-plane of every other convex piece),
      so every segment lies inside one convex region.
    * **Edges** carry continuity: the object pose, and the pusher position where a free
      motion ends or starts at a contact point. The source is the measured start (object
      pose and pusher), the target the goal pose.

Relaxation and rounding
    The bilinear constraints (SO(2), R(θ)·δ, σ·c_n) make every contact vertex a small
    nonconvex QCQP. By default (``relaxation="mccormick"``) each bilinear term gets its
    McCormick envelope, with ``(c, s)`` kept in the convex hull of the arc of headings
    between start and goal (padded by ``heading_pad_rad``): every vertex is a polyhedron
    and the graph's convex relaxation is a small conic program, solved by Clarabel (SCS
    as fallback). ``relaxation="sdp"`` is the paper's band-sparse semidefinite (Shor)
    relaxation instead — one PSD moment matrix per pair of consecutive knots, Drake's
    ``MakeSemidefiniteRelaxation`` with variable groups — tighter but ~30–100× slower with
    open-source solvers (docs/gcs.md). Candidate paths are random walks on the relaxed
    flows (most probable first); the plan on a path is rounded by a local nonlinear solve
    (SNOPT, or IPOPT) with the exact SE(2) step, warm-started from the relaxation. When no
    candidate rounds, the two-contact paths through the faces with the most relaxed flow
    are tried.

Costs: object path length (Σ‖Δp‖), rotation (Σ|δθ|), pusher travel in free motion
(Σ‖Δq‖), a small force regulariser and a constant cost per contact mode.

A plan is timed afterwards: the pusher moves at ``settings.speed`` along it. Quasi-static
pushing has no intrinsic time scale, so this changes nothing in the plan's geometry.
"""

from __future__ import annotations

import time
from collections import deque
from dataclasses import dataclass, field, replace

import numpy as np

from dexpush.checks import check_params, checked_vector
from dexpush.geometry import Shape, distance_to_polygons
from dexpush.se2 import pose_error

__all__ = ["Face", "GCSSettings", "GCSTracker", "Plan", "PlanningError", "contact_faces", "free_regions", "plan_push"]


class PlanningError(RuntimeError):
    """The GCS planner found no plan (infeasible relaxation, failed rounding, bad input)."""


@dataclass(frozen=True)
class GCSSettings:
    """Settings of the GCS planner. Defaults are what the benchmark uses.

    Attributes:
        knots: knot points per contact mode (``N``; ``N − 1`` impulses).
        retry_knots: when no path rounds, plan again with each of these knot counts in turn
            (finer steps give the rounding more freedom; on the T in Task II, 9 of 30 start
            states that fail with 5 knots were tried with 7 and rounded, docs/gcs.md).
        mu_margin: plan with ``μ' = mu_margin·μ`` so that the planned contact sticks with a
            margin (a force on the cone's edge would be a coin-flip between stick and slide
            for the C-GVMM).
        max_step_m: bound on the body-frame translation of one step (m).
        max_step_rad: bound on the rotation of one step (rad).
        sigma_margin_m: keep the contact point this far from a face's ends (m).
        free_margin_m: clearance of free pusher motion from the object beyond ρ (m).
        workspace_margin_m: the object stays within the start/goal bounding box grown by this.
        w_path, w_rot, w_free, w_force, w_mode: cost weights (per metre of object path, per
            radian, per metre of free pusher travel, on Σ(c_n² + c_f²), per contact mode).
        rounding_trials, max_rounded_paths: random walks on the relaxed flows, and how many
            distinct paths (most probable first) the nonlinear rounding tries.
        max_enumerated_paths: when none of those rounds, how many two-contact paths
            (ranked by relaxed flow through their faces) to try.
        tight_relaxation: add the products of every pair of linear constraints to the
            relaxation (tighter, ~10× slower); by default only the diagonal bounds.
        relaxation_solver: ``clarabel`` (default) or ``scs``.
        rounding_solver: ``snopt`` (default) or ``ipopt``.
        speed: pusher speed used to time the plan (m/s); below the ±v_max/√2 per-axis clip.
    """

    knots: int = 5
    retry_knots: tuple[int, ...] = (7,)
    mu_margin: float = 0.8
    max_step_m: float = 0.15
    max_step_rad: float = 0.5
    sigma_margin_m: float = 0.005
    free_margin_m: float = 0.004
    workspace_margin_m: float = 0.3
    w_path: float = 1.0
    w_rot: float = 0.05
    w_free: float = 0.2
    w_force: float = 0.1
    w_mode: float = 0.05
    relaxation: str = "mccormick"
    rounding_trials: int = 50
    max_rounded_paths: int = 3
    max_enumerated_paths: int = 12
    heading_pad_rad: float = 0.6
    tight_relaxation: bool = False
    relaxation_solver: str = "clarabel"
    rounding_solver: str = "snopt"
    speed: float = 0.06

    def __post_init__(self) -> None:
        if int(self.knots) < 2 or any(int(k) < 2 for k in self.retry_knots):
            raise ValueError(f"knots must be >= 2, got {self.knots} and retry_knots {self.retry_knots}")
        if not 0.0 < self.mu_margin <= 1.0:
            raise ValueError(f"mu_margin must be in (0, 1], got {self.mu_margin}")
        for name in ("max_step_m", "max_step_rad", "speed"):
            if not float(getattr(self, name)) > 0:
                raise ValueError(f"{name} must be positive, got {getattr(self, name)}")
        if self.relaxation not in ("mccormick", "sdp"):
            raise ValueError(f"relaxation must be mccormick or sdp, got {self.relaxation!r}")
        if self.relaxation_solver not in ("clarabel", "scs"):
            raise ValueError(f"relaxation_solver must be clarabel or scs, got {self.relaxation_solver!r}")
        if self.rounding_solver not in ("snopt", "ipopt"):
            raise ValueError(f"rounding_solver must be snopt or ipopt, got {self.rounding_solver!r}")


# ---------------------------------------------------------------------------------- geometry
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


def _is_convex_ccw(poly: np.ndarray) -> bool:
    e = np.roll(poly, -1, axis=0) - poly
    cross = e[:, 0] * np.roll(e, -1, axis=0)[:, 1] - e[:, 1] * np.roll(e, -1, axis=0)[:, 0]
    return bool(np.all(cross > -1e-12))


def contact_faces(shape: Shape, sigma_margin: float = 0.005, samples: int = 801) -> list[Face]:
    """The faces a point pusher can push on: the outer boundary of the union of convex pieces.

    Each edge of each piece is kept where the pusher disc touching it does not overlap
    another piece (so an edge covered by another piece is dropped and a concave corner
    shortens both faces by ρ); every such interval of at least 1 cm, shrunk by
    ``sigma_margin`` at both ends, is a face.
    """
    polys = shape.polygons
    if not all(_is_convex_ccw(p) for p in polys):
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


def _region_graph(regions: list[Region], min_overlap: float = 1e-3) -> list[list[int]]:
    adj: list[list[int]] = [[] for _ in regions]
    for i in range(len(regions)):
        for j in range(i + 1, len(regions)):
            A = np.vstack([regions[i].A, regions[j].A])
            b = np.concatenate([regions[i].b, regions[j].b])
            if _chebyshev_radius(A, b) > min_overlap:
                adj[i].append(j)
                adj[j].append(i)
    return adj


def _route(adj: list[list[int]], start: int, goal: int) -> list[int] | None:
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


# ---------------------------------------------------------------------------------- the plan
@dataclass
class Plan:
    """A rounded GCS plan and its timed reference.

    Attributes:
        modes: the path's vertex names (``start``, ``free i→j``, ``face j``, ..., ``goal``).
        knots: per contact mode, (N, 3) object poses at the knots.
        times, poses, pusher, face: the timed reference sampled every ``dt`` seconds:
            object pose (T, 3), pusher centre (T, 2) and the face in contact (−1 free).
        relaxation_cost, rounded_cost: objective of the convex relaxation and of the
            rounded plan (their ratio bounds the optimality gap).
        relaxation_s, rounding_s: wall time of the two solves (s); ``planning_s`` is all of it.
    """

    modes: list[str]
    knots: list[np.ndarray]
    times: np.ndarray
    poses: np.ndarray
    pusher: np.ndarray
    face: np.ndarray
    relaxation_cost: float
    rounded_cost: float
    relaxation_s: float
    rounding_s: float
    planning_s: float
    params: np.ndarray = field(default_factory=lambda: np.zeros(3))

    @property
    def duration(self) -> float:
        return float(self.times[-1])

    def commands(self) -> np.ndarray:
        """Pusher velocities (T−1, 2) that move the pusher along the reference."""
        return np.diff(self.pusher, axis=0) / np.diff(self.times)[:, None]


# ---------------------------------------------------------------------------------- problem
@dataclass
class _Problem:
    """Everything the graph, the rounding and the timing share."""

    shape: Shape
    faces: list[Face]
    regions_rho: list[Region]        #: offset ρ (where a contact starts and ends)
    regions_free: list[Region]       #: offset ρ + margin (free motion)
    adj: list[list[int]]
    M: np.ndarray
    mu: float                        #: μ' = mu_margin·μ
    start: np.ndarray                #: (3,) object pose
    pusher_body: np.ndarray          #: (2,) start pusher in {B}
    goal: np.ndarray
    lo: np.ndarray                   #: workspace box of the object position
    hi: np.ndarray
    settings: GCSSettings

    @property
    def heading_range(self) -> tuple[float, float]:
        """Headings the plan may pass: start to (unwrapped) goal, padded."""
        th0 = self.start[2]
        thg = self.goal[2] + 2 * np.pi * np.round((th0 - self.goal[2]) / (2 * np.pi))
        pad = self.settings.heading_pad_rad
        return min(th0, thg) - pad, max(th0, thg) + pad

    @property
    def rho(self) -> float:
        return self.shape.pusher_radius

    def step_wrench(self, f: Face, sigma: object, cn: object, cf: object) -> tuple:
        """Body wrench [f_x, f_y, τ] of the impulse (c_n, c_f) at σ on face f (any algebra)."""
        n_in, t = -f.n_out, f.tangent
        qx = f.a[0] + sigma * f.d[0] + self.rho * f.n_out[0]
        qy = f.a[1] + sigma * f.d[1] + self.rho * f.n_out[1]
        fx, fy = cn * n_in[0] + cf * t[0], cn * n_in[1] + cf * t[1]
        return fx, fy, qx * fy - qy * fx

    def translation(self, fx: object, fy: object, omega: object) -> tuple:
        """(δx, δy) of eq. 5 with the moment eliminated through δθ = M₂·[f; τ] = ω."""
        M = self.M
        tau = (omega - M[2, 0] * fx - M[2, 1] * fy) / M[2, 2]
        return M[0, 0] * fx + M[0, 1] * fy + M[0, 2] * tau, M[1, 0] * fx + M[1, 1] * fy + M[1, 2] * tau

    def twist(self, wrench: tuple) -> tuple:
        M = self.M
        return tuple(M[i, 0] * wrench[0] + M[i, 1] * wrench[1] + M[i, 2] * wrench[2] for i in range(3))


def _quiet_drake() -> None:
    """Drake logs every GCS solve at INFO; keep warnings only."""
    import logging

    logging.getLogger("drake").setLevel(logging.WARNING)


def _make_problem(shape: Shape, start: np.ndarray, pusher: np.ndarray, goal: np.ndarray,
                  params: np.ndarray, mu: float, settings: GCSSettings) -> _Problem:
    from dexpush.model import limit_surface_matrix

    faces = contact_faces(shape, settings.sigma_margin_m)
    rho = shape.pusher_radius
    regions_rho = free_regions(shape, faces, rho)
    regions_free = free_regions(shape, faces, rho + settings.free_margin_m)
    c, s = np.cos(start[2]), np.sin(start[2])
    pb = np.array([[c, s], [-s, c]]) @ (pusher - start[:2])
    lo = np.minimum(start[:2], goal[:2]) - settings.workspace_margin_m
    hi = np.maximum(start[:2], goal[:2]) + settings.workspace_margin_m
    return _Problem(shape, faces, regions_rho, regions_free, _region_graph(regions_free),
                    limit_surface_matrix(params), settings.mu_margin * mu, start, pb, goal, lo, hi, settings)


def _free_route_rows(P: _Problem, route: list[int], fixed_start: bool) -> list[tuple[int, Region]]:
    """(knot index, region) pairs of a free motion along ``route`` (see the module doc)."""
    rows: list[tuple[int, Region]] = []
    if not fixed_start:
        rows.append((0, P.regions_rho[route[0]]))
    rows.append((1, P.regions_free[route[0]]))
    for h in range(1, len(route)):
        rows += [(h + 1, P.regions_free[route[h - 1]]), (h + 1, P.regions_free[route[h]])]
    L = len(route) - 1
    rows += [(L + 2, P.regions_free[route[-1]]), (L + 3, P.regions_rho[route[-1]])]
    return rows


def _start_routes(P: _Problem) -> dict[int, list[int]]:
    """For every face, the shortest chain of regions from the start pusher to it."""
    q = P.pusher_body
    starts = [i for i, r in enumerate(P.regions_rho) if r.contains(q, 5e-4)]
    if not starts:
        raise PlanningError(
            f"the pusher's start {q.round(4).tolist()} (object frame) is in no collision-free region: "
            "it overlaps the object or is too far from it")
    routes = {}
    for f in range(len(P.faces)):
        cands = [r for r in (_route(P.adj, s0, f) for s0 in starts) if r is not None]
        if cands:
            routes[f] = min(cands, key=len)
    return routes


# ---------------------------------------------------------------------------------- the graph
class _Vertex:
    """A GCS vertex and where its named variables sit in ``vertex.x()``."""

    def __init__(self, kind: str, name: str, gcs_vertex: object, index: dict[str, object],
                 face: int | None = None, route: list[int] | None = None, knots: int = 0):
        self.kind, self.name, self.v, self.index = kind, name, gcs_vertex, index
        self.face, self.route, self.knots = face, route, knots

    def var(self, key: str) -> object:
        idx = self.index[key]
        x = self.v.x()
        return x[idx] if np.isscalar(idx) else x[np.asarray(idx)]


class _Lifted:
    """A polyhedral relaxation under construction: named variables, ``A·z ≤ b`` and ``E·z = e``."""

    def __init__(self) -> None:
        self.n, self.lo, self.hi, self.ineq, self.eq = 0, [], [], [], []

    def new(self, count: int, lo: float, hi: float) -> np.ndarray:
        idx = np.arange(self.n, self.n + count)
        self.n += count
        self.lo += [lo] * count
        self.hi += [hi] * count
        return idx

    def le(self, terms: dict, bound: float) -> None:      # Σ coeff·z[i] ≤ bound
        self.ineq.append((terms, bound))

    def equal(self, terms: dict, value: float = 0.0) -> None:
        self.eq.append((terms, value))

    def product(self, u: int, v: int) -> int:
        """A variable w with the McCormick envelope of w = z[u]·z[v] (bounds of u and v)."""
        w = int(self.new(1, -np.inf, np.inf)[0])
        lu, hu, lv, hv = self.lo[u], self.hi[u], self.lo[v], self.hi[v]
        self.le({w: -1, v: lu, u: lv}, lu * lv)      # w ≥ lu·v + lv·u − lu·lv
        self.le({w: -1, v: hu, u: hv}, hu * hv)
        self.le({w: 1, v: -hu, u: -lv}, -hu * lv)    # w ≤ hu·v + lv·u − hu·lv
        self.le({w: 1, v: -lu, u: -hv}, -lu * hv)
        return w

    @staticmethod
    def _matrix(rows: list, n: int) -> tuple[np.ndarray, np.ndarray]:
        A = np.zeros((len(rows), n))
        for r, (terms, _) in enumerate(rows):
            for i, a in terms.items():
                A[r, int(i)] += a
        return A, np.array([b for _, b in rows], dtype=np.float64)

    def polyhedron(self) -> object:
        from pydrake.geometry.optimization import HPolyhedron

        rows = list(self.ineq)
        for i in range(self.n):
            if np.isfinite(self.hi[i]):
                rows.append(({i: 1.0}, self.hi[i]))
            if np.isfinite(self.lo[i]):
                rows.append(({i: -1.0}, -self.lo[i]))
        A, b = self._matrix(rows, self.n)
        return HPolyhedron(A, b)


def _contact_vertex(gcs: object, P: _Problem, f: Face) -> _Vertex:
    """Face f's contact mode, relaxed as ``settings.relaxation`` says."""
    if P.settings.relaxation == "sdp":
        return _contact_vertex_sdp(gcs, P, f)
    return _contact_vertex_mccormick(gcs, P, f)


def _contact_vertex_mccormick(gcs: object, P: _Problem, f: Face) -> _Vertex:
    """Face f's contact mode as a polyhedron: McCormick envelopes of the bilinear terms.

    (c, s) lies in the convex hull of the unit-circle arc of the plan's heading range
    (tangent cuts and the chord); every product of a rotation entry with an impulse, of two
    rotation entries, and σ·c_n gets its McCormick envelope on the variables' bounds.
    """
    from pydrake.solvers import Binding, LinearEqualityConstraint

    S, N = P.settings, P.settings.knots
    L = _Lifted()
    th_lo, th_hi = P.heading_range
    arc = np.linspace(th_lo, th_hi, 721)
    cs_lo = [float(np.cos(arc).min()), float(np.sin(arc).min())]
    cs_hi = [float(np.cos(arc).max()), float(np.sin(arc).max())]
    c, s = L.new(N, cs_lo[0], cs_hi[0]), L.new(N, cs_lo[1], cs_hi[1])
    x, y = L.new(N, P.lo[0], P.hi[0]), L.new(N, P.lo[1], P.hi[1])
    sig = int(L.new(1, f.sigma_lo, f.sigma_hi)[0])
    fmax = S.max_step_m
    cn, cf = L.new(N - 1, 0.0, fmax), L.new(N - 1, -P.mu * fmax, P.mu * fmax)
    om = L.new(N - 1, -S.max_step_rad, S.max_step_rad)
    mid, half = (th_lo + th_hi) / 2, (th_hi - th_lo) / 2
    for k in range(N):      # conv(arc): tangent cuts (outside) and the chord (inside)
        for a in np.linspace(th_lo, th_hi, 9):
            L.le({c[k]: np.cos(a), s[k]: np.sin(a)}, 1.0)
        L.le({c[k]: -np.cos(mid), s[k]: -np.sin(mid)}, -np.cos(half))
    n_in, t = -f.n_out, f.tangent
    M = P.M
    for k in range(N - 1):
        L.le({cf[k]: 1, cn[k]: -P.mu}, 0)                                            # friction cone
        L.le({cf[k]: -1, cn[k]: -P.mu}, 0)
        # δθ = M₂·[f; q(σ)×f] = ω: linear in (c_n, c_f) plus the σ·c_n term
        g_n, g_t, g_sn = _rotation_coefficients(P, f)
        L.equal({om[k]: -1, cn[k]: g_n, cf[k]: g_t, L.product(sig, cn[k]): g_sn})
        # (δx, δy) linear in (c_n, c_f, ω)
        fxn, fyn, fxt, fyt = n_in[0], n_in[1], t[0], t[1]
        ax = np.array([M[0, 0] * fxn + M[0, 1] * fyn, M[0, 0] * fxt + M[0, 1] * fyt, 0.0])
        ay = np.array([M[1, 0] * fxn + M[1, 1] * fyn, M[1, 0] * fxt + M[1, 1] * fyt, 0.0])
        # τ = (ω − M20 fx − M21 fy)/M22 enters δx, δy through M02, M12
        rn = (M[2, 0] * fxn + M[2, 1] * fyn) / M[2, 2]
        rt = (M[2, 0] * fxt + M[2, 1] * fyt) / M[2, 2]
        ax += M[0, 2] * np.array([-rn, -rt, 1 / M[2, 2]])
        ay += M[1, 2] * np.array([-rn, -rt, 1 / M[2, 2]])
        for (row, lim) in ((ax, S.max_step_m), (ay, S.max_step_m)):
            L.le({cn[k]: row[0], cf[k]: row[1], om[k]: row[2]}, lim)
            L.le({cn[k]: -row[0], cf[k]: -row[1], om[k]: -row[2]}, lim)
        pc = [L.product(c[k], v) for v in (cn[k], cf[k], om[k])]
        ps = [L.product(s[k], v) for v in (cn[k], cf[k], om[k])]
        # x⁺ − x = c·δx − s·δy,  y⁺ − y = s·δx + c·δy
        ex = {x[k + 1]: 1, x[k]: -1}
        ey = {y[k + 1]: 1, y[k]: -1}
        for j in range(3):
            ex[pc[j]] = ex.get(pc[j], 0) - ax[j]
            ex[ps[j]] = ex.get(ps[j], 0) + ay[j]
            ey[ps[j]] = ey.get(ps[j], 0) - ax[j]
            ey[pc[j]] = ey.get(pc[j], 0) - ay[j]
        L.equal(ex)
        L.equal(ey)
        # s⁺c − c⁺s = ω (sin δθ ≈ δθ)
        L.equal({L.product(s[k + 1], c[k]): 1, L.product(c[k + 1], s[k]): -1, om[k]: -1})
    v = gcs.AddVertex(L.polyhedron(), f"face {f.index}")
    E, e = L._matrix(L.eq, L.n)
    v.AddConstraint(Binding[LinearEqualityConstraint](LinearEqualityConstraint(E, e), v.x()))
    index = dict(c=list(c), s=list(s), x=list(x), y=list(y), sigma=sig, cn=list(cn), cf=list(cf), omega=list(om))
    V = _Vertex("contact", f"face {f.index}", v, index, face=f.index, knots=N)
    _contact_costs(V, P, f)
    return V


def _rotation_coefficients(P: _Problem, f: Face) -> tuple[float, float, float]:
    """δθ = g_n·c_n + g_t·c_f + g_σn·σ·c_n on face f (row 2 of eq. 5)."""
    fx0, fy0, t0 = P.step_wrench(f, 0.0, 1.0, 0.0)
    fx1, fy1, t1 = P.step_wrench(f, 0.0, 0.0, 1.0)
    _, _, ts = P.step_wrench(f, 1.0, 1.0, 0.0)
    M = P.M[2]
    g_n = M[0] * fx0 + M[1] * fy0 + M[2] * t0
    g_t = M[0] * fx1 + M[1] * fy1 + M[2] * t1
    return float(g_n), float(g_t), float(M[2] * (ts - t0))


def _contact_vertex_sdp(gcs: object, P: _Problem, f: Face) -> _Vertex:
    """Face f's contact mode: the band-sparse SDP relaxation of its QCQP as a Spectrahedron."""
    from pydrake.geometry.optimization import Spectrahedron
    from pydrake.solvers import MakeSemidefiniteRelaxation, MathematicalProgram, SemidefiniteRelaxationOptions
    from pydrake.symbolic import Variables

    S, N = P.settings, P.settings.knots
    prog = MathematicalProgram()
    c, s = prog.NewContinuousVariables(N, "c"), prog.NewContinuousVariables(N, "s")
    x, y = prog.NewContinuousVariables(N, "x"), prog.NewContinuousVariables(N, "y")
    sig = prog.NewContinuousVariables(1, "sigma")[0]
    cn, cf = prog.NewContinuousVariables(N - 1, "cn"), prog.NewContinuousVariables(N - 1, "cf")
    om = prog.NewContinuousVariables(N - 1, "omega")      # δθ_k, better scaled than the moment τ_k
    fmax = S.max_step_m
    prog.AddBoundingBoxConstraint(-1, 1, c)
    prog.AddBoundingBoxConstraint(-1, 1, s)
    prog.AddBoundingBoxConstraint(P.lo[0], P.hi[0], x)
    prog.AddBoundingBoxConstraint(P.lo[1], P.hi[1], y)
    prog.AddBoundingBoxConstraint(f.sigma_lo, f.sigma_hi, sig)
    prog.AddBoundingBoxConstraint(0, fmax, cn)
    prog.AddBoundingBoxConstraint(-P.mu * fmax, P.mu * fmax, cf)
    prog.AddBoundingBoxConstraint(-S.max_step_rad, S.max_step_rad, om)
    cos_max = float(np.cos(S.max_step_rad))
    for k in range(N):
        prog.AddQuadraticConstraint(c[k] * c[k] + s[k] * s[k] - 1, 0, 0)               # SO(2)
    for k in range(N - 1):
        prog.AddLinearConstraint(cf[k] <= P.mu * cn[k])                                # friction cone
        prog.AddLinearConstraint(cf[k] >= -P.mu * cn[k])
        fx, fy, tq = P.step_wrench(f, sig, cn[k], cf[k])
        _, _, w = P.twist((fx, fy, tq))
        prog.AddQuadraticConstraint(w - om[k], 0, 0)                                    # δθ = M₂·[f; q(σ) × f]
        vx, vy = P.translation(fx, fy, om[k])                                           # eq. 5, τ eliminated
        prog.AddLinearConstraint(vx, -S.max_step_m, S.max_step_m)
        prog.AddLinearConstraint(vy, -S.max_step_m, S.max_step_m)
        prog.AddQuadraticConstraint(x[k + 1] - x[k] - (c[k] * vx - s[k] * vy), 0, 0)    # p⁺ = p + R δ
        prog.AddQuadraticConstraint(y[k + 1] - y[k] - (s[k] * vx + c[k] * vy), 0, 0)
        prog.AddQuadraticConstraint(s[k + 1] * c[k] - c[k + 1] * s[k] - om[k], 0, 0)   # θ⁺ = θ + δθ
        prog.AddQuadraticConstraint(c[k + 1] * c[k] + s[k + 1] * s[k], cos_max, 1)
    groups = [Variables(np.concatenate([[c[k], s[k], x[k], y[k], c[k + 1], s[k + 1], x[k + 1], y[k + 1],
                                          sig, cn[k], cf[k], om[k]]])) for k in range(N - 1)]
    # bounded moment diagonal without the O(n²) products of every pair of bounds
    for var, bound in (() if P.settings.tight_relaxation else
                       ((c, 1.0), (s, 1.0), (cn, fmax), (cf, P.mu * fmax), (om, S.max_step_rad))):
        for v_ in var:
            prog.AddQuadraticConstraint(v_ * v_, 0, bound * bound)
    if not P.settings.tight_relaxation:
        prog.AddQuadraticConstraint(sig * sig, 0, max(f.sigma_lo ** 2, f.sigma_hi ** 2))
    for var, lo_, hi_ in (() if P.settings.tight_relaxation else ((x, P.lo[0], P.hi[0]), (y, P.lo[1], P.hi[1]))):
        for v_ in var:
            prog.AddQuadraticConstraint(v_ * v_, 0, max(lo_ * lo_, hi_ * hi_))
    options = SemidefiniteRelaxationOptions()
    options.add_implied_linear_constraints = P.settings.tight_relaxation
    options.add_implied_linear_equality_constraints = True
    relaxed = MakeSemidefiniteRelaxation(prog, groups, options)
    v = gcs.AddVertex(Spectrahedron(relaxed), f"face {f.index}")
    pos = {var.get_id(): relaxed.FindDecisionVariableIndex(var) for var in prog.decision_variables()}

    def idx(arr: object) -> object:
        return [pos[a.get_id()] for a in arr] if isinstance(arr, np.ndarray) else pos[arr.get_id()]

    index = dict(c=idx(c), s=idx(s), x=idx(x), y=idx(y), sigma=idx(sig), cn=idx(cn), cf=idx(cf), omega=idx(om))
    V = _Vertex("contact", f"face {f.index}", v, index, face=f.index, knots=N)
    _contact_costs(V, P, f)
    return V


def _contact_costs(V: _Vertex, P: _Problem, f: Face) -> None:
    from pydrake.solvers import Binding, Cost, L2NormCost

    S = P.settings
    x, y, cn, cf, om = V.var("x"), V.var("y"), V.var("cn"), V.var("cf"), V.var("omega")
    for k in range(S.knots - 1):
        # object path: w·‖p_{k+1} − p_k‖ and rotation w·|δθ|
        A = S.w_path * np.array([[-1, 1, 0, 0], [0, 0, -1, 1.0]])
        V.v.AddCost(Binding[Cost](L2NormCost(A, np.zeros(2)), np.array([x[k], x[k + 1], y[k], y[k + 1]])))
        V.v.AddCost(Binding[Cost](L2NormCost(np.array([[S.w_rot]]), np.zeros(1)), np.array([om[k]])))
        V.v.AddCost(S.w_force * (cn[k] * cn[k] + cf[k] * cf[k]))
    V.v.AddCost(S.w_mode + 0 * cn[0])


def _free_vertex(gcs: object, P: _Problem, name: str, route: list[int], fixed_start: bool) -> _Vertex:
    """Contact-free pusher motion along a chain of regions; the object pose is constant."""
    from pydrake.geometry.optimization import HPolyhedron
    from pydrake.solvers import Binding, Cost, L2NormCost

    K = len(route) + 3
    n = 4 + 2 * K
    rows_A, rows_b = [], []
    reach = P.shape.bounding_radius + 0.25      # every knot stays in a box around the object
    box_lo = np.concatenate([[-1, -1], P.lo, np.full(2 * K, -reach)])
    box_hi = np.concatenate([[1, 1], P.hi, np.full(2 * K, reach)])
    for i in range(n):
        e = np.zeros(n)
        e[i] = 1
        rows_A += [e, -e]
        rows_b += [box_hi[i], -box_lo[i]]
    for knot, region in _free_route_rows(P, route, fixed_start):
        for a, b in zip(region.A, region.b):
            row = np.zeros(n)
            row[4 + 2 * knot: 6 + 2 * knot] = a
            rows_A.append(row)
            rows_b.append(b)
    v = gcs.AddVertex(HPolyhedron(np.array(rows_A), np.array(rows_b)), name)
    index = dict(c=0, s=1, x=2, y=3, q=[4 + i for i in range(2 * K)])
    V = _Vertex("free", name, v, index, route=route, knots=K)
    q = V.var("q").reshape(K, 2)
    for m in range(K - 1):
        A = P.settings.w_free * np.array([[-1, 0, 1, 0], [0, -1, 0, 1.0]])
        v.AddCost(Binding[Cost](L2NormCost(A, np.zeros(2)), np.concatenate([q[m], q[m + 1]])))
    return V


def _pose(V: _Vertex, which: int) -> list:
    if V.kind != "contact":
        return [V.var("c"), V.var("s"), V.var("x"), V.var("y")]
    return [V.var("c")[which], V.var("s")[which], V.var("x")[which], V.var("y")[which]]


def _contact_point(V: _Vertex, P: _Problem) -> list:
    f = P.faces[V.face]
    sig = V.var("sigma")
    return [f.a[i] + sig * f.d[i] + P.rho * f.n_out[i] for i in range(2)]


def _connect(gcs: object, u: _Vertex, v: _Vertex, P: _Problem) -> None:
    """An edge u → v with pose continuity and pusher continuity at free/contact borders."""
    e = gcs.AddEdge(u.v, v.v, f"{u.name} -> {v.name}")
    pu, pv = _pose(u, -1), _pose(v, 0)
    for a, b in zip(pu, pv):
        e.AddConstraint(a == b)
    if u.kind == "source":
        for a, b in zip(u.var("q"), v.var("q")[:2]):
            e.AddConstraint(a == b)
    if u.kind == "contact" and v.kind == "free":
        q0 = v.var("q")[:2]
        for a, b in zip(_contact_point(u, P), q0):
            e.AddConstraint(a == b)
    if u.kind == "free" and v.kind == "contact":
        ql = u.var("q")[-2:]
        for a, b in zip(ql, _contact_point(v, P)):
            e.AddConstraint(a == b)


@dataclass
class _Graph:
    gcs: object
    source: _Vertex
    target: _Vertex
    vertices: dict[str, _Vertex]


def _build_graph(P: _Problem) -> _Graph:
    from pydrake.geometry.optimization import GraphOfConvexSets, Point

    gcs = GraphOfConvexSets()
    th0, thg = P.start[2], P.goal[2]
    src = gcs.AddVertex(Point(np.array([np.cos(th0), np.sin(th0), *P.start[:2], *P.pusher_body])), "start")
    tgt = gcs.AddVertex(Point(np.array([np.cos(thg), np.sin(thg), *P.goal[:2]])), "goal")
    source = _Vertex("source", "start", src, dict(c=0, s=1, x=2, y=3, q=[4, 5]))
    target = _Vertex("target", "goal", tgt, dict(c=0, s=1, x=2, y=3))
    verts: dict[str, _Vertex] = {}
    contacts = [_contact_vertex(gcs, P, f) for f in P.faces]
    for V in contacts:
        verts[V.name] = V
    for f, route in _start_routes(P).items():
        V = _free_vertex(gcs, P, f"start -> face {f}", route, fixed_start=True)
        verts[V.name] = V
        _connect(gcs, source, V, P)
        _connect(gcs, V, contacts[f], P)
    for i, Ci in enumerate(contacts):
        _connect(gcs, Ci, target, P)
        for j, Cj in enumerate(contacts):
            route = _route(P.adj, i, j) if i != j else None
            if route is None:
                continue
            V = _free_vertex(gcs, P, f"face {i} -> face {j}", route, fixed_start=False)
            verts[V.name] = V
            _connect(gcs, Ci, V, P)
            _connect(gcs, V, Cj, P)
    return _Graph(gcs, source, target, verts)


def _solve_relaxation(G: _Graph, P: _Problem) -> tuple[list[list[_Vertex]], dict[str, np.ndarray], float]:
    """Solve the convex relaxation; return candidate paths (most flow first), vertex values, cost.

    Candidate paths come from randomized rounding on the relaxed flows (Marcucci et al.):
    walk from the source, taking each outgoing edge with probability proportional to its
    flow, never revisiting a vertex.
    """
    from pydrake.geometry.optimization import GraphOfConvexSetsOptions
    from pydrake.solvers import ClarabelSolver, ScsSolver

    opts = GraphOfConvexSetsOptions()
    opts.convex_relaxation = True
    opts.preprocessing = False
    opts.max_rounded_paths = 0
    solvers = [ClarabelSolver(), ScsSolver()]
    if P.settings.relaxation_solver == "scs":
        solvers.reverse()
    result = None
    for solver in solvers:
        opts.solver = solver
        if solver.solver_id() == ClarabelSolver().solver_id():
            # the GCS perspective constraints are degenerate (equal rows through the flow
            # variables); Clarabel's default regularization 1e-8 stalls on them
            opts.solver_options.SetOption(solver.solver_id(), "static_regularization_constant", 1e-6)
        result = G.gcs.SolveShortestPath(G.source.v, G.target.v, opts)
        if result.is_success():
            break
    if not result.is_success():
        details = result.get_solution_result()
        raise PlanningError(
            f"the GCS convex relaxation failed (Clarabel and SCS: {details}); "
            "the goal may be unreachable within the workspace box or the step bounds")
    by_id = {V.v.id(): V for V in (G.source, G.target, *G.vertices.values())}
    flows = {}
    for e in G.gcs.Edges():
        flows.setdefault(e.u().id(), []).append((e.v().id(), max(float(result.GetSolution(e.phi())), 0.0)))
    rng = np.random.default_rng(0)
    paths: dict[tuple, float] = {}
    for _trial in range(P.settings.rounding_trials):
        node, seen, score, ok = G.source.v.id(), {G.source.v.id()}, 1.0, False
        path = [node]
        while True:
            if node == G.target.v.id():
                ok = True
                break
            out = [(v, f) for v, f in flows.get(node, []) if v not in seen and f > 1e-6]
            if not out:
                break
            w = np.array([f for _, f in out])
            i = int(rng.choice(len(out), p=w / w.sum())) if _trial else int(np.argmax(w))
            node = out[i][0]
            score *= w[i] / w.sum()
            seen.add(node)
            path.append(node)
        if ok:
            paths[tuple(path)] = max(paths.get(tuple(path), 0.0), score)
    if not paths:
        raise PlanningError("the GCS relaxation's flows contain no path from the start to the goal")
    ordered = sorted(paths, key=lambda k: -paths[k])[: P.settings.max_rounded_paths]
    candidates = [[by_id[i] for i in path] for path in ordered]
    values = {V.name: np.asarray(V.v.GetSolution(result), dtype=np.float64)
              for V in (G.source, G.target, *G.vertices.values())}
    inflow: dict[str, float] = {}
    for e in G.gcs.Edges():
        name = by_id[e.v().id()].name
        inflow[name] = inflow.get(name, 0.0) + max(float(result.GetSolution(e.phi())), 0.0)
    return candidates, values, float(result.get_optimal_cost()), inflow


def _two_mode_paths(G: _Graph, inflow: dict[str, float]) -> list[list[_Vertex]]:
    """start → face i → face j → goal for all i ≠ j, most relaxed flow through i and j first."""
    verts = G.vertices
    paths = []
    for name_i, Vi in verts.items():
        for name_j, Vj in verts.items():
            if Vi.kind != "contact" or Vj.kind != "contact" or Vi is Vj:
                continue
            s_i, t_ij = verts.get(f"start -> {name_i}"), verts.get(f"{name_i} -> {name_j}")
            if s_i is None or t_ij is None:
                continue
            score = inflow.get(name_i, 0.0) + inflow.get(name_j, 0.0)
            paths.append((score, [G.source, s_i, Vi, t_ij, Vj, G.target]))
    paths.sort(key=lambda p: -p[0])
    return [p for _, p in paths]


# ---------------------------------------------------------------------------------- rounding
def _sinc(z: object) -> object:
    """sin(z)/z by its series (|z| ≤ 0.25 here: error < 1e-9), safe at z = 0 for autodiff."""
    z2 = z * z
    return 1 - z2 / 6 + z2 * z2 / 120 - z2 * z2 * z2 / 5040


def _exact_step(P: _Problem, f: Face, pose: tuple, sigma: object, cn: object, cf: object,
                cos: object = np.cos, sin: object = np.sin) -> tuple:
    """Pose after one impulse: the SE(2) exponential of the constant body twist δ = M·w."""
    vx, vy, w = P.twist(P.step_wrench(f, sigma, cn, cf))
    th, x, y = pose
    mid, k = th + w / 2, _sinc(w / 2)
    return th + w, x + k * (cos(mid) * vx - sin(mid) * vy), y + k * (sin(mid) * vx + cos(mid) * vy)


def _interpolated_values(path: list[_Vertex], P: _Problem) -> dict[str, np.ndarray]:
    """A warm start for a path the relaxation did not use: poses interpolated start → goal."""
    N = P.settings.knots
    contacts = [V for V in path if V.kind == "contact"]
    th0 = P.start[2]
    thg = P.goal[2] + 2 * np.pi * np.round((th0 - P.goal[2]) / (2 * np.pi))
    lam = np.linspace(0, 1, len(contacts) * N)
    poses = np.stack([P.start[0] + lam * (P.goal[0] - P.start[0]), P.start[1] + lam * (P.goal[1] - P.start[1]),
                      th0 + lam * (thg - th0)], -1)
    out: dict[str, np.ndarray] = {}
    for m, V in enumerate(contacts):
        f = P.faces[V.face]
        val = np.zeros(max(max(np.atleast_1d(i)) for i in V.index.values()) + 1)
        seg = poses[m * N:(m + 1) * N]
        val[V.index["c"]], val[V.index["s"]] = np.cos(seg[:, 2]), np.sin(seg[:, 2])
        val[V.index["x"]], val[V.index["y"]] = seg[:, 0], seg[:, 1]
        val[V.index["sigma"]] = (f.sigma_lo + f.sigma_hi) / 2
        val[V.index["cn"]] = 0.02
        out[V.name] = val
    for V in path:
        if V.kind == "free":
            anchor = np.mean([P.faces[r].pusher_point((P.faces[r].sigma_lo + P.faces[r].sigma_hi) / 2, P.rho)
                              + 0.02 * P.faces[r].n_out for r in V.route], axis=0)
            val = np.zeros(4 + 2 * V.knots)
            val[4:] = np.tile(anchor, V.knots)
            out[V.name] = val
    return out


def _round(path: list[_Vertex], values: dict[str, np.ndarray], P: _Problem) -> tuple[dict, float]:
    """The local nonlinear solve on the relaxation's path (exact dynamics, warm-started)."""
    import pydrake.symbolic as sym
    from pydrake.solvers import IpoptSolver, MathematicalProgram, SnoptSolver

    S, N = P.settings, P.settings.knots
    prog = MathematicalProgram()
    guess: list[tuple[object, object]] = []
    values = values or _interpolated_values(path, P)
    # unwrap the relaxation's headings along the path, starting from the measured start
    th_prev = P.start[2]
    contacts, frees = [], []
    for V in path[1:-1]:
        val = values[V.name]
        if V.kind == "contact":
            c, s = val[V.index["c"]], val[V.index["s"]]
            th = np.unwrap(np.concatenate([[th_prev], np.arctan2(s, c)]))[1:]
            th_prev = th[-1]
            vars_ = dict(th=prog.NewContinuousVariables(N, "th"), x=prog.NewContinuousVariables(N, "x"),
                         y=prog.NewContinuousVariables(N, "y"), sigma=prog.NewContinuousVariables(1, "sig")[0],
                         cn=prog.NewContinuousVariables(N - 1, "cn"), cf=prog.NewContinuousVariables(N - 1, "cf"))
            guess += [(vars_["th"], th), (vars_["x"], val[V.index["x"]]), (vars_["y"], val[V.index["y"]]),
                      (vars_["sigma"], val[V.index["sigma"]]), (vars_["cn"], np.maximum(val[V.index["cn"]], 0)),
                      (vars_["cf"], val[V.index["cf"]])]
            contacts.append((V, vars_))
        else:
            q = prog.NewContinuousVariables(V.knots, 2, "q")
            guess.append((q, val[V.index["q"]].reshape(V.knots, 2)))
            frees.append((V, q))
    thg = P.goal[2] + 2 * np.pi * np.round((th_prev - P.goal[2]) / (2 * np.pi))
    for var, g in guess:
        prog.SetInitialGuess(var, g)

    prev_pose = (P.start[2], P.start[0], P.start[1])
    cost = 0
    order = {V.name: i for i, V in enumerate(path)}
    for V, var in contacts:
        f = P.faces[V.face]
        th, x, y, sig, cn, cf = (var[k] for k in ("th", "x", "y", "sigma", "cn", "cf"))
        for a, b in zip((th[0], x[0], y[0]), prev_pose):
            prog.AddConstraint(a == b)
        prog.AddBoundingBoxConstraint(f.sigma_lo, f.sigma_hi, sig)
        prog.AddBoundingBoxConstraint(0, S.max_step_m, cn)
        for k in range(N - 1):
            prog.AddLinearConstraint(cf[k] <= P.mu * cn[k])
            prog.AddLinearConstraint(cf[k] >= -P.mu * cn[k])
            _vx, _vy, w = P.twist(P.step_wrench(f, sig, cn[k], cf[k]))
            prog.AddConstraint(w, -S.max_step_rad, S.max_step_rad)
            nxt = _exact_step(P, f, (th[k], x[k], y[k]), sig, cn[k], cf[k], sym.cos, sym.sin)
            for a, b in zip((th[k + 1], x[k + 1], y[k + 1]), nxt):
                prog.AddConstraint(a - b, 0, 0)
            dx, dy = x[k + 1] - x[k], y[k + 1] - y[k]
            cost += S.w_path * sym.sqrt(dx * dx + dy * dy + 1e-8) + S.w_rot * sym.sqrt(w * w + 1e-8)
            cost += S.w_force * (cn[k] * cn[k] + cf[k] * cf[k])
        cost += S.w_mode
        prev_pose = (th[-1], x[-1], y[-1])
    for a, b in zip(prev_pose, (thg, P.goal[0], P.goal[1])):
        prog.AddConstraint(a == b)
    # free motions: knots in their regions, ends on the neighbouring contact points
    by_name = {V.name: var for V, var in contacts}
    for V, q in frees:
        i = order[V.name]
        for knot, region in _free_route_rows(P, V.route, fixed_start=path[i - 1].kind == "source"):
            prog.AddLinearConstraint(region.A, np.full(len(region.b), -np.inf), region.b, q[knot])
        before, after = path[i - 1], path[i + 1]
        start = P.pusher_body if before.kind == "source" else \
            P.faces[before.face].pusher_point(by_name[before.name]["sigma"], P.rho)
        end = P.faces[after.face].pusher_point(by_name[after.name]["sigma"], P.rho)
        for a, b in zip(q[0], start):
            prog.AddConstraint(a == b)
        for a, b in zip(q[-1], end):
            prog.AddConstraint(a == b)
        for m in range(V.knots - 1):
            # scalar Expression arithmetic: numpy's object-array subtraction checks the FPU
            # flags afterwards and reports a spurious 'invalid value' from Drake's internals
            dx, dy = q[m + 1, 0] - q[m, 0], q[m + 1, 1] - q[m, 1]
            cost += S.w_free * sym.sqrt(dx * dx + dy * dy + 1e-8)
    prog.AddCost(cost)

    from pydrake.solvers import SolverOptions

    solvers = [SnoptSolver()] if S.rounding_solver == "snopt" else [IpoptSolver()]
    options = SolverOptions()
    options.SetOption(IpoptSolver().solver_id(), "max_iter", 300)
    options.SetOption(SnoptSolver().solver_id(), "Major iterations limit", 300)
    result = None
    for solver in solvers:
        result = solver.Solve(prog, None, options)
        if result.is_success():
            break
    if result is None or not result.is_success():
        raise PlanningError(f"rounding the GCS relaxation failed ({result.get_solver_id().name()}: "
                            f"{result.get_solution_result()}) on the path {' -> '.join(V.name for V in path)}")
    sol = {"contacts": [(V, {k: np.atleast_1d(result.GetSolution(v)) for k, v in var.items()}) for V, var in contacts],
           "frees": [(V, result.GetSolution(q)) for V, q in frees]}
    return sol, float(result.get_optimal_cost())


# ---------------------------------------------------------------------------------- timing
def _timed_reference(path: list[_Vertex], sol: dict, P: _Problem, dt: float
                     ) -> tuple[list[np.ndarray], np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Sample the rounded plan every ``dt`` seconds with the pusher at ``settings.speed``."""
    speed = P.settings.speed
    t_acc, samples = 0.0, []            # rows: t, θ, x, y, pusher x, pusher y, face
    pose = np.array([P.start[2], P.start[0], P.start[1]])
    contacts = iter(sol["contacts"])
    frees = iter(sol["frees"])
    knots = []

    def world(pose: np.ndarray, q: np.ndarray) -> np.ndarray:
        c, s = np.cos(pose[0]), np.sin(pose[0])
        return pose[1:] + np.array([c * q[0] - s * q[1], s * q[0] + c * q[1]])

    samples.append([0.0, *pose, *world(pose, P.pusher_body), -1])
    for V in path[1:-1]:
        if V.kind == "free":
            _, q = next(frees)
            for m in range(len(q) - 1):
                a, b = world(pose, q[m]), world(pose, q[m + 1])
                length = float(np.linalg.norm(b - a))
                if length < 1e-9:
                    continue
                n = max(2, int(np.ceil(length / (speed * dt))) + 1)
                for lam in np.linspace(0, 1, n)[1:]:
                    samples.append([t_acc + lam * length / speed, *pose, *(a + lam * (b - a)), -1])
                t_acc += length / speed
        else:
            _, v = next(contacts)
            f = P.faces[V.face]
            qc = f.pusher_point(v["sigma"][0], P.rho)
            knots.append(np.stack([v["x"], v["y"], v["th"]], -1))
            pose = np.array([v["th"][0], v["x"][0], v["y"][0]])
            for k in range(len(v["cn"])):
                vx, vy, w = P.twist(P.step_wrench(f, v["sigma"][0], v["cn"][k], v["cf"][k]))
                body_speed = float(np.hypot(vx - w * qc[1], vy + w * qc[0]))   # |v + ω × q|
                duration = max(body_speed / speed, dt)
                n = max(2, int(np.ceil(duration / dt)) * 4 + 1)
                for lam in np.linspace(0, 1, n)[1:]:
                    th, x, y = _exact_step(P, f, tuple(pose), v["sigma"][0], lam * v["cn"][k], lam * v["cf"][k])
                    p = np.array([th, x, y])
                    samples.append([t_acc + lam * duration, *p, *world(p, qc), f.index])
                t_acc += duration
                pose = np.array(samples[-1][1:4])
    arr = np.array(samples)
    times = np.arange(0.0, arr[-1, 0] + dt, dt)
    ref = np.stack([np.interp(times, arr[:, 0], arr[:, i]) for i in range(1, 6)], -1)
    face = arr[np.clip(np.searchsorted(arr[:, 0], times), 0, len(arr) - 1), 6].astype(int)
    poses = ref[:, [1, 2, 0]]
    return knots, times, poses, ref[:, 3:5], face


# ---------------------------------------------------------------------------------- entry point
def plan_push(shape: Shape, start: object, pusher: object, goal: object, params: object,
              mu: float = 0.3, settings: GCSSettings | None = None, dt: float = 0.04) -> Plan:
    """Plan a push of ``shape`` from ``start`` (x, y, θ) with the pusher at ``pusher`` to ``goal``.

    The plan uses ``params`` (λ = [β, x_bf, y_bf]) in the limit surface and the
    pusher–object friction ``mu``; it is sampled every ``dt`` seconds. Raises
    :class:`PlanningError` when the relaxation is infeasible or the rounding fails, and
    ``ValueError`` for bad input.
    """
    settings = settings or GCSSettings()
    if not isinstance(shape, Shape):
        raise ValueError(f"shape must be a dexpush Shape, got {type(shape).__name__}")
    start = checked_vector("start", start, 3)
    pusher = checked_vector("pusher", pusher, 2)
    goal = checked_vector("goal", goal, 3)
    p = checked_vector("params", params, 3)
    check_params(p)
    if not (np.isfinite(mu) and mu > 0):
        raise ValueError(f"mu must be positive, got {mu}")
    if not dt > 0:
        raise ValueError(f"dt must be positive, got {dt}")
    _quiet_drake()
    t0 = time.perf_counter()
    ladder = [settings] + [replace(settings, knots=int(k), retry_knots=()) for k in settings.retry_knots]
    for i, attempt in enumerate(ladder):
        try:
            plan = _plan_once(shape, start, pusher, goal, p, float(mu), attempt, dt)
            break
        except PlanningError:
            if i == len(ladder) - 1:
                raise
    plan.planning_s = time.perf_counter() - t0       # all attempts
    return plan


def _plan_once(shape: Shape, start: np.ndarray, pusher: np.ndarray, goal: np.ndarray, p: np.ndarray, mu: float,
               settings: GCSSettings, dt: float) -> Plan:
    """One build–relax–round pass of :func:`plan_push` with fixed settings."""
    t0 = time.perf_counter()
    P = _make_problem(shape, start, pusher, goal, p, mu, settings)
    G = _build_graph(P)
    t1 = time.perf_counter()
    candidates, values, relax_cost, vertex_flow = _solve_relaxation(G, P)
    t2 = time.perf_counter()
    # the relaxation's own paths first; if none rounds (a loose relaxation likes a single
    # contact mode that cannot end exactly at the goal), the two-mode paths through the
    # faces that carry the most relaxed flow, warm-started by interpolation
    fallback = _two_mode_paths(G, vertex_flow)[: settings.max_enumerated_paths]
    best, errors = None, []
    for path in candidates + fallback:
        try:
            sol, cost = _round(path, values if path in candidates else {}, P)
        except PlanningError as exc:
            errors.append(str(exc))
            continue
        best = (path, sol, cost)
        break
    if best is None:
        raise PlanningError(f"no path of the GCS relaxation could be rounded with {settings.knots} knots "
                            f"({len(errors)} tried); "
                            f"first failure: {errors[0]}")
    relax_s, round_s = t2 - t1, time.perf_counter() - t2
    path, sol, rounded_cost = best
    knots, times, poses, pusher_ref, face = _timed_reference(path, sol, P, dt)
    return Plan([V.name for V in path], knots, times, poses, pusher_ref, face, relax_cost, rounded_cost,
                relaxation_s=relax_s, rounding_s=round_s, planning_s=time.perf_counter() - t0, params=p)


# ---------------------------------------------------------------------------------- tracking
class GCSTracker:
    """Execute GCS plans in closed loop at the control rate (the baseline's controller).

    Each control step commands the pusher velocity that brings the pusher to the plan's
    next reference point, ``u = (p_ref[i+1] − p)/Δt`` clipped per axis to ``±v_max/√2``
    (feedback on the pusher). The object is not steered between plans: when its pose
    strays from the plan's by more than ``replan_m`` or ``replan_deg``, or the plan ends
    short of the goal, the tracker replans from the measured state (object pose and
    pusher), at most ``max_replans`` times (default 40). It gives up (:attr:`gave_up`, zero
    velocity from then on) when a plan fails, or when the last allowed plan has run out.

    Attributes after use: ``plans`` (every plan made), ``planning_s`` (their times).
    """

    def __init__(self, shape: Shape, goal: object, params: object, mu: float = 0.3,
                 settings: GCSSettings | None = None, control_period: float = 0.04, v_max: float = 0.1,
                 replan_m: float = 0.01, replan_deg: float = 4.0, max_replans: int = 40) -> None:
        self.shape, self.goal = shape, checked_vector("goal", goal, 3)
        self.params, self.mu = checked_vector("params", params, 3), float(mu)
        self.settings = settings or GCSSettings()
        self.dt, self.u_max = float(control_period), float(v_max) / np.sqrt(2)
        self.replan_m, self.replan_deg = float(replan_m), float(replan_deg)
        self.max_replans = int(max_replans)
        self.plans: list[Plan] = []
        self.planning_s: list[float] = []
        self.failures: list[str] = []
        self._plan: Plan | None = None
        self._i = 0

    def plan(self, pose: object, pusher: object) -> Plan | None:
        """Plan from the measured object pose and pusher position; the new plan (or ``None``
        when the planner fails, with the reason appended to ``failures``) replaces the current one."""
        pose, pusher = checked_vector("pose", pose, 3), checked_vector("pusher", pusher, 2)
        t0 = time.perf_counter()
        try:
            self._plan = plan_push(self.shape, pose, pusher, self.goal, self.params, self.mu, self.settings, self.dt)
            self.plans.append(self._plan)
        except PlanningError as exc:
            self._plan = None
            self.failures.append(str(exc))
        self.planning_s.append(time.perf_counter() - t0)
        self._i = 0
        return self._plan

    @property
    def gave_up(self) -> bool:
        """Nothing left to execute: the last planning attempt failed (planning again from the
        same resting state would fail again), or the plan has run out and no replans are left."""
        if not self.planning_s:
            return False
        if self._plan is None:
            return True
        return self._i >= len(self._plan.times) - 1 and len(self.planning_s) > self.max_replans

    def command(self, pose: object, pusher: object) -> np.ndarray:
        """The pusher velocity for the measured object pose and pusher position (plans on the
        first call unless :meth:`plan` was called; zero once the tracker has given up)."""
        pose, pusher = checked_vector("pose", pose, 3), checked_vector("pusher", pusher, 2)
        if not self.planning_s:
            self.plan(pose, pusher)
        plan = self._plan
        if plan is not None:
            pos_err, head_err = pose_error(pose, plan.poses[min(self._i, len(plan.times) - 1)])
            strayed = pos_err > self.replan_m or head_err > self.replan_deg
            ended = self._i >= len(plan.times) - 1
            if (strayed or ended) and len(self.planning_s) <= self.max_replans:
                plan = self.plan(pose, pusher)
            elif ended:
                plan = None
        if plan is None:
            return np.zeros(2)
        i = min(self._i + 1, len(plan.times) - 1)
        self._i += 1
        return np.clip((plan.pusher[i] - pusher) / self.dt, -self.u_max, self.u_max)
