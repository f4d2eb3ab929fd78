"""Latency of ``PushingController.act`` in a robot loop with a jittering, lossy camera.

    python benchmarks/act_latency.py [--calls 2000] [--estimate]

A controller (UKF on with ``--estimate``) pushes the box on the model plant seen through a
camera whose frame period jitters (15 Hz ± 20 %, drawn per frame) with 60 ms latency and 5 %
lost frames. Times every ``act`` call after ``reset`` (which compiles) and prints the median,
the 99th percentile and their ratio (the target, issue 16: p99 within 2× the median, no call
recompiling), and how long ``reset`` took (it compiles; with ``--cache DIR`` a second
process loads the programs from DIR instead). The last line printed is JSON.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

import dexpush
from dexpush.common.interfaces import Observation
from dexpush.world.model_plant import ModelPlant


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--calls", type=int, default=2000)
    ap.add_argument("--estimate", action="store_true", help="run the UKF too (mppi-ukf)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--cache", default=None, metavar="DIR",
                    help="use JAX's persistent compilation cache in DIR (run twice: the second reset loads)")
    args = ap.parse_args()
    if args.cache:
        from dexpush.common import compile_cache

        compile_cache.enable(args.cache)
    rng = np.random.default_rng(args.seed)
    shape = dexpush.Shape.rectangle()
    settings = dexpush.ControllerSettings(estimate_params=args.estimate)
    ctrl = dexpush.PushingController(shape, (0.6, 0.3, 0.0), params=(15.0, 0.0, 0.0), settings=settings)
    plant = ModelPlant(shape)
    obs = plant.reset((0.0, 0.0, 0.0), (-0.16, 0.0))
    t0 = time.perf_counter()
    ctrl.reset(obs.object_pose, obs.pusher_xy)
    reset_s = time.perf_counter() - t0
    T, latency = 0.04, 0.06
    pending: list[tuple[float, Observation]] = [(0.0, obs)]
    next_capture, clock, ms = 0.0, 0.0, []
    for _ in range(args.calls):
        arrived = [f for t, f in pending if t <= clock + 1e-9]
        pending = [(t, f) for t, f in pending if t > clock + 1e-9]
        frame = arrived[-1] if arrived else None
        period = float(1 / 15 * rng.uniform(0.8, 1.2))
        t0 = time.perf_counter()
        u = ctrl.act(frame, period)
        ms.append((time.perf_counter() - t0) * 1e3)
        obs = plant.step(u, T)
        clock += T
        while next_capture <= clock:
            next_capture += period
            if rng.random() > 0.05:
                pending.append((clock + latency, Observation(obs.object_pose, obs.pusher_xy, clock)))
        if np.hypot(*(obs.object_pose[:2] - [0.6, 0.3])) < 0.01:     # start over: keep pushing
            obs = plant.reset((0.0, 0.0, 0.0), (-0.16, 0.0))
            ctrl.reset()
            pending, next_capture, clock = [(0.0, obs)], 0.0, 0.0
    ms_a = np.asarray(ms)
    out = {"calls": len(ms), "estimate": args.estimate, "reset_s": round(reset_s, 2),
           "median_ms": round(float(np.median(ms_a)), 3), "p99_ms": round(float(np.percentile(ms_a, 99)), 3),
           "max_ms": round(float(ms_a.max()), 2)}
    out["p99_over_median"] = round(out["p99_ms"] / out["median_ms"], 2)
    print(f"act(): median {out['median_ms']} ms, p99 {out['p99_ms']} ms ({out['p99_over_median']}× the median), "
          f"max {out['max_ms']} ms over {len(ms)} calls; reset (compiles) {out['reset_s']} s")
    print(json.dumps(out))


if __name__ == "__main__":
    main()
