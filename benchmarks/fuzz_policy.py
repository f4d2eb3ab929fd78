"""Fuzz the controller's pure step with hostile observations and count what goes wrong.

    python benchmarks/fuzz_policy.py [--observations 100000] [--shapes rect,tee]

Each lane is a controller with the UKF on (λ_pred starts at [15, 0, 0]) fed a sequence of
observations: a pusher walking into the object and pushing it (from the model plant), with
hostile frames mixed in at random: a far-off object or pusher (up to ±0.5 m, one frame),
a far-off heading, a frame repeated, huge but finite values (1e6 m), and bursts of all of
them. ``policy_step`` runs vmapped over the lanes and scanned over the steps, the way the
batched simulator runs it. Counted at the end: lanes whose λ or covariance is non-finite,
commands that are non-finite or outside ±v_max/√2, and the estimator's own counts of
rejected frames and resets. The last line printed is JSON. ``--samples`` sets MPPI's K.
"""

from __future__ import annotations

import argparse
import json
import time
from functools import partial

import jax
import jax.numpy as jnp
import numpy as np

from dexpush.control.controller import ControllerSettings, policy_init, policy_step
from dexpush.control.mppi import MPPISettings
from dexpush.experiments.registry import make_shape
from dexpush.model.cgvmm import Contour
from dexpush.problem.scene import Scene
from dexpush.world.model_plant import ModelPlant


def clean_sequences(shape_name: str, lanes: int, steps: int, seed: int) -> np.ndarray:
    """(steps, lanes, 5) observations of pushes on the model plant (pusher heading at the object)."""
    shape = make_shape(shape_name)
    rng = np.random.default_rng(seed)
    ang = rng.uniform(-np.pi, np.pi, lanes)
    plant = ModelPlant(shape)
    obs = plant.reset(np.zeros((lanes, 3)), (shape.bounding_radius + 0.02) * np.stack([np.cos(ang), np.sin(ang)], -1))
    out = []
    for _ in range(steps):
        d = obs.object_pose[:, :2] - obs.pusher_xy
        v = 0.06 * d / np.linalg.norm(d, axis=-1, keepdims=True) + rng.normal(0, 0.01, (lanes, 2))
        obs = plant.step(np.clip(v, -0.07, 0.07), 0.04)
        out.append(obs.state)
    return np.asarray(out)


def corrupt(X: np.ndarray, rate: float, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    X = X.copy()
    steps, lanes, _ = X.shape
    kind = rng.integers(0, 6, (steps, lanes))
    hit = rng.random((steps, lanes)) < rate
    far = rng.uniform(-0.5, 0.5, (steps, lanes, 2))
    for t, k in zip(*np.nonzero(hit)):
        match kind[t, k]:
            case 0:
                X[t, k, :2] += far[t, k]
            case 1:
                X[t, k, 3:] += far[t, k]
            case 2:
                X[t, k, 2] += rng.uniform(-np.pi, np.pi)
            case 3:
                X[t, k] = X[t - 1, k]
            case 4:
                X[t, k, rng.integers(0, 5)] = rng.choice([-1e6, 1e6])
            case _:
                X[t:t + 5, k] += rng.uniform(-0.5, 0.5, (min(5, steps - t), 5))
    return X


def run(shape_name: str, lanes: int, steps: int, rate: float, seed: int, samples: int) -> dict:
    shape = make_shape(shape_name)
    settings = ControllerSettings(estimate_params=True, mppi=MPPISettings(num_samples=samples))
    contour, scene = Contour.of(shape), Scene.make(shape, (0.3, 0.0, 0.0), (), settings.weights)
    X = corrupt(clean_sequences(shape_name, lanes, steps, seed), rate, seed + 1)
    init = jax.vmap(lambda s: policy_init((15.0, 0.0, 0.0), settings, s))(jnp.arange(lanes))
    step = partial(policy_step, contour=contour, scene=scene, settings=settings)

    @jax.jit
    def go(state, xs):
        def body(st, x):
            st, u, _ = jax.vmap(lambda a, b: step(a, b, True))(st, x)
            return st, u
        return jax.lax.scan(body, state, xs)

    t0 = time.perf_counter()
    final, U = go(init, jnp.asarray(X, jnp.float32))
    U = np.asarray(U)
    wall = time.perf_counter() - t0
    est = final.estimator
    lam_bad = ~np.all(np.isfinite(np.asarray(est.filter.mean)), -1) | ~np.all(
        np.isfinite(np.asarray(est.filter.cov)).reshape(lanes, -1), -1)
    limit = settings.mppi.v_clip * (1 + 1e-6)
    return {"shape": shape_name, "observations": int(steps * lanes), "lanes": lanes,
            "hostile_frames": int(np.sum(np.any(X != clean_sequences(shape_name, lanes, steps, seed), -1))),
            "lanes_with_nonfinite_estimate": int(lam_bad.sum()),
            "nonfinite_commands": int(np.sum(~np.isfinite(U))),
            "commands_out_of_limits": int(np.sum(np.abs(U) > limit)),
            "zero_commands_after_step_10": int(np.sum(np.all(U[10:] == 0, -1))),
            "frames_rejected_by_gate": int(np.asarray(est.rejected).sum()),
            "estimator_resets": int(np.asarray(est.resets).sum()), "wall_s": round(wall, 1)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--observations", type=int, default=100_000, help="per shape (default 100000)")
    ap.add_argument("--shapes", default="rect,tee")
    ap.add_argument("--rate", type=float, default=0.05, help="share of hostile frames (default 0.05)")
    ap.add_argument("--lanes", type=int, default=500)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--samples", type=int, default=128,
                    help="MPPI samples K (default 128: the fuzz aims at the estimator and the command path, whose "
                         "code does not depend on K; 1024 only makes it 8x slower)")
    args = ap.parse_args()
    steps = max(1, args.observations // args.lanes)
    rows = [run(s, args.lanes, steps, args.rate, args.seed, args.samples) for s in args.shapes.split(",")]
    for r in rows:
        print(" ".join(f"{k}={v}" for k, v in r.items()), flush=True)
    print(json.dumps({"results": rows}))


if __name__ == "__main__":
    main()
