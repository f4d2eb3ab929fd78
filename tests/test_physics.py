"""The MuJoCo physics plant (docs/conventions.md#plants): scripted pushes behave as rigid bodies on a table should."""

from __future__ import annotations

import numpy as np
import pytest

from dexpush import Shape
from dexpush.world.physics_plant import PhysicsPlant, PhysicsSettings, _support_points

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


@pytest.mark.parametrize("name,corners,reference,pusher,pieces", [
    # an L: the pusher starts in the notch, inside the L's convex hull but 1.1 cm clear of the L
    ("L", [[0, 0], [0.1, 0], [0.1, 0.03], [0.03, 0.03], [0.03, 0.1], [0, 0.1]], (0.015, 0.015), (0.04, 0.04), 2),
    # a U-like block with a shallow slot: the pusher starts in the slot, 1.5 cm above its floor
    ("U", [[0, 0], [0.2, 0], [0.2, 0.06], [0.15, 0.06], [0.13, 0.04], [0.07, 0.04], [0.05, 0.06], [0, 0.06]],
     (0.1, 0.01), (0.0, 0.055), 4),
])
def test_a_concave_polygon_is_simulated_as_itself_not_its_hull(name: str, corners: list, reference: tuple,
                                                                 pusher: tuple, pieces: int) -> None:
    """A non-convex polygon becomes convex prisms that tile it: the pusher moves freely in the notch
    (MuJoCo would otherwise collide it with the hull) and pushes the object once it reaches the faces."""
    from dexpush.world.physics_plant import convex_prisms

    shape = Shape.polygon(corners, reference=reference, name=name)
    assert len(convex_prisms(shape)) == pieces
    plant = PhysicsPlant(shape)
    plant.reset((0.0, 0.0, 0.0), pusher)
    direction = -np.asarray(pusher) / np.linalg.norm(pusher)                  # towards the reference
    obs = plant.step(0.05 * direction, 0.1)                                    # 5 mm: still clear
    assert np.max(np.abs(obs.object_pose)) < 1e-6
    obs = plant.step(0.05 * direction, 0.5)                                    # 25 mm more: pushes it
    assert float(np.asarray(obs.object_pose[:2]) @ direction) > 0.005


@pytest.mark.parametrize("pressure", ["ring", "corners"])
def test_support_pressure_patterns(pressure: str) -> None:
    """A ring keeps the support points near the outline, corners near the hull's corners; both keep the
    centre of pressure where symmetry puts it."""
    rect = Shape.rectangle()
    every = _support_points(rect, 0.01)
    pts = _support_points(rect, 0.01, pressure, 0.02)
    assert 3 <= len(pts) < len(every)
    to_edge = np.minimum(0.10 - np.abs(pts[:, 0]), 0.06 - np.abs(pts[:, 1]))
    if pressure == "ring":
        assert np.all(to_edge <= 0.02 + 1e-9)
    else:
        assert np.all(np.hypot(0.10 - np.abs(pts[:, 0]), 0.06 - np.abs(pts[:, 1])) <= 0.02 + 1e-9)
    np.testing.assert_allclose(pts.mean(0), 0.0, atol=1e-9)


def test_randomized_worlds_are_seeded_and_within_their_ranges() -> None:
    from dexpush.experiments.registry import make_plant, world_sensor
    from dexpush.world.sensing import SensorSettings

    worlds = [PhysicsSettings.randomized(s) for s in range(40)]
    assert PhysicsSettings.randomized(3) == worlds[3] and worlds[3] != worlds[4]
    for w in worlds:
        assert 0.15 <= w.table_friction <= 0.5 and 0.15 <= w.pusher_friction <= 0.5
        assert 0.2 <= w.mass <= 2.0 and 0.8 <= w.pusher_radius_scale <= 1.2
    assert {w.pressure for w in worlds} == {"uniform", "ring", "corners"}
    cam = world_sensor("physics-random", SensorSettings.realistic(), 5)
    assert cam == SensorSettings.randomized(5) and 0.5e-3 <= cam.pos_std_m <= 2e-3 and cam.rate_hz in (10, 15, 30)
    assert world_sensor("physics", None, 5) is None
    plant = make_plant("physics-random", Shape.tee(), 5)
    assert plant.settings == PhysicsSettings.randomized(5)
    obs = plant.reset([0.0, 0.0, 0.0], [-0.2, 0.0])
    for _ in range(5):
        obs = plant.step([0.1, 0.0], 0.04)
    assert np.all(np.isfinite(obs.object_pose))
    with pytest.raises(ValueError, match="pressure"):
        PhysicsSettings(pressure="random")


def test_pusher_friction_acts_on_its_sliding(rect_plant: PhysicsPlant) -> None:
    """Pushed 5° off the face normal, inside the 14° friction cone (μ_c = 0.25), the pusher mostly sticks:
    it slides along the face far less than its 4.4 mm of tangential travel, and the slider turns. (A mocap
    pusher, which MuJoCo gives no velocity, slid 4.2 mm: its friction never acted.)"""
    rect_plant.reset([0.0, 0.0, 0.0], [-0.111, 0.0])
    a = np.radians(5.0)
    for _ in range(25):
        rect_plant.step(0.05 * np.array([np.cos(a), np.sin(a)]), 0.04)
    x = rect_plant.state
    c, s = np.cos(x[2]), np.sin(x[2])
    slide = -s * (x[3] - x[0]) + c * (x[4] - x[1])     # the pusher along the face, in the body frame
    assert abs(slide) < 2.5e-3, slide
    assert abs(np.degrees(x[2])) > 0.8
