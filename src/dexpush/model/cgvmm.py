"""The contact-aware generalized velocity–motion model (C-GVMM), paper Sec. III-B, Algorithm 1.

This is the one implementation of the pushing physics in dexpush: the plants, MPPI, the
UKF and the dataset validation all call :func:`solve_contact` (through :func:`cgvmm`,
:func:`step` or :func:`integrate`).

Conventions (docs/conventions.md#units-and-frames):
    state  x = [x_b, y_b, θ, x_c, y_c]   object pose in {S}, pusher centre in {S}
    input  u = [v_x, v_y]                pusher velocity in {S}
    params λ = [β, x_bf, y_bf]           β in 1/m, p_bf = CoF in {B}
    L̃ = α²·diag(1, 1, β²);  α cancels in the velocity model (α = 1 by default).

Per sample (single contact, N_c = 1), with φ_c the contact azimuth and r, ∂φr the
inflated contour's radial vector and tangent:

    N       = [n̂ᵀ; t̂ᵀ]   n̂ inward unit normal, t̂ = ∂φr/|∂φr|               (eq. 1)
    C       = A_bf·L̃·A_bfᵀ·J*ᵀ·N,  V_sb = C·f_c                            (eq. 5)
    w       = N·R(θ)ᵀ·u = Γ·f_c + η·φ̇,  Γ = N·J*·C,  η = N·∂φr = [0, |∂φr|]  (eq. 6–7)
    f_c     = [f⁺ + f⁻, μ(f⁺ − f⁻)]                                         (eq. 8)

Where the pusher sits in a concave corner of the contour it touches two faces; there
:mod:`dexpush.model.corner` solves eq. 5–8 with both contacts (mode ``CORNER`` when it jams).

Modes, tested in this order (docs/conventions.md#motion-model): stick if [[1,1],[μ,−μ]]⁻¹Γ⁻¹w > 0; sliding CCW
if [[1,g₀],[μ,g₁]]⁻¹Γ⁻¹w ≥ 0 (g = Γ⁻¹η); sliding CW if [[1,−g₀],[−μ,−g₁]]⁻¹Γ⁻¹w ≥ 0;
otherwise, or when the pusher is outside the contour, free (separation).

All 2×2 and 3×3 algebra is written out in components so that XLA fuses a whole batch
of evaluations into a few elementwise loops; everything broadcasts over leading axes.
"""

from __future__ import annotations

from functools import partial
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from dexpush.common import fastmath
from dexpush.common.checks import check_params, check_values, checked_vector
from dexpush.model.corner import corner_fix, corner_solve, corner_table
from dexpush.model.shape import Shape, contour_lookup

__all__ = [
    "CONTACT_TOL",
    "CORNER",
    "FREE",
    "LAMBDA_TRUE",
    "MODE_NAMES",
    "MU_C",
    "SLIDE_CCW",
    "SLIDE_CW",
    "STICK",
    "ContactSolution",
    "Contour",
    "cgvmm",
    "components",
    "contact_gap",
    "force_motion",
    "integrate",
    "limit_surface_matrix",
    "replay",
    "resolve_penetration",
    "solve_contact",
    "step",
]

STICK, SLIDE_CCW, SLIDE_CW, FREE, CORNER = 0, 1, 2, 3, 4
MODE_NAMES = ("stick", "slide_ccw", "slide_cw", "free", "corner")
#: λ_true of the paper's numerical experiments (Sec. IV-B): [β, x_bf, y_bf]
LAMBDA_TRUE = (25.0, -0.01, 0.02)
#: the pusher–object friction coefficient μ_c the model, the model plant and the controller assume
#: unless told otherwise
MU_C = 0.3
#: contact test tolerance (m): in contact iff |p_c − p_b| ≤ |r(φ_c)| + CONTACT_TOL. One micron
#: is far below any physical scale but above float32 round-off of metre-scale coordinates,
#: so a pusher that the integrator left exactly on the contour stays in contact.
CONTACT_TOL = 1e-6


class Contour(NamedTuple):
    """A shape's inflated contour as a cubic table, and its concave corners (a pytree, so jit
    sees arrays)."""

    coefficients: jnp.ndarray  #: (n, 4), see :func:`dexpush.model.shape.hermite_coefficients`
    #: (n_c, 12) concave corners (:func:`dexpush.model.corner.corner_table`), or None for a shape without any
    corners: jnp.ndarray | None = None

    @staticmethod
    def of(shape: Shape | Contour) -> Contour:
        if isinstance(shape, Contour):
            return shape
        if not isinstance(shape, Shape):
            raise TypeError(f"expected a dexpush.Shape, got {type(shape).__name__}")
        # jax's default float: float32, or float64 when jax_enable_x64 is on
        corners = jnp.asarray(corner_table(shape.corners)) if len(shape.corners) else None
        return Contour(jnp.asarray(shape.coefficients), corners)

    def lookup(self, phi: jnp.ndarray) -> tuple[jnp.ndarray, jnp.ndarray]:
        """(R(φ), R'(φ)) in φ's dtype."""
        return contour_lookup(self.coefficients, phi)


class ContactSolution(NamedTuple):
    """Everything Algorithm 1 computes for one state and input (all broadcast over batch axes).

    Attributes:
        xdot: (..., 5) state derivative [q̇_sb, ṗ_sc].
        mode: int32 (...,), 0 stick, 1 sliding CCW, 2 sliding CW, 3 free.
        force: (..., 2) contact force f_c = [f_n, f_t] in the contact frame (0 if free).
        phidot: (...,) sliding rate φ̇_c (0 in stick and free).
        phi: (...,) contact azimuth φ_c in {B}.
        in_contact: bool (...,), |p_c − p_b| ≤ |r(φ_c)|.
        decision: (..., 2) mode-decision vector Γ⁻¹w.
        boundary: (..., 2) sliding/free boundary Γ⁻¹η.
        twist: (..., 3) body twist V_sb.
    """

    xdot: jnp.ndarray
    mode: jnp.ndarray
    force: jnp.ndarray
    phidot: jnp.ndarray
    phi: jnp.ndarray
    in_contact: jnp.ndarray
    decision: jnp.ndarray
    boundary: jnp.ndarray
    twist: jnp.ndarray


def _limit_surface(params: jnp.ndarray, alpha: float | jnp.ndarray) -> tuple[jnp.ndarray, ...]:
    """Entries of the symmetric M = A_bf·L̃·A_bfᵀ (eq. 5) as (m00, m01, m02, m11, m12, m22)."""
    beta, xf, yf = params[..., 0], params[..., 1], params[..., 2]
    a2 = alpha * alpha
    b2 = beta * beta
    return (a2 * (1 + b2 * yf * yf), -a2 * b2 * xf * yf, a2 * b2 * yf,
            a2 * (1 + b2 * xf * xf), -a2 * b2 * xf, a2 * b2)


def limit_surface_matrix(params: object, alpha: float = 1.0) -> np.ndarray:
    """M = A_bf·L̃·A_bfᵀ of eq. 5 as a (3, 3) float64 array: body twist V_sb = M·[f; r × f].

    For planners that need the force–motion map as a matrix (the GCS baseline); the same
    entries as the C-GVMM's own :func:`_limit_surface`.
    """
    p = checked_vector("params", params, 3)
    m00, m01, m02, m11, m12, m22 = (float(v) for v in _limit_surface(p, alpha))
    return np.array([[m00, m01, m02], [m01, m11, m12], [m02, m12, m22]])


def _sym3_mul(m: tuple[jnp.ndarray, ...], v: tuple[jnp.ndarray, ...]) -> tuple[jnp.ndarray, ...]:
    m00, m01, m02, m11, m12, m22 = m
    return (m00 * v[0] + m01 * v[1] + m02 * v[2],
            m01 * v[0] + m11 * v[1] + m12 * v[2],
            m02 * v[0] + m12 * v[1] + m22 * v[2])


def _contact_frame(contour: Contour, px: jnp.ndarray, py: jnp.ndarray,
                   one: jnp.ndarray | float = 1.0) -> tuple[jnp.ndarray, ...]:
    """Contact geometry for the pusher at p = (px, py) in {B} (φ_c = atan2(py, px)).

    Returns φ, |p|, R(φ), the contour point r, |∂φr|, inward normal n̂ and tangent t̂.
    cos φ and sin φ come from p itself, so the only transcendental is one atan2. ``one``
    (a traced 1, see :func:`dexpush.common.fastmath.materialize`) marks φ and R, R' to be stored once.
    """
    (phi,) = fastmath.materialize(one, fastmath.atan2(py, px))
    dist = jnp.sqrt(px * px + py * py)
    inv = 1.0 / jnp.where(dist > 0, dist, 1.0)
    c, s = jnp.where(dist > 0, px * inv, 1.0), py * inv
    R, dR = fastmath.materialize(one, *contour.lookup(phi))
    rx, ry = R * c, R * s
    drx, dry = dR * c - R * s, dR * s + R * c
    ndr = jnp.sqrt(drx * drx + dry * dry)
    tx, ty = drx / ndr, dry / ndr
    return phi, dist, R, rx, ry, ndr, -ty, tx, tx, ty  # n̂ = (−t_y, t_x)


State = jnp.ndarray | tuple[jnp.ndarray, ...]


def components(x: State) -> tuple[jnp.ndarray, ...]:
    """The state's components (x_b, y_b, θ, x_c, y_c) from a (..., 5) array or a 5-tuple.

    Rollouts carry the state as a tuple of (K,) arrays: stacking components into one
    (K, 5) array every step makes XLA's CPU backend re-evaluate the whole shared model
    expression once per stacked component (docs/performance.md).
    """
    return tuple(x) if isinstance(x, tuple | list) else tuple(x[..., i] for i in range(x.shape[-1]))


def _like(x: State, parts: tuple[jnp.ndarray, ...]) -> State:
    """Return ``parts`` in the same form (tuple or stacked array) as ``x``."""
    return tuple(parts) if isinstance(x, tuple | list) else jnp.stack(parts, -1)


def _to_body(xs: tuple[jnp.ndarray, ...], one: jnp.ndarray | float = 1.0) -> tuple[jnp.ndarray, ...]:
    """cos θ, sin θ and the pusher position relative to the object in {B} (each stored once
    when ``one`` is a traced 1, see :func:`dexpush.common.fastmath.materialize`)."""
    xb, yb, th, xc, yc = xs
    sth, cth = fastmath.materialize(one, *fastmath.sincos(th))
    dx, dy = xc - xb, yc - yb
    return (cth, sth, *fastmath.materialize(one, cth * dx + sth * dy, -sth * dx + cth * dy))


def _solve(contour: Contour, xs: tuple[jnp.ndarray, ...], u: jnp.ndarray, params: jnp.ndarray,
           mu: float | jnp.ndarray, alpha: float | jnp.ndarray,
           one: jnp.ndarray | float = 1.0) -> dict[str, jnp.ndarray]:
    """Algorithm 1 on state components; returns every intermediate by name (unstacked).

    ``one``, a traced 1 (:func:`dexpush.common.fastmath.materialize`), stores the intermediates that
    several later loops share, where XLA's CPU backend would otherwise recompute them.
    """
    keep = partial(fastmath.materialize, one)
    ux, uy = u[..., 0], u[..., 1]
    cth, sth, px, py = _to_body(xs, one)
    phi, dist, R, rx, ry, ndr, nx, ny, tx, ty = _contact_frame(contour, px, py, one)   # line 1
    in_contact = dist <= R + CONTACT_TOL                                 # line 5

    vbx, vby = keep(cth * ux + sth * uy, -sth * ux + cth * uy)          # R(θ)ᵀ u
    w0, w1 = nx * vbx + ny * vby, tx * vbx + ty * vby                    # line 2

    # wrench directions J*ᵀ n̂ and J*ᵀ t̂ (force, moment r × f)
    Wn = (nx, ny, rx * ny - ry * nx)
    Wt = (tx, ty, rx * ty - ry * tx)
    M = _limit_surface(params, alpha)
    MWn, MWt = _sym3_mul(M, Wn), _sym3_mul(M, Wt)                        # columns of C
    g00 = Wn[0] * MWn[0] + Wn[1] * MWn[1] + Wn[2] * MWn[2]               # line 4: Γ = N J* C
    g01 = Wn[0] * MWt[0] + Wn[1] * MWt[1] + Wn[2] * MWt[2]
    g11 = Wt[0] * MWt[0] + Wt[1] * MWt[1] + Wt[2] * MWt[2]
    g00, g01, g11 = keep(g00, g01, g11)
    det = g00 * g11 - g01 * g01
    a0, a1 = (g11 * w0 - g01 * w1) / det, (g00 * w1 - g01 * w0) / det    # Γ⁻¹w
    e0, e1 = -g01 * ndr / det, g00 * ndr / det                           # g = Γ⁻¹η, line 3

    # line 8: stick, [f⁺, f⁻] = [[1,1],[μ,−μ]]⁻¹ Γ⁻¹w
    fp_s, fm_s = (mu * a0 + a1) / (2 * mu), (mu * a0 - a1) / (2 * mu)
    # line 9: CCW, [f⁺, φ̇] = [[1, g0],[μ, g1]]⁻¹ Γ⁻¹w
    dccw = e1 - mu * e0
    fp_c, pd_c = (e1 * a0 - e0 * a1) / dccw, (a1 - mu * a0) / dccw
    # line 10: CW, [f⁻, −φ̇] = [[1, −g0],[−μ, −g1]]⁻¹ Γ⁻¹w
    dcw = -e1 - mu * e0
    fm_w, npd_w = (e0 * a1 - e1 * a0) / dcw, (a1 + mu * a0) / dcw

    stick = in_contact & (fp_s > 0) & (fm_s > 0)                         # line 11
    ccw = in_contact & ~stick & (fp_c >= 0) & (pd_c >= 0)                # line 13
    cw = in_contact & ~stick & ~ccw & (fm_w >= 0) & (npd_w >= 0)         # line 16
    zero = jnp.zeros_like(a0)
    fn = jnp.where(stick, a0, jnp.where(ccw, fp_c, jnp.where(cw, fm_w, zero)))   # line 23
    ft = jnp.where(stick, a1, jnp.where(ccw, mu * fp_c, jnp.where(cw, -mu * fm_w, zero)))
    fn, ft = keep(fn, ft)
    phidot = jnp.where(ccw, pd_c, jnp.where(cw, -npd_w, zero))
    mode = jnp.where(stick, STICK, jnp.where(ccw, SLIDE_CCW, jnp.where(cw, SLIDE_CW, FREE)))

    F = (fn * Wn[0] + ft * Wt[0], fn * Wn[1] + ft * Wt[1], fn * Wn[2] + ft * Wt[2])
    Vx, Vy, Vw = keep(*_sym3_mul(M, F))                                  # V_sb = C f_c (eq. 5)
    out = dict(mode=mode, fn=fn, ft=ft, phidot=phidot, phi=phi, in_contact=in_contact,
               a=(a0, a1), e=(e0, e1))
    if contour.corners is not None:                     # N_c = 2 at a concave corner (eq. 5–8)
        k = corner_solve(contour.corners, px, py, vbx, vby, M, mu, one)
        at = k.at
        k_mode = jnp.where(k.jam, CORNER, jnp.where(k.slide, jnp.where(k.side > 0, SLIDE_CCW, SLIDE_CW), FREE))
        for name, value in (("mode", k_mode), ("fn", k.fn), ("ft", k.ft), ("phidot", k.phidot)):
            out[name] = jnp.where(at, value, out[name])
        out["in_contact"] = in_contact | at
        cx, cy = k.c
        kV = _sym3_mul(M, (k.F[0], k.F[1], cx * k.F[1] - cy * k.F[0]))   # V_sb = M·J*ᵀF
        Vx, Vy, Vw = (jnp.where(at, kv, v) for kv, v in zip(kV, (Vx, Vy, Vw)))
        out["corner"] = k
    out["V"] = (Vx, Vy, Vw)
    out["xdot"] = (cth * Vx - sth * Vy, sth * Vx + cth * Vy, Vw, ux, uy)   # line 24–25
    return out


def solve_contact(contour: Contour, x: State, u: jnp.ndarray, params: jnp.ndarray,
                  mu: float | jnp.ndarray = MU_C, alpha: float | jnp.ndarray = 1.0) -> ContactSolution:
    """Algorithm 1 of the paper (single contact), traceable and broadcast over leading axes.

    This is the unchecked core: inputs must already be arrays of matching dtype. Use
    :func:`cgvmm` or :func:`contact_solution` from outside jit-compiled code.
    """
    o = _solve(contour, components(x), u, params, mu, alpha)
    return ContactSolution(
        xdot=jnp.stack(o["xdot"], -1), mode=o["mode"].astype(jnp.int32),
        force=jnp.stack([o["fn"], o["ft"]], -1), phidot=o["phidot"], phi=o["phi"],
        in_contact=o["in_contact"], decision=jnp.stack(o["a"], -1), boundary=jnp.stack(o["e"], -1),
        twist=jnp.stack(o["V"], -1))


def force_motion(shape: Shape | Contour, phi: object, force: object, params: object,
                 alpha: float = 1.0) -> jnp.ndarray:
    """The force–motion model (eq. 5): body twist V_sb = C(φ_c; λ)·f_c, shape (..., 3).

    Unlike the velocity model, the result scales with α² (α sets the limit surface's size).
    """
    contour = Contour.of(shape)
    phi, f, p = _float_arrays(phi=phi, force=force, params=params)
    _require_last(f, 2, "force")
    _require_last(p, 3, "params")
    _, _, _, rx, ry, _, nx, ny, tx, ty = _contact_frame(contour, jnp.cos(phi), jnp.sin(phi))
    fn, ft = f[..., 0], f[..., 1]
    F = (fn * nx + ft * tx, fn * ny + ft * ty, fn * (rx * ny - ry * nx) + ft * (rx * ty - ry * tx))
    return jnp.stack(_sym3_mul(_limit_surface(p, alpha), F), -1)


def contact_gap(contour: Contour, x: State) -> jnp.ndarray:
    """|p_c − p_b| − R(φ_c): negative when the pusher centre is inside the inflated contour."""
    _, _, px, py = _to_body(components(x))
    _, dist, R, *_ = _contact_frame(contour, px, py)
    return dist - R


def resolve_penetration(contour: Contour, x: State, keep_contact: jnp.ndarray | bool = False) -> State:
    """Move the object (never the pusher) so that the pusher centre sits on the contour.

    The pusher is position-controlled, so a pusher centre found inside the inflated
    contour displaces the object along the contact normal by the penetration depth. With
    ``keep_contact`` (True where the last step was in stick or sliding contact) a gap that
    opened between pusher and contour is closed as well: in those modes the continuous
    model keeps the pusher on the contour (eq. 6), so the gap is Euler's O(Δt²) error.
    The correction is first order in the depth (exact for flat faces).
    """
    xs = components(x)
    return _like(x, _resolve(contour, xs, keep_contact, _to_body(xs)))


def _resolve(contour: Contour, xs: tuple[jnp.ndarray, ...], keep_contact: jnp.ndarray | bool,
             body: tuple[jnp.ndarray, ...], one: jnp.ndarray | float = 1.0) -> tuple[jnp.ndarray, ...]:
    """:func:`resolve_penetration` on components, given ``_to_body(xs)``."""
    cth, sth, px, py = body
    _, dist, R, _, _, _, nx, ny, _, _ = _contact_frame(contour, px, py, one)
    radial = jnp.where(keep_contact, R - dist, jnp.maximum(R - dist, 0.0))
    # depth along the outward normal: (R − |p|)·(ê_r · n̂_out), with n̂_out = −n̂
    inv = 1.0 / jnp.where(dist > 0, dist, 1.0)
    (depth,) = fastmath.materialize(one, radial * -(nx * px + ny * py) * inv)
    mx, my = cth * nx - sth * ny, sth * nx + cth * ny   # inward normal in {S}: the push direction
    return (xs[0] + depth * mx, xs[1] + depth * my, *xs[2:])


def step(contour: Contour, x: State, u: jnp.ndarray, dt: float | jnp.ndarray,
         params: jnp.ndarray, mu: float | jnp.ndarray = MU_C) -> State:
    """One explicit-Euler step of the C-GVMM followed by :func:`resolve_penetration`.

    ``step(x, u, λ) -> x'`` is what MPPI rolls out and what the model plant integrates
    with substeps. After a free step a pusher that entered the object pushes it out;
    after a contact step the pusher is put back on the contour (see
    :func:`resolve_penetration`). ``x`` is a (..., 5) array or a 5-tuple of arrays, and
    the result has the same form.
    """
    xs = components(x)
    one = fastmath.traced_one(dt)     # seams for XLA's CPU fusion (dexpush.common.fastmath.materialize)
    o = _solve(contour, xs, u, params, mu, 1.0, one)
    moved = tuple(xi + dt * di for xi, di in zip(xs, o["xdot"]))
    body = _to_body(moved, one)
    fixed = _resolve(contour, moved, o["mode"] != FREE, body, one)
    if "corner" in o:
        fixed = corner_fix(o["corner"], moved, fixed, body[0], body[1], one)
    return _like(x, fixed)


def integrate(contour: Contour, x: jnp.ndarray, u: jnp.ndarray, duration: float | jnp.ndarray,
              params: jnp.ndarray, mu: float | jnp.ndarray = MU_C, substeps: int = 10) -> jnp.ndarray:
    """Hold ``u`` for ``duration`` seconds, integrating with ``substeps`` calls of :func:`step`."""
    h = duration / substeps
    return jax.lax.fori_loop(0, substeps, lambda _, xi: step(contour, xi, u, h, params, mu), x)


def replay(contour: Contour, x0: jnp.ndarray, inputs: jnp.ndarray, dt: float | jnp.ndarray,
           params: jnp.ndarray, mu: float | jnp.ndarray = MU_C, substeps: int = 10) -> jnp.ndarray:
    """States (T, 5) after each of the T inputs (T, 2), each held for ``dt`` from ``x0`` (5,).

    An open-loop replay of recorded pusher motion: the UKF's measurement model and the
    dataset's whole-push prediction.
    """
    def body(x: jnp.ndarray, u: jnp.ndarray) -> tuple[jnp.ndarray, jnp.ndarray]:
        x1 = integrate(contour, x, u, dt, params, mu, substeps)
        return x1, x1

    return jax.lax.scan(body, x0, inputs)[1]


# ---------------------------------------------------------------------- public, checked entry
def _float_arrays(**arrays: object) -> tuple[jnp.ndarray, ...]:
    out = []
    for name, a in arrays.items():
        try:
            arr = np.asarray(a)
        except Exception as exc:
            raise ValueError(f"{name} must be a numeric array, got {type(a).__name__}") from exc
        if arr.dtype == object or not np.issubdtype(arr.dtype, np.number):
            raise ValueError(f"{name} must be a numeric array, got dtype {arr.dtype}")
        out.append(check_values(name, arr))
    # float64 numpy input stays float64 only when jax_enable_x64 is on; ints become float
    jarrs = [jnp.asarray(a) for a in out]
    dtype = jnp.result_type(*[a.dtype for a in jarrs if jnp.issubdtype(a.dtype, jnp.floating)]
                            or [float])
    return tuple(a.astype(dtype) for a in jarrs)


def _require_last(a: jnp.ndarray, n: int, name: str) -> None:
    if a.ndim == 0 or a.shape[-1] != n:
        raise ValueError(f"{name} must have shape (..., {n}), got {tuple(a.shape)}")


@jax.jit
def _solve_jit(contour: Contour, x: jnp.ndarray, u: jnp.ndarray, params: jnp.ndarray,
               mu: jnp.ndarray, alpha: jnp.ndarray) -> ContactSolution:
    return solve_contact(contour, x, u, params, mu, alpha)


def contact_solution(shape: Shape | Contour, x: object, u: object, params: object = LAMBDA_TRUE,
                     mu: float = MU_C, alpha: float = 1.0) -> ContactSolution:
    """Checked, jit-compiled :func:`solve_contact`: every quantity of Algorithm 1.

    Raises ``ValueError`` for NaN/inf input, wrong trailing sizes, β ≤ 0 or μ ≤ 0.
    """
    contour = Contour.of(shape)
    x, u, p = _float_arrays(x=x, u=u, params=params)
    _require_last(x, 5, "x (state [x_b, y_b, θ, x_c, y_c])")
    _require_last(u, 2, "u (pusher velocity [v_x, v_y])")
    _require_last(p, 3, "params ([β, x_bf, y_bf])")
    check_params(p)
    if not (np.isfinite(mu) and mu > 0):
        raise ValueError(f"mu (pusher–object friction) must be > 0, got {mu!r}")
    if not (np.isfinite(alpha) and alpha > 0):
        raise ValueError(f"alpha must be > 0, got {alpha!r}")
    try:
        batch = jnp.broadcast_shapes(x.shape[:-1], u.shape[:-1], p.shape[:-1])
    except ValueError as exc:
        raise ValueError(
            f"batch shapes of x {x.shape[:-1]}, u {u.shape[:-1]} and params {p.shape[:-1]} "
            "do not broadcast") from exc
    x = jnp.broadcast_to(x, (*batch, 5))
    u = jnp.broadcast_to(u, (*batch, 2))
    p = jnp.broadcast_to(p, (*batch, 3))
    return _solve_jit(contour, x, u, p, jnp.asarray(mu, x.dtype), jnp.asarray(alpha, x.dtype))


def cgvmm(shape: Shape | Contour, x: object, u: object, params: object = LAMBDA_TRUE,
          mu: float = MU_C, alpha: float = 1.0) -> tuple[jnp.ndarray, jnp.ndarray]:
    """The C-GVMM (Algorithm 1): state derivative and contact mode.

    Args:
        shape: the pushed object (its pusher-inflated contour is used).
        x: (..., 5) states [x_b, y_b, θ, x_c, y_c] in {S}.
        u: (..., 2) pusher velocities [v_x, v_y] in {S}.
        params: (..., 3) λ = [β, x_bf, y_bf]; defaults to the paper's λ_true.
        mu: pusher–object friction coefficient μ_c.
        alpha: limit-surface scale α; it cancels (kept to test that it does).

    Returns:
        ``(xdot, mode)``: (..., 5) derivative and int32 (...,) mode, 0 stick,
        1 sliding CCW, 2 sliding CW, 3 free. Leading axes broadcast; the dtype follows
        the inputs (float32 by default, float64 with ``jax_enable_x64`` and float64 input).
    """
    sol = contact_solution(shape, x, u, params, mu, alpha)
    return sol.xdot, sol.mode
