"""The push chosen after a stall (dexpush.control.push_plan): its search, carrying it out, its settings."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from dexpush import Shape
from dexpush.control.controller import PushingController
from dexpush.control.mppi import MPPISettings
from dexpush.control.policy import ControllerSettings, plan_step, policy_init, progress_units
from dexpush.control.push_plan import (
    EndgamePushSettings,
    PushPlanSettings,
    endgame_candidates,
    follow_push,
    idle_push,
    progress_error,
    push_plan_init,
    search_endgame_push,
    search_push,
)
from dexpush.model.cgvmm import LAMBDA_TRUE, MU_C, integrate
from dexpush.problem.cost import plan_margin
from dexpush.problem.problem import Problem
from dexpush.problem.regions import wall

RECT = Shape.rectangle()
MP = MPPISettings()
PP = PushPlanSettings(enabled=True)
LAM = jnp.asarray(LAMBDA_TRUE, jnp.float32)
MU = jnp.float32(MU_C)


def _search(problem: Problem, x: np.ndarray) -> tuple[bool, object]:
    x = jnp.asarray(x, jnp.float32)
    scene = plan_margin(x, problem.local_scene, problem.weights)
    found, plan = jax.jit(search_push, static_argnames=("weights", "settings", "speed"))(
        x, problem.contour, scene, weights=problem.weights, params=LAM, mu=MU, settings=PP, speed=MP.v_clip)
    return bool(found), plan


def _search_endgame(problem: Problem, x: np.ndarray) -> tuple[bool, object]:
    x = jnp.asarray(x, jnp.float32)
    scene = plan_margin(x, problem.local_scene, problem.weights)
    found, plan = jax.jit(search_endgame_push, static_argnames=("weights", "settings", "speed", "units"))(
        x, problem.contour, scene, weights=problem.weights, params=LAM, mu=MU, settings=PP, speed=MP.v_clip,
        units=progress_units(ControllerSettings()))
    return bool(found), plan


def _carry_out(problem: Problem, x: np.ndarray, plan: object, periods: int = 400) -> tuple[np.ndarray, np.ndarray]:
    """Follow ``plan`` on the model plant (the model's own λ) until it ends: the states and the commands."""
    @jax.jit
    def period(plan: object, x: jnp.ndarray) -> tuple:
        scene = plan_margin(x, problem.local_scene, problem.weights)
        plan, u, use = follow_push(plan, x, problem.contour, scene, problem.weights, LAM, MU, PP, MP.v_clip,
                                   MP.control_period)
        return plan, u, use, integrate(problem.contour, x, u, jnp.float32(MP.control_period), LAM, MU, 10)

    x = jnp.asarray(x, jnp.float32)
    states, commands = [np.asarray(x)], []
    for _ in range(periods):
        plan, u, use, x = period(plan, x)
        if not bool(use):
            break
        commands.append(np.asarray(u))
        states.append(np.asarray(x))
    return np.array(states), np.array(commands).reshape(-1, 2)


def test_in_the_open_it_walks_behind_the_object_and_pushes_it_toward_the_goal() -> None:
    problem = Problem(RECT, (0.0, 0.0, 0.0))
    x = np.array([-0.3, 0.0, 0.0, -0.3, 0.15])          # the pusher above the box; the goal to its right
    found, plan = _search(problem, x)
    assert found and np.cos(float(plan.target)) < -0.9   # contact on the box's left side
    assert float(plan.way) == 1.0                         # the short way round, counter-clockwise
    states, commands = _carry_out(problem, x, plan)
    assert len(commands) > 10 and np.all(np.isfinite(commands))
    assert np.all(np.abs(commands) <= MP.v_clip * (1 + 1e-5))
    assert np.hypot(*states[-1, :2]) < np.hypot(*x[:2]) - 0.05     # pushed toward the goal
    assert states[-1, 0] - x[0] > 0.05


def test_a_wall_beside_the_object_sends_the_walk_the_long_way_round() -> None:
    """The box 5 mm above a wall, the pusher on its right, the push needed on its left: the short way (below,
    clockwise) has no room for the pusher, so the walk goes over the top; no point of it or of the push enters
    the wall's margin."""
    barrier = wall(-0.7, -0.075, 0.15, -0.075, 0.02)    # its top face 5 mm below the box's bottom
    problem = Problem(RECT, (0.0, 0.0, 0.0), polygons=(tuple(map(tuple, barrier)),))
    x = np.array([-0.3, 0.0, 0.0, -0.3 + 0.13, -0.01])
    found, plan = _search(problem, x)
    assert found and np.cos(float(plan.target)) < -0.9
    assert float(plan.way) == 1.0                         # the long way: counter-clockwise over the top
    states, _ = _carry_out(problem, x, plan)
    assert np.all(states[:, 4] > -0.06)                   # the pusher never went below the box
    assert states[-1, 0] - x[0] > 0.03
    assert not np.any(problem.collides(states))


def test_nothing_is_chosen_when_no_push_gains() -> None:
    problem = Problem(RECT, (0.0, 0.0, 0.0))
    found, plan = _search(problem, np.array([0.004, 0.0, 0.0, -0.12, 0.0]))    # 4 mm from the goal
    assert not found and not bool(plan.active)


@pytest.mark.parametrize("shape", [RECT, Shape.tee()], ids=["box", "tee"])
@pytest.mark.parametrize("offset", [(-0.012, 0.004, 0.0), (0.0, -0.014, 0.02), (0.01, 0.01, -0.03),
                                    (0.0, 0.0, 0.09)])
def test_near_the_goal_the_endgame_push_brings_the_object_within_the_success_tolerances(shape, offset) -> None:
    """1–1.5 cm and up to 2° from the goal, or at it but 5° off, the pusher 4 cm off the object: one push chosen by E
    (the success test's terms) and carried out on the model plant ends within 8 mm and 3°, without a touch."""
    problem = Problem(shape, (0.0, 0.0, 0.0))
    x = np.array([*offset, 0.0, 0.0])
    below = min(float(poly[:, 1].min()) for poly in shape.polygons)
    x[3:] = (x[0], x[1] + below - shape.pusher_radius - 0.04)          # 4 cm below it
    found, plan = _search_endgame(problem, x)
    assert found and float(plan.clearance) == pytest.approx(PP.endgame.clearance_m)
    assert abs(float(plan.angle)) < np.arctan(MU_C)
    states, commands = _carry_out(problem, x, plan)
    assert len(commands) > 5 and np.all(np.abs(commands) <= MP.v_clip * (1 + 1e-5))
    end = states[-1]
    assert bool(problem.success(end[:3])), (np.hypot(*end[:2]) * 1000, np.degrees(end[2]))
    units = progress_units(ControllerSettings())
    assert float(progress_error(jnp.asarray(end, jnp.float32), problem.local_scene, *units)) < \
        float(progress_error(jnp.asarray(x, jnp.float32), problem.local_scene, *units)) - PP.endgame.min_gain


def test_the_endgame_measures_the_position_error_straight_not_along_the_cost_to_go() -> None:
    """With a cost-to-go by heading (a table round the goal) the length along V counts the turn too; the endgame's
    E takes the distance itself, as the success test does: 2 mm and 1.15° off is E = 1.15° / 2° there."""
    goal = (0.0, 0.0, np.pi / 16)
    problem = Problem(Shape.tee(), goal, workspace=(-0.5, -0.5, 0.5, 0.5))
    x = jnp.asarray([0.002, 0.0, goal[2] + 0.02, 0.0, -0.2], jnp.float32)
    units = progress_units(ControllerSettings())
    scene = plan_margin(x, problem.local_scene, problem.weights)
    k = endgame_candidates(x, problem.contour, scene, problem.weights, LAM, MU, PP, MP.v_clip, units)
    assert float(k.now) == pytest.approx(0.02 / units[1], rel=1e-4)
    assert float(progress_error(x, scene, *units)) > float(k.now) + 0.1      # along V: 3.5 mm, E = 0.71


def test_a_stall_near_the_goal_searches_the_endgame_push_and_far_from_it_the_far_one() -> None:
    """The policy's choice: within ``endgame.distance_m`` the plan is the endgame's (its closer walk), beyond it the
    far search's; a stall near the goal does not stretch the horizon."""
    s = ControllerSettings(mppi=MPPISettings(num_samples=64))
    problem = Problem(RECT, (0.0, 0.0, 0.0))
    plans = {}
    for name, xb in (("near", -0.014), ("far", -0.3)):
        x = jnp.asarray([xb, 0.0, 0.0, xb, 0.12], jnp.float32)         # the pusher above the box, out of contact
        state = policy_init(LAMBDA_TRUE, s, 0)
        state = state._replace(best=jnp.float32(0.0), idle=jnp.float32(s.stall.after_s))
        state, _, _ = jax.jit(plan_step, static_argnames=("settings",))(
            state, x, contour=problem.contour, scene=problem.local_scene, settings=s)
        assert int(state.stalls) == 1 and bool(state.push.active)
        plans[name] = state
    assert float(plans["near"].push.clearance) == pytest.approx(s.push_plan.endgame.clearance_m)
    assert float(plans["far"].push.clearance) == pytest.approx(s.push_plan.clearance_m)
    assert float(plans["near"].stretch) == 1.0 and float(plans["far"].stretch) == s.stall.horizon_scale


@settings(max_examples=20, deadline=None)
@given(x=st.tuples(st.floats(-0.3, 0.3), st.floats(-0.3, 0.3), st.floats(-3.1, 3.1), st.floats(0.08, 0.2),
                   st.floats(-3.1, 3.1)),
       target=st.floats(-3.1, 3.1), way=st.sampled_from([-1.0, 1.0]), left=st.floats(0.0, 0.2),
       time_left=st.floats(-1.0, 10.0))
def test_an_inactive_plan_is_followed_as_idle_push_says(x, target, way, left, time_left) -> None:
    """The policy skips follow_push while no plan is active (a ``cond``): idle_push must give what it would."""
    problem = Problem(RECT, (0.0, 0.0, 0.0))
    bx, by = x[3] * np.cos(x[4]), x[3] * np.sin(x[4])          # the pusher 8–20 cm from the centroid
    state = jnp.asarray([x[0], x[1], x[2], x[0] + bx, x[1] + by], jnp.float32)
    plan = push_plan_init()._replace(target=jnp.float32(target), way=jnp.float32(way), left_m=jnp.float32(left),
                                     time_left=jnp.float32(time_left), direction=jnp.asarray([0.6, 0.8], jnp.float32))
    scene = plan_margin(state, problem.local_scene, problem.weights)
    followed = jax.jit(follow_push, static_argnames=("weights", "settings", "speed", "period"))(
        plan, state, problem.contour, scene, weights=problem.weights, params=LAM, mu=MU, settings=PP, speed=MP.v_clip,
        period=MP.control_period)
    idle = idle_push(plan, MP.control_period)
    for a, b in zip(jax.tree.leaves(followed), jax.tree.leaves(idle), strict=True):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))


def test_until_a_stall_the_controller_commands_what_it_did_without_the_plan() -> None:
    problem = Problem(RECT, (0.3, 0.1, 0.5))
    pose, pusher = (0.0, 0.0, 0.0), (-0.13, 0.0)
    runs = []
    for pp in (PushPlanSettings(enabled=False), PP):
        ctrl = PushingController(problem, params=LAMBDA_TRUE, seed=3,
                                 settings=ControllerSettings(mppi=MPPISettings(num_samples=64), push_plan=pp))
        runs.append(np.array([ctrl.command(pose, pusher) for _ in range(5)]))
        assert ctrl.push_plans == (0 if pp.enabled else None)
    np.testing.assert_array_equal(runs[0], runs[1])
    assert np.abs(runs[0]).max() > 0


@pytest.mark.parametrize("kwargs, message", [
    ({"targets": 1}, "push_plan.targets must be a whole number >= 2"),
    ({"lengths_m": ()}, "push_plan.lengths_m must be a non-empty list"),
    ({"lengths_m": (0.05, -0.01)}, "push_plan.lengths_m must be a non-empty list"),
    ({"enabled": "yes"}, "push_plan.enabled must be true or false"),
    ({"tolerance": 0.0}, "push_plan.tolerance"),
    ({"endgame": {"targets": 48}}, "push_plan.endgame must be an EndgamePushSettings"),
])
def test_bad_settings_are_refused_in_one_line(kwargs: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        PushPlanSettings(**kwargs)


@pytest.mark.parametrize("kwargs, message", [
    ({"angles_rad": (0.0, 0.4)}, r"push_plan.endgame.angles_rad must be .* friction cone"),
    ({"angles_rad": ()}, "push_plan.endgame.angles_rad must be a non-empty list"),
    ({"lengths_m": (0.01, 0.0)}, "push_plan.endgame.lengths_m must be a non-empty list of positive"),
    ({"targets": 1}, "push_plan.endgame.targets must be a whole number >= 2"),
    ({"clearance_m": -0.001}, "push_plan.endgame.clearance_m"),
    ({"min_gain": -1.0}, "push_plan.endgame.min_gain"),
    ({"enabled": 1}, "push_plan.endgame.enabled must be true or false"),
])
def test_bad_endgame_settings_are_refused_in_one_line(kwargs: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        EndgamePushSettings(**kwargs)
