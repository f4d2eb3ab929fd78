"""What the cost-to-go costs: its build per problem, and its share of an MPPI iteration.

    python benchmarks/guidance_cost.py [--samples 1024] [--repeats 200] [--rounds 5]

1. **Per iteration**: one compiled controller step (``plan_step``) for Task IV on the T (the walled area,
   three discs), its goal distance measured four ways: straight through the obstacles (eq. (9) as
   written), round the discs (the detour, ``CostWeights(guidance=False)``), along the cost-to-go of one
   layer (the larger of it and the detour) and along the cost-to-go by heading (``guidance_turn_m``;
   ``dexpush.problem.cost.guided_length_sq``), in the terminal cost and (opt-in, ``guidance_running``) in the
   running cost too, timed in alternating rounds. Target (issue 36): the
   cost-to-go at most 15 % dearer than the detour it replaces.
2. **Per problem**: the cost-to-go's build (``dexpush.problem.guidance.cost_to_go``) for a 1 × 1 m table
   with six obstacles (two discs, two boxes, two walls), each shape, one layer, by heading, and by heading
   with the pusher's room (``guidance_pusher_room``, opt-in; the rollout reads it as the field by heading),
   median of 9 builds.
   Target: ≤ 50 ms.
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

#: the turn length of the field by heading that is timed (m per radian)
TURN_M = 0.1
TABLE = dict(goal=(0.30, 0.30, 1.5), obstacles=((0.0, 0.25, 0.04), (-0.25, -0.3, 0.05)),
             polygons=(box(0.15, -0.1, 0.16, 0.08, 0.4), box(-0.3, 0.3, 0.1, 0.1),
                       wall(-0.1, -0.45, 0.3, -0.45, 0.02), wall(0.45, -0.3, 0.45, 0.1, 0.02)),
             workspace=(-0.5, -0.5, 0.5, 0.5))


def main() -> None:
    args = timing_args(__doc__)
    shape, task = Shape.tee(), get_task("IV")
    mppi = MPPISettings(num_samples=args.samples)
    weights = {"straight (eq. 9)": CostWeights(detour=False, guidance=False),
               "detour round the disc": CostWeights(guidance=False),
               "cost-to-go, one layer": CostWeights(guidance_turn_m=None),
               "cost-to-go by heading": CostWeights(guidance_turn_m=TURN_M),
               "by heading, in the running cost too": CostWeights(guidance_turn_m=TURN_M, guidance_running=True)}
    x = np.array([0.1, 0.05, -0.3, -0.02, -0.1], np.float32)      # on the way, the obstacle ahead
    variants = {}
    for name, w in weights.items():
        problem = task.problem(shape, w)
        variants[name] = (problem.contour, problem.scene, ControllerSettings(mppi=mppi, weights=w))
    med = time_plan_steps(variants, x, args)
    print_ms_table(f"T Task IV, K = {args.samples}, N_p = {mppi.horizon}", "goal distance", med, args)
    ratios = {}
    for name in ("cost-to-go, one layer", "cost-to-go by heading", "by heading, in the running cost too"):
        ratios[name] = round(med[name] / med["detour round the disc"] - 1, 4)
        print(f"{name} vs detour: {100 * ratios[name]:+.1f} % (allowed: +15 %); "
              f"vs straight: {100 * (med[name] / med['straight (eq. 9)'] - 1):+.1f} %")
    builds = {}
    for label, turn, room in (("one layer", None, False), ("by heading", TURN_M, False),
                              ("pusher's room", TURN_M, True)):
        for s in (Shape.rectangle(), Shape.tee(), Shape.ellipse()):
            w = CostWeights(guidance_turn_m=turn, guidance_pusher_room=room)
            times = [Problem(s, weights=w, **TABLE).guide.build_s for _ in range(9)]
            builds[f"{label}, {s.name}"] = round(float(np.median(times)) * 1e3, 2)
    print("cost-to-go build on a 1 × 1 m table, 6 obstacles (ms, median of 9): "
          + ", ".join(f"{k} {v}" for k, v in builds.items()) + " (allowed: 50)")
    print(json.dumps({"ms": {k: round(v, 4) for k, v in med.items()}, "slowdown_vs_detour": ratios,
                      "build_ms": builds}))


if __name__ == "__main__":
    main()
