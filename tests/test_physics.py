"""The MuJoCo physics plant (docs/conventions.md#plants): scripted pushes behave as rigid bodies on a table should."""

from __future__ import annotations

import numpy as np
import pytest

from dexpush import Shape
from dexpush.plants import PhysicsPlant, PhysicsSettings, _support_points

pytest.importorskip("mujoco")


@pytest.fixture(scope="module")
def rect_plant() -> PhysicsPlant:
    return PhysicsPlant(Shape.rectangle())


def test_object_at_rest_stays_put(rect_plant: PhysicsPlant) -> None:
    rect_plant.reset([0.1, -0.2, 0.3], [-0.3, 0.0])
    for _ in range(25):                                  # one second, pusher still and far away
        obs = rect_plant.step([0.0, 0.0])
    np.testing.assert_allclose(obs.object_pose, [0.1, -0.2, 0.3], atol=1e-6)


def test_central_push_translates_without_rotation(rect_plant: PhysicsPlant) -> None:
    rect_plant.reset([0.0, 0.0, 0.0], [-0.115, 0.0])    # touching the left face, aimed at the centre
    for _ in range(25):
        obs = rect_plant.step([0.1, 0.0])               # 0.1 m/s for 1 s: no tunnelling either
    x, y, th = obs.object_pose
    assert 0.09 < x < 0.105 and abs(y) < 1e-3 and abs(th) < np.radians(0.5)
    assert obs.pusher_xy[0] < x - 0.105                 # still outside the object
    assert rect_plant.max_penetration < 2e-3


@pytest.mark.parametrize("side, sign", [(0.03, -1), (-0.03, 1)])
def test_off_centre_push_rotates_the_expected_way(rect_plant: PhysicsPlant, side: float, sign: int) -> None:
    rect_plant.reset([0.0, 0.0, 0.0], [-0.115, side])   # above the centre → clockwise, below → ccw
    for _ in range(15):
        obs = rect_plant.step([0.1, 0.0])
    assert sign * obs.object_pose[2] > np.radians(3)


def test_released_object_stops_quickly(rect_plant: PhysicsPlant) -> None:
    rect_plant.reset([0.0, 0.0, 0.0], [-0.115, 0.0])
    for _ in range(10):
        rect_plant.step([0.1, 0.0])
    rect_plant.step([-0.1, 0.0], 0.02)                   # retreat: contact breaks at once
    before = rect_plant.observe().object_pose
    for _ in range(10):
        after = rect_plant.step([-0.1, 0.0]).object_pose
    assert np.linalg.norm(after[:2] - before[:2]) < 1e-3     # < 1 mm more in the next 0.4 s


def test_support_points_cover_a_union_once() -> None:
    tee = Shape.tee()
    pts = _support_points(tee, 0.01)
    assert len(pts) == len(np.unique(pts, axis=0)) and len(pts) > 50
    # every point lies inside the footprint
    from matplotlib.path import Path
    inside = np.any([Path(p).contains_points(pts) for p in tee.polygons], axis=0)
    assert inside.all()


def test_bad_input_is_named(rect_plant: PhysicsPlant) -> None:
    with pytest.raises(ValueError, match="inside"):
        rect_plant.reset([0.0, 0.0, 0.0], [0.0, 0.0])
    with pytest.raises(ValueError, match=r"NaN|finite"):
        rect_plant.step([np.nan, 0.0])
    with pytest.raises(ValueError, match="mass"):
        PhysicsSettings(mass=0.0)
