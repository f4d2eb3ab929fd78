"""MPPI samples K against time per iteration and closed-loop success: a Pareto table in one run.

    python benchmarks/pareto.py [--sizes 128,256,512,1024,4096,16384] [--trials 30] [--out DIR]

For each K: the time of one MPPI iteration (rect and T, Task I scene; ``mppi_speed.py``'s
timing, best of 5 blocks) and, when pytorch-mppi is installed (``pip install -e ".[bench]"``),
pytorch-mppi driving the same dynamics and cost; then the success rate of MPPI+UKF with
unknown λ on the model plant, Tasks I and III with the T, seeds 0 … trials − 1
(``dexpush.experiments.benchmark.run_benchmark``, one resumable folder per K under ``--out``). All timing
runs first, before any trial, so the trials' processes do not disturb it. On a GPU machine
run it with ``JAX_PLATFORMS=cuda``. The last line printed is JSON.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import jax

from dexpush.control.controller import ControllerSettings
from dexpush.control.mppi import MPPISettings
from dexpush.experiments.benchmark import run_benchmark
from mppi_speed import dexpush_iteration, pytorch_mppi_iteration


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", default="128,256,512,1024,4096,16384", help="values of K, comma-separated")
    ap.add_argument("--trials", type=int, default=30, help="seeds 0 … trials−1 per task (default 30)")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--repeats", type=int, default=40, help="calls per timed block")
    ap.add_argument("--out", default="/tmp/dexpush_pareto", help="trial records, one folder per K (resumable)")
    args = ap.parse_args()
    sizes = [int(k) for k in args.sizes.split(",")]
    # dexpush for every K first, then pytorch-mppi: torch's OpenMP threads busy-wait after a call and
    # can take the second core from whatever is timed next
    reps = {K: max(3, args.repeats * 1024 // max(K, 1024)) for K in sizes}   # fewer calls for large K
    ours = {}
    for K in sizes:
        ours[K] = dexpush_iteration(K, reps[K])
        print(f"K = {K}: {ours[K][0]:.2f} ms rect, {ours[K][1]:.2f} ms T", file=sys.stderr, flush=True)
    timing = {}
    for K in sizes:
        try:
            theirs = pytorch_mppi_iteration(K, max(3, reps[K] // 5))
        except ImportError:
            theirs = float("nan")
        timing[K] = (*ours[K], theirs)
        print(f"K = {K}: pytorch-mppi {theirs:.2f} ms rect", file=sys.stderr, flush=True)
    rows = []
    for K in sizes:
        t0 = time.time()
        settings = ControllerSettings(mppi=MPPISettings(num_samples=K))
        records = run_benchmark(Path(args.out) / f"K{K}", tasks=("I", "III"), shapes=("tee",), params=("unknown",),
                                methods=("mppi-ukf",), seeds=range(args.trials), settings=settings,
                                workers=args.workers, figures=False, progress=False)
        ok = {t: sum(r["success"] for r in records if r["task"] == t) for t in ("I", "III")}
        rows.append({"K": K, "ms_rect": round(timing[K][0], 3), "ms_tee": round(timing[K][1], 3),
                     "pytorch_mppi_ms_rect": round(timing[K][2], 3), "success_I": ok["I"], "success_III": ok["III"],
                     "trials_per_task": args.trials, "wall_s": round(time.time() - t0, 1)})
        print(f"K = {K}: Task I {ok['I']}/{args.trials}, Task III {ok['III']}/{args.trials} "
              f"({rows[-1]['wall_s']} s)", file=sys.stderr, flush=True)
    dev = jax.devices()[0]
    print(f"# {dev.platform} ({dev.device_kind}); MPPI+UKF, unknown λ, model plant, T, seeds 0–{args.trials - 1}")
    print("| K | ms / iteration, rect | ms / iteration, T | pytorch-mppi, rect (ms) | Task I | Task III |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['K']} | {r['ms_rect']:.2f} | {r['ms_tee']:.2f} | {r['pytorch_mppi_ms_rect']:.2f} | "
              f"{r['success_I']}/{r['trials_per_task']} | {r['success_III']}/{r['trials_per_task']} |")
    print(json.dumps({"device": f"{dev.platform} {dev.device_kind}", "rows": rows}))


if __name__ == "__main__":
    main()
