"""What the cost-to-go costs: its build per problem, and its share of an MPPI iteration.

    python benchmarks/guidance_cost.py [--samples 1024] [--repeats 200] [--rounds 5]

1. **Per iteration**: one compiled controller step (``plan_step``) for Task IV on the T (the walled area,
   three discs), its goal distance measured three ways: straight through the obstacles (eq. (9) as
   written), round the discs (the detour, ``CostWeights(guidance=False)``) and along the cost-to-go (the
   default, ``dexpush.problem.cost.guided_length_sq``), timed in alternating rounds. Target (issue 36):
   the cost-to-go at most 15 % dearer than the detour it replaces.
2. **Per problem**: the cost-to-go's build (``dexpush.problem.guidance.cost_to_go``) for a 1 × 1 m table
   with six obstacles (two discs, two boxes, two walls), each shape, median of 9 builds. Target: ≤ 50 ms.
Run on an idle machine.
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
from dexpush.problem.problem import Problem
from dexpush.problem.regions import box, wall
from dexpush.problem.weights import CostWeights

sys.path.insert(0, str(Path(__file__).resolve().parent))
from corner_cost import print_ms_table, time_plan_steps, timing_args  # a sibling script

TABLE = dict(goal=(0.30, 0.30, 1.5), obstacles=((0.0, 0.25, 0.04), (-0.25, -0.3, 0.05)),
             polygons=(box(0.15, -0.1, 0.16, 0.08, 0.4), box(-0.3, 0.3, 0.1, 0.1),
                       wall(-0.1, -0.45, 0.3, -0.45, 0.02), wall(0.45, -0.3, 0.45, 0.1, 0.02)),
             workspace=(-0.5, -0.5, 0.5, 0.5))


def main() -> None:
    args = timing_args(__doc__)
    shape, task = Shape.tee(), get_task("IV")
    mppi = MPPISettings(num_samples=args.samples)
    weights = {"straight (eq. 9)": CostWeights(detour=False, guidance=False),
               "detour round the disc": CostWeights(guidance=False), "cost-to-go": CostWeights()}
    x = np.array([0.1, 0.05, -0.3, -0.02, -0.1], np.float32)      # on the way, the obstacle ahead
    variants = {}
    for name, w in weights.items():
        problem = task.problem(shape, w)
        variants[name] = (problem.contour, problem.scene, ControllerSettings(mppi=mppi, weights=w))
    med = time_plan_steps(variants, x, args)
    print_ms_table(f"T Task IV, K = {args.samples}, N_p = {mppi.horizon}", "goal distance", med, args)
    ratio = med["cost-to-go"] / med["detour round the disc"]
    print(f"cost-to-go vs detour: {100 * (ratio - 1):+.1f} % (allowed: +15 %); "
          f"vs straight: {100 * (med['cost-to-go'] / med['straight (eq. 9)'] - 1):+.1f} %")
    builds = {}
    for s in (Shape.rectangle(), Shape.tee(), Shape.ellipse()):
        times = [Problem(s, **TABLE).guide.build_s for _ in range(9)]
        builds[s.name] = round(float(np.median(times)) * 1e3, 2)
    print("cost-to-go build on a 1 × 1 m table, 6 obstacles (ms, median of 9): "
          + ", ".join(f"{k} {v}" for k, v in builds.items()) + " (allowed: 50)")
    print(json.dumps({"ms": {k: round(v, 4) for k, v in med.items()}, "slowdown_vs_detour": round(ratio - 1, 4),
                      "build_ms": builds}))


if __name__ == "__main__":
    main()
