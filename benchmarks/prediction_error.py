"""How wrong is the state the controller plans from, against how far it was predicted (issue 15)?

    python benchmarks/prediction_error.py --seeds 1000-1007 [--shape tee] [--task III] [--gain 0]

With a realistic camera the controller plans from the newest frame predicted to the present
through the model (``PushingController.act``: 60 ms latency, a 15 Hz camera, lost frames).
This runs trials on the physics plant (MPPI + UKF, unknown λ) and, after every command,
compares

* ``shift``: how far the footprint's farthest point moved in that prediction
  (``PushingController.prediction_shift_m``), with
* ``error``: how far the footprint's farthest point is from where it truly is
  (:func:`dexpush.common.se2.footprint_shift` between the planning state and the plant's
  state), which includes the camera's noise.

It prints the error's percentiles per band of shift, and how often the error exceeds a margin
m₀ + a·shift for a few m₀ and gains a: the measurement behind
``ControllerSettings.prediction_margin.gain`` (docs/controller.md#the-margin-grows-with-the-prediction).
``--gain`` is the gain the trials run with. Tune on seeds ≥ 1000 (the benchmark reports 0–29).
"""

from __future__ import annotations

import argparse
import itertools
from dataclasses import replace

import numpy as np

from dexpush.cli.arguments import seed_list
from dexpush.common.se2 import footprint_shift
from dexpush.control.controller import ControllerSettings
from dexpush.control.settings import PredictionMarginSettings
from dexpush.experiments.methods import get_method
from dexpush.experiments.registry import PARAMS, make_plant, make_shape, world_sensor
from dexpush.experiments.runner import run_loop
from dexpush.experiments.scenarios import get_task, initial_conditions
from dexpush.world.sensing import SensorSettings

BANDS_MM = (0.0, 0.5, 2.0, 4.0, 6.0, 8.0, 10.0, 12.0, 15.0, 20.0, 40.0)


class Traced:
    """A controller that notes, after each command, the state it planned from and the prediction's shift."""

    def __init__(self, controller: object) -> None:
        self.controller, self.rows = controller, []

    def __getattr__(self, name: str):
        return getattr(self.controller, name)

    def act(self, frame, frame_period):
        u = self.controller.act(frame, frame_period)
        self.rows.append((self.controller.planning_state[:3].copy(), self.controller.prediction_shift_m))
        return u


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=seed_list, default=seed_list("1000-1007"))
    ap.add_argument("--shape", default="tee")
    ap.add_argument("--task", default="III")
    ap.add_argument("--gain", type=float, default=0.0, help="ControllerSettings.prediction_margin.gain of the trials")
    args = ap.parse_args()

    task, shape = get_task(args.task), make_shape(args.shape)
    corners = np.asarray(shape.edges[0])
    settings = ControllerSettings(prediction_margin=PredictionMarginSettings(gain=args.gain))
    shifts, errors = [], []
    for seed in args.seeds:
        sensor = SensorSettings.realistic()
        sensor = world_sensor("physics", replace(sensor, seed=sensor.seed * 1_000_003 + seed), seed)
        problem = task.problem(shape, settings.weights)
        ctrl = get_method("mppi-ukf").controller(problem, PARAMS["unknown"], seed, settings)
        traced = Traced(ctrl)
        pose, pusher = initial_conditions(task, shape, seed)
        result = run_loop(make_plant("physics", shape, seed), traced, problem, pose, pusher, sensor=sensor,
                          control_period=settings.mppi.control_period)
        states = np.asarray(result.states)
        shifts += [s for _, s in traced.rows]
        errors += [footprint_shift(corners, states[k, :3], q) for k, (q, _) in enumerate(traced.rows)]
        print(f"seed {seed}: {'success' if result.success else 'failure'} after {len(traced.rows)} steps", flush=True)
    shift, error = np.asarray(shifts) * 1e3, np.asarray(errors) * 1e3
    print(f"\n# Task {task.key}, {shape.name}, physics, realistic camera, MPPI+UKF, unknown λ, "
          f"seeds {args.seeds[0]}–{args.seeds[-1]}: {len(shift)} planning states")
    print("| shift (mm) | states | error p50 (mm) | p90 | p99 | max |")
    print("|---|---|---|---|---|---|")
    for lo, hi in itertools.pairwise(BANDS_MM):
        e = error[(shift >= lo) & (shift < hi)]
        if len(e):
            print(f"| {lo:g}–{hi:g} | {len(e)} | {np.median(e):.1f} | {np.percentile(e, 90):.1f} | "
                  f"{np.percentile(e, 99):.1f} | {e.max():.1f} |")
    print("\n| m₀ (mm) | a | states with error > m₀ + a·shift |")
    print("|---|---|---|")
    for m0 in (5.0, 10.0):
        for a in (0.0, 0.25, 0.5, 0.75, 1.0):
            print(f"| {m0:g} | {a:g} | {np.mean(error > m0 + a * shift) * 100:.2f} % |")


if __name__ == "__main__":
    main()
