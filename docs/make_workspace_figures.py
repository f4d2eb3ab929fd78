"""The figures of docs/workspaces.md: clutter trials over their cost-to-go fields.

    python docs/make_workspace_figures.py [--seeds 2,6] [--shape rect]

For each seed, one closed-loop episode of the clutter task C (model plant, MPPI + UKF from the unknown
λ, one lane: a clutter seed's batch in `dexpush bench --methods mppi-ukf --params unknown`, so each
trial is its bench record) is drawn over its layout's
cost-to-go V (:func:`dexpush.viz.plot_guidance`): docs/figures/clutter_<shape>_<seed>.png. About a
minute per seed on 2 cores.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

from dexpush.experiments.registry import make_shape
from dexpush.experiments.runner import run_episode
from dexpush.experiments.scenarios import get_task
from dexpush.viz import plot_guidance

FIGURES = Path(__file__).resolve().parent / "figures"


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--seeds", default="2,6", help="comma-separated clutter seeds (default 2,6)")
    p.add_argument("--shape", default="rect", help="rect, tee or ellipse (default rect)")
    args = p.parse_args()
    task, shape = get_task("C"), make_shape(args.shape)
    for seed in (int(s) for s in args.seeds.split(",")):
        ep = run_episode(task, args.shape, "unknown", "mppi-ukf", seed, lanes=1)
        r = ep.record
        outcome = "success" if r.success else f"failure, {r.final_error_m * 100:.0f} cm from the goal"
        title = (f"clutter C · {args.shape} · seed {seed} · model plant · MPPI + UKF (unknown λ): {outcome} "
                 f"in {r.time_s:g} s, {r.diagnostics.get('stall_resets', 0)} stall restarts")
        path = FIGURES / f"clutter_{args.shape}_{seed}.png"
        plt.close(plot_guidance(shape, task.problem(shape, seed=seed), ep.states, title=title, path=path))
        print(f"{path}: {outcome}")


if __name__ == "__main__":
    main()
