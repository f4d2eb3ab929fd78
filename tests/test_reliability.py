"""Reliability: hostile frames never stop the robot, and bad settings say what is wrong (issue 18)."""

from __future__ import annotations

import functools
import warnings

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import dexpush
from dexpush.common.interfaces import Observation
from dexpush.control.controller import ControllerSettings, PushingController, _estimate_jit, policy_init, policy_step
from dexpush.control.estimator import FrameGate, UKFSettings, estimator_init, estimator_observe
from dexpush.control.ukf import UKFState
from dexpush.model.cgvmm import Contour
from dexpush.problem.scene import Scene
from dexpush.world.model_plant import ModelPlant

SHAPE = dexpush.Shape.rectangle()
SETTINGS = ControllerSettings(estimate_params=True, mppi=dexpush.MPPISettings(num_samples=128))
STEPS = 40


@functools.cache
def clean_pushes() -> np.ndarray:
    """(STEPS, 5) observations of a pusher pushing the box on the model plant."""
    plant = ModelPlant(SHAPE)
    obs = plant.reset((0.0, 0.0, 0.0), (-0.12, 0.01))
    out = []
    for k in range(STEPS):
        obs = plant.step((0.05, 0.01 * np.sin(k / 5)), 0.04)
        out.append(obs.state)
    return np.asarray(out)


@functools.cache
def scanned_policy():
    contour, scene = Contour.of(SHAPE), Scene.make(SHAPE, (0.3, 0.0, 0.0), (), SETTINGS.weights)

    @jax.jit
    def run(xs):
        state = policy_init((15.0, 0.0, 0.0), SETTINGS, 0)

        def body(st, x):
            st, u, _ = policy_step(st, x, True, contour=contour, scene=scene, settings=SETTINGS)
            return st, u
        return jax.lax.scan(body, state, xs)
    return run


hostile = st.lists(st.tuples(st.integers(0, STEPS - 1), st.integers(0, 4),
                             st.sampled_from([0.5, -0.5, 3.0, 1e3, 1e6, -1e6, np.inf, np.nan])),
                   min_size=1, max_size=8)


@settings(max_examples=25, deadline=None)
@given(glitches=hostile)
def test_hostile_frames_never_poison_the_estimator_or_the_commands(glitches) -> None:
    X = clean_pushes().copy()
    for t, i, v in glitches:
        X[t, i] = v if not np.isfinite(v) or abs(v) > 10 else X[t, i] + v
    final, U = scanned_policy()(jnp.asarray(X, jnp.float32))
    est = final.estimator
    assert np.all(np.isfinite(np.asarray(est.filter.mean))) and np.all(np.isfinite(np.asarray(est.filter.cov)))
    U = np.asarray(U)
    assert np.all(np.isfinite(U)) and np.all(np.abs(U) <= SETTINGS.mppi.v_clip * (1 + 1e-6))
    lam = np.asarray(est.filter.mean)
    assert np.all(lam >= np.asarray(est.lower) - 1e-6) and np.all(lam <= np.asarray(est.upper) + 1e-6)


def test_one_far_off_frame_is_rejected_and_leaves_the_estimate_alone() -> None:
    """The issue's case: the object reported 0.5 m away for one frame."""
    ctrl = PushingController(SHAPE, (0.3, 0.0, 0.0), params=(15.0, 0.0, 0.0), settings=SETTINGS)
    X = clean_pushes()
    for k in range(30):
        ctrl.command(X[k, :3], X[k, 3:])
    est = ctrl.state.estimator
    before, prior = np.asarray(est.filter.mean, np.float64), np.asarray(est.prior, np.float64)
    glitch = X[30].copy()
    glitch[:2] += 0.5
    u = ctrl.command(glitch[:3], glitch[3:])
    assert ctrl.rejected_frames == 1 and ctrl.estimator_resets == 0
    # the filter never saw it: no update, only the relaxation toward the prior of a frame without information
    relaxed = prior + (before - prior) * np.exp(-SETTINGS.mppi.control_period / SETTINGS.ukf.prior_pull.time_s)
    np.testing.assert_allclose(np.asarray(ctrl.state.estimator.filter.mean), relaxed, rtol=1e-5)
    assert int(ctrl.state.estimator.count) == 0
    assert np.all(np.isfinite(u))
    for k in range(31, STEPS):
        u = ctrl.command(X[k, :3], X[k, 3:])
    assert np.all(np.isfinite(ctrl.params)) and np.all(np.abs(u) > 0)


def test_a_non_finite_filter_is_reset_to_the_prior() -> None:
    s = UKFSettings()
    state = estimator_init(jnp.asarray([15.0, 0.0, 0.0]), s)
    bad = state._replace(filter=UKFState(state.filter.mean.at[0].set(jnp.nan), state.filter.cov))
    out, updated = estimator_observe(bad, jnp.zeros(5), jnp.bool_(True), Contour.of(SHAPE), s, jnp.float32(0.3),
                                     jnp.float32(0.04), 10)
    assert int(out.resets) == 1 and not bool(updated)
    np.testing.assert_allclose(np.asarray(out.filter.mean), np.asarray(state.prior))


def test_act_takes_any_frame_period_without_recompiling() -> None:
    ctrl = PushingController(SHAPE, (0.3, 0.0, 0.0), params=(15.0, 0.0, 0.0), settings=SETTINGS)
    X = clean_pushes()
    ctrl.reset(X[0, :3], X[0, 3:])
    rng = np.random.default_rng(0)
    ctrl.act(Observation(X[0, :3], X[0, 3:], 0.0), 1 / 15)
    compiled = _estimate_jit._cache_size()
    t = 0.0
    for k in range(1, 20):
        t += 0.04
        u = ctrl.act(Observation(X[k, :3], X[k, 3:], t - 0.03), float(1 / 15 + rng.normal(0, 0.004)))
        assert np.all(np.isfinite(u))
    assert _estimate_jit._cache_size() == compiled


@pytest.mark.parametrize("make, match", [
    (lambda: ControllerSettings(mu=float("nan")), "mu"),
    (lambda: ControllerSettings(mu=-0.3), "mu"),
    (lambda: ControllerSettings(ukf_substeps=0), "ukf_substeps"),
    (lambda: ControllerSettings(mppi="fast"), "mppi"),
    (lambda: UKFSettings(meas_pos_std=float("inf")), "meas_pos_std"),
    (lambda: UKFSettings(process_std=(0.5, float("nan"), 5e-4)), "process_std"),
    (lambda: UKFSettings(alpha=float("nan")), "alpha"),
    (lambda: UKFSettings(gate=FrameGate(speed_m_s=0.0)), "gate.speed_m_s"),
    (lambda: ControllerSettings(weights=dexpush.control.controller.CostWeights(q_f=float("nan"))), "q_f"),
    (lambda: dexpush.control.controller.CostWeights(r_s=-0.2), "r_s"),
    (lambda: PushingController(SHAPE, (0, 0, 0), params=(25, 0, 0), seed=float("nan")), "seed"),
    (lambda: PushingController(SHAPE, (0, 0, 0), params=(25, 0, 0), seed=2**32), "seed"),
])
def test_bad_settings_name_the_field(make, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        make()


def test_bad_frames_name_what_is_wrong() -> None:
    ctrl = PushingController(SHAPE, (0.3, 0.0, 0.0), params=(25.0, 0.0, 0.0), settings=SETTINGS)
    X = clean_pushes()
    with pytest.raises(ValueError, match="frame_period"):
        ctrl.act(Observation(X[0, :3], X[0, 3:], 0.0), float("nan"))
    with pytest.raises(ValueError, match=r"frame\.time"):
        ctrl.act(Observation(X[0, :3], X[0, 3:], float("nan")), 0.04)


def test_a_controller_without_params_says_so() -> None:
    with pytest.warns(UserWarning, match="no params given"):
        PushingController(SHAPE, (0.3, 0.0, 0.0))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        PushingController(SHAPE, (0.3, 0.0, 0.0), params=(15.0, 0.0, 0.0))


def _reset_plant() -> ModelPlant:
    plant = ModelPlant(SHAPE)
    plant.reset((0.0, 0.0, 0.0), (-0.2, 0.0))
    return plant


def test_a_repeated_corner_is_merged_and_the_shape_works() -> None:
    sq = [[-0.05, -0.05], [0.05, -0.05], [0.05, -0.05], [0.05, 0.05], [-0.05, 0.05], [-0.05, -0.05]]
    shape = dexpush.Shape.polygon(sq)
    assert len(shape.polygons[0]) == 4
    assert np.all(np.isfinite(shape.radius_table)) and np.all(np.isfinite(shape.dradius_table))
    xdot, mode = dexpush.cgvmm(shape, [0.0, 0.0, 0.0, -0.06, 0.0], [0.05, 0.0])
    assert np.all(np.isfinite(np.asarray(xdot))) and int(mode) != 3


@pytest.mark.parametrize("call, match", [
    (lambda: dexpush.Shape.polygon([[0, 0], [0.1, 0.1], [0.1, 0], [0, 0.1]]), "self-intersecting"),
    (lambda: dexpush.Shape.rectangle(table_size=float("nan")), "table_size"),
    (lambda: dexpush.Shape.ellipse(table_size=10), "table_size"),
    (lambda: Scene.make(SHAPE, (0.3, 0, 0), [(0.1, 0.2), (0.3, 0.4), (0.5, 0.6)]), r"\(M, 3\)"),
    (lambda: dexpush.Camera(None), "not a plant"),
    (lambda: dexpush.SensorSettings(seed=float("nan")), "seed"),
    (lambda: dexpush.SensorSettings(latency_s="x"), "latency_s"),
    (lambda: _reset_plant().step((0.01, 0), "x"), "dt"),
    (lambda: dexpush.cgvmm(SHAPE, [1e20, 0, 0, 0, 0], [0, 0]), "magnitude"),
    (lambda: dexpush.cgvmm(SHAPE, [0, 0, 0, -0.2, 0], [0, 0], params=[2e4, 0, 0]), "β"),
    (lambda: PushingController(SHAPE, (0.3, 0, 0), params=(25, 0, 0)).command((1e39, 0, 0), (0, 0)), "magnitude"),
])
def test_unusable_input_is_refused_with_the_reason(call, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        call()


@pytest.mark.parametrize("plant", ["model", "physics"])
def test_a_speed_that_would_tunnel_through_the_object_is_refused(plant: str) -> None:
    from dexpush.experiments.registry import make_plant

    p = make_plant(plant, SHAPE)
    p.reset((0.0, 0.0, 0.0), (-0.2, 0.0))
    p.step((0.1, 0.0), 0.04)                                 # the speed limit is fine
    with pytest.raises(ValueError, match="pass through"):
        p.step((10.0, 0.0), 0.04)


def test_cli_errors_are_one_line_with_exit_code_2(tmp_path, capsys) -> None:
    from dexpush.cli import main

    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    data = tmp_path / "data"
    data.mkdir()
    assert main(["validate-mit", str(data), "--out", str(blocker / "sub")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("dexpush: error:") and "Traceback" not in err


class OffsetPlant:
    """The model plant seen from a world frame whose origin is ``offset`` metres away (float64 at the edge)."""

    def __init__(self, offset: float) -> None:
        self.inner, self.offset = ModelPlant(SHAPE), np.array([offset, offset])
        self.shift = np.array([offset, offset, 0.0, offset, offset])

    def _out(self, obs: Observation) -> Observation:
        return Observation(obs.object_pose + self.shift[:3], obs.pusher_xy + self.offset, obs.time)

    @property
    def state(self) -> np.ndarray:
        return self.inner.state + self.shift

    def observe(self) -> Observation:
        return self._out(self.inner.observe())

    def reset(self, object_pose, pusher_xy) -> Observation:
        return self._out(self.inner.reset(np.asarray(object_pose) - self.shift[:3],
                                          np.asarray(pusher_xy) - self.offset))

    def step(self, velocity, dt: float) -> Observation:
        return self._out(self.inner.step(velocity, dt))


def test_results_do_not_depend_on_where_the_world_origin_is() -> None:
    runs = []
    for offset in (0.0, 1e4):
        task = dexpush.Task("near", "near", goal=(offset + 0.04, offset, 0.0))
        ctrl = PushingController(SHAPE, task.goal, params=(25.0, -0.01, 0.02), settings=SETTINGS)
        runs.append(dexpush.run_loop(OffsetPlant(offset), ctrl, task.problem(SHAPE), (offset, offset, 0.0),
                                     (offset - 0.13, offset), max_steps=300))
    a, b = runs
    assert a.success and b.success and len(a.commands) == len(b.commands)
    np.testing.assert_allclose(a.commands, b.commands, atol=1e-6)


def test_the_physics_plant_refuses_an_outline_too_ragged_to_simulate() -> None:
    from dexpush.world.physics_plant import MAX_PRISMS, PhysicsPlant

    t = np.linspace(0, 2 * np.pi, 2 * 80, endpoint=False)                   # a star with 80 points
    star = np.stack([np.cos(t), np.sin(t)], -1) * np.where(np.arange(160) % 2, 0.07, 0.1)[:, None]
    with pytest.raises(ValueError, match=f"at most {MAX_PRISMS}"):
        PhysicsPlant(dexpush.Shape.polygon(star))
