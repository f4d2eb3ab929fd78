"""What each dexpush command does (run/demo, bench, validate-mit, fit): a function
of its parsed arguments that writes its files and returns the one-line JSON summary."""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING

from dexpush.cli.flags import camera_overrides, planner_overrides
from dexpush.cli.settings_file import merge
from dexpush.common.interfaces import CONTROL_PERIOD_S
from dexpush.experiments.methods import get_method, method_names
from dexpush.experiments.records import CONDITION_KEYS
from dexpush.experiments.registry import PARAMS, SHAPES

if TYPE_CHECKING:
    from dexpush.robot.safety import SafetySettings

__all__ = ["cmd_bench", "cmd_fit", "cmd_robot", "cmd_run", "cmd_validate", "effective_config", "given_flags",
           "safety_settings"]


def _episode_files(episode, shape, out: Path, animation: bool, control_period: float = CONTROL_PERIOD_S,
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
    regions = {"polygons": episode.polygons, "workspace": episode.workspace, "region": episode.region}
    fig = plot_episode(shape, episode.states, episode.modes, episode.goal, episode.obstacles, title=title,
                       path=files["trajectory"], events=episode.events, **regions)
    plt.close(fig)
    if get_method(rec.method).estimates:
        files["params"] = str(out / "params.png")
        plt.close(plot_params(episode.params, truth, files["params"], dt=control_period, title=title))
    if animation:
        duration = len(episode.states) * control_period
        speedup = max(1, math.ceil(duration / 30.0))      # long episodes play faster (the caption says so)
        files["animation"] = animate_episode(shape, episode.states, episode.modes, episode.goal, episode.obstacles,
                                             out / "animation.mp4", control_period=control_period,
                                             speedup=speedup, title=title, **regions)
    files["trajectory_data"] = str(out / "trajectory.npz")
    with atomic_path(files["trajectory_data"]) as tmp, open(tmp, "wb") as fh:
        np.savez_compressed(fh, **episode.arrays())
    write_json_atomic(files["summary"], episode.summary())
    return files


#: ``dexpush run`` flags that override the config's [run] table (None: not given)
_RUN_KEYS = ("task", "shape", "goal", "goal_region", "params", "lambda_pred", "method", "seed", "plant", "true_params",
             "mu",
             "max_steps")


def effective_config(args: argparse.Namespace, run_flags: bool = True):
    """The effective :class:`dexpush.cli.config.RunConfig`: the defaults, then ``--config``, then the
    flags (``run``'s what-and-where flags with ``run_flags``, the planner and camera flags always)."""
    from dexpush.cli.config import default_config, load_config

    over: dict = {}
    if run_flags:
        over["run"] = {k: getattr(args, k) for k in _RUN_KEYS if getattr(args, k, None) is not None}
        for flag, key in (("obstacle", "obstacles"), ("obstacle_box", "boxes"), ("wall", "walls"),
                          ("table_workspace", "workspace"), ("scene", "scene")):
            if getattr(args, flag, None) is not None:
                over["run"][key] = getattr(args, flag)
    planner, args.planner_text = planner_overrides(args)
    camera, args.camera_text = camera_overrides(args)
    over = merge(merge(over, planner), camera)
    return load_config(args.config, over) if getattr(args, "config", None) else default_config(over)


def cmd_run(args: argparse.Namespace) -> dict:
    from dexpush.cli.config import (
        build_plant,
        build_sensor,
        build_task,
        check_run_config,
        lambda_pred,
        load_shape,
        to_toml,
    )
    from dexpush.experiments.runner import run_episode
    from dexpush.model.cgvmm import LAMBDA_TRUE

    config = effective_config(args)
    check_run_config(config)
    if getattr(args, "print_config", False):
        if config.run.shape.endswith(".toml"):    # the printed file names the shape file from wherever it is saved
            config = config.replace(run={"shape": str(Path(config.run.shape).resolve())})
        sys.stdout.write(to_toml(config))
        return {}
    run = config.run
    shape = load_shape(run.shape)
    if shape.origin != (0.0, 0.0) and not args.quiet:
        print(f"dexpush: {shape.name}: reference point (the pose the goal refers to) at "
              f"({shape.origin[0]:.4f}, {shape.origin[1]:.4f}) m in the shape file's frame", file=sys.stderr)
    task = build_task(run)
    sensor = build_sensor(config)
    params = run.params if run.lambda_pred is None else lambda_pred(run)
    settings = config.controller
    episode = run_episode(task, shape, params=params, method=run.method, seed=run.seed,
                          max_steps=run.max_steps, settings=settings, progress=not args.quiet, lanes=args.lanes,
                          plant=build_plant(config, shape, None if task.region is None else task.problem(shape).table),
                          sensor=sensor)
    out = Path(args.out)
    files = _episode_files(episode, shape, out, animation=not args.no_animation,
                           control_period=settings.mppi.control_period,
                           truth=(run.true_params or LAMBDA_TRUE) if run.plant == "model" else None)
    summary = episode.summary()
    summary["files"] = files
    return summary


def cmd_robot(args: argparse.Namespace) -> dict:
    """``dexpush robot``: one episode on the simulated FR3 (``--sim``, the default) or a real Franka
    (``--robot ADDRESS``), through the frame guard, the safety filter and the watchdog (docs/robot.md)."""
    from dexpush.cli.config import build_sensor, build_task, check_run_config, lambda_pred, load_shape
    from dexpush.experiments.robot_trial import RobotSettings, run_robot_episode
    from dexpush.robot.driver import DriverSettings
    from dexpush.world.sensing import SensorSettings

    config = effective_config(args)
    run = config.run
    check_run_config(config, plant="franka")
    if args.robot is not None:
        raise ValueError(f"--robot {args.robot}: a real Franka needs the object's pose from your tracker; run it "
                         "from Python with run_robot_episode(..., address=..., sim=your_pose_source) "
                         "(docs/robot.md#a-real-franka)")
    shape = load_shape(run.shape)
    task = build_task(run)
    refuse_region(task, "dexpush robot")
    sensor = build_sensor(config)
    if sensor is None and getattr(args, "camera", None) != "exact":
        sensor = SensorSettings.realistic(seed=0)           # a robot sees through a camera unless told otherwise
    driver = DriverSettings(**given_flags(args, dynamics_factor="dynamics_factor", cutoff_frequency="cutoff_frequency"))
    robot = RobotSettings(safety=safety_settings(args), driver=driver)
    params = run.params if run.lambda_pred is None else lambda_pred(run)
    t0 = time.perf_counter()
    episode, report = run_robot_episode(task, shape, params=params, method=run.method, seed=run.seed,
                                        settings=config.controller, sensor=sensor, robot=robot,
                                        max_steps=run.max_steps, progress=not args.quiet)
    report["wall_s"] = round(time.perf_counter() - t0, 2)
    out = Path(args.out)
    files = _episode_files(episode, shape, out, animation=not args.no_animation,
                           control_period=config.controller.mppi.control_period)
    from dexpush.common.files import atomic_path, write_json_atomic

    files["log"] = str(out / "push_log.csv")         # what `dexpush fit` reads: one row per control step
    T = config.controller.mppi.control_period
    with atomic_path(files["log"]) as tmp, open(tmp, "w") as fh:
        fh.write("t,x,y,theta,px,py\n")
        for k, x in enumerate(episode.states):
            fh.write(f"{k * T:.4f}," + ",".join(f"{v:.6f}" for v in x) + "\n")
    summary = episode.summary()
    summary["robot"] = report
    write_json_atomic(files["summary"], summary)
    summary["files"] = files
    return summary


def cmd_clear(args: argparse.Namespace) -> dict:
    """``dexpush clear``: the pushing-and-grasping demonstration on the simulated FR3
    (:func:`dexpush.experiments.clearing.run_clearing`)."""
    from dexpush.common.files import write_json_atomic
    from dexpush.experiments.clearing import run_clearing
    from dexpush.world.sensing import SensorSettings

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    say = None if args.quiet else (lambda text: print(f"dexpush clear: {text}", file=sys.stderr, flush=True))
    record = run_clearing(args.seed, sensor=SensorSettings.realistic(args.seed),
                          video=None if args.no_video else out / "video.mp4", log=say)
    write_json_atomic(out / "clearing.json", record)
    keys = ("seed", "success", "props_in_bin", "overhang", "dropped", "grasped", "lifted", "plate_in_bin",
            "plate_time_s", "total_s", "error")
    return {k: record.get(k) for k in keys} | {"files": {"record": str(out / "clearing.json"),
                                                         "video": record.get("video")}}


def given_flags(args: argparse.Namespace, **fields: str) -> dict[str, object]:
    """The settings fields (name → the flag's dest) whose flags were given: the settings' own defaults stand for
    the rest, so that a default is written once, in its settings class."""
    return {name: getattr(args, dest) for name, dest in fields.items() if getattr(args, dest, None) is not None}


def safety_settings(args: argparse.Namespace) -> SafetySettings:
    """The safety filter's settings from ``--v-limit`` and ``--a-limit``, where given."""
    from dexpush.robot.safety import SafetySettings

    return SafetySettings(**given_flags(args, v_max="v_limit", a_max="a_limit"))


def refuse_region(task: object, command: str) -> None:
    """A one-line ``ValueError`` for a goal region where ``command`` takes goal poses only."""
    if getattr(task, "region", None) is not None:
        raise ValueError(f"{command} takes a goal pose; goal regions (docs/goal_regions.md) run in dexpush run and "
                         "dexpush bench")


def cmd_ros(args: argparse.Namespace) -> dict:
    """``dexpush ros``: the ROS 2 node until Ctrl-C (docs/ros.md); the summary holds its last status."""
    from dexpush.cli.config import build_task, check_run_config, lambda_pred, load_shape
    from dexpush.common.netns import LOCALHOST_ENV
    from dexpush.problem.problem import Problem
    from dexpush.problem.scene_file import Layout
    from dexpush.robot.smoothing import SmoothingSettings
    from dexpush.ros.core import NodeCore, NodeSettings
    from dexpush.ros.node import Topics, require_rclpy, run_node

    require_rclpy()
    for key, value in LOCALHOST_ENV.items():       # discovery stays on this machine unless the user widens it
        os.environ.setdefault(key, value)
    config = effective_config(args)
    check_run_config(config)
    run = config.run
    shape = load_shape(run.shape)
    task = build_task(run)
    refuse_region(task, "dexpush ros")
    node = NodeSettings(world_frame=args.world_frame, twist_frame=args.twist_frame, trigger=args.trigger,
                        stale_s=args.stale, watchdog_s=args.watchdog,
                        smoothing=SmoothingSettings(**given_flags(args, a_max="a_limit", j_max="j_limit"))
                        if args.smooth else None,
                        stream_hz=args.stream_rate, safety=safety_settings(args))
    topics = Topics(**{name: getattr(args, f"topic_{name}") for name in Topics().__dict__})
    params = run.params if run.lambda_pred is None else lambda_pred(run)
    lam = PARAMS[params] if isinstance(params, str) else tuple(params)
    method = get_method(run.method)
    method.check_sensing(exact_observations=False)

    def controller_for(problem: Problem) -> object:
        return method.controller(problem, lam, run.seed, config.controller)

    core = NodeCore(shape, Layout(task.obstacles, task.polygons, task.workspace), controller_for,
                    settings=config.controller, node=node,
                    log=(lambda text: None) if args.quiet else (lambda text: print(text, file=sys.stderr)),
                    goal=None if args.wait_for_goal else task.goal)
    return {"node": run_node(core, topics, args.node_name, duration_s=args.duration, until_reached=args.until_reached)}


def cmd_validate(args: argparse.Namespace) -> dict:
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
    """``validate-mit --online``: dexpush.data.online_ukf per object, written to online.json and lambda.png."""
    import matplotlib.pyplot as plt

    from dexpush.common.files import write_json_atomic
    from dexpush.control.estimator import UKFSettings
    from dexpush.data.mit import OBJECTS
    from dexpush.data.online_ukf import online_session
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


def cmd_fit(args: argparse.Namespace) -> dict:
    import matplotlib.pyplot as plt

    from dexpush.cli.config import load_shape
    from dexpush.common.files import write_json_atomic
    from dexpush.data.fitting import MAX_FIT_SAMPLES, fit_pushes
    from dexpush.data.mit import OBJECTS
    from dexpush.data.push_logs import read_log
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
    rows = sum(len(p.time) for p in pushes)
    if rows > 50_000 and not args.quiet:
        print(f"dexpush: fitting {len(pushes)} pushes ({rows} samples at 25 Hz; at most {MAX_FIT_SAMPLES} contact "
              "samples are used, thinned evenly)", file=sys.stderr, flush=True)
    result = fit_pushes(pushes, shape, mu=args.mu, fit_mu=args.fit_mu)
    summary = {"log": str(args.log), "shape": shape.name, **result.summary(), "explains_motion": result.explains}
    if not result.explains:
        print(f"dexpush: note: the fit's one-step error ({result.one_step_error_mm:.2f} mm) is as large as the "
              f"object's motion per sample ({result.motion_mm:.2f} mm): λ explains little. Check the shape (--shape), "
              "the columns (t, x, y, theta, px, py) and their units (s, m, rad)", file=sys.stderr)
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


def cmd_bench(args: argparse.Namespace) -> dict:
    import datetime
    import platform

    from dexpush.cli.config import build_sensor, check_bench_config, to_toml
    from dexpush.experiments.benchmark import run_benchmark
    from dexpush.experiments.results_folder import folder_records
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
    config = effective_config(args, run_flags=False)
    if getattr(args, "print_config", False):
        sys.stdout.write(to_toml(config, tables=("controller", "sensor", "render")))
        return {}
    check_bench_config(config, args)
    if config.run.camera == "rendered" and args.plant == "model":
        raise ValueError("--camera rendered sees the MuJoCo plant: add --plant physics (or --randomize)")
    if args.engine == "ray" and args.ray_address is None:   # a local Ray instance listens on every interface
        from dexpush.common.netns import run_in_loopback_namespace, why_not_loopback

        if not args.quiet and why_not_loopback() is not None:
            print("dexpush: starting Ray in a loopback-only network namespace", file=sys.stderr)
        code = run_in_loopback_namespace([sys.executable, "-m", "dexpush.cli", *args.argv],
                                         {"RAY_USAGE_STATS_ENABLED": "0"})
        if code is not None:
            raise SystemExit(code)
    t0 = time.perf_counter()
    records = run_benchmark(args.out, tasks, shapes, params, methods, seeds, max_steps=args.max_steps,
                            lanes=args.lanes, progress=not args.quiet, figures=not args.no_figures,
                            workers=args.workers, plant=args.plant, sensor=build_sensor(config),
                            settings=config.controller, engine=args.engine, address=args.ray_address)
    wall = time.perf_counter() - t0
    seed_text = f"--seeds {args.seeds_text}" if args.seeds is not None else f"--trials {args.trials}"
    meta = {"command": f"dexpush bench --tasks {args.tasks} --shapes {args.shapes} --params {args.params} "
                       f"--methods {args.methods} {seed_text} --lanes {args.lanes} --plant {args.plant}"
                       f"{args.camera_text}{args.planner_text}"
                       f"{f' --config {args.config}' if args.config else ''} --workers {args.workers}"
                       f"{' --engine ray' if args.engine == 'ray' else ''} --out {args.out}",
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


def cmd_calibrate(args: argparse.Namespace) -> dict:
    """``dexpush calibrate``: a camera's intrinsics (unless given) and its pose on the table from images
    of a board, written to a camera file (merged by camera name into an existing one)."""
    from dexpush.perception.calibration import calibrate_extrinsics, calibrate_intrinsics, read_board_file
    from dexpush.perception.camera_file import read_camera_file, write_camera_file
    from dexpush.perception.detect import require_cv2

    cv2 = require_cv2()
    board = read_board_file(args.board)
    if args.board_image:
        from dexpush.common.files import atomic_path

        with atomic_path(args.board_image) as tmp:
            if not cv2.imwrite(str(tmp), board.image()):
                raise OSError(f"cannot write {args.board_image} (give a .png file)")
        if not args.images:
            return {"board_image": str(args.board_image)}
    if not args.images:
        raise ValueError("give the calibration images: the first with the board flat at its [board] pose")
    images = []
    for path in args.images:
        img = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
        if img is None:
            raise ValueError(f"cannot read image {path} (missing, or not an image file)")
        images.append(img)
    intrinsic_rms = None
    if args.intrinsics:
        known = read_camera_file(args.intrinsics)
        match = [c for c in known if c.name == args.name] or known[:1]
        intrinsics = match[0]
        if (intrinsics.height, intrinsics.width) != images[0].shape:
            raise ValueError(f"camera file {args.intrinsics}: {intrinsics.width}×{intrinsics.height} pixels, but "
                             f"{args.images[0]} is {images[0].shape[1]}×{images[0].shape[0]}")
    elif len(images) >= 3:
        intrinsics = calibrate_intrinsics(images, board, args.name)
        intrinsic_rms = intrinsics.reprojection_error_px
    else:
        raise ValueError("give --intrinsics (a camera file from the maker or an earlier calibration), or 3 or more "
                         "images of the board at varied angles to estimate them")
    intrinsics = dataclasses.replace(intrinsics, name=args.name)
    camera = calibrate_extrinsics(images[0], intrinsics, board)
    out = Path(args.out)
    cameras = [c for c in (read_camera_file(out) if out.exists() else []) if c.name != args.name] + [camera]
    write_camera_file(out, cameras, f"written by dexpush calibrate --board {args.board} ({len(images)} images)")
    if not args.quiet and camera.reprojection_error_px > 1.0:
        print(f"dexpush: note: the reprojection error is {camera.reprojection_error_px:.2f} px (expect < 0.5): check "
              "the board's size and pose in the board file, and the intrinsics", file=sys.stderr)
    return {"camera": camera.name, "camera_file": str(out), "images": len(images),
            "reprojection_error_px": round(camera.reprojection_error_px, 4),
            "intrinsic_rms_px": None if intrinsic_rms is None else round(intrinsic_rms, 4),
            "position_m": [round(float(v), 5) for v in camera.position],
            "fx": round(camera.fx, 3), "fy": round(camera.fy, 3), "cx": round(camera.cx, 3), "cy": round(camera.cy, 3)}
