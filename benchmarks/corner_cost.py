"""What the two-contact corner model costs MPPI: one iteration on the T with and without it.

    python benchmarks/corner_cost.py [--samples 1024] [--repeats 200]

The same controller step (``plan_step``: sampling, rollouts through ``dexpush.model.cgvmm.step``,
cost, update and warm-start shift) for Task I on the T, once with the T's two concave corners
in the contour (what dexpush uses) and once with them removed (the single-contact model of
0.3.0). Issue 14 allows at most 20 % more time per iteration. Run on an idle machine; the two
variants are timed in alternating rounds so that drift in machine load hits both alike.
"""

from __future__ import annotations

import argparse
import json
import platform
import time
from collections.abc import Callable
from functools import partial

import jax
import numpy as np

from dexpush import Shape
from dexpush.control.controller import ControllerSettings, plan_step, policy_init
from dexpush.control.mppi import MPPISettings
from dexpush.model.cgvmm import LAMBDA_TRUE, Contour
from dexpush.problem.scene import Scene


def timing_args(doc: str | None) -> argparse.Namespace:
    """--samples (K), --repeats (timed calls per variant) and --rounds (alternations)."""
    ap = argparse.ArgumentParser(description=doc, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--samples", type=int, default=1024)
    ap.add_argument("--repeats", type=int, default=200)
    ap.add_argument("--rounds", type=int, default=5)
    return ap.parse_args()


def median_ms_alternating(calls: dict[str, Callable[[], object]], repeats: int, rounds: int) -> dict[str, float]:
    """Median ms per call of each compiled call, timed in ``rounds`` alternating rounds of
    ``repeats // rounds`` calls each, so that drift in machine load hits every variant alike."""
    times: dict[str, list[float]] = {name: [] for name in calls}
    for _ in range(rounds):
        for name, call in calls.items():
            for _ in range(repeats // rounds):
                t0 = time.perf_counter()
                jax.block_until_ready(call())
                times[name].append(time.perf_counter() - t0)
    return {name: float(np.median(t) * 1e3) for name, t in times.items()}


def time_plan_steps(variants: dict[str, tuple[Contour, Scene, ControllerSettings]], x: np.ndarray,
                    args: argparse.Namespace) -> dict[str, float]:
    """Median ms of one compiled ``plan_step`` from ``x`` for each (contour, scene, settings) variant."""
    calls = {}
    for name, (contour, scene, settings) in variants.items():
        fn = jax.jit(partial(plan_step, contour=contour, scene=scene, settings=settings))
        state = policy_init(LAMBDA_TRUE, settings, 0)
        jax.block_until_ready(fn(state, x))                   # compile outside the timing
        calls[name] = partial(fn, state, x)
    return median_ms_alternating(calls, args.repeats, args.rounds)


def print_ms_table(what: str, column: str, med: dict[str, float], args: argparse.Namespace) -> None:
    """The machine, ``what`` was timed, and a markdown table of ms per iteration per variant."""
    print(f"# {platform.machine()}, {what}, median of {args.repeats // args.rounds * args.rounds} iterations each")
    print(f"| {column} | ms per iteration |")
    print("|---|---|")
    for name, m in med.items():
        print(f"| {name} | {m:.3f} |")


def main() -> None:
    args = timing_args(__doc__)
    shape = Shape.tee()
    settings = ControllerSettings(mppi=MPPISettings(num_samples=args.samples))
    scene = Scene.make(shape, (0.6, 0.3, 0.0), (), settings.weights)
    with_corners = Contour.of(shape)
    variants = {"single contact": with_corners._replace(corners=None), "with corners": with_corners}
    x = np.array([0.0, 0.0, 0.0, -0.05, -0.08], np.float32)      # pusher below the bar, beside the stem
    med = time_plan_steps({name: (contour, scene, settings) for name, contour in variants.items()}, x, args)
    ratio = med["with corners"] / med["single contact"]
    print_ms_table(f"T Task I, K = {args.samples}, N_p = {settings.mppi.horizon}", "model", med, args)
    print(f"slowdown: {100 * (ratio - 1):+.1f} % (allowed: +20 %)")
    print(json.dumps({"ms_single_contact": round(med["single contact"], 4),
                      "ms_with_corners": round(med["with corners"], 4), "slowdown": round(ratio - 1, 4)}))


if __name__ == "__main__":
    main()
