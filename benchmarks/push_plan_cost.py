"""What the push plan after a stall costs (``ControllerSettings.push_plan``; dexpush.control.push_plan).

    python benchmarks/push_plan_cost.py [--samples 1024] [--repeats 200] [--rounds 5]

One compiled controller step (``plan_step``) for the clutter family's T (tuning seed 1068's layout, from
its start), timed in alternating rounds:

* without the push plan (``--no-push-plan``);
* with it, between stalls: no plan is searched, the step only checks whether one is being followed;
* with it, at a stall: every call is a stall restart that searches J = 16 contact points, both ways round,
  three push lengths (96 candidates: 32 walks checked against the obstacles, 48 pushes rolled through the
  C-GVMM). A robot's controller pays this once per stall; a batch of simulated lanes
  (:mod:`dexpush.experiments.simulate`) pays it in every period where one of its lanes stalls;
* with it, at a stall 1.3 cm from the goal: the endgame's search (``push_plan.endgame``: J = 48, both ways
  round, three turns, six lengths: 96 walks, 864 pushes).

Run on an idle machine.
"""

from __future__ import annotations

import json
import sys
from dataclasses import replace
from functools import partial
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

from dexpush import Shape
from dexpush.control.controller import ControllerSettings
from dexpush.control.mppi import MPPISettings
from dexpush.control.policy import plan_step, policy_init
from dexpush.control.push_plan import PushPlanSettings
from dexpush.experiments.scenarios import get_task
from dexpush.model.cgvmm import LAMBDA_TRUE

sys.path.insert(0, str(Path(__file__).resolve().parent))
from corner_cost import median_ms_alternating, print_ms_table, timing_args  # a sibling script


def main() -> None:
    args = timing_args(__doc__)
    shape, seed = Shape.tee(), 1068
    problem, q0, p0 = get_task("C").layout(shape, seed)
    o = problem.origin                          # the controller's frame: the goal's position at its origin
    x = np.array([q0[0] - o[0], q0[1] - o[1], q0[2], p0[0] - o[0], p0[1] - o[1]], np.float32)
    on = ControllerSettings(mppi=MPPISettings(num_samples=args.samples), weights=problem.weights,
                            push_plan=PushPlanSettings(enabled=True))
    base = replace(on, push_plan=PushPlanSettings(enabled=False))
    # 1.3 cm from the goal in its heading, the pusher 4 cm beyond the footprint's reach
    th = float(problem.goal[2])
    reach = shape.bounding_radius + shape.pusher_radius + 0.04
    near = np.array([0.012, -0.005, th, 0.012 - reach * np.cos(th), -0.005 - reach * np.sin(th)], np.float32)
    calls = {}
    for name, settings, stalled, at in (("without the push plan", base, False, x),
                                        ("push plan, between stalls", on, False, x),
                                        ("push plan, at a stall (the search)", on, True, x),
                                        ("push plan, at a stall near the goal (the endgame's search)", on, True, near)):
        fn = jax.jit(partial(plan_step, contour=problem.contour, scene=problem.local_scene, settings=settings))
        state = policy_init(LAMBDA_TRUE, settings, 0)
        if stalled:     # the clock at its patience: each call restarts and searches
            state = state._replace(idle=jnp.float32(settings.stall.after_s), best=jnp.float32(0.0))
        jax.block_until_ready(fn(state, at))
        calls[name] = partial(fn, state, at)
    med = median_ms_alternating(calls, args.repeats, args.rounds)
    print_ms_table(f"T clutter seed {seed}, K = {args.samples}, N_p = {base.mppi.horizon}", "controller step", med,
                   args)
    ratios = {name: round(m / med["without the push plan"] - 1, 4) for name, m in med.items()}
    for name, r in ratios.items():
        print(f"{name}: {100 * r:+.1f} %")
    print(json.dumps({"ms": {k: round(v, 4) for k, v in med.items()}, "slowdown": ratios}))


if __name__ == "__main__":
    main()
