"""Goal regions (dexpush.problem.goal_region; docs/goal_regions.md): what a region is, what its cost and its
success test read, a drop off the table's edge, their syntax, and the push to the edge on both plants."""

from __future__ import annotations

import json
from pathlib import Path

import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from dexpush import Shape
from dexpush.cli import main
from dexpush.experiments.registry import make_plant, make_shape
from dexpush.experiments.scenarios import get_task
from dexpush.problem.cost import goal_distance_sq
from dexpush.problem.goal_region import AtWall, Overhang, PoseBox, footprint_centroid, parse_region
from dexpush.problem.problem import Problem
from dexpush.problem.regions import wall

TABLE = (-0.30, -0.35, 0.45, 0.35)
PLATE = Shape.ellipse(0.12, 0.12, name="plate")


def overhang_problem(shape: Shape = PLATE, depth: float = 0.06) -> Problem:
    return Problem(shape, Overhang("+x", depth), workspace=TABLE)


def states(poses: np.ndarray) -> np.ndarray:
    """Poses (N, 3) with the pusher 1 m away, clear of everything but the table (x inside it)."""
    return np.c_[poses, np.full(len(poses), -0.25), np.zeros(len(poses))]


def test_overhang_success_is_the_depth_with_the_centre_of_mass_on_the_table() -> None:
    p = overhang_problem()
    # the plate's rim passes x = 0.45 by x + 0.12 − 0.45: at least 6 cm from x = 0.39 on; the centre falls at 0.45
    for x, ok, fell in ((0.30, False, False), (0.385, False, False), (0.395, True, False), (0.449, True, False),
                        (0.451, False, True)):
        assert bool(p.success(np.array([x, 0.0, 1.0]))) is ok, x
        assert bool(p.dropped(np.array([x, 0.0, 1.0]))) is fell, x
    # overhanging is no touch; the drop is judged as one, which ends a trial as a failure
    assert list(p.collides(states(np.array([[0.40, 0, 0], [0.46, 0, 0]])))) == [False, True]
    # the pusher stays on the table (the cost's own bound); the table's other edges bound the footprint too
    rows = lambda a: len(np.unique(np.asarray(a), axis=0))    # noqa: E731  (padding repeats a row)
    assert rows(p.scene.edge_bounds) == 1 and rows(p.scene.bounds) == 3
    assert p.table == TABLE


def test_jnp_and_numpy_success_agree_and_the_goal_marker_is_inside() -> None:
    p = overhang_problem(Shape.tee())
    rng = np.random.default_rng(1)
    poses = np.c_[rng.uniform(0.2, 0.5, 400), rng.uniform(-0.3, 0.3, 400), rng.uniform(-np.pi, np.pi, 400)]
    host = p.success(poses)
    device = np.asarray(p.success(jnp.asarray(poses, jnp.float32), jnp))
    near_edge = np.abs(poses[:, 0] - 0.45) < 1e-4
    assert np.array_equal(host[~near_edge], device[~near_edge]) and 20 < host.sum() < 380
    assert p.success(np.asarray(p.goal)) and p.goal_error(np.asarray(p.goal)) == (0.0, 0.0)


@settings(max_examples=10)
@given(st.integers(0, 2**16))
def test_the_cost_is_zero_only_where_the_test_passes_with_room(seed: int) -> None:
    """Zero goal distance (no heading in an overhang) is inside the region with room for the aim: 5 mm back
    from the edge the overhang is still enough, 2 cm on the centre of mass is still on the table; and the
    distance never falls as the object backs away from the edge."""
    p = overhang_problem(Shape.ellipse())
    rng = np.random.default_rng(seed)
    q = np.c_[rng.uniform(0.38, 0.46, 2000), rng.uniform(-0.3, 0.3, 2000), rng.uniform(-np.pi, np.pi, 2000)]

    def d2(poses: np.ndarray) -> np.ndarray:
        x = jnp.asarray(np.c_[poses, np.zeros((len(poses), 2))], jnp.float32)
        return np.asarray(goal_distance_sq(x, p.scene, 0.1))

    here, back = d2(q), d2(q - [0.05, 0, 0])      # (arrays of one shape: one compilation for every example)
    zero = here < 1e-10
    assert zero.sum() > 20
    assert p.success(q[zero] - [0.0049, 0, 0]).all() and p.success(q[zero] + [0.0199, 0, 0]).all()
    inner = q[:, 0] < 0.43          # (beyond, backing away brings the centre of mass onto the table)
    assert np.all(back[inner] >= here[inner] - 1e-7)


def test_the_centroid_is_the_centre_of_mass() -> None:
    assert np.allclose(footprint_centroid(Shape.rectangle()), 0.0, atol=1e-12)
    tee = Shape.tee()
    bar, stem = 0.20 * 0.05, 0.05 * 0.15            # the T's bar above its stem: its centroid lies in the bar's half
    assert footprint_centroid(tee)[1] > -0.05 and bar > stem


@pytest.mark.parametrize("make, message", [
    (lambda: Problem(PLATE, Overhang("+x", 0.06)), "needs a workspace"),
    (lambda: overhang_problem(depth=0.11), "more than the object allows"),
    (lambda: Problem(PLATE, Overhang("45", 0.06), workspace=TABLE), "no workspace edge faces"),
    (lambda: Problem(PLATE, Overhang("+x", -0.01), workspace=TABLE), "overhang depth"),
    (lambda: Problem(Shape.rectangle(), AtWall(2, 0.03, "-x"), polygons=(wall(0.4, -0.2, 0.4, 0.2, 0.02),)),
     "names polygon 2"),
    (lambda: Problem(Shape.rectangle(), AtWall(0, 0.012, "-x"), polygons=(wall(0.4, -0.2, 0.4, 0.2, 0.02),)),
     "leaves no room"),
    (lambda: Problem(Shape.rectangle(), PoseBox((0.3, 0.1, 0.0), 0.0, 0.01)), "x tolerance"),
])
def test_bad_regions_are_one_line(make, message: str) -> None:
    with pytest.raises(ValueError, match=message) as info:
        make()
    assert "\n" not in str(info.value)


def test_at_wall_and_pose_box_regions() -> None:
    rect = Shape.rectangle()
    w = wall(0.4, -0.2, 0.4, 0.2, 0.02)              # its −x face at x = 0.39, from y = −0.2 to 0.2
    p = Problem(rect, AtWall(0, 0.03, "-x"), polygons=(w,))
    assert p.success(np.asarray(p.goal)) and not p.collides(states(np.asarray([p.goal])))[0]
    # the box's +x side (x + 0.1) within 3 cm of the face, its centre in front of the face
    assert p.success(np.array([0.265, 0.0, 0.0])) and not p.success(np.array([0.255, 0.0, 0.0]))
    assert not p.success(np.array([0.28, 0.25, 0.0]))            # past the wall's end
    b = Problem(rect, PoseBox((0.3, 0.1, 0.0), 0.05, 0.01))
    assert b.success(np.array([0.345, 0.1, 0.02])) and not b.success(np.array([0.3, 0.115, 0.0]))
    assert not b.success(np.array([0.3, 0.1, np.radians(4)]))     # the heading as in the paper's test
    # the cost aims within half the tolerance: zero there, more beyond
    at = [float(goal_distance_sq(jnp.asarray([x, 0.1, 0.0, 0, 0], jnp.float32), b.scene, 0.1)) for x in (0.32, 0.33)]
    assert at[0] == 0.0 < at[1]


def test_a_goal_pose_keeps_its_scene() -> None:
    p = Problem(Shape.rectangle(), (0.6, 0.3, 0.0), workspace=(-0.5, -0.5, 1.0, 1.0))
    assert p.region is None and not p.scene.has_region and float(p.scene.heading_weight) == 1.0
    assert p.table is None and not p.dropped(np.array([5.0, 0.0, 0.0]))


def test_region_syntax_and_scene_files(tmp_path: Path) -> None:
    assert parse_region("overhang:+x,0.06,0.03") == Overhang("+x", 0.06, 0.03)
    assert parse_region("box:0.3,0.1,90deg,0.05,0.01") == PoseBox((0.3, 0.1, np.pi / 2), 0.05, 0.01)
    assert parse_region("wall:1,-y,0.03") == AtWall(1, 0.03, "-y")
    from dexpush.problem.scene_file import load_scene

    path = tmp_path / "edge.toml"
    path.write_text('workspace = [-0.3, -0.35, 0.45, 0.35]\ngoal_region = "overhang:+x,0.06"\n')
    assert load_scene(path).region == Overhang("+x", 0.06)
    path.write_text('goal_region = "overhang:+q,0.06"\n')
    with pytest.raises(ValueError, match=r"edge\.toml: a direction is"):
        load_scene(path)


def test_the_physics_table_holds_the_plate_until_its_centre_passes_the_edge() -> None:
    tilts = {}
    for x in (0.43, 0.46):
        plant = make_plant("physics", make_shape("plate"), 0, TABLE)
        plant.reset((x, 0.0, 0.0), (x - 0.2, 0.0))
        for _ in range(20):
            plant.step((0.0, 0.0))
        tilts[x] = plant.tilt_deg
    assert tilts[0.43] < 0.5 < 10 < tilts[0.46]
    assert make_plant("physics", make_shape("plate")).settings.height == 0.005


def test_task_v_pushes_the_plate_over_the_edge_on_the_physics_plant(tmp_path: Path, capsys) -> None:
    """The push to the edge, end to end on MuJoCo with a realistic camera (the CI run of Task V)."""
    assert get_task("edge").region == Overhang("+x", 0.06)
    code = main(["run", "--task", "V", "--shape", "plate", "--plant", "physics", "--camera", "realistic",
                 "--method", "mppi-ukf", "--params", "unknown", "--seed", "3", "--no-animation", "--quiet",
                 "--out", str(tmp_path)])
    summary = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert code == 0 and summary["success"] and summary["dropped"] is False and summary["collisions"] == 0
    assert summary["final_error_m"] == 0.0 and summary["time_s"] < 20


def test_a_physics_config_keeps_the_tasks_table(tmp_path: Path) -> None:
    from dexpush.cli.config import build_plant, build_task, load_config

    path = tmp_path / "run.toml"
    path.write_text("[run]\ntask = \"V\"\nshape = \"plate\"\nplant = \"physics\"\n\n[physics]\nmass = 0.3\n")
    config = load_config(path)
    plant = build_plant(config, PLATE, build_task(config.run).problem(PLATE).table)
    assert plant.settings.table == TABLE and plant.settings.mass == 0.3
