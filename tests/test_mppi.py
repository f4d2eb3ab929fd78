"""MPPI: cost reduction, clipping, warm-start shift; the controller's contract."""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from dexpush import Shape
from dexpush.control.controller import ControllerSettings, PushingController
from dexpush.control.mppi import MPPISettings, _spread, mppi_iteration, shift_in_time


@functools.cache
def point_mass_planner(**kw):
    """One jitted MPPI iteration for a point that moves with the input, cost = squared distance to
    the target: ``plan(key, U, x0, params, target)`` (cached: Hypothesis examples reuse one compile)."""
    def dynamics(x, u, dt, params):
        return x + dt * u

    def cost(x, target):
        return jnp.sum((x - target) ** 2, -1)

    return jax.jit(functools.partial(mppi_iteration, dynamics=dynamics, running_cost=cost,
                                     terminal_cost=lambda x, t: 10 * cost(x, t), settings=MPPISettings(**kw)))


def test_mppi_lowers_the_cost_on_a_simple_problem() -> None:
    planner = point_mass_planner(num_samples=256)
    x0, target = jnp.array([0.3, -0.2]), jnp.zeros(2)
    U = jnp.zeros((25, 2))
    key = jax.random.PRNGKey(0)
    costs = []
    for _ in range(15):
        key, sub = jax.random.split(key)
        res = planner(sub, U, x0, None, target)
        costs.append(float(res.cost_nominal))
        U = res.sequence
    assert costs[-1] < 0.5 * costs[0]
    # the first input heads towards the target at the speed limit, per axis
    assert U[0, 0] < -0.03 and U[0, 1] > 0.03


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 10**6), scale=st.floats(0.0, 10.0))
def test_clipping_holds_for_every_output(seed: int, scale: float) -> None:
    planner = point_mass_planner(num_samples=64)
    U = scale * jax.random.normal(jax.random.PRNGKey(seed), (25, 2))
    res = planner(jax.random.PRNGKey(seed + 1), U, jnp.array([1.0, 1.0]), None, jnp.zeros(2))
    assert np.all(np.abs(np.asarray(res.sequence)) <= 0.1 / np.sqrt(2) + 1e-7)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_sampled_update_keeps_a_nominal_at_the_bound_and_the_clipped_one_drags_it_inward(seed: int) -> None:
    """A target far off along +x: the best input is the bound v_max/√2 in every slot. From a nominal there,
    the sampled update (clip the average of U + ε) stays on it; the clipped one (average of clip(U + ε))
    comes off it, as every sample below the bound has some weight and none can lie above it (the more, the
    broader the weights: τ = 0.5 here)."""
    bound = 0.1 / np.sqrt(2)
    U = jnp.zeros((25, 2)).at[:, 0].set(bound)
    x0, target = jnp.zeros(2), jnp.array([5.0, 0.0])
    key = jax.random.PRNGKey(seed)
    sampled = point_mass_planner(num_samples=256, update="sampled", temperature=0.5)(key, U, x0, None, target)
    clipped = point_mass_planner(num_samples=256, update="clipped", temperature=0.5)(key, U, x0, None, target)
    np.testing.assert_allclose(np.asarray(sampled.sequence)[:, 0], bound, rtol=1e-6)
    assert float(np.mean(np.asarray(clipped.sequence)[:, 0])) < bound - 1e-3
    assert float(sampled.cost_min) == pytest.approx(float(clipped.cost_min))   # the same samples, rolled out


def test_warm_start_shift_is_exact_in_time_for_a_linear_sequence() -> None:
    s = MPPISettings()
    d = s.step_durations()
    mid = np.cumsum(d) - d / 2
    U = np.stack([0.01 + 0.02 * mid, -0.03 * mid], -1)
    shifted = np.asarray(shift_in_time(jnp.asarray(U), jnp.asarray(d), 0.04))
    expect = np.stack([0.01 + 0.02 * (mid + 0.04), -0.03 * (mid + 0.04)], -1)
    inside = mid + 0.04 <= mid[-1]
    np.testing.assert_allclose(shifted[inside], expect[inside], atol=1e-6)
    np.testing.assert_allclose(shifted[~inside], np.broadcast_to(U[-1], shifted[~inside].shape), atol=1e-6)
    # a slot shift would be wrong: slots are longer than the control period
    assert not np.allclose(shifted[5:-1], U[6:], atol=1e-4)


def test_step_durations_follow_the_paper() -> None:
    d = MPPISettings().step_durations()
    assert d[0] == pytest.approx(0.04)
    np.testing.assert_allclose(d[1:] / d[:-1], np.exp(2 / 25))
    assert d.sum() == pytest.approx(3.07, abs=0.01)


@pytest.mark.parametrize("bad", [dict(num_samples=0), dict(temperature=0.0), dict(noise_sigma=-1.0),
                                 dict(refine_fraction=1.5), dict(control_cost=-1.0), dict(update="mean"),
                                 dict(spread_cap=0.0), dict(check_substeps=0), dict(check_substeps=2.5)])
def test_bad_settings(bad: dict) -> None:
    with pytest.raises(ValueError, match=next(iter(bad))):
        MPPISettings(**bad)


@functools.cache
def controller() -> PushingController:
    return PushingController(Shape.rectangle(), goal=(0.3, 0.0, 0.0), params=(25.0, -0.01, 0.02),
                             settings=ControllerSettings(mppi=MPPISettings(num_samples=256)))


def test_controller_returns_finite_bounded_commands_and_is_reproducible() -> None:
    ctrl = controller()
    ctrl.reset(seed=4)
    a = [ctrl.command([0, 0, 0], [-0.15, 0.0]) for _ in range(3)]
    ctrl.reset(seed=4)
    b = [ctrl.command([0, 0, 0], [-0.15, 0.0]) for _ in range(3)]
    np.testing.assert_array_equal(a, b)
    for u in a:
        assert u.shape == (2,) and np.all(np.isfinite(u)) and np.all(np.abs(u) <= 0.1 / np.sqrt(2))
    assert a[-1][0] > 0.01  # pusher behind the box heads for it


@pytest.mark.parametrize("pose, pusher, match", [
    ([0, 0, np.nan], [-0.15, 0.0], "NaN"),
    ([0, 0], [-0.15, 0.0], r"shape \(3,\)"),
    ([0, 0, 0], [np.inf, 0.0], "NaN or infinite"),
])
def test_controller_rejects_bad_observations(pose, pusher, match) -> None:
    with pytest.raises(ValueError, match=match):
        controller().command(pose, pusher)


def test_controller_rejects_bad_construction() -> None:
    with pytest.raises(ValueError, match="goal"):
        PushingController(Shape.rectangle(), goal=(0.0, 0.0))
    with pytest.raises(ValueError, match="β"):
        PushingController(Shape.rectangle(), goal=(0, 0, 0), params=(0.0, 0.0, 0.0))
    with pytest.raises(TypeError, match="Shape"):
        PushingController("rect", goal=(0, 0, 0))


def test_a_colder_temperature_weights_fewer_samples() -> None:
    """τ passed per iteration replaces ``MPPISettings.temperature``: the same τ gives the same update,
    and a colder one concentrates the weights (fewer effective samples, down to the best one)."""
    planner = point_mass_planner(num_samples=256)
    args = (jax.random.PRNGKey(1), jnp.zeros((25, 2)), jnp.array([0.02, 0.01]), None, jnp.zeros(2))
    default = planner(*args)
    same = planner(*args, temperature=MPPISettings().temperature)
    np.testing.assert_array_equal(default.sequence, same.sequence)
    ess = [float(planner(*args, temperature=t).ess) for t in (0.5, 0.1, 0.02, 1e-7)]
    assert ess[0] > ess[1] > ess[2] > ess[3] and ess[3] == pytest.approx(1.0, abs=1e-3)


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 10**6), n=st.integers(1, 200), penalized=st.integers(0, 300))
def test_the_temperature_spread_is_the_median_of_the_samples_that_paid_no_penalty(seed: int, n: int,
                                                                                   penalized: int) -> None:
    """λ's spread is median − min over the costs within ``spread_cap`` of the best: the plain median, bit for
    bit, where none is beyond it; the median of the others, however many paid a penalty."""
    rng = np.random.default_rng(seed)
    fair = rng.exponential(1.0, n).astype(np.float32)
    S = jnp.asarray(np.concatenate([fair, 1e9 * (1 + rng.random(penalized))]).astype(np.float32))
    S_min = jnp.min(S)
    got = float(_spread(S, S_min, 1e6))
    assert got == pytest.approx(float(np.median(fair) - fair.min()), rel=1e-6, abs=1e-7)
    if penalized == 0:
        assert got == float(_spread(S, S_min, None))


def test_beside_a_wall_the_update_stays_selective_when_most_samples_pay_its_penalty() -> None:
    """A point in a corridor 2 cm wide, its target 0.3 m along it: most samples cross a wall (1e9 per slot
    beyond it). Their median sets λ so high that the samples inside weigh alike (a wide, averaged update);
    measured over the samples inside, the update follows the best up the corridor, to a lower cost."""
    def plan(cap):
        def dynamics(x, u, dt, params):
            return x + dt * u

        def cost(x, target):
            return jnp.sum((x - target) ** 2, -1) + 1e9 * (jnp.abs(x[..., 0]) > 0.01)

        return jax.jit(functools.partial(mppi_iteration, dynamics=dynamics, running_cost=cost,
                                         terminal_cost=lambda x, t: 10 * cost(x, t),
                                         settings=MPPISettings(num_samples=512, spread_cap=cap)))

    runs = {}
    for cap in (1e6, None):
        planner, U, key, ess = plan(cap), jnp.zeros((25, 2)), jax.random.PRNGKey(3), []
        for _ in range(10):
            key, sub = jax.random.split(key)
            res = planner(sub, U, jnp.zeros(2), None, jnp.array([0.0, 0.3]))
            U = res.sequence
            ess.append(float(res.ess))
        runs[cap] = float(res.cost_nominal), float(np.median(ess))
    (capped, capped_ess), (plain, plain_ess) = runs[1e6], runs[None]
    assert plain_ess > 5 * capped_ess
    assert capped < 0.8 * plain


@pytest.mark.parametrize("check_substeps", [4, 1])
def test_with_the_spread_cap_no_update_pays_a_penalty_its_finer_rollout_shows(check_substeps: int) -> None:
    """A point pushed toward a wall at x = 0.1 (1e9 per slot beyond it), its target behind the wall: the rollout's
    one Euler step per slot under-predicts the travel (x' = x + Δt·u·(1 − cΔt), where n steps of Δt/n travel
    farther), so the samples the capped λ weighs are those that stop just short of the wall in one step and cross
    it in four. Checked with four steps per slot, every update keeps short of it in four and the point still comes
    most of the way (a part of the capped step fits); checked with one (no check), the plan crosses it."""
    def dynamics(x, u, dt, params):
        return x + dt * u * (1.0 - 2.5 * dt)

    def cost(x, target):
        return jnp.sum((x - target) ** 2, -1) + 1e9 * (x[..., 0] > 0.1)

    settings = MPPISettings(num_samples=512, spread_cap=1e6, check_substeps=check_substeps)
    planner = jax.jit(functools.partial(mppi_iteration, dynamics=dynamics, running_cost=cost,
                                        terminal_cost=lambda x, t: 10 * cost(x, t), settings=settings))
    fine = MPPISettings(num_samples=512, spread_cap=1e6, check_substeps=4)
    U, key, target, worst = jnp.zeros((25, 2)), jax.random.PRNGKey(5), jnp.array([0.3, 0.0]), 0.0
    for _ in range(10):
        key, sub = jax.random.split(key)
        U = planner(sub, U, jnp.zeros(2), None, target).sequence
        x = jnp.zeros(2)
        for v, dt in zip(U, fine.step_durations()):
            for _ in range(4):
                x = dynamics(x, v, dt / 4, None)
                worst = max(worst, float(x[0]))
    if check_substeps == 4:
        assert 0.05 < worst <= 0.1              # measured: 94 mm, the wall at 100
    else:
        assert worst > 0.1                       # measured: 133 mm


def test_without_obstacles_the_spread_cap_changes_no_command() -> None:
    """No obstacle, no workspace: no sample pays a penalty, so the capped spread is the plain median and the
    controller's commands are the same, bit for bit."""
    runs = []
    for cap in (1e6, None):
        ctrl = PushingController(Shape.rectangle(), goal=(0.3, 0.0, 0.5), params=(25.0, -0.01, 0.02),
                                 settings=ControllerSettings(mppi=MPPISettings(num_samples=256, spread_cap=cap)))
        ctrl.reset(seed=2)
        pose, pusher, commands = np.zeros(3), np.array([-0.15, 0.0]), []
        for _ in range(8):
            u = ctrl.command(pose, pusher)
            pusher = pusher + 0.04 * u
            commands.append(u)
        runs.append(np.array(commands))
    np.testing.assert_array_equal(runs[0], runs[1])
    assert np.abs(runs[0]).max() > 0.01
