"""Steps per second of the Gymnasium environments: PushEnv one by one, VectorPushEnv batched.

    python benchmarks/env_speed.py [--envs 1,16,256,1024] [--steps 200]

Random actions on Task I with the rect on the model plant; the first steps (compilation)
are not timed. Prints one JSON line per configuration: environment steps per second
(num_envs × vector steps / wall time).
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from dexpush.env import PushEnv, VectorPushEnv


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--envs", default="1,16,256,1024", help="comma-separated batch sizes (default 1,16,256,1024)")
    ap.add_argument("--steps", type=int, default=200, help="timed steps per configuration (default 200)")
    args = ap.parse_args()
    rng = np.random.default_rng(0)

    env = PushEnv()
    env.reset(seed=0)
    for _ in range(5):
        env.step(rng.uniform(-0.07, 0.07, 2))
    t0 = time.perf_counter()
    for _ in range(args.steps):
        *_, term, trunc, _ = env.step(rng.uniform(-0.07, 0.07, 2))
        if term or trunc:
            env.reset()
    wall = time.perf_counter() - t0
    print(json.dumps({"env": "PushEnv", "num_envs": 1, "steps_per_s": round(args.steps / wall, 1)}))

    for n in (int(v) for v in args.envs.split(",")):
        venv = VectorPushEnv(num_envs=n)
        venv.reset(seed=0)
        for _ in range(5):
            venv.step(rng.uniform(-0.07, 0.07, (n, 2)))
        t0 = time.perf_counter()
        for _ in range(args.steps):
            venv.step(rng.uniform(-0.07, 0.07, (n, 2)))
        wall = time.perf_counter() - t0
        print(json.dumps({"env": "VectorPushEnv", "num_envs": n, "steps_per_s": round(n * args.steps / wall, 1)}))


if __name__ == "__main__":
    main()
