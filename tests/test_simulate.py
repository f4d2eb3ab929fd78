"""The batched simulator: lanes are independent, and it runs the same controller a robot would."""

from __future__ import annotations

from functools import partial

import numpy as np
import pytest

from dexpush.control.controller import ControllerSettings, PushingController
from dexpush.experiments.registry import make_shape
from dexpush.experiments.scenarios import get_task, initial_conditions
from dexpush.experiments.simulate import TrialSpec, simulate
from dexpush.world.model_plant import ModelPlant

UNKNOWN = (15.0, 0.0, 0.0)



def _simulate(task, shape, trials, *args, **kwargs):
    """simulate() on the task's problem for the shape, from the task's starts."""
    return simulate(task.problem(shape), trials, *args, starts=partial(task.trial_start, shape), **kwargs)


def test_a_trial_does_not_depend_on_its_neighbours_or_its_lane() -> None:
    task, shape = get_task("II"), make_shape("rect")       # lanes=2, chunk 25: the program test_benchmark compiles
    specs = [TrialSpec(s, UNKNOWN, estimate=s % 2 == 0) for s in range(4)]
    forward = _simulate(task, shape, specs, lanes=2, max_steps=30)
    backward = _simulate(task, shape, specs[::-1], lanes=2, max_steps=30)[::-1]
    alone = _simulate(task, shape, [specs[2]], lanes=2, max_steps=30)[0]
    for a, b in zip(forward, backward):
        assert a.spec == b.spec
        np.testing.assert_array_equal(a.states, b.states)
        np.testing.assert_array_equal(a.params, b.params)
    np.testing.assert_array_equal(forward[2].states, alone.states)
    assert not np.array_equal(forward[0].params, forward[1].params)   # the UKF lanes did estimate
    # the third and fourth trials waited for a free lane and still ran their full 30 steps
    assert [r.steps for r in forward] == [30] * 4
    assert forward[0].states.shape == (31, 5) and forward[0].commands.shape == (30, 2)


def test_simulate_runs_the_controller_a_robot_runs() -> None:
    """PushingController + ModelPlant, stepped from Python, follows the batched simulation."""
    task, shape = get_task("I"), make_shape("rect")
    settings = ControllerSettings(estimate_params=True)
    sim = _simulate(task, shape, [TrialSpec(4, UNKNOWN, estimate=True)], settings, max_steps=40, lanes=1)[0]
    assert np.abs(sim.params[-1] - UNKNOWN).max() > 1e-3          # the estimate moved: the check below means something
    pose, pusher = initial_conditions(task, shape, 4)
    plant = ModelPlant(shape)
    obs = plant.reset(pose, pusher)
    ctrl = PushingController(shape, task.goal, params=UNKNOWN, settings=settings, seed=4)
    states = [obs.state]
    for _ in range(40):
        obs = plant.step(ctrl.command(obs.object_pose, obs.pusher_xy))
        states.append(obs.state)
    # different compiled programs round differently; the closed loops stay within 1 mm
    assert np.max(np.abs(np.asarray(states) - sim.states)) < 1e-3
    np.testing.assert_allclose(ctrl.params, sim.params[-1], rtol=1e-2, atol=1e-3)


def test_every_result_is_reported_as_it_ends() -> None:
    seen: list[int] = []
    specs = [TrialSpec(s) for s in range(3)]
    out = _simulate(get_task("I"), make_shape("rect"), specs, lanes=2, max_steps=3,
                   on_result=lambda r: seen.append(r.spec.seed))
    assert sorted(seen) == [0, 1, 2] and [r.spec.seed for r in out] == [0, 1, 2]
    assert all(r.steps == 3 and not r.success and len(r.step_ms) == 3 for r in out)

    class StopRunError(Exception):
        pass

    def first(r) -> None:           # an interrupted run: the first finished trial was already reported
        seen.append(r.spec.seed)
        raise StopRunError

    seen.clear()
    with pytest.raises(StopRunError):
        _simulate(get_task("I"), make_shape("rect"), specs, lanes=2, max_steps=3, on_result=first)
    assert seen == [0]


@pytest.mark.parametrize("kwargs, match", [
    (dict(lanes=0), "lanes"),
    (dict(substeps=5), "substeps"),
    (dict(plant_params=(25.0, np.nan, 0.0)), r"NaN|finite"),
])
def test_bad_arguments_are_named(kwargs: dict, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        _simulate(get_task("I"), make_shape("rect"), [TrialSpec(0)], **kwargs)


def test_bad_trial_is_named() -> None:
    with pytest.raises(ValueError, match="seed"):
        _simulate(get_task("I"), make_shape("rect"), [TrialSpec(-1)])
    with pytest.raises(ValueError, match=r"β|beta|params"):
        _simulate(get_task("I"), make_shape("rect"), [TrialSpec(0, (-1.0, 0.0, 0.0))])


def test_touching_an_obstacle_fails_the_trial_at_the_touch() -> None:
    """docs/conventions.md#benchmark-tasks: a disc under the object's start touches it at once; the trial ends there."""
    from dexpush.experiments.scenarios import Task

    task = Task("X", "touch", goal=(0.6, 0.0, 0.0), obstacles=((0.0, 0.0, 0.02),))
    out = _simulate(task, make_shape("rect"), [TrialSpec(0), TrialSpec(1)], lanes=1, max_steps=50)
    assert all(not r.success and r.steps == 1 and len(r.states) == 2 for r in out)


def test_a_trial_that_starts_at_its_goal_takes_no_steps() -> None:
    from dexpush.experiments.scenarios import Task

    task = Task("X", "at goal", goal=(0.0, 0.0, 0.0), start_jitter_m=0.0, start_jitter_deg=0.0)
    out = _simulate(task, make_shape("rect"), [TrialSpec(0)], lanes=1, max_steps=5)[0]
    assert out.success and out.steps == 0 and out.states.shape == (1, 5) and out.commands.shape == (0, 2)


def test_a_per_lane_estimate_flag_updates_exactly_the_lanes_it_marks() -> None:
    """estimate_step with a traced per-lane flag (as the batched simulator calls it): flagged lanes
    follow the update a static True compiles, unflagged lanes keep their state bit for bit."""
    import jax
    import jax.numpy as jnp

    from dexpush.control.controller import estimate_step, policy_init
    from dexpush.model.cgvmm import Contour

    shape = make_shape("rect")
    settings, contour = ControllerSettings(), Contour.of(shape)
    plant = ModelPlant(shape, params=(20.0, 0.01, -0.01))
    obs = plant.reset((0.0, 0.0, 0.0), (-0.12, 0.01))
    frames = []
    for k in range(40):
        obs = plant.step((0.05, 0.01 * np.sin(k / 5)), 0.04)
        frames.append(np.asarray(obs.state, np.float32))
    flags = jnp.asarray([True, False, True, False])
    start = jax.vmap(lambda s: policy_init(UNKNOWN, settings, s, shape.footprint_box))(jnp.arange(4))
    per_lane = jax.jit(jax.vmap(lambda s, x, e: estimate_step(s, x, e, contour=contour, settings=settings)))
    always = jax.jit(jax.vmap(lambda s, x: estimate_step(s, x, True, contour=contour, settings=settings)))
    assert estimate_step(start, frames[0], False, contour=contour, settings=settings) is start
    mixed, on = start, start
    for f in frames:
        x = jnp.tile(jnp.asarray(f), (4, 1))
        mixed, on = per_lane(mixed, x, flags), always(on, x)
    assert int(on.estimator.updates[0]) > 5                       # the windows were informative
    for a, b, c in zip(jax.tree.leaves(mixed), jax.tree.leaves(on), jax.tree.leaves(start)):
        a, b, c = np.asarray(a), np.asarray(b), np.asarray(c)
        np.testing.assert_array_equal(a[1::2], c[1::2])
        np.testing.assert_allclose(a[::2], b[::2], rtol=1e-4, atol=1e-6)


def test_a_batch_takes_the_obstacle_cost_under_the_start_as_the_controller_does() -> None:
    """``obstacles_under_start`` in the batched simulator, whose estimate flag is traced per lane: with obstacles,
    ``plan_step`` traces the program of a controller with the UKF (each sample rolled out twice), not the one of a
    controller without it (traced only, nothing compiled)."""
    import jax
    import jax.numpy as jnp

    from dexpush.control.policy import plan_step, policy_init

    task, shape = get_task("III"), make_shape("rect")
    problem = task.problem(shape)
    settings = ControllerSettings()
    state = policy_init(UNKNOWN, settings, 0, shape.footprint_box)
    x = jnp.asarray([-0.4, 0.0, 0.0, -0.52, 0.0], jnp.float32)

    def equations(estimating: object, scene: object = problem.local_scene) -> int:
        def plan(st, xs, *flag):
            return plan_step(st, xs, contour=problem.contour, scene=scene, settings=settings,
                             estimating=flag[0] if flag else estimating)
        args = (state, x, jnp.bool_(True)) if estimating == "traced" else (state, x)
        return str(jax.make_jaxpr(plan)(*args)).count(" = ")

    traced, on, off = equations("traced"), equations(True), equations(False)
    assert traced == on > off
    no_obstacles = get_task("I").problem(shape).local_scene
    assert equations("traced", no_obstacles) == equations(False, no_obstacles)
