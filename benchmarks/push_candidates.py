"""What the push plan's two searches see at one state of a trial: why a stall found a push, or none.

    python benchmarks/push_candidates.py RUN_FOLDER [--step N]

``RUN_FOLDER`` is the output of ``dexpush run ... --out RUN_FOLDER`` on the model plant (its ``summary.json``
names the task, shape and seed; its ``trajectory.npz`` holds the states and λ_pred of every step). At step ``N``
(default: the last) both searches of :mod:`dexpush.control.push_plan` are weighed with the defaults, through the
model with that step's λ_pred, and for each this prints how many walks are open and pushes clear, the candidate
with the best measure (blocked or not) and the best open and clear one, each with its end's position error (m,
straight) and heading error (degrees), and how many candidates end within the success tolerances (8 mm, 3°).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

from dexpush.control.policy import ControllerSettings, progress_units
from dexpush.control.push_plan import PushCandidates, endgame_candidates, goal_errors, push_candidates
from dexpush.experiments.registry import make_shape
from dexpush.experiments.scenarios import get_task
from dexpush.problem.cost import plan_margin
from dexpush.problem.problem import SUCCESS_HEADING_DEG, SUCCESS_POSITION_M


def _report(name: str, k: PushCandidates, scene: object) -> None:
    e_p, e_th = (np.asarray(v) for v in goal_errors(tuple(k.ends[..., i] for i in range(5)), scene, guided=False))
    e_th = np.degrees(e_th)
    end, score = np.asarray(k.end), np.asarray(k.score)
    walks = np.asarray(k.walk_open)
    within = (e_p < SUCCESS_POSITION_M) & (e_th < SUCCESS_HEADING_DEG)
    usable = np.isfinite(score).any(axis=1)                      # (J, A, L): some way round open, the push clear
    print(f"{name}: measure now {float(k.now):.4f}; {int(walks.sum())}/{walks.size} walks open, "
          f"{int(np.asarray(k.push_clear).sum())}/{k.push_clear.size} pushes clear; "
          f"{int(within.sum())} pushes end within the tolerances, {int((within & usable).sum())} of them usable")
    for label, values in (("best, blocked or not", end), ("best open and clear", np.where(usable, end, np.inf))):
        i = np.unravel_index(np.argmin(values), values.shape)
        if not np.isfinite(values[i]):
            print(f"  {label}: none")
            continue
        j, a, l_ = i
        print(f"  {label}: target {float(k.targets[j]):+.3f} rad, turn {float(k.angles[a]):+.2f} rad, travel "
              f"{1000 * float(k.travel_m[l_]):.0f} mm -> measure {values[i]:.4f}, {1000 * e_p[i]:.1f} mm, "
              f"{e_th[i]:.2f} deg")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("folder", type=Path)
    parser.add_argument("--step", type=int, default=-1)
    args = parser.parse_args()
    try:
        summary = json.loads((args.folder / "summary.json").read_text())
        run = np.load(args.folder / "trajectory.npz")
        states, params = run["states"], run["params"]
    except (OSError, KeyError, ValueError) as exc:
        raise SystemExit(f"{args.folder}: not a dexpush run folder ({exc})") from None
    if not -len(states) <= args.step < len(states):
        raise SystemExit(f"--step must be within the trial's {len(states)} states, got {args.step}")
    shape = make_shape(summary["shape"])
    settings = ControllerSettings()
    problem = get_task(summary["task"]).problem(shape, settings.weights, seed=summary["seed"])
    x = jnp.asarray(states[args.step], jnp.float32)
    lam = jnp.asarray(params[min(args.step % len(states), len(params) - 1)], jnp.float32)
    scene = plan_margin(x, problem.scene, settings.weights)
    e_p, e_th = goal_errors(x, scene, guided=False)
    print(f"task {summary['task']} {summary['shape']} seed {summary['seed']}, step {args.step % len(states)}: "
          f"{1000 * float(e_p):.1f} mm and {np.degrees(float(e_th)):.2f} deg from the goal; "
          f"λ_pred {np.round(np.asarray(lam), 4).tolist()}")
    static = ("weights", "settings", "speed")
    kw = {"weights": settings.weights, "settings": settings.push_plan, "speed": settings.mppi.v_clip}
    args_ = (x, problem.contour, scene, lam, jnp.float32(settings.mu))
    far = jax.jit(lambda x, c, s, p, m, **k: push_candidates(x, c, s, k["weights"], p, m, k["settings"], k["speed"]),
                  static_argnames=static)
    near = jax.jit(lambda x, c, s, p, m, units, **k: endgame_candidates(x, c, s, k["weights"], p, m, k["settings"],
                                                                       k["speed"], units),
                   static_argnames=(*static, "units"))
    _report("far search (measure d, m)", far(*args_, **kw), scene)
    _report("endgame search (measure E)", near(*args_, units=progress_units(settings), **kw), scene)


if __name__ == "__main__":
    main()
