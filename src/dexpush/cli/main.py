"""dexpush: contact-aware planar pushing with the C-GVMM, long-horizon MPPI and a UKF.

    dexpush demo [--out DIR]                 Task I, rect, known parameters, MPPI
    dexpush run --task I --shape tee --params unknown --method mppi --seed 3 --out DIR
    dexpush bench [--tasks I,II --shapes rect --trials 5 --out DIR]   the Sec. IV-B table
    dexpush bench --tasks I --shapes tee --params unknown --methods mppi --seeds 7   re-run one trial
    dexpush validate-mit DATA_DIR [--out DIR] [--online]  C-GVMM (and the online UKF) against recorded MIT pushes
    dexpush fit LOG --shape FILE.toml        fit λ (and μ_c) to your own recorded pushes
    dexpush calibrate --board B.toml IMG...  a camera's pose (and intrinsics) from images of a board
    dexpush robot --sim --task I --shape rect  one episode on a simulated Franka FR3 (needs dexpush[franka])
    dexpush clear [--seed N --out DIR]       clear a table on the simulated FR3: pick, push to the edge, grasp
    dexpush ros --shape tee --scene scene.toml  the ROS 2 node: poses and goals in, twists out (needs dexpush[ros])

Every command writes its files under ``--out`` and prints a one-line JSON summary last.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import sys
import warnings
from collections.abc import Sequence

from dexpush.cli.arguments import floats, out_folder, positive_float, positive_int, seed, seed_list
from dexpush.cli.commands import cmd_bench, cmd_calibrate, cmd_clear, cmd_fit, cmd_robot, cmd_ros, cmd_run, cmd_validate
from dexpush.cli.flags import add_camera_flags, add_planner_flags
from dexpush.experiments.benchmark import BENCH_LANES
from dexpush.experiments.cluster import ENGINES
from dexpush.experiments.methods import method_names
from dexpush.experiments.registry import PARAMS, PLANTS, SHAPES
from dexpush.experiments.scenarios import MAX_STEPS
from dexpush.model.cgvmm import MU_C
from dexpush.problem.goal_region import REGION_SYNTAX

__all__ = ["main"]


def _version() -> str:
    import importlib.metadata

    try:
        return importlib.metadata.version("dexpush")
    except importlib.metadata.PackageNotFoundError:  # pragma: no cover (a source tree without install)
        return "unknown"


def share_run_flags(parser: argparse.ArgumentParser, what: argparse._ArgumentGroup, how: argparse._ArgumentGroup,
                    skip: tuple[str, ...]) -> None:
    """``run``'s what-and-where flags (all but ``skip``) and its method flags, on another command."""
    for action in what._group_actions:
        if action.dest not in skip:
            parser._add_action(action)
    for name in ("method", "params", "lambda_pred"):
        parser._add_action(next(a for a in how._group_actions if a.dest == name))


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="dexpush", description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--version", action="version", version=f"%(prog)s {_version()}")
    sub = p.add_subparsers(dest="command", required=True)

    def episode_args(sp: argparse.ArgumentParser, out: str) -> None:
        sp.add_argument("--out", type=out_folder, default=out, help=f"output folder (default {out})")
        sp.add_argument("--max-steps", type=positive_int, default=None,
                        help=f"control steps before giving up (default {MAX_STEPS})")
        sp.add_argument("--no-animation", action="store_true", help="skip the animation")
        sp.add_argument("--quiet", action="store_true", help="no progress bar")

    demo = sub.add_parser("demo", help="closed-loop demo: Task I, rect, known parameters, MPPI")
    episode_args(demo, "out/demo")
    demo.set_defaults(task="I", shape="rect", params="known", method="mppi", seed=0, lanes=1, plant="model",
                      camera="exact", func=cmd_run)

    run = sub.add_parser("run", help="one closed-loop episode: a benchmark task, or your own object, goal and "
                                     "obstacles", formatter_class=argparse.RawDescriptionHelpFormatter,
                         epilog="examples:\n"
                                "  dexpush run --task III --shape tee --method mppi-ukf --params unknown --seed 3\n"
                                "  dexpush run --shape examples/shapes/l_block.toml --goal 0.4,0.2,30deg "
                                "--obstacle 0.2,0.1,0.03\n"
                                "  dexpush run --print-config > run.toml   # edit, then: dexpush run --config run.toml")
    what = run.add_argument_group("what to push where (flags override --config)")
    what.add_argument("--config", metavar="FILE.toml", default=None,
                      help="a configuration file (see --print-config for every key and its default)")
    what.add_argument("--print-config", action="store_true",
                      help="print the effective configuration as TOML and exit")
    what.add_argument("--task", default=None,
                      help="I, II, III, IV, V or C: start distribution, goal, obstacles (default I)")
    what.add_argument("--shape", default=None, metavar="NAME|FILE.toml",
                      help=f"{', '.join(SHAPES)}, or a shape file (docs/conventions.md#shapes) (default rect)")
    what.add_argument("--goal", type=floats(3, "--goal", angle_last=True), default=None, metavar="X,Y,THETA",
                      help="goal pose of the shape's reference point: x, y in m, θ in rad (or e.g. 30deg) "
                           "(default: the task's)")
    what.add_argument("--goal-region", default=None, metavar="KIND:ARGS",
                      help=f"a goal region instead of a pose (docs/goal_regions.md): {REGION_SYNTAX}, e.g. "
                           "overhang:+x,0.06 (the footprint 6 cm past the workspace's +x edge, its centre of mass on "
                           "the table)")
    what.add_argument("--obstacle", type=floats(3, "--obstacle"), action="append", default=None,
                      metavar="CX,CY,R", help="a disc obstacle in m; repeat for more (default: the task's)")
    what.add_argument("--obstacle-box", type=floats((4, 5), "--obstacle-box", angle_last=True), action="append",
                      default=None, metavar="CX,CY,W,H[,YAW]",
                      help="a box obstacle: centre and size in m, yaw in rad (or e.g. 30deg); repeat for more")
    what.add_argument("--wall", type=floats(5, "--wall"), action="append", default=None, metavar="X0,Y0,X1,Y1,T",
                      help="a wall from (x0, y0) to (x1, y1), t thick (m); repeat for more")
    what.add_argument("--workspace", type=floats(4, "--workspace"), default=None, metavar="X0,Y0,X1,Y1",
                      dest="table_workspace",
                      help="the rectangle the object and the pusher must stay inside (m)")
    what.add_argument("--scene", default=None, metavar="SCENE.toml",
                      help="discs, boxes, walls and a workspace from a file (docs/workspaces.md#scene-files); "
                           "a scene or any obstacle flag replaces the task's obstacles")
    what.add_argument("--seed", type=seed, default=None, help="start perturbation and MPPI sampling (default 0)")
    how = run.add_argument_group("controller and world")
    how.add_argument("--method", default=None, choices=method_names(),
                     help="MPPI with fixed λ_pred, MPPI with the UKF estimating λ online, or the GCS "
                          "plan-and-track baseline (no obstacles; needs the `drake` package) (default mppi)")
    how.add_argument("--params", default=None, choices=tuple(PARAMS),
                     help="the controller's first λ_pred: λ_true (known) or [15, 0, 0] (unknown) (default known)")
    how.add_argument("--lambda-pred", type=floats(3, "--lambda-pred"), default=None, metavar="BETA,XBF,YBF",
                     help="the controller's first λ_pred = [β (1/m), x_bf (m), y_bf (m)], e.g. from `dexpush fit`; "
                          "overrides --params")
    how.add_argument("--plant", default=None, choices=PLANTS,
                     help="the world: model (C-GVMM), physics (MuJoCo) or physics-random (MuJoCo world --seed "
                          "of the randomised family, with its own camera) (default model)")
    how.add_argument("--true-params", type=floats(3, "--true-params"), default=None, metavar="BETA,XBF,YBF",
                     help="the model plant's true λ (default 25,-0.01,0.02)")
    how.add_argument("--mu", type=positive_float, default=None, help=f"the model plant's true μ_c (default {MU_C:g})")
    how.add_argument("--lanes", type=positive_int, default=1,
                     help=f"batch lanes of the simulation (default 1); {BENCH_LANES} (the bench's) reproduces a "
                          "`dexpush bench` record exactly")
    add_planner_flags(run)
    add_camera_flags(run)
    episode_args(run, "out/run")
    run.set_defaults(func=cmd_run)

    rob = sub.add_parser("robot", help="one episode on a Franka: the simulated FR3 (franky-sim, loopback) or a real "
                                       "robot; needs pip install 'dexpush[franka]'",
                         formatter_class=argparse.RawDescriptionHelpFormatter,
                         epilog="examples:\n"
                                "  dexpush robot --sim --task II --shape ellipse --seed 3\n"
                                "  dexpush robot --config run.toml --out out/robot")
    where = rob.add_mutually_exclusive_group()
    where.add_argument("--sim", action="store_true", help="the simulated FR3 on 127.0.0.1, started and shut down "
                                                         "here (the default)")
    where.add_argument("--robot", metavar="ADDRESS", default=None, help="a real Franka's FCI address")
    share_run_flags(rob, what, how, skip=("print_config",))
    safe = rob.add_argument_group("robot and safety filter")
    from dexpush.robot.driver import DriverSettings
    from dexpush.robot.safety import SafetySettings
    from dexpush.robot.smoothing import SmoothingSettings

    safety, driver, smoothing = SafetySettings(), DriverSettings(), SmoothingSettings()
    safe.add_argument("--v-limit", type=positive_float, default=None,
                      help=f"the filter's speed limit (m/s, default {safety.v_max:g})")
    safe.add_argument("--a-limit", type=positive_float, default=None,
                      help=f"the filter's acceleration limit (m/s², default {safety.a_max:g})")
    safe.add_argument("--dynamics-factor", type=positive_float, default=None,
                      help=f"fraction of the Franka's velocity, acceleration and jerk limits "
                           f"(default {driver.dynamics_factor:g})")
    safe.add_argument("--cutoff-frequency", type=positive_float, default=None, metavar="HZ",
                      help=f"libfranka's low-pass filter on the velocity stream (Hz; default "
                           f"{driver.cutoff_frequency:g}: 1000 is off; libfranka's own default is 100; "
                           "docs/robot.md#libfrankas-filter)")
    add_planner_flags(rob)
    add_camera_flags(rob)
    episode_args(rob, "out/robot")
    rob.set_defaults(func=cmd_robot, plant=None, lanes=1, true_params=None, mu=None)

    clear = sub.add_parser("clear", help="clear a table on the simulated FR3 (the paper's Sec. IV-D): pick a cup and a "
                                         "block, push a plate over the edge with the closed fingers, grasp its rim, "
                                         "lift it, drop it in a bin; needs pip install 'dexpush[franka]'",
                           formatter_class=argparse.RawDescriptionHelpFormatter,
                           epilog="examples:\n  dexpush clear\n  dexpush clear --seed 3 --out out/clear --no-video")
    clear.add_argument("--seed", type=seed, default=0, help="the plate's start (default 0)")
    clear.add_argument("--out", type=out_folder, default="out/clear", help="folder for clearing.json and the video")
    clear.add_argument("--no-video", action="store_true", help="skip the video from the scene's camera")
    clear.add_argument("--quiet", action="store_true", help="no progress lines")
    clear.set_defaults(func=cmd_clear)

    ros = sub.add_parser("ros", help="the ROS 2 node: object and pusher poses and goals in, twists out (docs/ros.md); "
                                     "needs pip install 'dexpush[ros]' or a sourced ROS 2",
                         formatter_class=argparse.RawDescriptionHelpFormatter,
                         epilog="examples:\n"
                                "  dexpush ros --shape tee --scene scene.toml --world-frame table\n"
                                "  dexpush ros --task III --shape tee --goal 0.6,0.3,0 --smooth --twist-topic /cmd")
    share_run_flags(ros, what, how, skip=("print_config",))
    rg = ros.add_argument_group("topics, frames and timing")
    rg.add_argument("--world-frame", default="world", help="the frame of poses and goals (default world)")
    rg.add_argument("--twist-frame", default="", help="the twist's header frame (default: the world frame)")
    from dexpush.ros.core import TRIGGERS
    from dexpush.ros.node import Topics

    for field_name, default in Topics().__dict__.items():
        rg.add_argument(f"--{field_name.replace('_', '-')}-topic", dest=f"topic_{field_name}", default=default,
                        help=f"(default {default})")
    rg.add_argument("--trigger", choices=TRIGGERS, default="timer",
                    help="plan every control period (timer), or on each object pose (pose: for a pose stream at "
                         "the control rate) (default timer)")
    rg.add_argument("--wait-for-goal", action="store_true",
                    help="start without a goal (else: --goal, or the task's goal)")
    rg.add_argument("--stale", type=positive_float, default=0.5,
                    help="zero twist when the newest pose is older than this (s, default 0.5)")
    rg.add_argument("--watchdog", type=positive_float, default=0.1,
                    help="zero twist when the planner made no command for this long (s, default 0.1)")
    rg.add_argument("--smooth", action="store_true",
                    help="stream twists at --stream-rate within --a-limit and --j-limit (for robots that need "
                         "continuous commands)")
    rg.add_argument("--stream-rate", type=positive_float, default=250.0, help="with --smooth (Hz, default 250)")
    rg.add_argument("--a-limit", type=positive_float, default=None,
                    help=f"acceleration limit of the filter and of the stream (m/s², default {safety.a_max:g} and "
                         f"{smoothing.a_max:g})")
    rg.add_argument("--j-limit", type=positive_float, default=None,
                    help=f"with --smooth: jerk limit (m/s³, default {smoothing.j_max:g})")
    rg.add_argument("--v-limit", type=positive_float, default=None,
                    help=f"the filter's speed limit (m/s, default {safety.v_max:g})")
    rg.add_argument("--duration", type=positive_float, default=None, help="stop after this many seconds")
    rg.add_argument("--until-reached", action="store_true", help="stop once the goal is reached")
    rg.add_argument("--node-name", default="dexpush", help="the node's name (default dexpush)")
    add_planner_flags(ros)
    ros.add_argument("--quiet", action="store_true", help="no notes on stderr")
    ros.set_defaults(func=cmd_ros, plant=None, lanes=1, true_params=None, mu=None)

    bench = sub.add_parser("bench", help="the paper's Sec. IV-B table (batched, resumable)")
    bench.add_argument("--tasks", default="I,II,III",
                       help="comma-separated tasks from I, II, III, IV (confined), V (push to the edge), C (random "
                            "clutter) "
                            "(default I,II,III)")
    bench.add_argument("--shapes", default="rect,tee",
                       help=f"comma-separated shapes from {', '.join(SHAPES)} (default rect,tee)")
    bench.add_argument("--params", default="known,unknown",
                       help="comma-separated: known (λ_pred = λ_true), unknown (λ_pred starts at [15, 0, 0])")
    bench.add_argument("--methods", default=",".join(method_names(default_only=True)),
                       help=f"comma-separated, from {', '.join(method_names())} (methods without obstacle support "
                            f"skip task III) (default {','.join(method_names(default_only=True))})")
    bench.add_argument("--trials", type=positive_int, default=30, help="seeds 0 … trials−1 (default 30)")
    bench.add_argument("--seeds", type=seed_list, default=None, metavar="LIST",
                       help="run these seeds instead, e.g. 7 or 0-4,9 (re-running a seed reproduces its record)")
    bench.add_argument("--lanes", type=positive_int, default=BENCH_LANES,
                       help=f"trials simulated together in one vmapped batch (default {BENCH_LANES})")
    bench.add_argument("--no-figures", action="store_true", help="skip the per-condition trajectory figures")
    bench.add_argument("--workers", type=positive_int, default=os.cpu_count() or 1,
                       help="processes, one (task, shape) group each, one XLA thread each (default: the "
                            f"core count, {os.cpu_count() or 1} here)")
    bench.add_argument("--engine", default="local", choices=ENGINES,
                       help="run the (task, shape) groups in local worker processes, or as tasks on Ray (a local "
                            "instance of --workers CPUs on 127.0.0.1, or --ray-address; needs dexpush[cluster]) "
                            "(default local)")
    bench.add_argument("--ray-address", default=None, metavar="ADDRESS",
                       help="with --engine ray: a running cluster (ray://HOST:10001 or HOST:6379); its nodes must see "
                            "--out at the same path (docs/performance.md#sweeps-on-ray)")
    bench.add_argument("--plant", default="model", choices=PLANTS,
                       help="model: batched C-GVMM world; physics: MuJoCo, trials one by one; physics-random: "
                            "the same as --plant physics --randomize (default model)")
    bench.add_argument("--randomize", action="store_true",
                       help="with --plant physics: trial s runs in random world s (table and pusher friction, "
                            "support pressure, mass, pusher radius) seen through random camera s; the camera "
                            "options are then unused")
    add_camera_flags(bench)
    bench.add_argument("--max-steps", type=positive_int, default=MAX_STEPS,
                       help=f"control steps before a trial fails (default {MAX_STEPS})")
    add_planner_flags(bench)
    bench.add_argument("--config", metavar="FILE.toml", default=None,
                       help="a configuration file's [controller] and [sensor] tables (the same file as "
                            "`dexpush run --config`; flags override it)")
    bench.add_argument("--print-config", action="store_true",
                       help="print the effective [controller] and [sensor] as TOML and exit")
    bench.add_argument("--out", type=out_folder, default="out/bench",
                       help="output folder; re-running resumes (default out/bench)")
    bench.add_argument("--quiet", action="store_true", help="no progress output")
    bench.set_defaults(func=cmd_bench)

    val = sub.add_parser("validate-mit", help="validate the C-GVMM on MIT push-dataset files (paper Sec. IV-A)")
    val.add_argument("data_dir", help="folder with the dataset's motion_*.h5 / motion_*.json files")
    val.add_argument("--out", type=out_folder, default="out/validate-mit",
                     help="output folder (default out/validate-mit)")
    val.add_argument("--mu", type=positive_float, default=0.25,
                     help="pusher–object friction μ_c (default 0.25, as the paper)")
    val.add_argument("--online", action="store_true",
                     help="also run the controller's UKF over each object's pushes in order: λ over time, "
                          "convergence, whole-push error and NMSE with the online estimate (online.json, lambda.png)")
    val.add_argument("--estimate-mu", action="store_true",
                     help="with --online: the UKF estimates μ_c as well, from --mu as its prior")
    val.add_argument("--quiet", action="store_true", help="no per-object lines on stderr")
    val.set_defaults(func=cmd_validate)

    fit = sub.add_parser("fit", help="fit λ = [β, x_bf, y_bf] (and μ_c) to your recorded pushes",
                         description="Fit the C-GVMM's λ to recorded pushes: a CSV or NPZ log (columns t, x, y, "
                                     "theta, px, py: object pose and pusher centre in m, rad, s), MIT push files, "
                                     "or a folder of these. See docs/robot.md.")
    fit.add_argument("log", help="a .csv or .npz log, an MIT motion_*.h5/.json file, or a folder of them")
    fit.add_argument("--shape", default=None, metavar="NAME|FILE.toml",
                     help=f"the object: {', '.join(SHAPES)} or a shape file (MIT files: known from their names)")
    fit.add_argument("--mu", type=positive_float, default=0.25, help="pusher–object friction μ_c (the start value with "
                                                           "--fit-mu) (default 0.25)")
    fit.add_argument("--fit-mu", action="store_true", help="fit μ_c as well")
    fit.add_argument("--out", type=out_folder, default="out/fit",
                     help="output folder for fit.json and fit.png (default out/fit)")
    fit.add_argument("--quiet", action="store_true", help="no report on stderr")
    fit.set_defaults(func=cmd_fit)

    cal = sub.add_parser("calibrate", help="a camera's pose on the table (and its intrinsics) from images of a board",
                         description="Calibrate a camera from images of a ChArUco board or a marker (the [board] "
                                     "table of a TOML file): the first image shows the board flat on the table at "
                                     "its pose; with no --intrinsics, 3 or more images (the board held at varied "
                                     "angles) give them too. Writes (or updates, by camera name) a camera file that "
                                     "`--camera-file` reads. Needs dexpush[camera]. See docs/perception.md.")
    cal.add_argument("images", nargs="*", help="image files (PNG, JPEG, ...); the first: the board on the table")
    cal.add_argument("--board", required=True, metavar="FILE.toml", help="the board: kind, squares, sizes, pose")
    cal.add_argument("--intrinsics", metavar="CAMERA.toml", default=None,
                     help="take the intrinsics from this camera file (the camera named --name, else its first)")
    cal.add_argument("--name", default="camera", help="the camera's name in the file (default camera)")
    cal.add_argument("--board-image", metavar="FILE.png", default=None, help="also write the printable board here")
    cal.add_argument("--out", default="camera.toml", help="the camera file to write or update (default camera.toml)")
    cal.add_argument("--quiet", action="store_true", help="no notes on stderr")
    cal.set_defaults(func=cmd_calibrate)
    return p


#: flags whose value may be a negative number (argparse takes "-0.3,0.2,0" for an option)
_NUMERIC_FLAGS = ("--goal", "--obstacle", "--obstacle-box", "--wall", "--workspace", "--lambda-pred",
                  "--true-params")


def _joined_negatives(argv: Sequence[str]) -> list[str]:
    """``--goal -0.3,0.2,0`` as ``--goal=-0.3,0.2,0``, so that a negative coordinate is a value."""
    out: list[str] = []
    i = 0
    while i < len(argv):
        a = argv[i]
        if a in _NUMERIC_FLAGS and i + 1 < len(argv) and re.match(r"^-\.?\d", argv[i + 1]):
            out.append(f"{a}={argv[i + 1]}")
            i += 2
            continue
        out.append(a)
        i += 1
    return out


def _note(message: Warning | str, category: type[Warning], *_: object, **__: object) -> None:
    """Warnings as one line on stderr (a note to the user, not a traceback-like report)."""
    print(f"dexpush: note: {message}", file=sys.stderr)


def main(argv: Sequence[str] | None = None) -> int:
    argv = _joined_negatives(list(sys.argv[1:] if argv is None else argv))
    args = build_parser().parse_args(argv)
    args.argv = argv                        # a command that runs itself again (in a namespace) passes them on
    import matplotlib

    matplotlib.use("Agg")                   # figures go to files: no display needed, none opened
    if not os.environ.get("DEXPUSH_NO_CACHE"):
        from dexpush.common import compile_cache

        try:
            compile_cache.enable()          # a second run loads the compiled controller instead of compiling
        except OSError as exc:              # an unwritable cache folder only costs compile time
            print(f"dexpush: note: no compilation cache ({exc})", file=sys.stderr)
    if getattr(args, "seeds", None) is not None:
        args.seeds_text = ",".join(map(str, args.seeds))
    with warnings.catch_warnings():
        warnings.simplefilter("default", FutureWarning)
        warnings.showwarning = _note
        try:
            summary = args.func(args)
        except (ValueError, OSError, ImportError) as exc:  # bad input, a path or a system that cannot be used,
            # a missing optional extra: one line, no traceback
            print(f"dexpush: error: {exc}", file=sys.stderr)
            return 2
        except KeyboardInterrupt:
            resume = (f"; every finished trial is saved in {args.out}: the same command resumes there"
                      if args.command == "bench" else "")
            print(f"\ndexpush: interrupted{resume}", file=sys.stderr)
            return 130
    if summary:                         # --print-config printed the config instead
        print(json.dumps(summary))
    return 1 if summary.get("success") is False else 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
