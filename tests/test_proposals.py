"""Contact proposals (dexpush.control.proposals) and MPPI's use of them."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from dexpush import Shape
from dexpush.control.mppi import MPPISettings, mppi_iteration
from dexpush.control.proposals import contact_proposals
from dexpush.model.cgvmm import Contour

MP = MPPISettings()
SLOTS = jnp.asarray(MP.step_durations(), jnp.float32)
TEE = Shape.tee()
SHAPES = {"rect": Shape.rectangle(), "tee": TEE, "ellipse": Shape.ellipse()}
PROPOSE = jax.jit(contact_proposals, static_argnums=(3,))


def _pusher_path(x: np.ndarray, seq: np.ndarray, slots: np.ndarray) -> np.ndarray:
    """The pusher's positions in {B} at the slot ends, the object standing still."""
    pw = x[3:5] + np.cumsum(seq * slots[:, None], axis=0)
    c, s = np.cos(x[2]), np.sin(x[2])
    d = pw - x[:2]
    return np.stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]], -1)


def _radial_gap(shape: Shape, pb: np.ndarray) -> np.ndarray:
    """Distance of each point (…, 2) in {B} from the inflated contour, along its ray (> 0 outside)."""
    R, _ = Contour.of(shape).lookup(jnp.asarray(np.arctan2(pb[..., 1], pb[..., 0]), jnp.float32))
    return np.hypot(pb[..., 0], pb[..., 1]) - np.asarray(R)


@settings(max_examples=25, deadline=None)
@given(th=st.floats(-np.pi, np.pi), phi=st.floats(-np.pi, np.pi), out=st.floats(0.0, 0.15),
       name=st.sampled_from(["rect", "tee", "ellipse"]))
def test_walks_stay_clear_of_the_object_and_end_in_a_push_at_the_target(th: float, phi: float, out: float,
                                                                        name: str) -> None:
    shape = SHAPES[name]
    R, _ = Contour.of(shape).lookup(jnp.float32(phi))
    r = float(R) + out
    x = np.array([0.3, -0.2, th, 0.3 + r * np.cos(th + phi), -0.2 + r * np.sin(th + phi)])
    long = np.full(240, 0.04, np.float32)              # 9.6 s: every walk ends well inside it
    P = np.asarray(PROPOSE(jnp.asarray(x, jnp.float32), Contour.of(shape), jnp.asarray(long), 16, MP.v_clip))
    assert P.shape == (16, 240, 2) and np.all(np.isfinite(P))
    assert np.all(np.abs(P) <= MP.v_clip * (1 + 1e-4))  # the walk's speed: no axis is clipped
    targets = 2 * np.pi * np.arange(16) / 16 - np.pi
    for j in range(16):
        pb = _pusher_path(x, P[j], long)
        gap = _radial_gap(shape, pb)
        reached = np.abs(np.arctan2(np.sin(np.arctan2(pb[:, 1], pb[:, 0]) - targets[j]),
                                    np.cos(np.arctan2(pb[:, 1], pb[:, 0]) - targets[j]))) < 0.03
        walking = ~np.maximum.accumulate(reached)
        if out >= 0.005:                               # from clear of the object: the walk touches nothing
            assert np.all(gap[walking] > 0.0)
        assert np.any(reached)                          # the walk arrives at φ_j ...
        assert np.any(gap[~walking] < 0.0)              # ... and pushes into the contour there


def test_proposals_turn_and_move_with_the_scene() -> None:
    x = np.array([0.0, 0.0, 0.0, 0.04, -0.06])
    base = np.asarray(PROPOSE(jnp.asarray(x, jnp.float32), Contour.of(TEE), SLOTS, 8, MP.v_clip))
    a, t = 1.1, np.array([0.4, -0.3])
    c, s = np.cos(a), np.sin(a)
    Rm = np.array([[c, -s], [s, c]])
    moved = np.concatenate([t + Rm @ x[:2], [x[2] + a], t + Rm @ x[3:5]])
    P = np.asarray(PROPOSE(jnp.asarray(moved, jnp.float32), Contour.of(TEE), SLOTS, 8, MP.v_clip))
    np.testing.assert_allclose(P, base @ Rm.T, atol=2e-5)


def test_mppi_follows_a_proposal_that_is_far_better_than_its_samples() -> None:
    """An integrator whose cost is the distance to a point 0.2 m away: a proposal that goes straight
    there dominates the weights; with the proposal set to zeros, nothing changes but that row."""
    settings = MPPISettings(num_samples=64, horizon=10)
    goal = jnp.asarray([0.2, 0.0])
    dyn = lambda x, u, dt, p: x + u * dt                      # noqa: E731
    run = lambda x, ctx: 100.0 * jnp.sum((x - goal) ** 2, -1)  # noqa: E731
    U = jnp.zeros((10, 2))
    straight = jnp.broadcast_to(jnp.asarray([settings.v_clip, 0.0]), (1, 10, 2))
    args = dict(dynamics=dyn, running_cost=run, terminal_cost=run, settings=settings)
    with_proposal = mppi_iteration(jax.random.PRNGKey(0), U, jnp.zeros(2), None, None, proposals=straight, **args)
    without = mppi_iteration(jax.random.PRNGKey(0), U, jnp.zeros(2), None, None, **args)
    assert float(with_proposal.cost_min) < float(without.cost_min)
    np.testing.assert_allclose(np.asarray(with_proposal.sequence)[:, 0], settings.v_clip, rtol=0.05)
    with pytest.raises(ValueError, match="do not fit"):
        mppi_iteration(jax.random.PRNGKey(0), U, jnp.zeros(2), None, None,
                       proposals=jnp.zeros((40, 10, 2)), **args)
