"""The Gymnasium environment ``dexpush/Push-v0``, driven by the MPPI controller as its policy.

    python examples/gym_env.py [--steps 600] [--plant model|physics]

Any Gymnasium agent sees the same observation (object pose, pusher position, goal pose),
action (pusher velocity, m/s) and reward (minus the paper's decoupled distance to the goal).
Here the policy is :class:`dexpush.PushingController`; prints the reward every 25 steps and
a one-line JSON summary.
"""

from __future__ import annotations

import argparse
import json

import gymnasium as gym
import numpy as np

import dexpush
import dexpush.env  # registers dexpush/Push-v0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--steps", type=int, default=600, help="environment steps at most (default 600)")
    ap.add_argument("--plant", default="model", choices=["model", "physics"])
    args = ap.parse_args()

    env = gym.make("dexpush/Push-v0", task="II", shape="rect", plant=args.plant)
    obs, info = env.reset(seed=0)
    goal = obs[5:8]
    policy = dexpush.PushingController(dexpush.Shape.rectangle(), goal, params=dexpush.LAMBDA_TRUE)
    policy.reset(obs[:3], obs[3:5])
    first = None
    for t in range(args.steps):
        action = policy.command(obs[:3], obs[3:5])
        obs, reward, terminated, truncated, info = env.step(action.astype(np.float32))
        first = reward if first is None else first
        if t % 25 == 0:
            print(f"step {t:4d}  reward {reward:+.4f}  heading {np.degrees(obs[2]):6.1f}°")
        if terminated or truncated:
            break
    print(json.dumps({"steps": t + 1, "first_reward": round(float(first), 4), "last_reward": round(float(reward), 4),
                      "is_success": bool(info["is_success"])}))


if __name__ == "__main__":
    main()
