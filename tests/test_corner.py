"""Two contacts at a concave corner (dexpush.model.corner): an independent float64 reference and the
physical properties (no pulling, rigid jammed push, scene invariance, reduction to one contact)."""

from __future__ import annotations

import functools

import jax
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from dexpush import Shape, contact_solution
from dexpush.common.se2 import rotate
from dexpush.model.cgvmm import CORNER, FREE, SLIDE_CCW, SLIDE_CW, STICK, Contour, integrate
from dexpush.model.convex_pieces import convex_pieces
from dexpush.model.corner import CORNER_REACH, CORNER_TOL
from dexpush.model.radial_table import concave_corners
from scenes import scenes_with_pusher_at


# ----------------------------------------------------------------- the reference, written plainly
def reference_solutions(lam: np.ndarray, c: np.ndarray, n1: np.ndarray, n2: np.ndarray, v: np.ndarray,
                        mu: float) -> list[np.ndarray]:
    """Every body twist V that satisfies quasi-static Coulomb contact at both faces, in float64.

    Unknowns: the two contact forces f_i = a_i·n_i + b_i·t_i (t_i = n_i turned −90°) and the
    pusher's velocity relative to the material point at c, v_rel = v − J*·V, V = M·J*ᵀ(f₁ + f₂).
    Each contact is separated (f_i = 0, n_i·v_rel ≤ 0), or sliding (n_i·v_rel = 0, b_i = ±μa_i,
    a_i ≥ 0, ±t_i·v_rel ≥ 0), or sticking (v_rel·n_i = v_rel·t_i = 0, a_i ≥ 0, |b_i| ≤ μa_i): all 16
    combinations are solved as linear systems and kept when their inequalities hold. A sticking
    contact makes v_rel = 0; then the total force is G⁻¹v and only its membership in the sum of the
    two friction cones matters, decided with every pair of the four cone edges (Carathéodory).
    """
    beta, xf, yf = lam
    A = np.array([[1.0, 0.0, yf], [0.0, 1.0, -xf], [0.0, 0.0, 1.0]])
    M = A @ np.diag([1.0, 1.0, beta**2]) @ A.T
    J = np.array([[1.0, 0.0, -c[1]], [0.0, 1.0, c[0]]])
    G = J @ M @ J.T
    t1, t2 = np.array([n1[1], -n1[0]]), np.array([n2[1], -n2[0]])
    twists = []
    # v_rel = 0: both sticking, or one sticking, or both sliding with zero relative motion
    F = np.linalg.solve(G, v)
    edges = [n1 + mu * t1, n1 - mu * t1, n2 + mu * t2, n2 - mu * t2]
    in_cone = False
    for i in range(4):
        for j in range(i + 1, 4):
            E = np.stack([edges[i], edges[j]], 1)
            if abs(np.linalg.det(E)) > 1e-12:
                w = np.linalg.solve(E, F)
                in_cone |= bool(np.all(w >= -1e-9 * np.linalg.norm(w)))
    if in_cone:
        twists.append(M @ J.T @ F)
    # v_rel ≠ 0 needs at least one separated contact: unknowns z = [a1, b1, a2, b2, vr_x, vr_y]
    normals, tangents = (n1, n2), (t1, t2)
    for m1 in ("sep", "slide+", "slide-"):
        for m2 in ("sep", "slide+", "slide-"):
            rows, rhs = [], []
            # v_rel + G(a1 n1 + b1 t1 + a2 n2 + b2 t2) = v
            for k in range(2):
                rows.append(np.array([G[k] @ n1, G[k] @ t1, G[k] @ n2, G[k] @ t2, float(k == 0), float(k == 1)]))
                rhs.append(v[k])
            for i, m in enumerate((m1, m2)):
                a, b = np.zeros(6), np.zeros(6)
                a[2 * i], b[2 * i + 1] = 1.0, 1.0
                if m == "sep":
                    rows += [a, b]
                    rhs += [0.0, 0.0]
                else:
                    rows.append(np.r_[0, 0, 0, 0, normals[i]])
                    rows.append(b - (mu if m == "slide+" else -mu) * a)
                    rhs += [0.0, 0.0]
            Amat = np.array(rows)
            if abs(np.linalg.det(Amat)) < 1e-14:
                continue
            z = np.linalg.solve(Amat, np.array(rhs))
            vr = z[4:]
            tol = 1e-9 * max(np.linalg.norm(v), 1e-12)
            ok = True
            for i, m in enumerate((m1, m2)):
                if m == "sep":
                    ok &= bool(normals[i] @ vr <= tol)
                else:
                    ok &= bool(z[2 * i] >= -tol)
                    ok &= bool((tangents[i] @ vr) * (1 if m == "slide+" else -1) >= -tol)
            if ok:
                Ft = z[0] * n1 + z[1] * t1 + z[2] * n2 + z[3] * t2
                twists.append(M @ J.T @ Ft)
    return twists


# ----------------------------------------------------------------- corner scenes
@functools.cache
def corner_shapes() -> tuple[Shape, ...]:
    """The T, an L and crosses of two bars at several angles: concave corners of 60°–150°."""
    rng = np.random.default_rng(7)
    out = [Shape.tee(), Shape.polygon([[0, 0], [0.2, 0], [0.2, 0.05], [0.05, 0.05], [0.05, 0.15], [0, 0.15]],
                                      reference=(0.02, 0.02), name="L")]
    for k in range(4):
        ang = np.radians(30 + 30 * k) + rng.uniform(-0.1, 0.1)
        a, b = rng.uniform(0.06, 0.12, 2), rng.uniform(0.015, 0.03, 2)
        bar = np.array([[-a[0], -b[0]], [a[0], -b[0]], [a[0], b[0]], [-a[0], b[0]]])
        R = np.array([[np.cos(ang), -np.sin(ang)], [np.sin(ang), np.cos(ang)]])
        other = np.array([[-a[1], -b[1]], [a[1], -b[1]], [a[1], b[1]], [-a[1], b[1]]]) @ R.T
        out.append(Shape.union([bar, other], name=f"cross{k}"))
    return tuple(out)


def corner_states(rng: np.random.Generator, n: int) -> list[tuple]:
    """(shape, corner row, state, input, λ, μ) with the pusher centre exactly at a corner."""
    shapes = corner_shapes()
    out = []
    for _ in range(n):
        shape = shapes[rng.integers(len(shapes))]
        row = shape.corners[rng.integers(len(shape.corners))]
        th = rng.uniform(-np.pi, np.pi)
        pb = rng.uniform(-1, 1, 2)
        x = np.r_[pb, th, pb + rotate(row[:2], th)]
        u = rng.normal(size=2) * 0.05
        lam = np.array([rng.uniform(5, 60), rng.uniform(-0.03, 0.03), rng.uniform(-0.03, 0.03)])
        out.append((shape, row, x, u, lam, rng.uniform(0.1, 1.0)))
    return out


def test_corners_found_from_the_faces() -> None:
    tee = Shape.tee()
    c = tee.corners[np.argsort(tee.corners[:, 0])]
    np.testing.assert_allclose(c[:, :2], [[-0.035, -0.035], [0.035, -0.035]], atol=1e-12)
    np.testing.assert_allclose(c[0, 2:], [0, 1, 1, 0], atol=1e-12)      # bar bottom, then the stem's left side
    np.testing.assert_allclose(c[1, 2:], [-1, 0, 0, 1], atol=1e-12)     # the stem's right side, then bar bottom
    assert len(Shape.rectangle().corners) == 0 and len(Shape.ellipse().corners) == 0
    assert len(corner_shapes()[1].corners) == 1                          # the L
    assert all(len(s.corners) == 4 for s in corner_shapes()[2:])         # crosses
    # a polygon approximating a smooth concave curve has kinks below the threshold: no corners
    xs = np.linspace(0.1, -0.1, 60)
    dish = np.concatenate([[[-0.1, -0.03], [0.1, -0.03]], np.stack([xs, 0.02 + 0.01 * (xs / 0.1) ** 2], -1)])
    shape = Shape.polygon(dish)
    assert len(concave_corners(shape.polygons, 0.01, shape.radius_table, shape.dradius_table)) == 0


def test_matches_float64_reference_on_1000_corner_states() -> None:
    rng = np.random.default_rng(2024)
    states = corner_states(rng, 1200)
    modes, multiple = [], 0
    with jax.enable_x64(True):
        for shape in corner_shapes():
            idx = [i for i, s in enumerate(states) if s[0] is shape]
            if not idx:
                continue
            x = np.array([states[i][2] for i in idx])
            u = np.array([states[i][3] for i in idx])
            lam = np.array([states[i][4] for i in idx])
            for mu in np.unique([states[i][5] for i in idx]):
                sel = [k for k, i in enumerate(idx) if states[i][5] == mu]
                sol = contact_solution(shape, x[sel], u[sel], lam[sel], mu=float(mu))
                assert sol.twist.dtype == np.float64
                for k, V, m in zip(sel, np.asarray(sol.twist), np.asarray(sol.mode)):
                    _, row, xs, us, ls, _ = states[idx[k]]
                    v = rotate(us, -xs[2])
                    refs = reference_solutions(ls, row[:2], row[2:4], row[4:6], v, float(mu))
                    assert refs, f"reference found no solution for state {idx[k]}"
                    scale = max(max(np.linalg.norm(r) for r in refs), np.linalg.norm(v))
                    unique = all(np.linalg.norm(r - refs[0]) < 1e-9 * scale for r in refs)
                    # the two friction cones together span more than a half-plane: γ + atan μ > 90°
                    wide = np.degrees(np.arccos(np.clip(row[2:4] @ row[4:6], -1, 1))) / 2 \
                        + np.degrees(np.arctan(mu)) > 90
                    if not unique:
                        assert wide, f"state {idx[k]}: several motions with cones spanning < 180°: {refs}"
                        multiple += 1
                    # several motions only where the cones can wedge; the model picks free, then jammed
                    if any(np.linalg.norm(r) < 1e-9 * scale for r in refs) and any(
                            np.linalg.norm(r) > 1e-9 * scale for r in refs):
                        expected = [np.zeros(3)]
                    else:
                        expected = refs if not unique else refs[:1]
                    err = min(np.linalg.norm(V - r) for r in expected) / scale
                    assert err < 1e-8, f"state {idx[k]}: twist {V} vs reference {refs} (mode {int(m)})"
                    modes.append(int(m))
    assert len(modes) >= 1000
    assert multiple < 0.1 * len(modes)
    counts = {m: modes.count(m) for m in (CORNER, SLIDE_CCW, SLIDE_CW, FREE)}
    assert all(c > 50 for c in counts.values()), counts  # every two-contact mode exercised
    assert STICK not in modes                             # at a corner sticking is the jammed mode


def _corner_batch(seed: int, n: int = 128):
    """``n`` random states with the pusher in one of the T's corners (a fixed size: one compile)."""
    rng = np.random.default_rng(seed)
    tee = corner_shapes()[0]
    rows = tee.corners[rng.integers(len(tee.corners), size=n)]
    x, u, lam = scenes_with_pusher_at(rng, rows[:, :2], beta=(5, 60), offset=0.03)
    return tee, x, u, lam, rows


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**31 - 1))
def test_jammed_push_is_rigid_and_never_pulls(seed: int) -> None:
    tee, x, u, lam, rows = _corner_batch(seed)
    sol = contact_solution(tee, x, u, lam, mu=0.3)
    mode, V = np.asarray(sol.mode), np.asarray(sol.twist, np.float64)
    vb = rotate(u, -x[:, 2])
    c = rows[:, :2]
    point = V[:, :2] + V[:, 2:3] * np.stack([-c[:, 1], c[:, 0]], -1)
    jam = mode == CORNER
    np.testing.assert_allclose(point[jam], vb[jam], atol=2e-5 * np.max(np.abs(u)))
    fn, ft = np.asarray(sol.force, np.float64).T
    assert np.all(fn >= -1e-6)
    # no pulling at either contact: the total force is in the sum of the two friction cones,
    # i.e. within γ + atan μ of the bisector
    n1, n2 = rows[:, 2:4], rows[:, 4:6]
    b = (n1 + n2) / np.linalg.norm(n1 + n2, axis=-1, keepdims=True)
    half = np.arccos(np.clip(np.sum(b * n1, -1), -1, 1)) + np.arctan(0.3)
    assert np.all(np.arctan2(np.abs(ft[jam]), fn[jam]) <= half[jam] + 1e-4)
    slide = (mode == SLIDE_CCW) | (mode == SLIDE_CW)
    assert np.all(np.abs(ft[slide]) <= 0.3 * fn[slide] * (1 + 1e-5) + 1e-9)
    free = mode == FREE
    assert np.all(V[free] == 0)


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), angle=st.floats(-np.pi, np.pi), dx=st.floats(-5, 5), dy=st.floats(-5, 5))
def test_invariant_to_rotating_and_translating_the_scene(seed: int, angle: float, dx: float, dy: float) -> None:
    tee, x, u, lam, _ = _corner_batch(seed)
    with jax.enable_x64(True):
        a = contact_solution(tee, x, u, lam)
        c, s = np.cos(angle), np.sin(angle)
        Rm = np.array([[c, -s], [s, c]])
        x2 = np.concatenate([x[:, :2] @ Rm.T + [dx, dy], (x[:, 2:3] + angle), x[:, 3:5] @ Rm.T + [dx, dy]], -1)
        b = contact_solution(tee, x2, u @ Rm.T, lam)
        np.testing.assert_array_equal(np.asarray(a.mode), np.asarray(b.mode))
        xd_a, xd_b = np.asarray(a.xdot), np.asarray(b.xdot)
        np.testing.assert_allclose(xd_a[:, :2] @ Rm.T, xd_b[:, :2], atol=1e-9)
        np.testing.assert_allclose(xd_a[:, 2], xd_b[:, 2], atol=1e-9)


def test_reduces_to_single_contact_where_one_face_is_left() -> None:
    """Where the T's corner solution keeps only the bar's bottom face (or sticks), the bar alone,
    pushed at the same point, moves the same: the stem only matters when it is pushed."""
    with jax.enable_x64(True):
        tee = Shape.tee()
        bar = Shape.rectangle(0.20, 0.05)
        rng = np.random.default_rng(3)
        row = tee.corners[np.argmax(tee.corners[:, 0])]             # right corner: stem side n1, bar bottom n2
        x, u, lam = scenes_with_pusher_at(rng, np.tile(row[:2], (400, 1)), beta=(5, 60), offset=0.03)
        t_sol, b_sol = contact_solution(tee, x, u, lam), contact_solution(bar, x, u, lam)
        tm, bm = np.asarray(t_sol.mode), np.asarray(b_sol.mode)
        on_bar = (tm == SLIDE_CCW) & (bm == SLIDE_CCW)            # sliding right along the bar, away from the stem
        sticks = bm == STICK                                       # the bar alone sticks: the T jams the same way
        assert on_bar.sum() > 30 and sticks.sum() > 30
        assert np.all(tm[sticks] == CORNER)
        for m in (on_bar, sticks):
            np.testing.assert_allclose(np.asarray(t_sol.twist)[m], np.asarray(b_sol.twist)[m], rtol=1e-6, atol=1e-12)


def test_step_keeps_a_jammed_pusher_in_the_corner() -> None:
    """A push into the corner carries the T along with the pusher exactly in the corner, where the
    single-contact model (its table bulges at the kink) let the pusher slide off."""
    tee = Shape.tee()
    contour = Contour.of(tee)
    row = tee.corners[np.argmax(tee.corners[:, 0])]
    x = np.array([0.0, 0.0, 0.0, row[0], row[1]], np.float32)
    u = np.array([-0.05, 0.05], np.float32)                                 # into both faces
    lam = np.array([25.0, 0.0, -0.04], np.float32)
    x = np.asarray(jax.jit(integrate, static_argnames="substeps")(contour, x, u, 1.0, lam, 0.3, substeps=250))
    rel = rotate(x[3:5] - x[:2], -x[2])
    assert np.linalg.norm(rel - row[:2]) < 1e-5
    assert abs(x[2]) > 0.1                                                   # and it turned
    assert int(contact_solution(tee, x, u, lam).mode) == CORNER


def test_corner_only_where_both_faces_touch() -> None:
    """Along the bar's bottom face, a push up jams at the corner, and is a single contact once the
    pusher is clear of the stem's face (by more than CORNER_TOL)."""
    tee = Shape.tee()
    row = tee.corners[np.argmax(tee.corners[:, 0])]
    n2 = row[4:6]
    t2 = np.array([n2[1], -n2[0]])
    for d, corner in ((0.5 * CORNER_TOL, True), (3 * CORNER_TOL, False), (CORNER_REACH, False)):
        p = row[:2] + d * t2                                                  # along the bar, away from the stem
        mode = int(contact_solution(tee, [0, 0, 0, *p], [0.0, 0.05]).mode)
        assert (mode == CORNER) == corner and mode != FREE, (d, mode)
    # inside both faces but beyond CORNER_REACH (deep penetration) is not a corner contact
    p = row[:2] + 2 * CORNER_REACH * (row[2:4] + row[4:6])
    assert int(contact_solution(tee, [0, 0, 0, *p], [0.0, 0.05]).mode) != CORNER


@pytest.mark.parametrize("corners,pieces", [
    ([[0, 0], [0.2, 0], [0.2, 0.05], [0.05, 0.05], [0.05, 0.15], [0, 0.15]], 2),                      # L
    ([[0, 0], [0.2, 0], [0.2, 0.1], [0.15, 0.1], [0.15, 0.04], [0.05, 0.04], [0.05, 0.1], [0, 0.1]], 3),  # U
])
def test_convex_pieces_tile_the_polygon(corners: list, pieces: int) -> None:
    from dexpush.model.polygons import as_polygon, inside_polygon, is_convex

    poly = as_polygon(corners)
    parts = convex_pieces(poly)
    assert len(parts) == pieces and all(is_convex(p) for p in parts)
    area = lambda v: 0.5 * np.sum(v[:, 0] * np.roll(v[:, 1], -1) - np.roll(v[:, 0], -1) * v[:, 1])  # noqa: E731
    assert sum(area(p) for p in parts) == pytest.approx(area(poly), rel=1e-12)
    pts = np.random.default_rng(0).uniform(poly.min(0), poly.max(0), (4000, 2))
    inside = inside_polygon(pts, poly)
    hits = sum(inside_polygon(pts, p).astype(int) for p in parts)
    interior = inside & ~np.any([np.abs(pts[:, 0] - v[0]) + np.abs(pts[:, 1] - v[1]) < 1e-9 for v in poly], 0)
    assert np.all(hits[~inside] == 0) and np.all(hits[interior] >= 1)
