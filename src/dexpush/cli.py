"""dexpush: contact-aware planar pushing with the C-GVMM, long-horizon MPPI and a UKF.

    dexpush demo [--out DIR]                 Task I, rect, known parameters, MPPI
    dexpush run --task I --shape tee --params unknown --method mppi --seed 3 --out DIR
    dexpush bench [--tasks I,II --shapes rect --trials 5 --out DIR]   the Sec. IV-B table
    dexpush bench --tasks I --shapes tee --params unknown --methods mppi --seeds 7   re-run one trial
    dexpush validate-mit DATA_DIR [--out DIR]  C-GVMM against recorded MIT pushes

Every command writes its files under ``--out`` and prints a one-line JSON summary last.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from dexpush.benchmark import BENCH_LANES
from dexpush.records import CONDITION_KEYS
from dexpush.registry import ALL_METHODS, PARAMS, PLANTS, SHAPES
from dexpush.tasks import MAX_STEPS

__all__ = ["main"]


def _episode_files(episode, shape, out: Path, animation: bool) -> dict[str, str]:
    import matplotlib.pyplot as plt
    import numpy as np

    from dexpush.files import atomic_path, write_json_atomic
    from dexpush.model import LAMBDA_TRUE
    from dexpush.viz import animate_episode, plot_episode, plot_params

    rec = episode.record
    title = (f"Task {rec.task} · {rec.shape} · {rec.params} params · {rec.method} · seed {rec.seed}: "
             f"{'success' if rec.success else 'failure'} in {rec.steps} steps")
    files = {"trajectory": str(out / "trajectory.png"), "summary": str(out / "summary.json")}
    fig = plot_episode(shape, episode.states, episode.modes, episode.goal, episode.obstacles, title=title,
                       path=files["trajectory"])
    plt.close(fig)
    if rec.method == "mppi-ukf":
        files["params"] = str(out / "params.png")
        plt.close(plot_params(episode.params, LAMBDA_TRUE, files["params"], title=title))
    if animation:
        files["animation"] = str(out / "animation.gif")
        animate_episode(shape, episode.states, episode.modes, episode.goal, episode.obstacles,
                        files["animation"], title=title)
    files["trajectory_data"] = str(out / "trajectory.npz")
    with atomic_path(files["trajectory_data"]) as tmp, open(tmp, "wb") as fh:
        np.savez_compressed(fh, states=episode.states, modes=episode.modes, commands=episode.commands,
                            planning_ms=episode.planning_ms, params=episode.params, goal=episode.goal,
                            obstacles=episode.obstacles)
    write_json_atomic(files["summary"], episode.summary())
    return files


def _cmd_run(args: argparse.Namespace) -> dict:
    from dexpush.controller import ControllerSettings
    from dexpush.mppi import MPPISettings
    from dexpush.registry import make_shape
    from dexpush.runner import run_episode

    shape = make_shape(args.shape)
    settings = ControllerSettings(mppi=MPPISettings(num_samples=args.samples))
    episode = run_episode(args.task, shape, params=args.params, method=args.method, seed=args.seed,
                          max_steps=args.max_steps, settings=settings, progress=not args.quiet, lanes=args.lanes,
                          plant=args.plant, sensor=_sensor(args))
    out = Path(args.out)
    files = _episode_files(episode, shape, out, animation=not args.no_animation)
    summary = episode.summary()
    summary["files"] = files
    return summary


def _cmd_validate(args: argparse.Namespace) -> dict:
    import matplotlib.pyplot as plt

    from dexpush.dataset import load_folder, validate
    from dexpush.files import write_json_atomic
    from dexpush.viz import plot_confusion, plot_mode_decisions

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
    summary["files"] = files
    return summary


def _seed_list(text: str) -> list[int]:
    """``0-29`` or ``3,7,11`` (or a mix) → sorted seeds."""
    seeds: set[int] = set()
    for part in text.split(","):
        lo, _, hi = part.strip().partition("-")
        try:
            a, b = int(lo), int(hi or lo)
        except ValueError:
            raise argparse.ArgumentTypeError(f"seeds must look like 0-29 or 3,7,11, got {text!r}") from None
        if a < 0 or b < a:
            raise argparse.ArgumentTypeError(f"bad seed range {part!r} in {text!r}")
        seeds.update(range(a, b + 1))
    return sorted(seeds)


def _sensor(args: argparse.Namespace):
    from dexpush.sensing import SensorSettings

    if args.camera == "realistic":
        return SensorSettings.realistic()
    import math

    return SensorSettings(pos_std_m=args.noise_mm / 1e3, heading_std_rad=math.radians(args.noise_deg),
                          rate_hz=args.camera_hz, latency_s=args.latency_ms / 1e3, drop_prob=args.drop)


def _sensor_text(args: argparse.Namespace) -> str:
    if args.camera == "realistic":
        return " --camera realistic"
    parts = [f" --{name.replace('_', '-')} {getattr(args, name)}"
             for name in ("noise_mm", "noise_deg", "camera_hz", "latency_ms", "drop") if getattr(args, name)]
    return "".join(parts)


def _cmd_bench(args: argparse.Namespace) -> dict:
    import datetime
    import platform

    from dexpush.benchmark import folder_records, run_benchmark
    from dexpush.tables import write_tables
    from dexpush.tasks import get_task

    tasks = [get_task(t).key for t in args.tasks.split(",")]
    shapes, params, methods = (args.shapes.split(","), args.params.split(","), args.methods.split(","))
    choices = (("shape", shapes, SHAPES), ("params", params, tuple(PARAMS)), ("method", methods, ALL_METHODS))
    for name, values, allowed in choices:
        bad = [v for v in values if v not in allowed]
        if bad:
            raise ValueError(f"unknown {name} {bad[0]!r}; choose from {', '.join(allowed)}")
    seeds = args.seeds if args.seeds is not None else list(range(args.trials))
    t0 = time.perf_counter()
    records = run_benchmark(args.out, tasks, shapes, params, methods, seeds, max_steps=args.max_steps,
                            lanes=args.lanes, progress=not args.quiet, figures=not args.no_figures,
                            workers=args.workers, plant=args.plant, sensor=_sensor(args))
    wall = time.perf_counter() - t0
    seed_text = f"--seeds {args.seeds_text}" if args.seeds is not None else f"--trials {args.trials}"
    meta = {"command": f"dexpush bench --tasks {args.tasks} --shapes {args.shapes} --params {args.params} "
                       f"--methods {args.methods} {seed_text} --lanes {args.lanes} --plant {args.plant}"
                       f"{_sensor_text(args)} --workers {args.workers} --out {args.out}",
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


def _positive_int(text: str) -> int:
    v = int(text)
    if v < 1:
        raise argparse.ArgumentTypeError(f"must be a positive integer, got {text}")
    return v


def _seed(text: str) -> int:
    v = int(text)
    if v < 0:
        raise argparse.ArgumentTypeError(f"seed must be >= 0, got {text}")
    return v


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="dexpush", description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--version", action="version", version=f"%(prog)s {_version()}")
    sub = p.add_subparsers(dest="command", required=True)

    def sensor_args(sp: argparse.ArgumentParser) -> None:
        g = sp.add_argument_group("sensing (what the controller sees; default: exact state every step)")
        g.add_argument("--camera", choices=["exact", "realistic"], default="exact",
                       help="realistic: 15 Hz, 1 mm / 0.5° noise, 60 ms latency, 5%% dropped frames")
        g.add_argument("--noise-mm", type=float, default=0.0, help="object position noise σ (mm)")
        g.add_argument("--noise-deg", type=float, default=0.0, help="object heading noise σ (deg)")
        g.add_argument("--camera-hz", type=float, default=None, help="camera rate (default: every control step)")
        g.add_argument("--latency-ms", type=float, default=0.0, help="capture-to-controller delay (ms)")
        g.add_argument("--drop", type=float, default=0.0, help="probability of a lost frame")

    def episode_args(sp: argparse.ArgumentParser, out: str) -> None:
        sp.add_argument("--out", default=out, help=f"output folder (default {out})")
        sp.add_argument("--max-steps", type=_positive_int, default=MAX_STEPS,
                        help=f"control steps before giving up (default {MAX_STEPS})")
        sp.add_argument("--samples", type=_positive_int, default=1024, help="MPPI samples K (default 1024)")
        sp.add_argument("--no-animation", action="store_true", help="skip the GIF")
        sp.add_argument("--quiet", action="store_true", help="no progress bar")

    demo = sub.add_parser("demo", help="closed-loop demo: Task I, rect, known parameters, MPPI")
    episode_args(demo, "out/demo")
    demo.set_defaults(task="I", shape="rect", params="known", method="mppi", seed=0, lanes=1, plant="model",
                      camera="exact", noise_mm=0.0, noise_deg=0.0, camera_hz=None, latency_ms=0.0, drop=0.0,
                      func=_cmd_run)

    run = sub.add_parser("run", help="one episode of a benchmark task")
    run.add_argument("--task", default="I", help="I, II or III (default I)")
    run.add_argument("--shape", default="rect", choices=SHAPES)
    run.add_argument("--params", default="known", choices=tuple(PARAMS),
                     help="λ_pred = λ_true (known) or [15, 0, 0] (unknown)")
    run.add_argument("--method", default="mppi", choices=ALL_METHODS,
                     help="MPPI with fixed λ_pred, MPPI with the UKF estimating λ online, or the GCS "
                          "plan-and-track baseline (tasks I and II; needs the `drake` package)")
    run.add_argument("--seed", type=_seed, default=0)
    run.add_argument("--plant", default="model", choices=PLANTS,
                     help="the world: model (C-GVMM, λ_true) or physics (MuJoCo) (default model)")
    run.add_argument("--lanes", type=_positive_int, default=1,
                     help="batch lanes of the simulation (default 1); 32 reproduces a `dexpush bench` record exactly")
    sensor_args(run)
    episode_args(run, "out/run")
    run.set_defaults(func=_cmd_run)

    bench = sub.add_parser("bench", help="the paper's Sec. IV-B table (batched, resumable)")
    bench.add_argument("--tasks", default="I,II,III", help="comma-separated tasks from I, II, III (default I,II,III)")
    bench.add_argument("--shapes", default="rect,tee",
                       help=f"comma-separated shapes from {', '.join(SHAPES)} (default rect,tee)")
    bench.add_argument("--params", default="known,unknown",
                       help="comma-separated: known (λ_pred = λ_true), unknown (λ_pred starts at [15, 0, 0])")
    bench.add_argument("--methods", default="mppi,mppi-ukf",
                       help="comma-separated, from mppi, mppi-ukf, gcs (gcs skips task III: no obstacles)")
    bench.add_argument("--trials", type=_positive_int, default=30, help="seeds 0 … trials−1 (default 30)")
    bench.add_argument("--seeds", type=_seed_list, default=None, metavar="LIST",
                       help="run these seeds instead, e.g. 7 or 0-4,9 (re-running a seed reproduces its record)")
    bench.add_argument("--lanes", type=_positive_int, default=BENCH_LANES,
                       help=f"trials simulated together in one vmapped batch (default {BENCH_LANES})")
    bench.add_argument("--no-figures", action="store_true", help="skip the per-condition trajectory figures")
    bench.add_argument("--workers", type=_positive_int, default=1,
                       help="processes, one (task, shape) group each (default 1; use the core count)")
    bench.add_argument("--plant", default="model", choices=PLANTS,
                       help="model: batched C-GVMM world; physics: MuJoCo, trials one by one (default model)")
    sensor_args(bench)
    bench.add_argument("--max-steps", type=_positive_int, default=MAX_STEPS)
    bench.add_argument("--out", default="out/bench", help="output folder; re-running resumes (default out/bench)")
    bench.add_argument("--quiet", action="store_true", help="no progress output")
    bench.set_defaults(func=_cmd_bench)

    val = sub.add_parser("validate-mit", help="validate the C-GVMM on MIT push-dataset files (paper Sec. IV-A)")
    val.add_argument("data_dir", help="folder with the dataset's motion_*.h5 / motion_*.json files")
    val.add_argument("--out", default="out/validate-mit", help="output folder (default out/validate-mit)")
    val.add_argument("--mu", type=float, default=0.25, help="pusher–object friction μ_c (default 0.25, as the paper)")
    val.add_argument("--quiet", action="store_true", help="no per-object lines on stderr")
    val.set_defaults(func=_cmd_validate)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if not os.environ.get("DEXPUSH_NO_CACHE"):
        from dexpush import compile_cache

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
    print(json.dumps(summary))
    return 1 if summary.get("success") is False else 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
