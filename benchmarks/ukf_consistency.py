"""Consistency of the λ estimator: NIS and NEES over closed-loop episodes (issue 15).

    python benchmarks/ukf_consistency.py [--plant model|physics] [--shapes rect,tee] [--seeds 1000-1003]
                                         [--task I] [--no-gate] [--max-steps 600]

MPPI + UKF (unknown λ: the prior [15, 0, 0]) pushes the object through the realistic camera
(15 Hz, 1 mm / 0.5°, 60 ms, 5 % drops). After every informative window the script records

* NIS/m, the window's normalised innovation squared (m = 3M measured numbers): a consistent
  filter gives values distributed as χ²_m/m, mean 1, 99.9 % below ≈ 2 for m = 30;
* NEES/n = (λ̂ − λ_true)ᵀ P⁻¹ (λ̂ − λ_true)/3 against the model plant's λ_true (model plant
  only; mean 1 when consistent).

It prints per shape the mean and median of both, the share of windows above the gate, and
the final |λ̂ − λ_true|. Settings come from ``UKFSettings`` (``--no-gate`` turns the gate off
to see the raw innovations). Tune on seeds ≥ 1000 (the benchmark reports 0–29).
"""

from __future__ import annotations

import argparse
import json
from dataclasses import replace

import numpy as np

from dexpush.common.interfaces import Observation
from dexpush.control.controller import ControllerSettings, PushingController
from dexpush.control.estimator import UKFSettings
from dexpush.experiments.registry import PARAMS, make_plant, make_shape
from dexpush.experiments.runner import run_loop
from dexpush.experiments.scenarios import get_task, initial_conditions
from dexpush.model.cgvmm import LAMBDA_TRUE
from dexpush.world.sensing import SensorSettings


class Recording:
    """A PushingController that notes NIS and NEES after each informative window."""

    def __init__(self, controller: PushingController) -> None:
        self.controller = controller
        self.nis: list[float] = []
        self.nees: list[float] = []
        self._updates = 0

    @property
    def params(self) -> np.ndarray:
        return self.controller.params

    def reset(self, object_pose: object, pusher_xy: object) -> None:
        self.controller.reset(object_pose, pusher_xy)
        self._updates = 0

    def act(self, frame: Observation | None, frame_period: float | None = None) -> np.ndarray:
        u = self.controller.act(frame, frame_period)
        est = self.controller.state.estimator
        if int(est.updates) > self._updates:
            self._updates = int(est.updates)
            self.nis.append(float(est.nis))
            e = np.asarray(est.filter.mean, np.float64) - np.asarray(LAMBDA_TRUE)
            self.nees.append(float(e @ np.linalg.solve(np.asarray(est.filter.cov, np.float64), e)) / 3)
        return u


def seeds(text: str) -> list[int]:
    out: list[int] = []
    for part in text.split(","):
        lo, _, hi = part.partition("-")
        out += list(range(int(lo), int(hi or lo) + 1))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--plant", choices=("model", "physics"), default="model")
    ap.add_argument("--shapes", default="rect,tee")
    ap.add_argument("--task", default="I")
    ap.add_argument("--seeds", default="1000-1003")
    ap.add_argument("--max-steps", type=int, default=600)
    ap.add_argument("--no-gate", action="store_true", help="turn the innovation gate off")
    args = ap.parse_args()
    ukf = UKFSettings(nis_gate=None) if args.no_gate else UKFSettings()
    settings = ControllerSettings(estimate_params=True, ukf=ukf)
    task = get_task(args.task)
    summary = {}
    for name in args.shapes.split(","):
        shape = make_shape(name)
        nis, nees, err = [], [], []
        for seed in seeds(args.seeds):
            ctrl = Recording(PushingController(shape, task.goal, PARAMS["unknown"], task.obstacles,
                                               replace(settings), seed=seed))
            pose, pusher = initial_conditions(task, shape, seed)
            run_loop(make_plant(args.plant, shape), ctrl, task, shape, pose, pusher,
                     sensor=SensorSettings.realistic(seed), max_steps=args.max_steps)
            nis += ctrl.nis
            nees += ctrl.nees
            err.append(np.abs(ctrl.params - np.asarray(LAMBDA_TRUE)))
        nis_a = np.asarray(nis)
        row = {"windows": len(nis), "nis_mean": round(float(nis_a.mean()), 2),
               "nis_median": round(float(np.median(nis_a)), 2),
               "above_gate": round(float(np.mean(nis_a > (ukf.nis_gate or 2.0))), 3)}
        if args.plant == "model":
            e = np.mean(err, 0)
            row |= {"nees_mean": round(float(np.mean(nees)), 2), "nees_median": round(float(np.median(nees)), 2),
                    "final_abs_error": [round(float(e[0]), 2), round(float(e[1]) * 1e3, 1),
                                        round(float(e[2]) * 1e3, 1)]}
        summary[name] = row
        print(f"| {args.plant} | {name} | {'off' if args.no_gate else ukf.nis_gate} | {row['windows']} | "
              f"{row['nis_mean']} | {row['nis_median']} | {100 * row['above_gate']:.1f} % | "
              f"{row.get('nees_mean', '–')} | {row.get('nees_median', '–')} |", flush=True)
    print(json.dumps({"plant": args.plant, "task": args.task, "seeds": args.seeds, "gate": ukf.nis_gate,
                      "consistency": summary}))


if __name__ == "__main__":
    main()
