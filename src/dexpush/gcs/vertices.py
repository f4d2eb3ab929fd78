"""The graph's convex sets: relaxed contact modes (McCormick polyhedron or SDP) and free motions.

A contact vertex holds the N knots of one face's contact mode; its bilinear constraints
are relaxed as ``settings.relaxation`` says (see :mod:`dexpush.gcs`). A free vertex holds a
contact-free pusher motion through a chain of collision-free regions with the object at rest.
"""

from __future__ import annotations

import numpy as np

from dexpush.gcs.geometry import Face
from dexpush.gcs.problem import Problem, free_route_rows

__all__ = ["Vertex", "contact_vertex", "free_vertex"]


class Vertex:
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


def contact_vertex(gcs: object, P: Problem, f: Face) -> Vertex:
    """Face f's contact mode, relaxed as ``settings.relaxation`` says."""
    if P.settings.relaxation == "sdp":
        return _contact_vertex_sdp(gcs, P, f)
    return _contact_vertex_mccormick(gcs, P, f)


def _contact_vertex_mccormick(gcs: object, P: Problem, f: Face) -> Vertex:
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
    V = Vertex("contact", f"face {f.index}", v, index, face=f.index, knots=N)
    _contact_costs(V, P, f)
    return V


def _rotation_coefficients(P: Problem, f: Face) -> tuple[float, float, float]:
    """δθ = g_n·c_n + g_t·c_f + g_σn·σ·c_n on face f (row 2 of eq. 5)."""
    fx0, fy0, t0 = P.step_wrench(f, 0.0, 1.0, 0.0)
    fx1, fy1, t1 = P.step_wrench(f, 0.0, 0.0, 1.0)
    _, _, ts = P.step_wrench(f, 1.0, 1.0, 0.0)
    M = P.M[2]
    g_n = M[0] * fx0 + M[1] * fy0 + M[2] * t0
    g_t = M[0] * fx1 + M[1] * fy1 + M[2] * t1
    return float(g_n), float(g_t), float(M[2] * (ts - t0))


def _contact_vertex_sdp(gcs: object, P: Problem, f: Face) -> Vertex:
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
    V = Vertex("contact", f"face {f.index}", v, index, face=f.index, knots=N)
    _contact_costs(V, P, f)
    return V


def _contact_costs(V: Vertex, P: Problem, f: Face) -> None:
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


def free_vertex(gcs: object, P: Problem, name: str, route: list[int], fixed_start: bool) -> Vertex:
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
    for knot, region in free_route_rows(P, route, fixed_start):
        for a, b in zip(region.A, region.b):
            row = np.zeros(n)
            row[4 + 2 * knot: 6 + 2 * knot] = a
            rows_A.append(row)
            rows_b.append(b)
    v = gcs.AddVertex(HPolyhedron(np.array(rows_A), np.array(rows_b)), name)
    index = dict(c=0, s=1, x=2, y=3, q=[4 + i for i in range(2 * K)])
    V = Vertex("free", name, v, index, route=route, knots=K)
    q = V.var("q").reshape(K, 2)
    for m in range(K - 1):
        A = P.settings.w_free * np.array([[-1, 0, 1, 0], [0, -1, 0, 1.0]])
        v.AddCost(Binding[Cost](L2NormCost(A, np.zeros(2)), np.concatenate([q[m], q[m + 1]])))
    return V
