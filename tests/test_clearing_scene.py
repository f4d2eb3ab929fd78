"""The clearing demonstration's scene, without a robot: the table, props and bin, the plate's starts, the
hand's grasp orientations, and where the planner lets the plate and the fingers go on the arm."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from dexpush.experiments.clearing import ClearingScene
from dexpush.experiments.robot_trial import RobotSettings, robot_area
from dexpush.problem.regions import workspace_halfplanes
from dexpush.robot.pick import hand_down, hand_level
from dexpush.robot.tabletop import Bin, Prop, Tabletop


def test_props_and_tables_refuse_what_no_hand_or_table_can_be() -> None:
    with pytest.raises(ValueError, match="hand opens 80 mm"):
        Prop("pot", (0.0, 0.0), size=0.05)
    with pytest.raises(ValueError, match="cylinder or a box"):
        Prop("cup", (0.0, 0.0), kind="sphere")
    with pytest.raises(ValueError, match="distinct names"):
        Tabletop(props=(Prop("cup", (0.0, 0.0)), Prop("cup", (0.1, 0.0))))
    with pytest.raises(ValueError, match="x_hi > x_lo"):
        Tabletop(table=(0.5, -0.3, 0.4, 0.3))
    with pytest.raises(ValueError, match="floor below its rim"):
        Bin((0.0, 0.0), floor_z=-0.05, rim_z=-0.1)


def test_the_bin_holds_what_lies_inside_it_below_its_rim() -> None:
    b = Bin((0.75, 0.55), half_size=(0.17, 0.17), floor_z=-0.25, rim_z=-0.06)
    assert b.holds((0.75, 0.55, -0.24))
    assert b.holds((0.90, 0.40, -0.20))
    assert not b.holds((0.95, 0.55, -0.24))          # beside it
    assert not b.holds((0.75, 0.55, 0.0))            # above its rim (still carried, or on the table)
    assert not b.holds((0.75, 0.55, -0.75))          # under it, on the floor


def test_the_plate_starts_on_the_table_clear_of_the_props_and_short_of_the_edge() -> None:
    scene = ClearingScene()
    shape, task = scene.shape(), scene.task()
    problem = task.problem(shape)
    lo_x, lo_y, hi_x, hi_y = scene.table
    for seed in range(30):
        pose, _ = task.trial_start(shape, seed)
        corners = shape.footprint_world(pose)[0]
        assert np.all(corners >= [lo_x, lo_y]) and np.all(corners <= [hi_x, hi_y])
        assert not problem.success(pose)             # the push has something to do
        for prop in scene.props:
            assert np.hypot(*(pose[:2] - prop.xy)) > scene.plate_radius + prop.size + 0.01


def test_on_the_arm_the_plate_may_cross_the_pushing_edge_and_the_fingers_may_not() -> None:
    scene = ClearingScene()
    shape, task, frames = scene.shape(), scene.task(), scene.frames()
    problem = task.problem(shape)
    edge = scene.table[2]
    assert np.allclose(frames.to_base([edge, 0.0]), [scene.edge_m, 0.0])   # the edge faces the robot
    pose, pusher = task.trial_start(shape, 0)
    held, reach, _ = robot_area(problem, RobotSettings(place_task=False, driver=frames), frames, pose, pusher)
    assert max(x for x, _ in held) > edge + 0.06                      # past the edge by more than the goal
    assert max(x for x, _ in reach) <= edge + 1e-9                    # the fingers stay on the table
    goal = np.asarray(problem.goal)                                    # the region's nominal pose lies in the area
    rows = workspace_halfplanes(np.asarray(held))
    assert np.all(rows[:, :2] @ goal[:2] <= rows[:, 2])


@settings(max_examples=40, deadline=None)
@given(st.floats(-np.pi, np.pi))
def test_grasp_orientations_are_rotations_pointing_where_asked(angle: float) -> None:
    d = np.array([np.cos(angle), np.sin(angle)])
    for R in (hand_level(d), hand_down(angle)):
        assert np.allclose(R.T @ R, np.eye(3), atol=1e-12) and np.isclose(np.linalg.det(R), 1.0)
    level = hand_level(d)
    assert np.allclose(level[:, 2], [*d, 0.0]) and np.allclose(level[:, 1], [0.0, 0.0, 1.0])   # fingers one above
    down = hand_down(angle)
    assert np.allclose(down[:, 2], [0.0, 0.0, -1.0]) and np.allclose(down[:2, 0], d)


def test_beside_the_tables_corner_the_planner_finishes_the_push() -> None:
    """Where seed 12's push stalled on the arm with stop 54's code: the plate 4 mm short of its overhang,
    17 mm from the table's side, most of MPPI's samples paying the edges' or the reach's penalty. With the
    temperature's spread taken over the samples that paid none (``MPPISettings.spread_cap``) the planner walks
    behind the plate and pushes it into the region within a second on the model plant; with the spread over
    every sample it hovered there (benchmarks/temperature_spread.py: 5 of 10 loops within 16 s, in 244–325
    steps). The default planner has that cap."""
    from dexpush.control.controller import ControllerSettings, PushingController
    from dexpush.experiments.robot_trial import robot_problem
    from dexpush.experiments.runner import run_loop
    from dexpush.world.model_plant import ModelPlant

    scene = ClearingScene(props=())
    shape, task, frames = scene.shape(), scene.task(), scene.frames()
    problem = task.problem(shape, seed=12)
    pose, pusher = task.trial_start(shape, 12)
    problem = robot_problem(problem, *robot_area(problem, RobotSettings(place_task=False, driver=frames), frames,
                                                 pose, pusher))
    plate, fingers, params = np.array([0.386, -0.1827, -2.1747]), np.array([0.2642, -0.0959]), (17.4, 0.0, 0.0)
    assert not problem.success(plate)
    settings = ControllerSettings()
    assert settings.mppi.spread_cap == 1e6
    controller = PushingController(problem, params=params, settings=settings, seed=0)
    trial = run_loop(ModelPlant(shape, params), controller, problem, plate, fingers, max_steps=25)
    assert trial.success
