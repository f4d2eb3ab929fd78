"""The C-GVMM with two contacts: the pusher centre at a concave corner (paper eq. 5–8, N_c = 2).

The paper derives the motion model for N_c contacts and uses one. A point pusher can touch two
faces of the (pusher-inflated) contour only at a concave corner (the T's two inner corners
under the bar, an L's inner corner), where the single-contact model's radial table smears the
kink into a bulge and the model would let the pusher slide through a wall. Here both contacts
are solved exactly, per sample and branch-free, from the corner's own geometry
(:attr:`dexpush.Shape.corners`); :mod:`dexpush.model.cgvmm` uses the result wherever the pusher is at a
corner, so the plants, MPPI, the UKF and the validation all see the same model.

Notation as in :mod:`dexpush.model.cgvmm`: M = A_bf·L̃·A_bfᵀ, v = R(θ)ᵀu the pusher's velocity in {B}.
"""

from __future__ import annotations

from typing import NamedTuple

import jax.numpy as jnp
import numpy as np

from dexpush.common import fastmath

__all__ = ["CORNER_REACH", "CORNER_TOL", "CornerSolution", "corner_fix", "corner_solve", "corner_table",
           "nearest_corner"]

#: the pusher centre touches both faces of a concave corner when it is within CORNER_REACH (m) of
#: the corner and no more than CORNER_TOL outside either face's line. CORNER_TOL covers the Euler
#: step's drift and the radial table's bulge at a kink (≤ 0.4 mm within one table cell of it).
CORNER_REACH = 2e-3
CORNER_TOL = 2e-4


class CornerSolution(NamedTuple):
    """The two-contact solve for each sample (all arrays broadcast like the pusher position).

    Attributes:
        at: the pusher is at the corner (touching both faces); the rest matters only there.
        jam: both contacts hold, the object moves rigidly with the pusher.
        slide: the pusher slides on one face alone (``side`` = +1 CCW, −1 CW), the other separates.
        free: the pusher leaves both faces.
        side: σ of the sliding face.
        F: (F_x, F_y) total contact force on the object in {B} (its wrench is [F, c × F]).
        fn, ft: the force reported as [f_n, f_t]: jammed, in the bisector's frame; sliding, on that face.
        phidot: φ̇ of the sliding contact (0 otherwise).
        c: (c_x, c_y) the corner in {B}.
        snap_n: inward normal of the sliding face (used by :func:`corner_fix`).
    """

    at: jnp.ndarray
    jam: jnp.ndarray
    slide: jnp.ndarray
    free: jnp.ndarray
    side: jnp.ndarray
    F: tuple[jnp.ndarray, jnp.ndarray]
    fn: jnp.ndarray
    ft: jnp.ndarray
    phidot: jnp.ndarray
    c: tuple[jnp.ndarray, jnp.ndarray]
    snap_n: tuple[jnp.ndarray, jnp.ndarray]


def corner_table(corners: np.ndarray) -> np.ndarray:
    """Per concave corner (rows of :attr:`dexpush.Shape.corners`), what the two-contact solve
    needs, as (n_c, 12) float64 rows:

        [c_x, c_y, n1_x, n1_y, n2_x, n2_y, b_x, b_y, cos γ, sin γ, σ1, σ2]

    c the corner and n1, n2 the two faces' inward unit normals in {B}; b = (n1 + n2)/|n1 + n2|
    the bisector and γ the angle between b and each normal; σ_i = ±1 the direction along
    face i's CCW tangent t_i = (n_i,y, −n_i,x) that leads away from the other face (the only
    way the pusher can slide on face i alone from the corner).
    """
    c = np.asarray(corners, dtype=np.float64).reshape(-1, 6)
    n1, n2 = c[:, 2:4], c[:, 4:6]
    b = (n1 + n2) / np.linalg.norm(n1 + n2, axis=-1, keepdims=True)
    cos_g = np.sum(b * n1, -1)
    sin_g = np.abs(b[:, 0] * n1[:, 1] - b[:, 1] * n1[:, 0])
    t1, t2 = np.stack([n1[:, 1], -n1[:, 0]], -1), np.stack([n2[:, 1], -n2[:, 0]], -1)
    s1, s2 = -np.sign(np.sum(n2 * t1, -1)), -np.sign(np.sum(n1 * t2, -1))
    return np.concatenate([c, b, cos_g[:, None], sin_g[:, None], s1[:, None], s2[:, None]], -1)


def nearest_corner(corners: jnp.ndarray, px: jnp.ndarray, py: jnp.ndarray,
                   one: jnp.ndarray | float = 1.0) -> tuple[jnp.ndarray, jnp.ndarray]:
    """The index (as a float) of the row of ``corners`` (see :func:`corner_table`) nearest to p,
    and the squared distance, both broadcast like ``px``. A static loop: shapes have few corners.

    With a traced ``one`` (:func:`dexpush.common.fastmath.materialize`) both are stored once,
    so that the loops that read the corner's constants pick them with a few selects each
    instead of repeating the search.
    """
    cols = corners.astype(px.dtype)
    d2 = (px - cols[0, 0]) ** 2 + (py - cols[0, 1]) ** 2
    index = jnp.zeros_like(px)
    for i in range(1, cols.shape[0]):
        di = (px - cols[i, 0]) ** 2 + (py - cols[i, 1]) ** 2
        closer = di < d2
        index = jnp.where(closer, i, index)
        d2 = jnp.where(closer, di, d2)
    return fastmath.materialize(one, index, d2)


def _corner_constants(row: jnp.ndarray, M: tuple[jnp.ndarray, ...],
                      mu: float | jnp.ndarray) -> tuple[jnp.ndarray, ...]:
    """What the two-contact solve needs of one corner (a row of :func:`corner_table`) that does
    not depend on the pusher's velocity, broadcast like M and μ (scalars in a rollout, where the
    parameters are shared by every sample):

        c, n1, n2, b, σ1, σ2, G⁻¹ (xx, xy, yy), cos(γ + atan μ), and per face i:
        d_i = σ_i·t_i, the cone edge g_i = n_i + μd_i, a_i = G·g_i, 1/(a_i × d_i)
    """
    cx, cy, n1x, n1y, n2x, n2y, bx, by, cg, sg, s1, s2 = (row[j] for j in range(12))
    m00, m01, m02, m11, m12, m22 = M
    # G = J*·M·J*ᵀ at c, J* = [[1, 0, −c_y], [0, 1, c_x]]
    gxx = m00 - 2 * m02 * cy + m22 * cy * cy
    gxy = m01 + m02 * cx - m12 * cy - m22 * cx * cy
    gyy = m11 + 2 * m12 * cx + m22 * cx * cx
    det = gxx * gyy - gxy * gxy
    cos_half = (cg - mu * sg) / jnp.sqrt(1 + mu * mu)                           # cos(γ + atan μ)
    faces = []
    for nx, ny, sig in ((n1x, n1y, s1), (n2x, n2y, s2)):
        dx, dy = sig * ny, -sig * nx                       # d = σ·t, t = (n_y, −n_x)
        gx, gy = nx + mu * dx, ny + mu * dy                # the cone edge F/f
        ax, ay = gxx * gx + gxy * gy, gxy * gx + gyy * gy  # G·(n + μd)
        faces += [dx, dy, gx, gy, ax, ay, 1 / (ax * dy - ay * dx)]
    return (cx, cy, n1x, n1y, n2x, n2y, bx, by, s1, s2, gyy / det, -gxy / det, gxx / det, cos_half, *faces)


def _pick(index: jnp.ndarray, rows: list[tuple[jnp.ndarray, ...]]) -> list[jnp.ndarray]:
    """Each value of ``rows[index]``, per sample (``index`` a float from :func:`nearest_corner`)."""
    picked = [jnp.broadcast_to(v, jnp.broadcast_shapes(jnp.shape(v), index.shape)) for v in rows[0]]
    for i in range(1, len(rows)):
        here = index == i
        picked = [jnp.where(here, v, p) for v, p in zip(rows[i], picked)]
    return picked


def corner_solve(corners: jnp.ndarray, px: jnp.ndarray, py: jnp.ndarray, vbx: jnp.ndarray, vby: jnp.ndarray,
                 M: tuple[jnp.ndarray, ...], mu: float | jnp.ndarray,
                 one: jnp.ndarray | float = 1.0) -> CornerSolution:
    """Eq. 5–8 with two contacts: the pusher centre p at a concave corner c touches two faces.

    Both contacts act at the one point c (in {B}) with inward normals n1, n2, so the total
    contact force F = f₁ + f₂ (in {B}) gives the body twist V = M·J*ᵀF (eq. 5) and moves the
    material point at c with G·F, G = J*·M·J*ᵀ (2×2, symmetric positive definite). With
    v = R(θ)ᵀu the pusher's velocity and v_rel = v − G·F its velocity relative to that point,
    Coulomb's law at each contact (f_i in its cone K_i = {a(n_i + μt_i) + b(n_i − μt_i)},
    no penetration n_i·v_rel ≤ 0, complementarity) leaves four modes, tested in this order:

    * free: n1·v ≤ 0 and n2·v ≤ 0 (the pusher leaves both faces). First, because in a notch
      narrower than 180° − 2·atan μ the two cones together span more than a half-plane and a
      wedged (jammed) motion is also consistent; a pusher moving out of the notch unloads it.
    * jammed ("corner", both contacts, v_rel = 0): F = G⁻¹v, valid iff F lies in K1 + K2,
      the cone of half-angle γ + atan μ about the bisector b: F·b ≥ |F|·cos(γ + atan μ).
      The object moves rigidly with the pusher (Lynch & Mason's stable push). Two active
      contacts with independent normals force v_rel = 0, so this is the only two-contact mode.
    * sliding on face i alone, along d_i = σ_i·t_i (away from the other face, so that
      n_j·v_rel ≤ 0): F = f(n_i + μd_i) and v_rel = s·d_i; G(n_i + μd_i)·f + d_i·s = v gives
      (f, s), valid iff f ≥ 0 and s ≥ 0. The other direction would push into face j.

    Branch-free (every mode is evaluated and selected with ``where``), so it vmaps. Where
    rounding leaves no mode valid (on a mode boundary) the jammed solution is used. The
    float64 reference in tests/test_corner.py, which solves all 16 combinations of the two
    contacts' modes, finds exactly this motion on 1200 random corner states, and no other
    except the wedged one above.

    Everything that does not depend on p or v (G⁻¹, the cone edges, the sliding systems'
    determinants) is computed per corner (:func:`_corner_constants`) and picked per sample.
    ``one``, a traced 1 (:func:`dexpush.common.fastmath.materialize`), stores the nearest
    corner, the mode and the force once for the several loops of a step that read them.
    """
    if isinstance(one, int | float):      # no traced 1 from the caller: one from p keeps the picks cheap
        one = fastmath.traced_one(px)
    index, d2 = nearest_corner(corners, px, py, one)
    table = corners.astype(px.dtype)
    rows = [_corner_constants(table[i], M, mu) for i in range(table.shape[0])]
    (cx, cy, n1x, n1y, n2x, n2y, bx, by, s1, s2, ixx, ixy, iyy, cos_half,
     d1x, d1y, g1x, g1y, a1x, a1y, r1, d2x, d2y, g2x, g2y, a2x, a2y, r2) = _pick(index, rows)
    qx, qy = px - cx, py - cy
    at = ((d2 <= CORNER_REACH**2) & (n1x * qx + n1y * qy >= -CORNER_TOL)
          & (n2x * qx + n2y * qy >= -CORNER_TOL))
    jx, jy = ixx * vbx + ixy * vby, ixy * vbx + iyy * vby                      # F = G⁻¹v
    fb = jx * bx + jy * by
    jam = fb * jnp.abs(fb) >= (jx * jx + jy * jy) * cos_half * jnp.abs(cos_half)

    # sliding on face i: [G·g_i, d_i]·(f, s) = v
    f1, sp1 = (vbx * d1y - vby * d1x) * r1, (a1x * vby - a1y * vbx) * r1
    f2, sp2 = (vbx * d2y - vby * d2x) * r2, (a2x * vby - a2y * vbx) * r2
    ok1, ok2 = (f1 >= 0) & (sp1 >= 0), (f2 >= 0) & (sp2 >= 0)
    free = (n1x * vbx + n1y * vby <= 0) & (n2x * vbx + n2y * vby <= 0)
    jam = ~free & jam
    sl1 = ~free & ~jam & ok1
    sl2 = ~free & ~jam & ~sl1 & ok2
    jam = ~(sl1 | sl2 | free)
    # the mode as one number, stored once: −1 not at the corner, 0 free, 1 jammed, 2 sliding
    # on face 1, 3 sliding on face 2
    code = jnp.where(at, jnp.where(jam, 1.0, jnp.where(sl1, 2.0, jnp.where(sl2, 3.0, 0.0))), -1.0)
    (code,) = fastmath.materialize(one, code.astype(px.dtype))
    at, jam, sl1, sl2, free = code >= 0, code == 1, code == 2, code == 3, code == 0
    zero = jnp.zeros_like(jx)
    Fx = jnp.where(jam, jx, jnp.where(sl1, f1 * g1x, jnp.where(sl2, f2 * g2x, zero)))
    Fy = jnp.where(jam, jy, jnp.where(sl1, f1 * g1y, jnp.where(sl2, f2 * g2y, zero)))
    Fx, Fy = fastmath.materialize(one, Fx, Fy)
    side = jnp.where(sl1, s1, s2)
    # reported force: jammed, F in the bisector frame [F·b, F·t_b]; sliding, [f, μσf] on that face
    fn = jnp.where(jam, Fx * bx + Fy * by, jnp.where(sl1, f1, jnp.where(sl2, f2, zero)))
    ft = jnp.where(jam, Fx * by - Fy * bx, jnp.where(sl1 | sl2, mu * side * fn, zero))
    # φ̇ = σ·s/|∂φr|, |∂φr| = |c|²/|c·n| on a flat face through c
    cc = cx * cx + cy * cy
    phidot = jnp.where(sl1, s1 * sp1 * jnp.abs(cx * n1x + cy * n1y) / cc,
                       jnp.where(sl2, s2 * sp2 * jnp.abs(cx * n2x + cy * n2y) / cc, zero))
    snap_n = (jnp.where(sl1, n1x, n2x), jnp.where(sl1, n1y, n2y))
    return CornerSolution(at=at, jam=jam, slide=sl1 | sl2, free=free, side=side, F=(Fx, Fy), fn=fn, ft=ft,
                          phidot=phidot, c=(cx, cy), snap_n=snap_n)


def corner_fix(k: CornerSolution, moved: tuple[jnp.ndarray, ...], fixed: tuple[jnp.ndarray, ...],
               cth: jnp.ndarray, sth: jnp.ndarray, one: jnp.ndarray | float = 1.0) -> tuple[jnp.ndarray, ...]:
    """After a step that began at a concave corner, place the object from the faces, not the table.

    Jammed: the object is translated so that its corner is back under the pusher (the rigid
    motion's Euler error). Sliding on one face: translated along that face's normal so that
    the pusher is on the face's line. Free: left where the step put it (the table's
    interpolation bulges by up to 0.4 mm at a kink, so its radial correction would be wrong).
    ``one`` (a traced 1) stores the depth once for both coordinates.
    """
    xb, yb, _, xc, yc = moved
    cx, cy = k.c
    ox, oy = xc - (cth * cx - sth * cy), yc - (sth * cx + cth * cy)       # the object's origin under a jam
    nx, ny = k.snap_n
    wnx, wny = cth * nx - sth * ny, sth * nx + cth * ny                   # face normal in {S}
    (depth,) = fastmath.materialize(one, wnx * (ox - xb) + wny * (oy - yb))   # > 0: pusher inside the face
    jam, slide, at = k.jam, k.slide, k.at
    x_new = jnp.where(jam, ox, jnp.where(slide, xb + depth * wnx, xb))
    y_new = jnp.where(jam, oy, jnp.where(slide, yb + depth * wny, yb))
    return (jnp.where(at, x_new, fixed[0]), jnp.where(at, y_new, fixed[1]), *fixed[2:])
