"""What the planner saw and planned in the steps before an obstacle touch (issue 15).

    python benchmarks/obstacle_trace.py --seed 1009 [--shape tee] [--plant physics] [--margin-cost off]
                                        [--obstacle-margin 0.01] [--steps 40]

One Task III trial (MPPI + UKF, unknown λ, the realistic camera) through
``PushingController.act``. After each command it prints, for the last ``--steps`` control steps:

* ``true``: the clearance (mm, :func:`dexpush.problem.obstacles.clearance`) of the plant's true state;
* ``seen``: the clearance of the state the controller planned from (``planning_state``: the
  newest frame predicted to the present through the model);
* ``plan``: the clearance the new nominal sequence predicts after 1, 2 and 3 slots, and the least
  over its first six slots;
* ``S_min``: the best sampled cost (≥ 1e13 when every sample touches; ≥ 1e9 inside the margin);
* ``next``: the true clearance after the command.

``--margin-cost off`` runs the planner of before 2026-12-01 (``CostWeights(C_margin=None)``).
Tune on seeds ≥ 1000 (the benchmark reports 0–29).
"""

from __future__ import annotations

import argparse
from dataclasses import replace

import jax
import jax.numpy as jnp
import numpy as np

from dexpush.control.controller import ControllerSettings
from dexpush.experiments.methods import get_method
from dexpush.experiments.registry import PARAMS, make_plant, make_shape, world_sensor
from dexpush.experiments.runner import run_loop
from dexpush.experiments.scenarios import get_task, initial_conditions
from dexpush.model.cgvmm import Contour, integrate
from dexpush.problem.obstacles import clearance
from dexpush.problem.weights import CostWeights
from dexpush.world.sensing import SensorSettings


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seed", type=int, default=1009)
    ap.add_argument("--shape", default="tee")
    ap.add_argument("--plant", default="physics", choices=("physics", "physics-random", "model"))
    ap.add_argument("--margin-cost", default=None, help="CostWeights.C_margin, or off (None)")
    ap.add_argument("--obstacle-margin", type=float, default=CostWeights().obstacle_margin_m,
                    help="CostWeights.obstacle_margin_m (m)")
    ap.add_argument("--steps", type=int, default=40, help="how many of the last steps to print")
    args = ap.parse_args()

    task, shape = get_task("III"), make_shape(args.shape)
    weights = CostWeights(obstacle_margin_m=args.obstacle_margin)
    if args.margin_cost is not None:
        weights = replace(weights, C_margin=None if args.margin_cost == "off" else float(args.margin_cost))
    settings = ControllerSettings(weights=weights)
    sensor = SensorSettings.realistic()
    sensor = world_sensor(args.plant, replace(sensor, seed=sensor.seed * 1_000_003 + args.seed), args.seed)
    problem = task.problem(shape, settings.weights)
    scene = problem.scene
    ctrl = get_method("mppi-ukf").controller(problem, PARAMS["unknown"], args.seed, settings)
    contour, slots = Contour.of(shape), settings.mppi.step_durations()

    @jax.jit
    def plan_gaps(x: jnp.ndarray, seq: jnp.ndarray, params: jnp.ndarray, mu: jnp.ndarray) -> jnp.ndarray:
        gaps = [clearance(x, scene)]
        for k in range(6):
            x = integrate(contour, x, seq[k], jnp.float32(slots[k]), params, mu, 4)
            gaps.append(clearance(x, scene))
        return jnp.stack(gaps)

    rows = []

    class Traced:
        """The controller, noting after each command what it planned from and what it planned."""

        def __getattr__(self, name: str):
            return getattr(ctrl, name)

        def act(self, frame, frame_period):
            u = ctrl.act(frame, frame_period)
            x = jnp.asarray(ctrl.planning_state, jnp.float32)
            gaps = plan_gaps(x, ctrl.last.sequence, ctrl.state.params, ctrl.state.mu)
            rows.append((np.asarray(gaps), float(ctrl.last.cost_min)))
            return u

    pose, pusher = initial_conditions(task, shape, args.seed)
    plant = make_plant(args.plant, shape, args.seed)
    result = run_loop(plant, Traced(), problem, pose, pusher, sensor=sensor,
                      control_period=settings.mppi.control_period)
    true = np.asarray(jax.jit(clearance)(jnp.asarray(result.states, jnp.float32), scene)) * 1e3
    print(f"# Task III, {args.shape}, {args.plant}, seed {args.seed}, C_margin {weights.C_margin}: "
          f"{'success' if result.success else 'failure'} after {len(result.commands)} steps, "
          f"least clearance {true.min():.1f} mm")
    print("| step | true (mm) | seen | plan +1 | +2 | +3 | least of 6 | S_min | next |")
    print("|---|---|---|---|---|---|---|---|---|")
    for i in range(max(0, len(rows) - args.steps), len(rows)):
        g, smin = rows[i]
        g = g * 1e3
        print(f"| {i} | {true[i]:.1f} | {g[0]:.1f} | {g[1]:.1f} | {g[2]:.1f} | {g[3]:.1f} | {g[1:].min():.1f} | "
              f"{smin:.3g} | {true[i + 1]:.1f} |")


if __name__ == "__main__":
    main()
