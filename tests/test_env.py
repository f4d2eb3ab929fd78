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


def test_random_goals_and_an_adjustable_success_gate() -> None:
    env = PushEnv(task="I", goal="random", goal_range=((0.2, 0.4), (-0.1, 0.1)), success_position_m=0.05,
                  success_heading_deg=20.0)
    goals = []
    for seed in range(5):
        obs, info = env.reset(seed=seed)
        goals.append(obs[5:8])
        assert np.allclose(info["goal"], obs[5:8], atol=1e-6)
        assert 0.2 <= obs[5] <= 0.4 and -0.1 <= obs[6] <= 0.1
    assert len({tuple(np.round(g, 5)) for g in goals}) == 5
    again, _ = env.reset(seed=2)
    assert np.array_equal(again[5:8], goals[2])                   # reproducible by seed
    # a pose 3 cm and 10° off passes the 5 cm / 20° gate, not the default 8 mm / 3°
    g = env._goal
    env.camera.reset([g[0] + 0.03, g[1], g[2] + np.radians(10)], [g[0] + 0.5, g[1] + 0.5])
    assert env.step([0.0, 0.0])[2]
    strict = PushEnv(goal=(0.3, 0.0, 0.0))
    strict.reset(seed=0)
    strict.camera.reset([0.33, 0.0, np.radians(10)], [0.9, 0.5])
    assert not strict.step([0.0, 0.0])[2]
    with pytest.raises(ValueError, match="goal must be"):
        PushEnv(goal="anywhere")
    with pytest.raises(ValueError, match="success gate"):
        PushEnv(success_position_m=0.0)


def test_the_vector_env_matches_the_single_env_and_autoresets() -> None:
    from dexpush.env import VectorPushEnv

    venv = gym.make_vec("dexpush/Push-v0", num_envs=4, vectorization_mode="vector_entry_point", task="II")
    obs, info = venv.reset(seed=1)
    assert obs.shape == (4, 8) and obs.dtype == np.float32 and info["is_success"].shape == (4,)
    single = PushEnv(task="II")
    single.reset(seed=0)
    single.camera.reset(obs[2, :3].astype(float), obs[2, 3:5].astype(float))
    actions = np.tile([[0.05, 0.02]], (4, 1)).astype(np.float32)
    obs2, reward, terminated, truncated, _ = venv.step(actions)
    s_obs, s_reward, *_ = single.step(actions[2])
    np.testing.assert_allclose(obs2[2], s_obs, atol=1e-5)
    assert reward[2] == pytest.approx(s_reward, abs=1e-5) and not terminated.any() and not truncated.any()
    # an environment at its step limit is truncated and reset in the same step
    short = VectorPushEnv(num_envs=3, max_steps=2)
    first, _ = short.reset(seed=0)
    short.step(np.zeros((3, 2)))
    obs3, _, _, truncated, infos = short.step(np.zeros((3, 2)))
    assert truncated.all() and infos["_final_obs"].all()
    np.testing.assert_allclose(infos["final_obs"][:, :5], first[:, :5], atol=1e-6)   # held still: same pose
    assert not np.allclose(obs3[:, :5], first[:, :5])                                  # new starts
    with pytest.raises(ValueError, match="actions"):
        short.step(np.zeros((2, 2)))
