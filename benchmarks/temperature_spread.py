"""MPPI's temperature beside a table edge: the spread over every sample against the spread over those that paid
no obstacle penalty (``MPPISettings.spread_cap``, docs/controller.md#the-temperature-beside-obstacles).

    python benchmarks/temperature_spread.py [--runs 10] [--steps 400]

The state is where the clearing demonstration's push of seed 12 stalled on the simulated Franka with stop 54's
code (docs/goal_regions.md#the-demonstration-on-the-franka; a rerun of that push, which stalled again): the
plate 4 mm short of its overhang, 17 mm from the table's side, the pusher behind it; the problem is that push's
on the arm (the object and pusher areas of :func:`dexpush.experiments.robot_trial.robot_area`). For each
setting it prints one iteration from a zero warm start: the cost of sample 0 (standing still), the best
sample's and the effective sample size; then
``--runs`` closed loops on the model plant (exact observations, λ_pred = the UKF's estimate then,
[17.4, 0, 0]) from that state, each with its own sampling seed: how many reached the region within
``--steps`` control steps, and the steps they took. Last, the time of one planning step
(``PushingController.command`` from that state) with each setting, timed in alternating blocks (best
block's mean) so that their ratio sees the same machine.
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace

import jax
import numpy as np

from dexpush.control.controller import ControllerSettings, PushingController
from dexpush.experiments.clearing import ClearingScene
from dexpush.experiments.robot_trial import RobotSettings, robot_area, robot_problem
from dexpush.experiments.runner import run_loop
from dexpush.world.model_plant import ModelPlant

SEED = 12
PLATE = np.array([0.386, -0.1827, -2.1747])     # the stalled state (table frame)
PUSHER = np.array([0.2642, -0.0959])
PARAMS = np.array([17.4, 0.0, 0.0])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--runs", type=int, default=10, help="closed loops per setting (sampling seeds 0 …)")
    parser.add_argument("--steps", type=int, default=400, help="control steps per loop")
    args = parser.parse_args()
    scene = ClearingScene(props=())
    shape, task, frames = scene.shape(), scene.task(), scene.frames()
    base = ControllerSettings()
    task_problem = task.problem(shape, base.weights, seed=SEED)
    pose, pusher = task.trial_start(shape, SEED)
    problem = robot_problem(task_problem, *robot_area(task_problem, RobotSettings(place_task=False, driver=frames),
                                                      frames, pose, pusher))
    print(f"# the clearing push of seed {SEED}, stalled: plate {PLATE.tolist()}, pusher {PUSHER.tolist()}")
    print("| spread_cap | one iteration: standing still S_0 | best S_min | ESS | reached | steps (median, max) |")
    print("|---|---|---|---|---|---|")
    for cap in (None, 1e6):
        settings = replace(base, mppi=replace(base.mppi, spread_cap=cap))
        controller = PushingController(problem, params=PARAMS, settings=settings, seed=0)
        controller.command(PLATE, PUSHER)
        result = controller.last
        steps = []
        for run in range(args.runs):
            loop = PushingController(problem, params=PARAMS, settings=settings, seed=run)
            trial = run_loop(ModelPlant(shape, PARAMS), loop, problem, PLATE, PUSHER, max_steps=args.steps)
            if trial.success:
                steps.append(len(trial.commands))
        told = f"{int(np.median(steps))}, {max(steps)}" if steps else "–"
        print(f"| {'off' if cap is None else f'{cap:g}'} | {float(result.cost_nominal):.3f} | "
              f"{float(result.cost_min):.3f} | {float(result.ess):.0f} | {len(steps)}/{args.runs} | {told} |")
    timers = {cap: PushingController(problem, params=PARAMS, settings=replace(base, mppi=replace(base.mppi,
                                                                                                 spread_cap=cap)))
              for cap in (None, 1e6)}
    best = {cap: np.inf for cap in timers}
    for _ in range(6):
        for cap, controller in timers.items():
            controller.command(PLATE, PUSHER)
            t0 = time.perf_counter()
            for _ in range(40):
                controller.command(PLATE, PUSHER)
            best[cap] = min(best[cap], (time.perf_counter() - t0) / 40 * 1e3)
    print(f"\nplanning step: {best[None]:.2f} ms (off), {best[1e6]:.2f} ms (1e6), ratio {best[1e6] / best[None]:.3f}")


if __name__ == "__main__":
    jax.config.update("jax_platform_name", "cpu")
    main()
