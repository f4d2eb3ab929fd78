"""dexpush: contact-aware planar pushing with the C-GVMM, long-horizon MPPI and a UKF.

    dexpush demo [--out DIR]                 Task I, rect, known parameters, MPPI
    dexpush run --task I --shape tee --params unknown --method mppi --seed 3 --out DIR
    dexpush bench [--tasks I,II --shapes rect --trials 5 --out DIR]   the Sec. IV-B table
    dexpush bench --tasks I --shapes tee --params unknown --methods mppi --seeds 7   re-run one trial
    dexpush validate-mit DATA_DIR [--out DIR] [--online]  C-GVMM (and the online UKF) against recorded MIT pushes
    dexpush fit LOG --shape FILE.toml        fit λ (and μ_c) to your own recorded pushes

Every command writes its files under ``--out`` and prints a one-line JSON summary last.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from dexpush.cli.arguments import floats, positive_int, seed, seed_list
from dexpush.cli.planner_flags import add_planner_flags, planner_settings
from dexpush.experiments.benchmark import BENCH_LANES
from dexpush.experiments.methods import get_method, method_names
from dexpush.experiments.records import CONDITION_KEYS
from dexpush.experiments.registry import PARAMS, PLANTS, SHAPES
from dexpush.experiments.scenarios import MAX_STEPS

__all__ = ["main"]


def _episode_files(episode, shape, out: Path, animation: bool, control_period: float = 0.04,
                   truth: object | None = None) -> dict[str, str]:
    import matplotlib.pyplot as plt
    import numpy as np

    from dexpush.common.files import atomic_path, write_json_atomic
    from dexpush.viz import animate_episode, plot_episode, plot_params

    rec = episode.record
    task = "custom goal" if rec.task == "custom" else f"Task {rec.task}"
    title = (f"{task} · {rec.shape} · {rec.method} ({rec.params} λ) · {rec.plant} plant · camera: {rec.sensor} · "
             f"seed {rec.seed}\n{'success' if rec.success else 'failure'} in {rec.steps} steps ({rec.time_s:g} s)")
    files = {"trajectory": str(out / "trajectory.png"), "summary": str(out / "summary.json")}
    fig = plot_episode(shape, episode.states, episode.modes, episode.goal, episode.obstacles, title=title,
                       path=files["trajectory"])
    plt.close(fig)
    if get_method(rec.method).estimates:
        files["params"] = str(out / "params.png")
        plt.close(plot_params(episode.params, truth, files["params"], dt=control_period, title=title))
    if animation:
        duration = len(episode.states) * control_period
        speedup = max(1, math.ceil(duration / 30.0))      # long episodes play faster (the caption says so)
        files["animation"] = animate_episode(shape, episode.states, episode.modes, episode.goal, episode.obstacles,
                                             out / "animation.mp4", control_period=control_period,
                                             speedup=speedup, title=title)
    files["trajectory_data"] = str(out / "trajectory.npz")
    with atomic_path(files["trajectory_data"]) as tmp, open(tmp, "wb") as fh:
        np.savez_compressed(fh, states=episode.states, modes=episode.modes, commands=episode.commands,
                            planning_ms=episode.planning_ms, params=episode.params, goal=episode.goal,
                            obstacles=episode.obstacles)
    write_json_atomic(files["summary"], episode.summary())
    return files


#: ``dexpush run`` flags that override the config's [run] table (None: not given)
_RUN_KEYS = ("task", "shape", "goal", "params", "lambda_pred", "method", "seed", "plant", "true_params", "mu",
             "max_steps")


def _run_config(args: argparse.Namespace):
    """The effective :class:`dexpush.cli.config.RunConfig`: defaults, then ``--config``, then the flags."""
    from dexpush.cli.config import default_config, load_config, to_dict

    over: dict = {"run": {k: getattr(args, k) for k in _RUN_KEYS if getattr(args, k, None) is not None}}
    if getattr(args, "obstacle", None) is not None:
        over["run"]["obstacles"] = args.obstacle
    if args.samples is not None:
        over["controller"] = {"mppi": {"num_samples": args.samples}}
    sensor = _sensor_flags(args)
    if sensor is not None:
        over["sensor"] = to_dict(sensor)
    return load_config(args.config, over) if getattr(args, "config", None) else default_config(over)


def _cmd_run(args: argparse.Namespace) -> dict:
    from dexpush.cli.config import build_plant, build_task, lambda_pred, load_shape, to_toml
    from dexpush.experiments.runner import run_episode
    from dexpush.model.cgvmm import LAMBDA_TRUE

    config = _run_config(args)
    if getattr(args, "print_config", False):
        sys.stdout.write(to_toml(config))
        return {}
    run = config.run
    shape = load_shape(run.shape)
    if shape.origin != (0.0, 0.0) and not args.quiet:
        print(f"dexpush: {shape.name}: reference point (the pose the goal refers to) at "
              f"({shape.origin[0]:.4f}, {shape.origin[1]:.4f}) m in the shape file's frame", file=sys.stderr)
    task = build_task(run)
    sensor = config.sensor if config.sensor != type(config.sensor)() else None
    params = run.params if run.lambda_pred is None else lambda_pred(run)
    settings = config.controller
    episode = run_episode(task, shape, params=params, method=run.method, seed=run.seed,
                          max_steps=run.max_steps, settings=settings, progress=not args.quiet, lanes=args.lanes,
                          plant=build_plant(config, shape), sensor=sensor)
    out = Path(args.out)
    files = _episode_files(episode, shape, out, animation=not args.no_animation,
                           control_period=settings.mppi.control_period,
                           truth=(run.true_params or LAMBDA_TRUE) if run.plant == "model" else None)
    summary = episode.summary()
    summary["files"] = files
    return summary


def _cmd_validate(args: argparse.Namespace) -> dict:
    import matplotlib.pyplot as plt

    from dexpush.common.files import write_json_atomic
    from dexpush.data.mit import load_folder
    from dexpush.data.validation import validate
    from dexpush.viz import plot_confusion, plot_mode_decisions

    if args.estimate_mu and not args.online:
        raise ValueError("--estimate-mu is an option of --online (the UKF's μ_c); add --online")
    pushes = load_folder(args.data_dir)
    result = validate(pushes, mu=args.mu)
    out = Path(args.out)
    files = {"mode_decisions": str(out / "mode_decisions.png"), "confusion": str(out / "confusion.png"),
             "summary": str(out / "validation.json")}
    plt.close(plot_mode_decisions(result.per_object, args.mu, files["mode_decisions"]))
    plt.close(plot_confusion(result.per_object, files["confusion"]))
    write_json_atomic(files["summary"], result.summary)
    if not args.quiet:
        for name, e in result.summary["objects"].items():
            print(f"{name}: {e['pushes']} pushes, {e['samples']} samples, β = {e['beta_fit']:.1f}, "
                  f"mode agreement {e['mode_agreement']:.1%}, one-step {e['one_step_error_mm']:.2f} mm / "
                  f"{e['one_step_error_deg']:.2f}°, whole push {e['whole_push_error_mm']:.2f} mm / "
                  f"{e['whole_push_error_deg']:.2f}°", file=sys.stderr)
    summary = {k: v for k, v in result.summary.items() if k != "objects"}
    summary["beta_fit"] = {k: e["beta_fit"] for k, e in result.summary["objects"].items()}
    summary["lambda_fit"] = {k: e.get("lambda_fit") for k, e in result.summary["objects"].items()}
    if args.online:
        summary["online"] = _validate_online(pushes, args, out, files)
    summary["files"] = files
    return summary


def _validate_online(pushes: list, args: argparse.Namespace, out: Path, files: dict) -> dict:
    """``validate-mit --online``: dexpush.data.online per object, written to online.json and lambda.png."""
    import matplotlib.pyplot as plt

    from dexpush.common.files import write_json_atomic
    from dexpush.control.estimator import UKFSettings
    from dexpush.data.mit import OBJECTS
    from dexpush.data.online import online_session
    from dexpush.experiments.registry import PARAMS
    from dexpush.viz import plot_online_lambda

    per_object, traces = {}, {}
    settings = UKFSettings(estimate_mu=args.estimate_mu)
    for name in sorted({p.shape for p in pushes}):
        per_object[name], traces[name] = online_session([p for p in pushes if p.shape == name], OBJECTS[name](),
                                                        prior=PARAMS["unknown"], mu=args.mu, settings=settings)
        if not args.quiet:
            e = per_object[name]
            mu_text = f", μ_c {args.mu:g} → {e['mu_c_final']:.3f}" if args.estimate_mu else ""
            print(f"{name} online: β {e['prior'][0]:g} → {e['lambda_final'][0]:.1f}{mu_text} (settled after push "
                  f"{e['settled_after_push']} of {e['pushes']}), whole push {e['whole_push_error_mm_online']:.2f} mm / "
                  f"{e['whole_push_error_deg_online']:.2f}° (prior {e['whole_push_error_mm_prior']:.2f} mm / "
                  f"{e['whole_push_error_deg_prior']:.2f}°), NMSE {e['nmse_online']:.2f} (prior {e['nmse_prior']:.2f})",
                  file=sys.stderr)
    files["online"], files["lambda"] = str(out / "online.json"), str(out / "lambda.png")
    write_json_atomic(files["online"], per_object)
    plt.close(plot_online_lambda(traces, files["lambda"]))
    return {name: {k: e[k] for k in ("lambda_final", "settled_after_push", "whole_push_error_deg_online",
                                     "whole_push_error_deg_prior", "nmse_online", "nmse_prior")}
            for name, e in per_object.items()}


def _cmd_fit(args: argparse.Namespace) -> dict:
    import matplotlib.pyplot as plt

    from dexpush.cli.config import load_shape
    from dexpush.common.files import write_json_atomic
    from dexpush.data.fitting import fit_pushes
    from dexpush.data.logs import read_log
    from dexpush.data.mit import OBJECTS
    from dexpush.viz import plot_fit

    pushes = read_log(args.log)
    if args.shape is not None:
        shape = load_shape(args.shape)
    else:
        kinds = {p.shape for p in pushes}
        if len(kinds) > 1 and kinds <= set(OBJECTS):
            raise ValueError(f"the log holds pushes of several objects ({', '.join(sorted(kinds))}); fit one object "
                             "at a time (a folder with only its files)")
        if len(kinds) != 1 or next(iter(kinds)) not in OBJECTS:
            raise ValueError("--shape is needed: the object's footprint (rect, tee, ellipse or a shape file), "
                             "with the logged pose being its reference point")
        shape = OBJECTS[next(iter(kinds))]()
    result = fit_pushes(pushes, shape, mu=args.mu, fit_mu=args.fit_mu)
    summary = {"log": str(args.log), "shape": shape.name, **result.summary()}
    out = Path(args.out)
    files = {"fit": str(out / "fit.json"), "figure": str(out / "fit.png")}
    plt.close(plot_fit(shape, [p.states for p in pushes], result.replays, summary, files["figure"]))
    lam = summary["lambda"]
    summary["use"] = (f"dexpush run --lambda-pred {lam[0]:g},{lam[1]:g},{lam[2]:g}"
                      + (f" (and [controller] mu = {summary['mu_c']:g} in a --config file)" if args.fit_mu else ""))
    write_json_atomic(files["fit"], summary)
    if not args.quiet:
        std = [v if v is not None else float("inf") for v in summary["lambda_std"]]
        mu = f"μ_c = {args.mu:g} (given)"
        if args.fit_mu:
            mu = (f"μ_c = {summary['mu_c']:.3f} ± {summary['mu_c_std']:.3f}" if summary["mu_c_std"] is not None
                  else f"μ_c = {summary['mu_c']:.3f}, not identifiable: no sample slides along the contour")
        print(f"{summary['pushes']} pushes, {summary['samples']} samples at 25 Hz\n"
              f"β    = {lam[0]:8.2f} ± {std[0]:.2f} 1/m\nx_bf = {lam[1] * 1e3:8.2f} ± {std[1] * 1e3:.2f} mm\n"
              f"y_bf = {lam[2] * 1e3:8.2f} ± {std[2] * 1e3:.2f} mm\n{mu}\n"
              f"one-step error {summary['one_step_error_mm']:.2f} mm / {summary['one_step_error_deg']:.2f}°, "
              f"whole push {summary['whole_push_error_mm']:.1f} mm / {summary['whole_push_error_deg']:.1f}°\n"
              f"use it: {summary['use']}", file=sys.stderr)
    summary["files"] = files
    return summary


def _sensor_flags(args: argparse.Namespace):
    """The camera the flags ask for, or None when no camera flag was given."""
    from dexpush.world.sensing import SensorSettings

    if args.camera == "realistic":
        return SensorSettings.realistic()
    if args.camera is None and not any((args.noise_mm, args.noise_deg, args.camera_hz, args.latency_ms, args.drop)):
        return None
    return SensorSettings(pos_std_m=args.noise_mm / 1e3, heading_std_rad=math.radians(args.noise_deg),
                          rate_hz=args.camera_hz, latency_s=args.latency_ms / 1e3, drop_prob=args.drop)


def _sensor(args: argparse.Namespace):
    from dexpush.world.sensing import SensorSettings

    return _sensor_flags(args) or SensorSettings()


def _sensor_text(args: argparse.Namespace) -> str:
    if args.camera == "realistic":
        return " --camera realistic"
    parts = [f" --{name.replace('_', '-')} {getattr(args, name)}"
             for name in ("noise_mm", "noise_deg", "camera_hz", "latency_ms", "drop") if getattr(args, name)]
    return "".join(parts)


def _cmd_bench(args: argparse.Namespace) -> dict:
    import datetime
    import platform

    from dexpush.experiments.benchmark import folder_records, run_benchmark
    from dexpush.experiments.scenarios import get_task
    from dexpush.experiments.tables import write_tables

    tasks = [get_task(t).key for t in args.tasks.split(",")]
    shapes, params, methods = (args.shapes.split(","), args.params.split(","), args.methods.split(","))
    choices = (("shape", shapes, SHAPES), ("params", params, tuple(PARAMS)), ("method", methods, method_names()))
    for name, values, allowed in choices:
        bad = [v for v in values if v not in allowed]
        if bad:
            raise ValueError(f"unknown {name} {bad[0]!r}; choose from {', '.join(allowed)}")
    seeds = args.seeds if args.seeds is not None else list(range(args.trials))
    if args.randomize:
        if args.plant not in ("physics", "physics-random"):
            raise ValueError("--randomize randomises the physics plant's world: use it with --plant physics")
        args.plant = "physics-random"
    settings, options = planner_settings(args)
    t0 = time.perf_counter()
    records = run_benchmark(args.out, tasks, shapes, params, methods, seeds, max_steps=args.max_steps,
                            lanes=args.lanes, progress=not args.quiet, figures=not args.no_figures,
                            workers=args.workers, plant=args.plant, sensor=_sensor(args), settings=settings)
    wall = time.perf_counter() - t0
    seed_text = f"--seeds {args.seeds_text}" if args.seeds is not None else f"--trials {args.trials}"
    meta = {"command": f"dexpush bench --tasks {args.tasks} --shapes {args.shapes} --params {args.params} "
                       f"--methods {args.methods} {seed_text} --lanes {args.lanes} --plant {args.plant}"
                       f"{_sensor_text(args)}{options} --workers {args.workers} --out {args.out}",
            "date": datetime.date.today().isoformat(),
            "machine": f"{platform.machine()}, {os.cpu_count()} CPUs, {platform.python_implementation()} "
                       f"{platform.python_version()}",
            "wall_s_this_invocation": round(wall, 1)}
    everything = folder_records(args.out)      # the tables cover every trial in the folder, not only this run's
    if len(everything) > len(records):
        meta["note"] = (f"{len(everything) - len(records)} of the {len(everything)} trials were recorded by earlier "
                        f"runs into {args.out} with the same settings (settings.json)")
    files = write_tables(args.out, everything, meta)
    ok = sum(r["success"] for r in records)
    n_cond = len({tuple(r[k] for k in CONDITION_KEYS) for r in records})
    return {"conditions": n_cond, "trials": len(records), "successes": ok,
            "success_rate": round(ok / len(records), 4) if records else None, "wall_s": round(wall, 1),
            "files": files}


def _version() -> str:
    import importlib.metadata

    try:
        return importlib.metadata.version("dexpush")
    except importlib.metadata.PackageNotFoundError:  # pragma: no cover (a source tree without install)
        return "unknown"


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="dexpush", description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--version", action="version", version=f"%(prog)s {_version()}")
    sub = p.add_subparsers(dest="command", required=True)

    def sensor_args(sp: argparse.ArgumentParser) -> None:
        g = sp.add_argument_group("sensing (what the controller sees; default: exact state every step)")
        g.add_argument("--camera", choices=["exact", "realistic"], default=None,
                       help="exact (default): the true state every step; realistic: 15 Hz, 1 mm / 0.5° noise, "
                            "60 ms latency, 5%% dropped frames")
        g.add_argument("--noise-mm", type=float, default=0.0, help="object position noise σ (mm)")
        g.add_argument("--noise-deg", type=float, default=0.0, help="object heading noise σ (deg)")
        g.add_argument("--camera-hz", type=float, default=None, help="camera rate (default: every control step)")
        g.add_argument("--latency-ms", type=float, default=0.0, help="capture-to-controller delay (ms)")
        g.add_argument("--drop", type=float, default=0.0, help="probability of a lost frame")

    def episode_args(sp: argparse.ArgumentParser, out: str) -> None:
        sp.add_argument("--out", default=out, help=f"output folder (default {out})")
        sp.add_argument("--max-steps", type=positive_int, default=None,
                        help=f"control steps before giving up (default {MAX_STEPS})")
        sp.add_argument("--samples", type=positive_int, default=None, help="MPPI samples K (default 1024)")
        sp.add_argument("--no-animation", action="store_true", help="skip the animation")
        sp.add_argument("--quiet", action="store_true", help="no progress bar")

    demo = sub.add_parser("demo", help="closed-loop demo: Task I, rect, known parameters, MPPI")
    episode_args(demo, "out/demo")
    demo.set_defaults(task="I", shape="rect", params="known", method="mppi", seed=0, lanes=1, plant="model",
                      camera="exact", noise_mm=0.0, noise_deg=0.0, camera_hz=None, latency_ms=0.0, drop=0.0,
                      func=_cmd_run)

    run = sub.add_parser("run", help="one closed-loop episode: a benchmark task, or your own object, goal and "
                                     "obstacles", formatter_class=argparse.RawDescriptionHelpFormatter,
                         epilog="examples:\n"
                                "  dexpush run --task III --shape tee --method mppi-ukf --params unknown --seed 3\n"
                                "  dexpush run --shape examples/shapes/l_block.toml --goal 0.4,0.2,30deg "
                                "--obstacle 0.2,0.1,0.03\n"
                                "  dexpush run --print-config > run.toml   # edit, then: dexpush run --config run.toml")
    what = run.add_argument_group("what to push where (flags override --config)")
    what.add_argument("--config", metavar="FILE.toml", default=None,
                      help="a run configuration (see --print-config for every key and its default)")
    what.add_argument("--print-config", action="store_true",
                      help="print the effective configuration as TOML and exit")
    what.add_argument("--task", default=None, help="I, II or III: start distribution, goal, obstacles (default I)")
    what.add_argument("--shape", default=None, metavar="NAME|FILE.toml",
                      help=f"{', '.join(SHAPES)}, or a shape file (docs/conventions.md#shapes) (default rect)")
    what.add_argument("--goal", type=floats(3, "--goal"), default=None, metavar="X,Y,THETA",
                      help="goal pose of the shape's reference point: x, y in m, θ in rad (or e.g. 30deg) "
                           "(default: the task's)")
    what.add_argument("--obstacle", type=floats(3, "--obstacle"), action="append", default=None,
                      metavar="CX,CY,R", help="a disc obstacle in m; repeat for more (default: the task's)")
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
    how.add_argument("--mu", type=float, default=None, help="the model plant's true μ_c (default 0.3)")
    how.add_argument("--lanes", type=positive_int, default=1,
                     help=f"batch lanes of the simulation (default 1); {BENCH_LANES} (the bench's) reproduces a "
                          "`dexpush bench` record exactly")
    sensor_args(run)
    episode_args(run, "out/run")
    run.set_defaults(func=_cmd_run)

    bench = sub.add_parser("bench", help="the paper's Sec. IV-B table (batched, resumable)")
    bench.add_argument("--tasks", default="I,II,III", help="comma-separated tasks from I, II, III (default I,II,III)")
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
    bench.add_argument("--plant", default="model", choices=PLANTS,
                       help="model: batched C-GVMM world; physics: MuJoCo, trials one by one; physics-random: "
                            "the same as --plant physics --randomize (default model)")
    bench.add_argument("--randomize", action="store_true",
                       help="with --plant physics: trial s runs in random world s (table and pusher friction, "
                            "support pressure, mass, pusher radius) seen through random camera s; the camera "
                            "options are then unused")
    sensor_args(bench)
    bench.add_argument("--max-steps", type=positive_int, default=MAX_STEPS,
                       help=f"control steps before a trial fails (default {MAX_STEPS})")
    add_planner_flags(bench)
    bench.add_argument("--out", default="out/bench", help="output folder; re-running resumes (default out/bench)")
    bench.add_argument("--quiet", action="store_true", help="no progress output")
    bench.set_defaults(func=_cmd_bench)

    val = sub.add_parser("validate-mit", help="validate the C-GVMM on MIT push-dataset files (paper Sec. IV-A)")
    val.add_argument("data_dir", help="folder with the dataset's motion_*.h5 / motion_*.json files")
    val.add_argument("--out", default="out/validate-mit", help="output folder (default out/validate-mit)")
    val.add_argument("--mu", type=float, default=0.25, help="pusher–object friction μ_c (default 0.25, as the paper)")
    val.add_argument("--online", action="store_true",
                     help="also run the controller's UKF over each object's pushes in order: λ over time, "
                          "convergence, whole-push error and NMSE with the online estimate (online.json, lambda.png)")
    val.add_argument("--estimate-mu", action="store_true",
                     help="with --online: the UKF estimates μ_c as well, from --mu as its prior")
    val.add_argument("--quiet", action="store_true", help="no per-object lines on stderr")
    val.set_defaults(func=_cmd_validate)

    fit = sub.add_parser("fit", help="fit λ = [β, x_bf, y_bf] (and μ_c) to your recorded pushes",
                         description="Fit the C-GVMM's λ to recorded pushes: a CSV or NPZ log (columns t, x, y, "
                                     "theta, px, py: object pose and pusher centre in m, rad, s), MIT push files, "
                                     "or a folder of these. See docs/robot.md.")
    fit.add_argument("log", help="a .csv or .npz log, an MIT motion_*.h5/.json file, or a folder of them")
    fit.add_argument("--shape", default=None, metavar="NAME|FILE.toml",
                     help=f"the object: {', '.join(SHAPES)} or a shape file (MIT files: known from their names)")
    fit.add_argument("--mu", type=float, default=0.25, help="pusher–object friction μ_c (the start value with "
                                                           "--fit-mu) (default 0.25)")
    fit.add_argument("--fit-mu", action="store_true", help="fit μ_c as well")
    fit.add_argument("--out", default="out/fit", help="output folder for fit.json and fit.png (default out/fit)")
    fit.add_argument("--quiet", action="store_true", help="no report on stderr")
    fit.set_defaults(func=_cmd_fit)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
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
    try:
        summary = args.func(args)
    except (ValueError, OSError) as exc:  # bad input, or a path that cannot be used: one clear line, no traceback
        print(f"dexpush: error: {exc}", file=sys.stderr)
        return 2
    if summary:                         # --print-config printed the config instead
        print(json.dumps(summary))
    return 1 if summary.get("success") is False else 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
