"""Stall detection (the planner restarts when the object stops coming closer to the goal) and the
endgame temperature."""

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
from dexpush.control.controller import ControllerSettings, plan_step, policy_init, watch_progress
from dexpush.control.mppi import slot_durations
from dexpush.control.settings import EndgameSettings, StallSettings
from dexpush.model.cgvmm import LAMBDA_TRUE, Contour
from dexpush.problem.scene import Scene

SHAPE = Shape.rectangle()
SCENE = Scene.make(SHAPE, (0.6, 0.0, 0.0))
CONTOUR = Contour.of(SHAPE)
WATCH = ControllerSettings(stall=StallSettings(after_s=4.0))


def _state_at(x_b: float, pusher_gap: float = 0.1, theta: float = 0.0) -> jnp.ndarray:
    """The rectangle at x_b turned by ``theta``, the pusher ``pusher_gap`` off its 0.1-m half-length
    (+ radius) behind it."""
    r = 0.1 + SHAPE.pusher_radius + pusher_gap
    return jnp.asarray([x_b, 0.0, theta, x_b - r * np.cos(theta), -r * np.sin(theta)], jnp.float32)


@functools.cache
def _compiled_watch(settings: ControllerSettings):
    return jax.jit(functools.partial(watch_progress, contour=CONTOUR, scene=SCENE, settings=settings))


def _watch(settings: ControllerSettings, positions: list[float], headings: list[float] | None = None) -> list[bool]:
    state, watch, out = policy_init(LAMBDA_TRUE, settings, 0), _compiled_watch(settings), []
    for xb, th in zip(positions, headings or [0.0] * len(positions), strict=True):
        state, stalled = watch(state, _state_at(xb, theta=th))
        out.append(bool(stalled))
    return out


def test_a_stall_is_declared_after_the_set_time_without_progress_and_not_before() -> None:
    s = WATCH
    n = round(s.stall.after_s / s.mppi.control_period)
    flags = _watch(s, [0.0] * (7 * n + 1))
    # while nothing moves: after stall_after_s, then after twice as long, then four times (the backoff)
    assert np.flatnonzero(flags).tolist() == [n, 3 * n, 7 * n]
    no_backoff = dataclasses.replace(s, stall=dataclasses.replace(s.stall, backoff=1.0))
    assert np.flatnonzero(_watch(no_backoff, [0.0] * (2 * n + 1))).tolist() == [n, 2 * n]
    # steady progress of 2 mm a period never stalls, though each step is below stall_progress_m
    assert not any(_watch(s, list(np.arange(3 * n) * 0.002)))
    off = dataclasses.replace(s, stall=dataclasses.replace(s.stall, after_s=None))
    assert not any(_watch(off, [0.0] * (2 * n + 1)))


def test_a_slow_turn_in_place_is_progress() -> None:
    """Task II's final turn: the position stays, the heading comes down by 2.5° every 3 s. d (eq. 9b)
    moves by less than stall_progress_m at a time, but the heading error improves by more than
    stall_progress_deg: no stall. Turning away from the goal is no progress."""
    s = WATCH
    n = round(3.0 / s.mppi.control_period)
    toward = np.repeat(np.radians(np.arange(30.0, 5.0, -2.5)), n)
    assert not any(_watch(s, [0.6] * len(toward), list(toward)))
    assert any(_watch(s, [0.6] * len(toward), list(toward[::-1])))


def test_near_means_within_the_success_tolerances_in_both_position_and_heading() -> None:
    s = WATCH
    n = round(s.stall.after_s / s.mppi.control_period)
    assert not any(_watch(s, [0.595] * (2 * n), [np.radians(2.0)] * (2 * n)))  # 5 mm and 2°: done
    assert any(_watch(s, [0.595] * (2 * n), [np.radians(20.0)] * (2 * n)))     # 5 mm but 20° off: not near
    assert any(_watch(s, [0.588] * (2 * n), [np.radians(1.0)] * (2 * n)))      # 12 mm: short of it, a stall


def test_the_stall_clock_rests_in_contact_and_near_the_goal() -> None:
    s = WATCH
    n = round(s.stall.after_s / s.mppi.control_period)
    state, watch = policy_init(LAMBDA_TRUE, s, 0), _compiled_watch(s)
    for x in [_state_at(0.0, pusher_gap=0.0)] * (2 * n) + [_state_at(0.595)] * (2 * n):
        state, stalled = watch(state, x)
        assert not bool(stalled)     # touching the object, then 5 mm from the goal: never a stall


@given(st.lists(st.floats(-0.3, 0.5), min_size=1, max_size=300))
def test_stalls_are_at_most_one_per_stall_time(positions: list[float]) -> None:
    s = dataclasses.replace(WATCH, stall=dataclasses.replace(WATCH.stall, after_s=1.0))
    flags = _watch(s, positions)
    assert sum(flags) <= len(positions) * s.mppi.control_period / s.stall.after_s + 1e-9
    if sum(flags):   # a stall comes only after a full stall time since the last progress
        assert np.flatnonzero(flags)[0] >= round(s.stall.after_s / s.mppi.control_period)


def test_a_stall_restarts_the_planner_from_a_zero_warm_start_with_a_longer_horizon() -> None:
    s = dataclasses.replace(WATCH, stall=dataclasses.replace(WATCH.stall, horizon_scale=2.0))
    contour, x = Contour.of(SHAPE), _state_at(0.0)
    state = policy_init(LAMBDA_TRUE, s, 3)
    state = state._replace(sequence=jnp.full_like(state.sequence, 0.05), best=jnp.float32(120.0),
                           idle=jnp.float32(s.stall.after_s - s.mppi.control_period / 2))
    stalled, _, res_stalled = plan_step(state, x, contour=contour, scene=SCENE, settings=s)
    fresh = state._replace(sequence=jnp.zeros_like(state.sequence), idle=jnp.float32(0.0),
                           stretch=jnp.float32(s.stall.horizon_scale))
    _, _, res_fresh = plan_step(fresh, x, contour=contour, scene=SCENE, settings=s)
    assert int(stalled.stalls) == 1 and float(stalled.idle) == 0.0
    assert float(stalled.stretch) == s.stall.horizon_scale
    np.testing.assert_allclose(res_stalled.sequence, res_fresh.sequence, atol=1e-6)
    # the next progress brings the paper's horizon back
    closer, _ = watch_progress(stalled, _state_at(0.1), contour=CONTOUR, scene=SCENE, settings=s)
    assert float(closer.stretch) == 1.0 and int(closer.stalls) == 1
    assert int(stalled.streak) == 1 and int(closer.streak) == 0     # progress ends the backoff
    # within endgame.distance_m the horizon is the paper's too, progress or not (the endgame needs the fine
    # slots), and a stall there does not stretch it
    there = stalled._replace(best=jnp.float32(0.0))
    there, _ = watch_progress(there, _state_at(0.59), contour=CONTOUR, scene=SCENE, settings=s)
    assert float(there.stretch) == 1.0 and int(there.streak) == 1
    close = state._replace(best=jnp.float32(0.0))
    close, again = watch_progress(close, _state_at(0.6 - 0.03), contour=CONTOUR, scene=SCENE, settings=s)
    assert bool(again) and float(close.stretch) == 1.0     # a stall 3 cm from the goal


def test_stretched_slots_keep_the_first_one_and_scale_the_rest() -> None:
    s = WATCH.mppi
    base = s.step_durations()
    got = np.asarray(slot_durations(s, 2.0))
    assert got[0] == pytest.approx(base[0]) and np.allclose(got[1:], 2.0 * base[1:])
    np.testing.assert_allclose(slot_durations(s), base, rtol=1e-6)


def test_the_watch_is_on_by_default_and_doubles_the_horizon_after_a_stall() -> None:
    s = ControllerSettings()
    assert s.stall.after_s == 4.0 and s.stall.horizon_scale == 2.0 and s.weights.detour


def test_the_plan_follows_the_stretch_field_only_when_the_horizon_may_stretch() -> None:
    """With ``stall_horizon_scale`` = 1 (the paper's horizon always) a stale ``stretch`` in the state
    changes nothing; with the default it does."""
    s = ControllerSettings(stall=StallSettings(horizon_scale=1.0))
    plan = jax.jit(functools.partial(plan_step, contour=CONTOUR, scene=SCENE, settings=s))
    state, x = policy_init(LAMBDA_TRUE, s, 3), _state_at(0.0, pusher_gap=0.0)
    state = state._replace(best=jnp.float32(0.0))      # no progress now, so a stretch would be kept
    a = plan(state, x)
    b = plan(state._replace(stretch=jnp.float32(2.0)), x)
    np.testing.assert_array_equal(a[1], b[1])
    np.testing.assert_array_equal(a[0].sequence, b[0].sequence)
    # with the default (2) the plan does follow the stretch
    default = ControllerSettings()
    plan = jax.jit(functools.partial(plan_step, contour=CONTOUR, scene=SCENE, settings=default))
    state = policy_init(LAMBDA_TRUE, default, 3)._replace(best=jnp.float32(0.0))
    a, b = plan(state, x), plan(state._replace(stretch=jnp.float32(2.0)), x)
    assert float(b[2].cost_min) != float(a[2].cost_min)


def test_stall_settings_are_checked() -> None:
    with pytest.raises(ValueError, match=r"stall\.after_s"):
        ControllerSettings(stall=StallSettings(after_s=0.0))
    with pytest.raises(ValueError, match=r"stall\.progress_m"):
        ControllerSettings(stall=StallSettings(progress_m=-1.0))
    with pytest.raises(ValueError, match=r"stall\.contact_gap_m"):
        ControllerSettings(stall=StallSettings(contact_gap_m=0.0))
    with pytest.raises(ValueError, match=r"stall\.horizon_scale"):
        ControllerSettings(stall=StallSettings(horizon_scale=0.5))
    with pytest.raises(ValueError, match=r"stall\.progress_deg"):
        ControllerSettings(stall=StallSettings(progress_deg=0.0))
    with pytest.raises(ValueError, match=r"stall\.backoff"):
        ControllerSettings(stall=StallSettings(backoff=0.9))


@functools.cache
def _compiled_plan(settings: ControllerSettings):
    return jax.jit(functools.partial(plan_step, contour=CONTOUR, scene=SCENE, settings=settings))


def _plan(settings: ControllerSettings, x: jnp.ndarray) -> np.ndarray:
    return np.asarray(_compiled_plan(settings)(policy_init(LAMBDA_TRUE, settings, 5), x)[0].sequence)


def test_near_the_goal_the_plan_weights_its_samples_with_the_endgame_temperature() -> None:
    endgame = ControllerSettings(endgame=EndgameSettings(temperature=0.001), stall=StallSettings(after_s=None))
    off = dataclasses.replace(endgame, endgame=dataclasses.replace(endgame.endgame, temperature=None))
    cold = dataclasses.replace(off, mppi=dataclasses.replace(off.mppi, temperature=0.001))
    near, far = _state_at(0.6 - 0.03, pusher_gap=0.0), _state_at(0.6 - 0.05, pusher_gap=0.0)
    np.testing.assert_array_equal(_plan(endgame, near), _plan(cold, near))       # 3 cm from the goal
    np.testing.assert_array_equal(_plan(endgame, far), _plan(off, far))          # 5 cm: the usual τ
    assert not np.array_equal(_plan(endgame, near), _plan(off, near))
    with pytest.raises(ValueError, match=r"endgame\.temperature"):
        ControllerSettings(endgame=EndgameSettings(temperature=0.0))


def test_a_horizon_stretched_through_the_inputs_plans_as_one_stretched_through_the_slots() -> None:
    """``rate_independent``: s·v held for Δt instead of v for s·Δt; the same samples, so the same
    plan to float32 round-off, on the T beside the obstacle of Task III (the C-GVMM is quasi-static)."""
    from dexpush.control.mppi import mppi_iteration
    from dexpush.model.cgvmm import step
    from dexpush.problem.cost import running_cost, terminal_cost

    shape = Shape.tee()
    contour = Contour.of(shape)
    s = ControllerSettings()
    scene = Scene.make(shape, (0.6, 0.0, 0.0), ((0.30, 0.0, 0.05),), s.weights)
    x = (0.154, 0.07, -0.527, -0.053, 0.147)           # a stall beside the obstacle on the physics plant
    x = tuple(jnp.float32(v) for v in x)

    @functools.partial(jax.jit, static_argnames="rate_independent")
    def plan(scale: jnp.ndarray, rate_independent: bool):
        return mppi_iteration(jax.random.key(4), jnp.zeros((s.mppi.horizon, 2), jnp.float32), x,
                              jnp.asarray(LAMBDA_TRUE, jnp.float32), scene,
                              dynamics=lambda xs, u, dt, p: step(contour, xs, u, dt, p, 0.3),
                              running_cost=lambda xs, sc: running_cost(xs, sc, s.weights),
                              terminal_cost=lambda xs, sc: terminal_cost(xs, sc, s.weights), settings=s.mppi,
                              horizon_scale=scale, rate_independent=rate_independent)

    for scale in (1.0, 2.0):
        a, b = plan(jnp.float32(scale), False), plan(jnp.float32(scale), True)
        assert float(b.cost_min) == pytest.approx(float(a.cost_min), rel=1e-5)
        np.testing.assert_allclose(b.sequence, a.sequence, atol=1e-4)


def test_the_flat_names_of_before_the_groups_are_read_with_a_warning() -> None:
    with pytest.warns(FutureWarning, match=r"stall_after_s → stall\.after_s"):
        old = ControllerSettings(stall_after_s=3.0, endgame_temperature=None)
    assert old == ControllerSettings(stall=StallSettings(after_s=3.0), endgame=EndgameSettings(temperature=None))
    with pytest.warns(FutureWarning):
        again = dataclasses.replace(old, stall_backoff=3.0)
    assert again.stall.backoff == 3.0 and again.stall.after_s == 3.0
