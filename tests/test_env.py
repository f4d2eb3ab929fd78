"""The Gymnasium environment dexpush/Push-v0."""

from __future__ import annotations

import numpy as np
import pytest

gym = pytest.importorskip("gymnasium")

import dexpush.env  # noqa: E402,F401  (registers the id)
from dexpush.env import PushEnv  # noqa: E402


@pytest.mark.parametrize("plant", ["model", "physics"])
def test_env_passes_the_gymnasium_checker(plant: str) -> None:
    from gymnasium.utils.env_checker import check_env

    env = gym.make("dexpush/Push-v0", plant=plant, render_mode="rgb_array")
    check_env(env.unwrapped)
    env.reset(seed=0)
    img = env.render()
    assert img.dtype == np.uint8 and img.ndim == 3 and img.shape[2] == 3


def test_reward_is_the_negative_decoupled_distance_and_success_terminates() -> None:
    env = PushEnv(task="II", shape="rect")
    obs, info = env.reset(seed=3)
    assert obs.shape == (8,) and not info["is_success"]
    np.testing.assert_allclose(obs[5:], [0.0, 0.0, np.pi / 2], atol=1e-6)
    _, reward, terminated, truncated, _ = env.step([0.0, 0.0])
    q = obs[:3].astype(float)
    expected = -np.sqrt(q[0] ** 2 + q[1] ** 2 + 0.1 * (1 - np.cos(q[2] - np.pi / 2)))
    assert reward == pytest.approx(expected, abs=1e-6) and not terminated and not truncated
    # put the object on the goal: the next step terminates with success
    env.camera.reset([0.0, 0.0, np.pi / 2], [0.3, 0.3])
    _, reward, terminated, _, info = env.step([0.0, 0.0])
    assert terminated and info["is_success"] and reward == pytest.approx(0.0, abs=1e-6)


def test_truncation_and_bad_input() -> None:
    env = PushEnv(max_steps=2)
    env.reset(seed=0)
    assert not env.step([0.0, 0.0])[3]
    assert env.step([0.0, 0.0])[3]
    with pytest.raises(ValueError, match="action"):
        env.step([np.nan, 0.0])
    with pytest.raises(ValueError, match="plant"):
        PushEnv(plant="bullet")


def test_env_runs_a_users_own_plant_and_shape() -> None:
    from dexpush import Shape
    from test_runner import EulerPlant

    shape = Shape.polygon([[-0.05, -0.05], [0.08, -0.05], [0.0, 0.07]])
    env = PushEnv(task="I", shape=shape, plant=EulerPlant(shape))
    obs, info = env.reset(seed=1)
    assert obs.shape == (8,) and not info["is_success"]
    obs2, reward, *_ = env.step([0.05, 0.0])
    assert env.camera.plant.steps == 1 and np.all(np.isfinite(obs2)) and reward < 0
    with pytest.raises(ValueError, match="not a plant"):
        PushEnv(plant=object())
