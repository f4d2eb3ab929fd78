"""Tasks, the obstacle test, and closed-loop episodes."""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np
import pytest

from dexpush import Shape
from dexpush.common.se2 import pose_error
from dexpush.experiments.runner import run_episode
from dexpush.experiments.scenarios import TASKS, Task, get_task, initial_conditions
from dexpush.model.cgvmm import Contour, contact_gap
from dexpush.problem.obstacles import collides
from dexpush.problem.problem import is_success
from dexpush.problem.scene import Scene


def test_tasks_match_the_spec() -> None:
    assert get_task("I").goal == (0.60, 0.30, 0.0)
    assert get_task("2").goal == pytest.approx((0.0, 0.0, np.pi / 2))
    assert get_task("obstacle").obstacles == ((0.30, 0.0, 0.05),)
    assert len(get_task("iv").polygons) == 4 and len(get_task("confined").obstacles) == 3
    assert get_task("5").region is not None and get_task("edge").workspace == (-0.30, -0.35, 0.45, 0.35)
    with pytest.raises(ValueError, match="unknown task 'VI'"):
        get_task("VI")


@pytest.mark.parametrize("name", ["rect", "tee"])
def test_initial_conditions_are_seeded_and_within_spec(name: str) -> None:
    shape = Shape.rectangle() if name == "rect" else Shape.tee()
    for seed in range(20):
        pose, pusher = initial_conditions(TASKS["I"], shape, seed)
        again = initial_conditions(TASKS["I"], shape, seed)
        np.testing.assert_array_equal(pose, again[0])
        assert np.all(np.abs(pose[:2]) <= 0.02) and abs(pose[2]) <= np.radians(10)
        gap = float(contact_gap(Contour.of(shape), jnp.asarray(np.concatenate([pose, pusher]))))
        assert gap == pytest.approx(0.05, abs=1e-5)
    with pytest.raises(ValueError, match="seed"):
        initial_conditions(TASKS["I"], shape, -1)


def test_success_test() -> None:
    goal = (0.6, 0.3, 0.0)
    assert is_success(np.array([0.6, 0.3 + 0.0079, np.radians(2.9)]), goal)
    assert not is_success(np.array([0.6, 0.3 + 0.0081, 0.0]), goal)
    assert not is_success(np.array([0.6, 0.3, np.radians(3.1)]), goal)
    assert is_success(np.array([0.6, 0.3, 2 * np.pi + 0.01]), goal)  # wrapped heading
    _, head = pose_error(np.array([0, 0, np.pi - 0.01]), (0, 0, -np.pi + 0.01))
    assert head == pytest.approx(np.degrees(0.02))


def test_collision_covers_footprint_and_pusher() -> None:
    shape = Shape.rectangle()
    scene = Scene.make(shape, (0.6, 0, 0), ((0.30, 0.0, 0.05),))
    far = [0.0, 0.0, 0.0, -0.15, 0.0]
    touching_box = [0.30 - 0.10 - 0.049, 0.0, 0.0, -0.3, 0.0]       # right face 1 mm inside the disc
    clear_box = [0.30 - 0.10 - 0.051, 0.0, 0.0, -0.3, 0.0]
    disc_inside_box = [0.30, 0.0, 0.0, 0.0, 0.5]                     # disc wholly inside the box
    pusher_hit = [0.0, 0.0, 0.0, 0.30, 0.059]                        # pusher disc overlaps
    rotated_corner = [0.30 - 0.115, 0.0, np.pi / 4, -0.3, 0.0]       # corner of a turned box
    hits = np.asarray(collides(jnp.asarray([far, touching_box, clear_box, disc_inside_box, pusher_hit,
                                            rotated_corner]), scene))
    assert hits.tolist() == [False, True, False, True, True, True]


def test_short_closed_loop_episode_reaches_a_nearby_goal() -> None:
    task = Task("near", "nearby goal", (0.08, 0.0, 0.0))
    ep = run_episode(task, "rect", seed=1, max_steps=300)
    assert ep.record.success, ep.record
    assert ep.record.steps < 300 and ep.record.object_path_m > 0.05
    assert ep.states.shape == (ep.record.steps + 1, 5)


def test_effective_free_roaming_radius() -> None:
    from dexpush.problem.weights import CostWeights

    assert float(Scene.make(Shape.rectangle(), (0, 0, 0)).r_s) == pytest.approx(0.2)
    tee = Shape.tee()
    assert float(Scene.make(tee, (0, 0, 0)).r_s) == pytest.approx(tee.bounding_radius + 0.05)
    assert float(Scene.make(tee, (0, 0, 0), weights=CostWeights(r_s_clearance=None)).r_s) == pytest.approx(0.2)


def test_task_three_run_never_touches_the_obstacle() -> None:
    """The controller heads for the goal past the disc: no step ends in collision."""
    ep = run_episode("III", "rect", seed=0, max_steps=150)
    assert ep.record.collisions == 0
    assert ep.states[-1, 0] - ep.states[0, 0] > 0.1   # it did advance towards the obstacle's side


def test_the_cost_keeps_a_margin_that_the_reported_collision_does_not() -> None:
    """The planner's collision test uses discs grown by obstacle_margin_m; a trial fails only on a real touch."""
    from dexpush.problem.cost import running_cost
    from dexpush.problem.weights import CostWeights

    shape, w = Shape.rectangle(), CostWeights()
    scene = Scene.make(shape, (0.6, 0, 0), ((0.30, 0.0, 0.05),), w)
    gap = 0.5 * w.obstacle_margin_m                                   # clear of the disc, inside the margin
    near_box = jnp.asarray([0.30 - 0.10 - 0.05 - gap, 0.0, 0.0, -0.3, 0.0])
    near_pusher = jnp.asarray([0.0, 0.0, 0.0, 0.30, 0.05 + shape.pusher_radius + gap])
    clear = jnp.asarray([0.30 - 0.10 - 0.05 - 2 * w.obstacle_margin_m, 0.0, 0.0, -0.3, 0.0])
    for x in (near_box, near_pusher):
        assert not bool(collides(x, scene)) and bool(collides(x, scene, w.obstacle_margin_m))
        assert float(running_cost(x, scene, w)) >= 0.49 * w.C_margin        # half way into the margin
        assert float(running_cost(x, scene, CostWeights(C_margin=None))) >= 0.99 * w.C_pen
    assert float(running_cost(clear, scene, w)) < 1e6
    no_margin = CostWeights(obstacle_margin_m=0.0)
    assert float(running_cost(near_box, scene, no_margin)) < 1e6
    with pytest.raises(ValueError, match="obstacle_margin_m"):
        CostWeights(obstacle_margin_m=-0.01)
