"""What the detour goal distance and the stall watch cost MPPI: one Task III iteration on the T.

    python benchmarks/detour_cost.py [--samples 1024] [--repeats 200]

The same controller step (``plan_step``) for Task III on the T, with the paper's straight
goal distance of eq. (9) and no stall watch (the defaults), and with the two options on
(``CostWeights(detour=True)``, ``stall_after_s=4``): the goal distance measured round the
obstacle (``dexpush.problem.cost.detour_length_sq``) in every rollout state, and the stall watch
(``dexpush.control.policy.watch_progress``) once per iteration. Run on an idle machine; the
variants are timed in alternating rounds so that drift in machine load hits both alike.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

from dexpush import Shape
from dexpush.control.controller import ControllerSettings
from dexpush.control.mppi import MPPISettings
from dexpush.experiments.scenarios import get_task
from dexpush.model.cgvmm import Contour
from dexpush.problem.scene import Scene
from dexpush.problem.weights import CostWeights

sys.path.insert(0, str(Path(__file__).resolve().parent))
from corner_cost import print_ms_table, time_plan_steps, timing_args  # a sibling script


def main() -> None:
    args = timing_args(__doc__)
    shape, task = Shape.tee(), get_task("III")
    mppi = MPPISettings(num_samples=args.samples)
    variants = {"straight (paper)": ControllerSettings(mppi=mppi),
                "detour + stall watch": ControllerSettings(mppi=mppi, weights=CostWeights(detour=True),
                                                           stall_after_s=4.0)}
    contour = Contour.of(shape)
    x = np.array([0.1, 0.05, -0.3, -0.02, -0.1], np.float32)      # on the way, the obstacle ahead
    med = time_plan_steps({name: (contour, Scene.make(shape, task.goal, task.obstacles, settings.weights), settings)
                           for name, settings in variants.items()}, x, args)
    base, new = med["straight (paper)"], med["detour + stall watch"]
    print_ms_table(f"T Task III, K = {args.samples}, N_p = {mppi.horizon}", "goal distance", med, args)
    print(f"slowdown: {100 * (new / base - 1):+.1f} %")
    print(json.dumps({"ms_straight": round(base, 4), "ms_detour": round(new, 4), "slowdown": round(new / base - 1, 4)}))


if __name__ == "__main__":
    main()
