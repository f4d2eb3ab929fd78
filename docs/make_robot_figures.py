"""The figures of docs/robot.md#the-tasks-area-round-the-disc, #task-ivs-place-on-the-arm and
#the-pushers-margin-at-the-reach: a task on the arm's problem, without the arm.

    python docs/make_robot_figures.py [--task III] [--shape tee] [--seed 0] [--margins 0.25,0.40]
    python docs/make_robot_figures.py --task II --shape tee --seed 11 --endgame 18 [--name after]

For each margin of the task's default area (:attr:`dexpush.experiments.robot_trial.RobotSettings.workspace_margin`),
one episode of the task placed and bounded as on the simulated FR3 (:func:`run_arm_problem`: the physics plant,
the realistic camera, MPPI + UKF from the unknown λ, the pusher moving as commanded) is drawn over its cost-to-go
(:func:`dexpush.viz.plot_guidance`, with the object's bound and the base's keep-out disc dashed):
docs/figures/arm_<task>_<shape>_<seed>_area<margin>.png. About a minute for two on 2 cores.

With ``--endgame S`` the episode runs behind the robot's safety filter (as ``benchmarks/robot_sim.py
--without-arm --with-filter``) and the figure is the end of it from S seconds on, near the goal: the object's and
the pusher's bounds dashed, the pusher's path coloured by time, the object's end filled:
docs/figures/arm_<task>_<shape>_<seed>_endgame[_<name>].png.
"""

from __future__ import annotations

import argparse
from dataclasses import replace
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from dexpush.cli.config import default_config
from dexpush.experiments.registry import make_shape
from dexpush.experiments.robot_trial import RobotSettings, place_on_arm, run_arm_problem
from dexpush.experiments.scenarios import get_task
from dexpush.viz import plot_endgame, plot_guidance
from dexpush.world.sensing import SensorSettings

FIGURES = Path(__file__).resolve().parent / "figures"


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--task", default="III", help="I, II, III or IV (default III)")
    p.add_argument("--shape", default="tee", help="rect, tee or ellipse (default tee)")
    p.add_argument("--seed", type=int, default=0, help="the trial's seed (default 0)")
    p.add_argument("--margins", default="0.25,0.40", help="comma-separated area margins in m (default 0.25,0.40)")
    p.add_argument("--endgame", type=float, default=None, metavar="S",
                   help="draw the episode behind the safety filter from S seconds on, near the goal")
    p.add_argument("--name", default="", help="a suffix for the endgame figure's file name")
    args = p.parse_args()
    try:
        task, shape = get_task(args.task), make_shape(args.shape)
        robots = [replace(RobotSettings(), workspace_margin=float(m)) for m in args.margins.split(",")]
        if args.endgame is not None and not 0 <= args.endgame < np.inf:
            raise ValueError(f"--endgame must be a finite time in seconds >= 0, got {args.endgame!r}")
        if any(not np.isfinite(r.workspace_margin) for r in robots):
            raise ValueError(f"--margins must be finite, got {args.margins!r}")
    except ValueError as exc:
        p.error(str(exc))
    settings = default_config().controller
    if args.endgame is not None:
        endgame(task, shape, args.seed, robots[-1], settings, args.endgame, args.name)
        return
    for robot in robots:
        margin = robot.workspace_margin
        placed = place_on_arm(task, shape, robot, args.seed, settings.weights)
        ep, _ = run_arm_problem(task, shape, seed=args.seed, settings=settings, robot=robot,
                                sensor=SensorSettings.realistic(seed=0), placed=placed)
        r = ep.record
        outcome = "success" if r.success else f"failure, {r.final_error_m * 100:.0f} cm from the goal"
        c = float(np.hypot(*placed.driver.to_base(np.asarray(placed.pose[:2] + placed.problem.goal[:2]) / 2)))
        area = "its own area" if placed.task_problem.workspace is not None else f"area {margin:.2f} m round the task"
        title = (f"Task {task.key} · {args.shape} · seed {args.seed} · the arm's band, {area}, c = {c:.3f} m\n"
                 f"{outcome} in {r.time_s:g} s")
        path = FIGURES / f"arm_{task.key}_{args.shape}_{args.seed}_area{margin:.2f}.png"
        plt.close(plot_guidance(shape, placed.problem, ep.states, title=title, path=path))
        print(f"{path}: {outcome}")


def endgame(task: object, shape: object, seed: int, robot: RobotSettings, settings: object, since_s: float,
            name: str) -> None:
    """The end of one episode behind the safety filter, from ``since_s`` on, near the goal."""
    placed = place_on_arm(task, shape, robot, seed, settings.weights)
    ep, _ = run_arm_problem(task, shape, seed=seed, settings=settings, robot=robot,
                            sensor=SensorSettings.realistic(seed=0), filtered=True, placed=placed)
    r, T = ep.record, settings.mppi.control_period
    first = min(round(since_s / T), len(ep.states) - 1)
    outcome = "success" if r.success else f"failure, {r.final_error_m * 100:.1f} cm from the goal"
    title = (f"Task {task.key} · {shape.name} · seed {seed} · behind the filter, from {first * T:g} s\n"
             f"{outcome} at {r.time_s:g} s")
    path = FIGURES / f"arm_{task.key}_{shape.name}_{seed}_endgame{'_' + name if name else ''}.png"
    plt.close(plot_endgame(shape, placed.problem, ep.states, first, T, title=title, path=path))
    print(f"{path}: {outcome}")


if __name__ == "__main__":
    main()
