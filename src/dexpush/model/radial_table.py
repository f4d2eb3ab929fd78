"""The pusher-inflated contour's radial table R(φ), R'(φ) for polygon footprints: rays cast from the
reference point against the footprint grown by the pusher radius (bracketing, then bisection), and
the contour's concave corners, where the pusher touches two faces."""

from __future__ import annotations

import numpy as np

from dexpush.common.checks import check_whole
from dexpush.model.polygons import cross2, inside_polygon, union_distance

__all__ = ["CORNER_MIN_ANGLE", "check_table_size", "concave_corners", "dradius_from_normal", "radial_exact",
           "radial_table_polygons", "table_azimuths"]


def check_table_size(table_size: object) -> int:
    return check_whole("table_size", table_size, 64)


def table_azimuths(n: int) -> np.ndarray:
    return -np.pi + 2 * np.pi * np.arange(n) / n


def dradius_from_normal(phi: np.ndarray, R: np.ndarray, n_out: np.ndarray) -> np.ndarray:
    """R' from the outward normal: ∂φ r ⟂ n gives R'(n·e_r) + R(n·e_φ) = 0."""
    er = np.stack([np.cos(phi), np.sin(phi)], -1)
    ephi = np.stack([-np.sin(phi), np.cos(phi)], -1)
    return -R * np.sum(n_out * ephi, -1) / np.sum(n_out * er, -1)


_RAY_SAMPLES = 400      # the radial grid that brackets R before bisection


_BISECTION_STEPS = 40


def _linear_range(alpha: np.ndarray, beta: np.ndarray, lo: float, hi: float) -> tuple[np.ndarray, np.ndarray]:
    """s-interval where lo <= alpha*s + beta <= hi (alpha may be 0)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        s1, s2 = (lo - beta) / alpha, (hi - beta) / alpha
    a, b = np.minimum(s1, s2), np.maximum(s1, s2)
    flat = alpha == 0
    ok = (beta >= lo) & (beta <= hi)
    a = np.where(flat, np.where(ok, -np.inf, np.inf), a)
    b = np.where(flat, np.where(ok, np.inf, -np.inf), b)
    return a, b


def _ray_intervals(polys: tuple[np.ndarray, ...], rho: float,
                   phi: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Where the rays s·e(φ), s ≥ 0, are inside the pusher-inflated union, exactly.

    The inflated union is the union of every polygon's interior (even-odd crossings of the ray)
    and every edge's capsule (two discs of radius ρ and the slab between them), each of which
    meets a ray in one interval. Returns (capsule starts, capsule ends) (n, E), one column per
    edge in the order of the concatenated polygons, and (interior starts, interior ends) (n, K);
    empty intervals are (inf, −inf)."""
    e = np.stack([np.cos(phi), np.sin(phi)], -1)[:, None, :]          # (n, 1, 2)
    starts, ends, cap_starts, cap_ends = [], [], [], []
    for poly in polys:
        a, b = poly, np.roll(poly, -1, axis=0)                         # (E, 2)
        d = b - a
        L = np.linalg.norm(d, axis=-1)
        u = d / L[:, None]
        nrm = np.stack([-u[:, 1], u[:, 0]], -1)
        # capsule: two discs and the slab
        lo_c, hi_c = np.full(e.shape[:1] + a.shape[:1], np.inf), np.full(e.shape[:1] + a.shape[:1], -np.inf)
        for c in (a, b):
            ec = np.sum(e * c, -1)
            disc = ec**2 - np.sum(c * c, -1) + rho**2
            r = np.sqrt(np.maximum(disc, 0))
            lo_c = np.where(disc >= 0, np.minimum(lo_c, ec - r), lo_c)
            hi_c = np.where(disc >= 0, np.maximum(hi_c, ec + r), hi_c)
        t0, t1 = _linear_range(np.sum(e * u, -1) / L, -np.sum(a * u, -1) / L, 0.0, 1.0)
        h0, h1 = _linear_range(np.sum(e * nrm, -1), -np.sum(a * nrm, -1), -rho, rho)
        s0, s1 = np.maximum(t0, h0), np.minimum(t1, h1)
        slab = s0 <= s1
        lo_c = np.where(slab, np.minimum(lo_c, s0), lo_c)
        hi_c = np.where(slab, np.maximum(hi_c, s1), hi_c)
        ahead = hi_c >= 0
        cap_starts.append(np.where(ahead, np.maximum(lo_c, 0.0), np.inf))
        cap_ends.append(np.where(ahead, hi_c, -np.inf))
        # interior: the ray's crossings with the edges cut it into pieces; a piece is inside when its
        # midpoint is (the point-in-polygon test, so rays through corners need no special case)
        ce_d = cross2(e, d)                                              # (n, E)
        with np.errstate(divide="ignore", invalid="ignore"):
            s = cross2(a, d) / ce_d
            tau = -cross2(e, a) / ce_d
        hit = (ce_d != 0) & (tau >= -1e-12) & (tau <= 1 + 1e-12) & (s > 0)
        width = max(int(hit.sum(-1).max()), 1)
        s = np.sort(np.where(hit, s, np.inf), axis=-1)[:, :width]       # (n, C) crossings, inf-padded
        st = np.concatenate([np.zeros((len(s), 1)), s[:, :-1]], -1)      # pieces [0, s0], [s0, s1], ...
        en = s
        finite = np.isfinite(en)
        mid = np.where(finite, 0.5 * (st + en), 0.0)
        inside = inside_polygon(mid[..., None] * e, poly) & finite
        starts.append(np.where(inside, st, np.inf))
        ends.append(np.where(inside, en, -np.inf))
    return (np.concatenate(cap_starts, -1), np.concatenate(cap_ends, -1), np.concatenate(starts, -1),
            np.concatenate(ends, -1))


def radial_table_polygons(polys: tuple[np.ndarray, ...], rho: float,
                           n: int) -> tuple[np.ndarray, np.ndarray]:
    """R(φ_i) and R'(φ_i) of the inflated union on the table's azimuths, from exact ray intervals.

    Star-shaped about the reference means every ray's intervals cover one segment [0, R]; a
    ray whose covered set has a gap is reported with where it leaves the shape. Cost O(n·E log E)
    for E edges (a 1000-corner polygon builds in well under a second).
    """
    phi = table_azimuths(n)
    R, n_out = radial_exact(polys, rho, phi)
    return R, dradius_from_normal(phi, R, n_out)


def radial_exact(polys: tuple[np.ndarray, ...], rho: float, phi: np.ndarray,
                 check: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """R(φ) and the outward unit normal (n, 2) of the inflated union at any azimuths φ (n,).

    With ``check`` a ray that leaves the shape and enters it again raises ``ValueError``;
    without, R is the ray's outermost crossing."""
    n = len(phi)
    cap_starts, cap_ends, inner_starts, inner_ends = _ray_intervals(polys, rho, phi)
    starts, ends = np.concatenate([cap_starts, inner_starts], -1), np.concatenate([cap_ends, inner_ends], -1)
    order = np.argsort(starts, axis=-1)
    starts, ends = np.take_along_axis(starts, order, -1), np.take_along_axis(ends, order, -1)
    reach = np.maximum.accumulate(ends, axis=-1)
    tol = 1e-9 * max(float(np.max(np.abs(np.concatenate(polys)))), rho)
    gaps = (starts[:, 1:] > reach[:, :-1] + tol) & np.isfinite(starts[:, 1:])
    if check and (np.any(gaps) or np.any(starts[:, 0] > tol)):
        i = int(np.argmax(np.any(gaps, axis=1) | (starts[:, 0] > tol)))
        j = int(np.argmax(gaps[i])) if np.any(gaps[i]) else -1
        leaves = f"leaves the (pusher-inflated) shape at {reach[i, j] * 1000:.1f} mm and enters it again further out" \
            if j >= 0 else "starts outside the shape"
        raise ValueError(
            "shape is not star-shaped about its reference point: the ray at azimuth "
            f"{np.degrees(phi[i]):.1f}° {leaves}. Move the reference into the shape's kernel, or split the "
            "object into star-shaped pieces.")
    # R to the last bit: bisection on the distance test inside the bracket of the ray's sample grid
    # (s_max/_RAY_SAMPLES apart) that holds the exact far end, as the tables were built before
    a = np.concatenate(polys)
    b = np.concatenate([np.roll(p, -1, axis=0) for p in polys])
    e = np.stack([np.cos(phi), np.sin(phi)], -1)
    s_max = np.max(np.linalg.norm(a, axis=-1)) + 2 * rho
    grid = np.linspace(0.0, s_max, _RAY_SAMPLES)
    k = np.clip(np.searchsorted(grid, reach[:, -1], side="right") - 1, 0, _RAY_SAMPLES - 2)
    lo, hi = grid[k], grid[k + 1]
    # only edges whose capsule reaches the bracket can be within ρ of a point in it: the distance test
    # on those alone gives the same answers as on all edges (the same bits: the same arithmetic)
    near_bracket = (cap_ends >= lo[:, None] - 1e-6) & (cap_starts <= hi[:, None] + 1e-6)
    width = max(int(near_bracket.sum(-1).max()), 1)
    cand = np.argsort(~near_bracket, axis=-1, kind="stable")[:, :width]          # (n, C) edge indices
    valid = np.take_along_axis(near_bracket, cand, -1)
    ca, cb = a[cand], b[cand]
    for _ in range(_BISECTION_STEPS):
        mid = 0.5 * (lo + hi)
        q = mid[:, None] * e
        ab, aq = cb - ca, q[:, None, :] - ca
        t = np.clip(np.sum(aq * ab, -1) / np.sum(ab * ab, -1), 0.0, 1.0)
        dist = np.linalg.norm(q[:, None, :] - (ca + t[..., None] * ab), axis=-1)
        inside = np.zeros(n, dtype=bool)
        for poly in polys:
            inside |= inside_polygon(q, poly)
        ins = inside | (np.min(np.where(valid, dist, np.inf), axis=-1) <= rho)
        lo, hi = np.where(ins, mid, lo), np.where(ins, hi, mid)
    R = 0.5 * (lo + hi)
    p = R[:, None] * e
    _, near = union_distance(p, polys, a, b)
    n_out = (p - near) / np.linalg.norm(p - near, axis=-1, keepdims=True)
    return R, n_out


#: smallest kink (angle between the two faces' normals) treated as a two-face corner; smaller
#: kinks (a polygon approximating a smooth concave curve) stay single-contact
CORNER_MIN_ANGLE = float(np.radians(3.0))


_CORNER_BISECTIONS = 48


def _signed_turn(n0: np.ndarray, n1: np.ndarray) -> np.ndarray:
    """Signed angle from unit vectors n0 to n1 (..., 2), positive counter-clockwise."""
    return np.arctan2(cross2(n0, n1), np.sum(n0 * n1, -1))


def concave_corners(polys: tuple[np.ndarray, ...], rho: float, R: np.ndarray, dR: np.ndarray,
                    min_angle: float = CORNER_MIN_ANGLE) -> np.ndarray:
    """The concave corners of the ρ-inflated union, from its exact face geometry.

    Going counter-clockwise round the inflated contour, its outward normal turns
    counter-clockwise on the arcs and not at all along the flat faces; it jumps clockwise
    only at a concave corner, where two faces (offset edges or arcs) meet and a pusher centre
    there touches both (the T's two inner corners under the bar, an L's inner corner). The
    table (R, R') brackets each such jump between two azimuths; the bracket is then halved
    ``_CORNER_BISECTIONS`` times with the exact ray test (:func:`radial_exact`), keeping the
    half where the normal turns clockwise, so corner and normals are exact to round-off,
    not smeared by the table's interpolation.

    Returns (n_c, 6) rows ``[c_x, c_y, n1_x, n1_y, n2_x, n2_y]``: the corner c and the inward
    unit normals of the face on its clockwise side (n1) and on its counter-clockwise side (n2).
    """
    n = len(R)
    phi = table_azimuths(n)
    c, s = np.cos(phi), np.sin(phi)
    t = np.stack([dR * c - R * s, dR * s + R * c], -1)
    n_out = np.stack([t[:, 1], -t[:, 0]], -1) / np.linalg.norm(t, axis=-1, keepdims=True)
    turn = _signed_turn(n_out, np.roll(n_out, -1, axis=0))
    idx = np.flatnonzero(turn < -min_angle / 2)
    if not len(idx):
        return np.zeros((0, 6))
    h = 2 * np.pi / n
    lo, hi = phi[idx], phi[idx] + h
    n_lo, n_hi = n_out[idx], np.roll(n_out, -1, axis=0)[idx]
    for _ in range(_CORNER_BISECTIONS):
        mid = 0.5 * (lo + hi)
        _, n_mid = radial_exact(polys, rho, mid, check=False)    # the table's azimuths were checked
        left = _signed_turn(n_lo, n_mid) < _signed_turn(n_mid, n_hi)
        hi, n_hi = np.where(left, mid, hi), np.where(left[:, None], n_mid, n_hi)
        lo, n_lo = np.where(left, lo, mid), np.where(left[:, None], n_lo, n_mid)
    mid = 0.5 * (lo + hi)
    Rc, _ = radial_exact(polys, rho, mid, check=False)
    corner = Rc[:, None] * np.stack([np.cos(mid), np.sin(mid)], -1)
    keep = _signed_turn(n_lo, n_hi) < -min_angle
    return np.concatenate([corner, -n_lo, -n_hi], -1)[keep]
