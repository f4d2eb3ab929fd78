"""C-GVMM: the physical properties of docs/conventions.md#motion-model and agreement with an independent reference."""

from __future__ import annotations

import functools
import math

import jax
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import reference as ref
from dexpush import LAMBDA_TRUE, Shape, cgvmm, contact_solution, force_motion
from dexpush.model.cgvmm import FREE, SLIDE_CCW, SLIDE_CW, STICK, Contour, step
from scenes import scenes_with_pusher_at


@functools.cache
def shapes() -> dict[str, Shape]:
    return {"rect": Shape.rectangle(), "tee": Shape.tee(), "ellipse": Shape.ellipse()}


def contact_states(shape: Shape, rng: np.random.Generator, n: int, depth: float = 0.0):
    """Random scenes with the pusher on (or ``depth`` inside) the contour, random pose and input.

    Single-contact states: points within 3 mm of a concave corner (two contacts, tests/test_corner.py)
    are left out and drawn again, so always ``n`` come back (one compiled batch size per shape)."""
    phi = np.zeros(0)
    while len(phi) < n:
        more = rng.uniform(-np.pi, np.pi, n)
        r, _ = shape.contour(more)
        r = np.asarray(r, np.float64)
        if len(shape.corners):
            more = more[np.min(np.linalg.norm(r[:, None, :] - shape.corners[None, :, :2], axis=-1), axis=1) > 3e-3]
        phi = np.concatenate([phi, more])
    phi = phi[:n]
    r = np.asarray(shape.contour(phi)[0], np.float64)
    x, u, lam = scenes_with_pusher_at(rng, r * (1.0 - depth))
    return x, u, lam, phi


def body_velocity(x: np.ndarray, u: np.ndarray) -> np.ndarray:
    th = x[..., 2]
    c, s = np.cos(th), np.sin(th)
    return np.stack([c * u[..., 0] + s * u[..., 1], -s * u[..., 0] + c * u[..., 1]], -1)


def body_twist(x: np.ndarray, xdot: np.ndarray) -> np.ndarray:
    th = x[..., 2]
    c, s = np.cos(th), np.sin(th)
    vx, vy = xdot[..., 0], xdot[..., 1]
    return np.stack([c * vx + s * vy, -s * vx + c * vy, xdot[..., 2]], -1)


# ----------------------------------------------------------------- reference agreement
@pytest.mark.parametrize("name", ["rect", "ellipse"])
def test_matches_independent_float64_reference(name: str) -> None:
    rng = np.random.default_rng(0)
    with jax.enable_x64(True):
        shape = Shape.rectangle() if name == "rect" else Shape.ellipse()
        if name == "rect":
            radius = functools.partial(ref.rect_radius, half_w=0.10, half_h=0.06, rho=0.01)
        else:
            radius = functools.partial(ref.ellipse_radius, a=0.10, b=0.06, rho=0.01)
        x, u, lam, phi = contact_states(shape, rng, 1200, depth=1e-4)
        if name == "rect":  # away from the rounded corners
            keep = np.array([ref.rect_on_face(p, 0.10, 0.06, 0.01) for p in phi])
            x, u, lam = x[keep], u[keep], lam[keep]
        assert len(x) >= 1000
        xdot, mode = cgvmm(shape, x, u, lam, mu=0.3)
        assert xdot.dtype == np.float64
        xdot, mode = np.asarray(xdot), np.asarray(mode)
    expected = [ref.algorithm1(radius, x[i], u[i], lam[i], 0.3) for i in range(len(x))]
    ref_xdot = np.array([e[0] for e in expected])
    ref_mode = np.array([e[1] for e in expected])
    agree = mode == ref_mode
    assert agree.mean() >= 0.99, f"mode agreement {agree.mean():.4f}"
    err = np.linalg.norm(xdot[agree, :3] - ref_xdot[agree, :3], axis=-1)
    scale = np.maximum(np.linalg.norm(ref_xdot[agree, :3], axis=-1), 1e-9)
    moving = np.linalg.norm(ref_xdot[agree, :3], axis=-1) > 1e-9
    assert np.max(err[moving] / scale[moving]) < 1e-3
    assert np.max(err[~moving], initial=0.0) < 1e-9
    assert set(np.unique(ref_mode)) == {STICK, SLIDE_CCW, SLIDE_CW, FREE}  # all modes exercised


# ----------------------------------------------------------------- docs/conventions.md#motion-model properties
@pytest.mark.parametrize("name", ["rect", "tee", "ellipse"])
def test_kinematics_of_every_contact_mode(name: str) -> None:
    """eq. (6): R(θ)ᵀu = J*·V_sb + ∂φr·φ̇ in every contact mode (φ̇ = 0 in stick: the
    material point under the pusher moves with the pusher)."""
    shape = shapes()[name]
    rng = np.random.default_rng(1)
    x, u, lam, _ = contact_states(shape, rng, 3000, depth=1e-4)
    sol = contact_solution(shape, x, u, lam)
    mode = np.asarray(sol.mode)
    V = np.asarray(sol.twist, np.float64)
    r, dr = (np.asarray(a, np.float64) for a in shape.contour(np.asarray(sol.phi)))
    point_vel = V[:, :2] + V[:, 2:3] * np.stack([-r[:, 1], r[:, 0]], -1)
    resid = body_velocity(x, u) - point_vel - dr * np.asarray(sol.phidot)[:, None]
    contact = mode != FREE
    assert np.sum(mode == STICK) > 100 and np.sum((mode == SLIDE_CCW) | (mode == SLIDE_CW)) > 100
    scale = np.linalg.norm(u, axis=-1)[contact]
    assert np.max(np.linalg.norm(resid[contact], axis=-1) / scale) < 2e-3
    assert np.all(np.asarray(sol.phidot)[mode == STICK] == 0)
    assert np.all(np.asarray(sol.phidot)[mode == SLIDE_CCW] >= 0)
    assert np.all(np.asarray(sol.phidot)[mode == SLIDE_CW] <= 0)


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), name=st.sampled_from(["rect", "tee", "ellipse"]))
def test_pusher_never_pulls_and_force_in_cone(seed: int, name: str) -> None:
    shape = shapes()[name]
    x, u, lam, _ = contact_states(shape, np.random.default_rng(seed), 256, depth=1e-4)
    sol = contact_solution(shape, x, u, lam, mu=0.3)
    fn, ft = np.asarray(sol.force).T
    assert np.all(fn >= 0)
    assert np.all(np.abs(ft) <= 0.3 * fn * (1 + 1e-5) + 1e-9)
    free = np.asarray(sol.mode) == FREE
    assert np.all(fn[free] == 0) and np.all(np.asarray(sol.xdot)[free, :3] == 0)


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), name=st.sampled_from(["rect", "tee", "ellipse"]))
def test_mode_partition_exclusive_and_exhaustive(seed: int, name: str) -> None:
    """The stick, CCW and CW cones of Γ⁻¹w tile the half-plane where the pusher moves into
    the object (n̂·v > 0); the rest is free. Exactly one mode holds for each sample.

    Known counterexample, found with HYPOTHESIS_PROFILE=explore (and failing on 0.1.0 too): seed
    170 on the tee, sample 88 (φ = −1.43 rad, the stem's bottom corner, β = 48): a nearly
    tangential push (n̂·v/|v| = −0.006 with n̂ from the table) is classified stick, in float32
    and float64 alike, and falls in the stick and the CW cone at once. Not yet explained."""
    shape = shapes()[name]
    x, u, lam, _ = contact_states(shape, np.random.default_rng(seed), 256, depth=1e-4)
    sol = contact_solution(shape, x, u, lam, mu=0.3)
    mode = np.asarray(sol.mode)
    a = np.asarray(sol.decision, np.float64)
    g = np.asarray(sol.boundary, np.float64)
    mu = 0.3
    stick = np.all(np.linalg.solve(np.array([[1, 1], [mu, -mu]]), a.T).T > 0, -1)
    ccw = np.array([np.all(np.linalg.solve([[1, gi[0]], [mu, gi[1]]], ai) >= 0) for ai, gi in zip(a, g)])
    cw = np.array([np.all(np.linalg.solve([[1, -gi[0]], [-mu, -gi[1]]], ai) >= 0) for ai, gi in zip(a, g)])
    n_true = stick.astype(int) + ccw + cw
    _, dr = (np.asarray(v, np.float64) for v in shape.contour(np.asarray(sol.phi)))
    n_hat = np.stack([-dr[:, 1], dr[:, 0]], -1) / np.linalg.norm(dr, axis=-1, keepdims=True)
    inward = np.sum(n_hat * body_velocity(x, u), -1) / np.linalg.norm(u, axis=-1)
    clear = np.abs(inward) > 1e-3
    # exclusive away from boundaries, exhaustive over the inward half-plane
    assert np.all(n_true[clear & (inward > 0)] == 1)
    assert np.all(n_true[clear & (inward < 0)] == 0)
    assert np.all((mode == FREE)[clear] == (inward[clear] < 0))
    assert np.all(np.isin(mode, [STICK, SLIDE_CCW, SLIDE_CW, FREE]))


def test_central_push_through_cof_translates() -> None:
    shape = shapes()["rect"]
    for pbf in ([0.0, 0.0], [0.03, 0.0]):
        # pusher on the left face, on the line y = y_bf = 0 through the CoF, pushing along +x
        x = np.array([0.0, 0.0, 0.0, -0.11, 0.0])
        xdot, mode = cgvmm(shape, x, [0.05, 0.0], [25.0, *pbf])
        assert int(mode) == STICK
        assert abs(float(xdot[2])) < 1e-6 and abs(float(xdot[1])) < 1e-6
        assert float(xdot[0]) == pytest.approx(0.05, rel=1e-5)
    # off-centre push (above the CoF) turns the box clockwise
    xdot, _ = cgvmm(shape, np.array([0.0, 0.0, 0.0, -0.11, 0.04]), [0.05, 0.0], [25.0, 0.0, 0.0])
    assert float(xdot[2]) < -0.05


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), psi=st.floats(-math.pi, math.pi),
       shift=st.tuples(st.floats(-2, 2), st.floats(-2, 2)), name=st.sampled_from(["rect", "tee"]))
def test_invariant_to_rotating_and_translating_the_scene(seed, psi, shift, name) -> None:
    """Exact in float64 (float32 round-off alone reaches ~1e-3 in badly conditioned slides)."""
    with jax.enable_x64(True):
        shape = shapes()[name]  # its tables become float64 inside this context
        x, u, lam, _ = contact_states(shape, np.random.default_rng(seed), 64, depth=1e-3)
        c, s = math.cos(psi), math.sin(psi)
        Rm = np.array([[c, -s], [s, c]])
        x2 = np.concatenate([x[:, :2] @ Rm.T + shift, x[:, 2:3] + psi, x[:, 3:] @ Rm.T + shift], -1)
        u2 = u @ Rm.T
        xd1, m1 = (np.asarray(a) for a in cgvmm(shape, x, u, lam))
        xd2, m2 = (np.asarray(a) for a in cgvmm(shape, x2, u2, lam))
    same = m1 == m2
    assert same.mean() >= 0.98  # only decisions sitting exactly on a cone boundary may flip
    tol = 1e-8 * np.abs(xd1).max()
    np.testing.assert_allclose(xd2[same, :2], xd1[same, :2] @ Rm.T, atol=tol)
    np.testing.assert_allclose(xd2[same, 2], xd1[same, 2], atol=tol)


def test_alpha_has_no_effect_on_velocity_model_but_scales_force_motion() -> None:
    shape = shapes()["tee"]
    x, u, lam, phi = contact_states(shape, np.random.default_rng(3), 500, depth=1e-4)
    ref_xdot, ref_mode = cgvmm(shape, x, u, lam)
    for alpha in (0.1, 3.0, 40.0):
        xdot, mode = cgvmm(shape, x, u, lam, alpha=alpha)
        assert np.mean(np.asarray(mode) == np.asarray(ref_mode)) > 0.99
        ok = np.asarray(mode) == np.asarray(ref_mode)
        np.testing.assert_allclose(np.asarray(xdot)[ok], np.asarray(ref_xdot)[ok], rtol=1e-3, atol=1e-5)
    f = np.array([1.0, 0.1])
    V1 = np.asarray(force_motion(shape, phi[:5], f, lam[:5], alpha=1.0))
    V2 = np.asarray(force_motion(shape, phi[:5], f, lam[:5], alpha=2.0))
    np.testing.assert_allclose(V2, 4 * V1, rtol=1e-5)


def test_pulling_away_or_out_of_contact_is_free() -> None:
    shape = shapes()["ellipse"]
    x, _, lam, phi = contact_states(shape, np.random.default_rng(4), 300, depth=1e-3)
    # velocity along the outward normal, in {S}
    _, dr = (np.asarray(a, np.float64) for a in shape.contour(phi))
    n_out = np.stack([dr[:, 1], -dr[:, 0]], -1) / np.linalg.norm(dr, axis=-1, keepdims=True)
    th = x[:, 2]
    c, s = np.cos(th), np.sin(th)
    u_away = 0.05 * np.stack([c * n_out[:, 0] - s * n_out[:, 1], s * n_out[:, 0] + c * n_out[:, 1]], -1)
    xdot, mode = cgvmm(shape, x, u_away, lam)
    assert np.all(np.asarray(mode) == FREE)
    assert np.all(np.asarray(xdot)[:, :3] == 0)
    np.testing.assert_allclose(np.asarray(xdot)[:, 3:], u_away, rtol=1e-6)
    # pusher 1 cm outside the contour, pushing inwards: still free
    x_out = x.copy()
    x_out[:, 3:] = x[:, :2] + (x[:, 3:] - x[:, :2]) * 1.2
    _, mode = cgvmm(shape, x_out, -u_away, lam)
    assert np.all(np.asarray(mode) == FREE)


def test_batched_over_leading_axes_and_broadcasts_params() -> None:
    shape = shapes()["rect"]
    x, u, _, _ = contact_states(shape, np.random.default_rng(5), 24, depth=1e-3)
    xdot, mode = cgvmm(shape, x.reshape(2, 3, 4, 5), u.reshape(2, 3, 4, 2), LAMBDA_TRUE)
    assert xdot.shape == (2, 3, 4, 5) and mode.shape == (2, 3, 4)
    assert xdot.dtype == np.float32
    flat, _ = cgvmm(shape, x, u)
    np.testing.assert_allclose(np.asarray(xdot).reshape(24, 5), np.asarray(flat), rtol=1e-6)


@pytest.mark.parametrize("bad, match", [
    (dict(x=[0, 0, np.nan, 0, 0]), "NaN"),
    (dict(x=[0, 0, 0, 0]), r"\(\.\.\., 5\)"),
    (dict(u=[1.0, 2.0, 3.0]), r"\(\.\.\., 2\)"),
    (dict(params=[0.0, 0, 0]), "β"),
    (dict(params=[25.0, 0]), r"\(\.\.\., 3\)"),
    (dict(x="abc"), "numeric"),
    (dict(mu=-0.1), "mu"),
    (dict(x=np.zeros((3, 5)), u=np.zeros((4, 2))), "broadcast"),
])
def test_bad_input_gives_clear_value_error(bad: dict, match: str) -> None:
    args = dict(x=[0, 0, 0, -0.11, 0], u=[0.05, 0.0], params=LAMBDA_TRUE, mu=0.3) | bad
    with pytest.raises(ValueError, match=match):
        cgvmm(shapes()["rect"], args["x"], args["u"], args["params"], mu=args["mu"])


def test_step_keeps_pusher_out_of_the_object() -> None:
    """A pusher driven into the object by an Euler step ends on the contour (penetration fix)."""
    shape = shapes()["rect"]
    contour = Contour.of(shape)
    x = np.array([[0.0, 0.0, 0.3, -0.13, 0.01]] * 3)
    u = np.array([[0.1, 0.0], [0.1, 0.05], [0.07, -0.07]])
    for _ in range(40):
        x = np.asarray(step(contour, x, u, 0.04, np.array(LAMBDA_TRUE, np.float32)))
        r, _ = shape.contour(np.arctan2(x[:, 4] - x[:, 1], x[:, 3] - x[:, 0]) - x[:, 2])
        depth = np.linalg.norm(np.asarray(r), axis=-1) - np.linalg.norm(x[:, 3:] - x[:, :2], axis=-1)
        assert np.all(depth < 1e-3)
    assert np.all(np.linalg.norm(x[:, :2], axis=-1) > 0.02)  # and the object really was pushed


@functools.cache
def _compiled_step(name: str):
    """``step`` for the shape, compiled once (the property test below draws 20 examples)."""
    contour = Contour.of(shapes()[name])
    return jax.jit(lambda x, u, dt, lam: step(contour, x, u, dt[:, 0], lam))


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), scale=st.floats(1.0, 4.0), name=st.sampled_from(["rect", "tee"]))
def test_quasi_static_holding_a_faster_input_is_holding_the_input_longer(seed, scale, name) -> None:
    """The C-GVMM is positively homogeneous of degree 1 in the input (Algorithm 1 is linear in u within
    a mode, and the modes are cones): step(x, s·u, Δt) = step(x, u, s·Δt) on and near the contour, to
    float32 round-off.
    MPPI's stretched horizon relies on it (``mppi_iteration(rate_independent=True)``)."""
    import jax.numpy as jnp

    shape = shapes()[name]
    rng = np.random.default_rng(seed)
    x, u, lam, _ = (a[:192] for a in contact_states(shape, rng, 256, depth=rng.uniform(-0.01, 0.01)))
    dt = rng.uniform(0.04, 0.28, len(x))[:, None]       # one batch size: one compilation per shape
    go = _compiled_step(name)
    f32 = functools.partial(jnp.asarray, dtype=jnp.float32)
    faster = np.asarray(go(f32(x), f32(u * scale), f32(dt), f32(lam)))
    longer = np.asarray(go(f32(x), f32(u), f32(dt * scale), f32(lam)))
    diff = np.abs(faster - longer)
    # exact in exact arithmetic; in float32 a decision sitting on a cone boundary may flip, and the
    # model being continuous across its boundaries, the two then differ a little (measured: 1e-4)
    assert np.mean(np.all(diff <= 5e-6, axis=1)) >= 0.99
    assert diff.max() <= 1e-3
