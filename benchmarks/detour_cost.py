"""What the detour goal distance and the stall watch cost MPPI: one Task III iteration on the T.

    python benchmarks/detour_cost.py [--samples 1024] [--repeats 200]

The same controller step (``plan_step``) for Task III on the T, with the paper's straight
goal distance of eq. (9) and no stall watch (the defaults), and with the two options on
(``CostWeights(detour=True)``, ``stall_after_s=4``): the goal distance measured round the
obstacle (``dexpush.cost.detour_length_sq``) in every rollout state, and the stall watch
(``dexpush.controller.watch_progress``) once per iteration. Run on an idle machine; the
variants are timed in alternating rounds so that drift in machine load hits both alike.
"""

from __future__ import annotations

import json
import platform
import sys
from functools import partial
from pathlib import Path

import jax
import numpy as np

from dexpush import Shape
from dexpush.controller import ControllerSettings, plan_step, policy_init
from dexpush.cost import CostWeights, Scene
from dexpush.model import LAMBDA_TRUE, Contour
from dexpush.mppi import MPPISettings
from dexpush.tasks import get_task

sys.path.insert(0, str(Path(__file__).resolve().parent))
from corner_cost import median_ms_alternating, timing_args  # a sibling script


def main() -> None:
    args = timing_args(__doc__)
    shape, task = Shape.tee(), get_task("III")
    mppi = MPPISettings(num_samples=args.samples)
    variants = {"straight (paper)": ControllerSettings(mppi=mppi),
                "detour + stall watch": ControllerSettings(mppi=mppi, weights=CostWeights(detour=True),
                                                           stall_after_s=4.0)}
    contour = Contour.of(shape)
    x = np.array([0.1, 0.05, -0.3, -0.02, -0.1], np.float32)      # on the way, the obstacle ahead
    steps = {}
    for name, settings in variants.items():
        scene = Scene.make(shape, task.goal, task.obstacles, settings.weights)
        fn = jax.jit(partial(plan_step, contour=contour, scene=scene, settings=settings))
        state = policy_init(LAMBDA_TRUE, settings, 0)
        jax.block_until_ready(fn(state, x))
        steps[name] = (fn, state)
    med = median_ms_alternating({name: partial(fn, state, x) for name, (fn, state) in steps.items()},
                                args.repeats, args.rounds)
    base, new = med["straight (paper)"], med["detour + stall watch"]
    print(f"# {platform.machine()}, K = {args.samples}, N_p = {mppi.horizon}, T Task III, "
          f"median of {args.repeats // args.rounds * args.rounds} iterations each")
    print("| goal distance | ms per iteration |")
    print("|---|---|")
    for name, m in med.items():
        print(f"| {name} | {m:.3f} |")
    print(f"slowdown: {100 * (new / base - 1):+.1f} %")
    print(json.dumps({"ms_straight": round(base, 4), "ms_detour": round(new, 4), "slowdown": round(new / base - 1, 4)}))


if __name__ == "__main__":
    main()
