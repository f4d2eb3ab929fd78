"""The model plant: docs/conventions.md#plants behaviour, batching and bad input."""

from __future__ import annotations

import numpy as np
import pytest

from dexpush import Shape
from dexpush.world.model_plant import ModelPlant


@pytest.fixture(scope="module")
def rect() -> Shape:
    return Shape.rectangle()


def test_push_through_cof_translates_and_off_centre_rotates(rect: Shape) -> None:
    plant = ModelPlant(rect, params=[25.0, 0.0, 0.0])
    plant.reset([0, 0, 0], [-0.12, 0.0])
    for _ in range(50):
        obs = plant.step([0.08, 0.0], 0.04)
    assert obs.object_pose[0] > 0.13 and abs(obs.object_pose[2]) < 1e-4
    plant.reset([0, 0, 0], [-0.12, 0.04])
    for _ in range(50):
        obs = plant.step([0.08, 0.0], 0.04)
    assert obs.object_pose[2] < -0.1  # pushing above the CoF turns the box clockwise
    assert obs.time == pytest.approx(2.0)


def test_retreating_pusher_leaves_object_at_rest(rect: Shape) -> None:
    plant = ModelPlant(rect)
    plant.reset([0.1, 0.2, 0.3], [0.1 - 0.111 * np.cos(0.3), 0.2 - 0.111 * np.sin(0.3)])
    for _ in range(20):
        obs = plant.step([-0.05, -0.02], 0.04)
    np.testing.assert_allclose(obs.object_pose, [0.1, 0.2, 0.3], atol=1e-7)  # float32 storage


def test_pusher_never_ends_a_step_more_than_1mm_inside() -> None:
    """64 noisy walks into the T at full speed, one batched plant (one table, one compile)."""
    rng = np.random.default_rng(0)
    plant = ModelPlant(Shape.tee())
    n = 64
    ang = rng.uniform(-np.pi, np.pi, n)
    plant.reset(np.zeros((n, 3)), 0.25 * np.stack([np.cos(ang), np.sin(ang)], -1))
    for _ in range(150):  # noisy walks towards the object at full speed
        obs = plant.observe()
        to_obj = -obs.pusher_xy + obs.object_pose[:, :2]
        v = 0.1 * to_obj / np.linalg.norm(to_obj, axis=-1, keepdims=True) + rng.normal(0, 0.03, (n, 2))
        plant.step(np.clip(v, -0.0707, 0.0707), 0.04)
    assert plant.max_penetration < 1e-3
    moved = np.linalg.norm(plant.observe().object_pose[:, :2], axis=-1)
    assert np.all(moved > 0.01)  # every pusher reached and pushed the T


def test_batched_plant_matches_single(rect: Shape) -> None:
    poses = np.array([[0, 0, 0], [0.1, 0, 0.5]])
    pushers = np.array([[-0.12, 0.01], [0.1 - 0.12 * np.cos(0.5), -0.12 * np.sin(0.5)]])
    vel = np.array([[0.07, 0.0], [0.05, 0.02]])
    batch = ModelPlant(rect)
    batch.reset(poses, pushers)
    for _ in range(10):
        ob = batch.step(vel)
    for i in range(2):
        single = ModelPlant(rect)
        single.reset(poses[i], pushers[i])
        for _ in range(10):
            os_ = single.step(vel[i])
        np.testing.assert_allclose(ob.state[i], os_.state, atol=1e-6)


@pytest.mark.parametrize("call, match", [
    (lambda p: p.step([np.nan, 0.0]), "NaN"),
    (lambda p: p.step([0.0, 0.0, 0.0]), r"\(\.\.\., 2\)"),
    (lambda p: p.step([0.0, 0.0], dt=0.0), "dt"),
    (lambda p: p.reset([0, 0, 0], [0.0, 0.0]), "inside the object"),
    (lambda p: p.reset([0, 0, np.inf], [0.3, 0.0]), "NaN or infinite"),
])
def test_bad_input(rect: Shape, call, match) -> None:
    plant = ModelPlant(rect)
    plant.reset([0, 0, 0], [0.3, 0.0])
    with pytest.raises(ValueError, match=match):
        call(plant)


def test_plant_settings_validated(rect: Shape) -> None:
    with pytest.raises(ValueError, match="substeps"):
        ModelPlant(rect, substeps=5)
    with pytest.raises(ValueError, match="β"):
        ModelPlant(rect, params=[-1.0, 0, 0])
    with pytest.raises(RuntimeError, match="reset"):
        ModelPlant(rect).step([0.0, 0.0])


def test_float32_matches_float64_and_substeps_converge(rect: Shape) -> None:
    """An off-centre push integrated in float32 tracks float64, and 10 substeps per period
    track 200 (the integration error is small against the 8 mm / 3° success test)."""
    import jax

    def run(substeps: int) -> np.ndarray:
        plant = ModelPlant(rect, substeps=substeps)
        plant.reset([0, 0, 0], [-0.12, 0.04])
        for _ in range(60):
            obs = plant.step([0.06, 0.01], 0.04)
        return obs.state

    x32 = run(10)
    with jax.enable_x64(True):
        x64 = run(10)
        x64_fine = run(200)
    assert abs(x64[2]) > 0.3  # it really turned
    np.testing.assert_allclose(x32, x64, atol=1e-5)
    assert np.linalg.norm(x64[:2] - x64_fine[:2]) < 1e-3
    assert abs(x64[2] - x64_fine[2]) < np.radians(0.5)
