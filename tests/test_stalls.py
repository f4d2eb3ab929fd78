"""Stall detection: the planner restarts when the object stops coming closer to the goal."""

from __future__ import annotations

import dataclasses
import functools

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from dexpush import Shape
from dexpush.controller import ControllerSettings, plan_step, policy_init, watch_progress
from dexpush.cost import Scene
from dexpush.model import LAMBDA_TRUE, Contour
from dexpush.mppi import slot_durations

SHAPE = Shape.rectangle()
SCENE = Scene.make(SHAPE, (0.6, 0.0, 0.0))
CONTOUR = Contour.of(SHAPE)
WATCH = ControllerSettings(stall_after_s=4.0)


def _state_at(x_b: float, pusher_gap: float = 0.1) -> jnp.ndarray:
    """The rectangle at x_b, the pusher behind it, ``pusher_gap`` off its 0.1-m half-length (+ radius)."""
    return jnp.asarray([x_b, 0.0, 0.0, x_b - 0.1 - SHAPE.pusher_radius - pusher_gap, 0.0], jnp.float32)


@functools.cache
def _compiled_watch(settings: ControllerSettings):
    return jax.jit(functools.partial(watch_progress, contour=CONTOUR, scene=SCENE, settings=settings))


def _watch(settings: ControllerSettings, positions: list[float]) -> list[bool]:
    state, watch, out = policy_init(LAMBDA_TRUE, settings, 0), _compiled_watch(settings), []
    for xb in positions:
        state, stalled = watch(state, _state_at(xb))
        out.append(bool(stalled))
    return out


def test_a_stall_is_declared_after_the_set_time_without_progress_and_not_before() -> None:
    s = WATCH
    n = round(s.stall_after_s / s.mppi.control_period)
    flags = _watch(s, [0.0] * (2 * n + 1))
    assert np.flatnonzero(flags).tolist() == [n, 2 * n]          # every stall_after_s while nothing moves
    # steady progress of 2 mm a period never stalls, though each step is below stall_progress_m
    assert not any(_watch(s, list(np.arange(3 * n) * 0.002)))
    assert not any(_watch(dataclasses.replace(s, stall_after_s=None), [0.0] * (2 * n + 1)))


def test_the_stall_clock_rests_in_contact_and_near_the_goal() -> None:
    s = WATCH
    n = round(s.stall_after_s / s.mppi.control_period)
    state, watch = policy_init(LAMBDA_TRUE, s, 0), _compiled_watch(s)
    for x in [_state_at(0.0, pusher_gap=0.0)] * (2 * n) + [_state_at(0.59)] * (2 * n):
        state, stalled = watch(state, x)
        assert not bool(stalled)     # touching the object, then 1 cm from the goal: never a stall


@given(st.lists(st.floats(-0.3, 0.5), min_size=1, max_size=300))
def test_stalls_are_at_most_one_per_stall_time(positions: list[float]) -> None:
    s = dataclasses.replace(WATCH, stall_after_s=1.0)
    flags = _watch(s, positions)
    assert sum(flags) <= len(positions) * s.mppi.control_period / s.stall_after_s + 1e-9
    if sum(flags):   # a stall comes only after a full stall time since the last progress
        assert np.flatnonzero(flags)[0] >= round(s.stall_after_s / s.mppi.control_period)


def test_a_stall_restarts_the_planner_from_a_zero_warm_start_with_a_longer_horizon() -> None:
    s = WATCH
    contour, x = Contour.of(SHAPE), _state_at(0.0)
    state = policy_init(LAMBDA_TRUE, s, 3)
    state = state._replace(sequence=jnp.full_like(state.sequence, 0.05), best=jnp.float32(0.6),
                           idle=jnp.float32(s.stall_after_s - s.mppi.control_period / 2))
    stalled, _, res_stalled = plan_step(state, x, contour=contour, scene=SCENE, settings=s)
    fresh = state._replace(sequence=jnp.zeros_like(state.sequence), idle=jnp.float32(0.0),
                           stretch=jnp.float32(s.stall_horizon_scale))
    _, _, res_fresh = plan_step(fresh, x, contour=contour, scene=SCENE, settings=s)
    assert int(stalled.stalls) == 1 and float(stalled.idle) == 0.0
    assert float(stalled.stretch) == s.stall_horizon_scale
    np.testing.assert_allclose(res_stalled.sequence, res_fresh.sequence, atol=1e-6)
    # the next progress brings the paper's horizon back
    closer, _ = watch_progress(stalled, _state_at(0.1), contour=CONTOUR, scene=SCENE, settings=s)
    assert float(closer.stretch) == 1.0 and int(closer.stalls) == 1


def test_stretched_slots_keep_the_first_one_and_scale_the_rest() -> None:
    s = WATCH.mppi
    base = s.step_durations()
    got = np.asarray(slot_durations(s, 2.0))
    assert got[0] == pytest.approx(base[0]) and np.allclose(got[1:], 2.0 * base[1:])
    np.testing.assert_allclose(slot_durations(s), base, rtol=1e-6)


def test_the_watch_is_off_unless_asked() -> None:
    assert ControllerSettings().stall_after_s is None


def test_stall_settings_are_checked() -> None:
    with pytest.raises(ValueError, match="stall_after_s"):
        ControllerSettings(stall_after_s=0.0)
    with pytest.raises(ValueError, match="stall_progress_m"):
        ControllerSettings(stall_progress_m=-1.0)
    with pytest.raises(ValueError, match="stall_contact_gap_m"):
        ControllerSettings(stall_contact_gap_m=0.0)
    with pytest.raises(ValueError, match="stall_horizon_scale"):
        ControllerSettings(stall_horizon_scale=0.5)
