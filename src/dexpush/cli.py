"""dexpush: contact-aware planar pushing with the C-GVMM, long-horizon MPPI and a UKF.

    dexpush demo [--out DIR]                 Task I, rect, known parameters, MPPI
    dexpush run --task I --shape tee --params unknown --method mppi --seed 3 --out DIR
    dexpush bench [--tasks I,II --shapes rect --trials 5 --out DIR]   the Sec. IV-B table
    dexpush validate-mit DATA_DIR [--out DIR]  C-GVMM against recorded MIT pushes

Every command writes its files under ``--out`` and prints a one-line JSON summary last.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from collections.abc import Sequence
from pathlib import Path

from dexpush.benchmark import METHODS, PARAMS, SHAPES
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
    from dexpush.benchmark import make_shape, run_episode
    from dexpush.controller import ControllerSettings
    from dexpush.mppi import MPPISettings

    shape = make_shape(args.shape)
    settings = ControllerSettings(mppi=MPPISettings(num_samples=args.samples))
    episode = run_episode(args.task, shape, params=args.params, method=args.method, seed=args.seed,
                          max_steps=args.max_steps, settings=settings, progress=not args.quiet)
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


def _cmd_bench(args: argparse.Namespace) -> dict:
    import datetime
    import platform

    from dexpush.benchmark import condition_name, run_condition, write_tables
    from dexpush.tasks import get_task

    tasks = [get_task(t).key for t in args.tasks.split(",")]
    shapes, params, methods = (args.shapes.split(","), args.params.split(","), args.methods.split(","))
    choices = (("shape", shapes, SHAPES), ("params", params, tuple(PARAMS)), ("method", methods, METHODS))
    for name, values, allowed in choices:
        bad = [v for v in values if v not in allowed]
        if bad:
            raise ValueError(f"unknown {name} {bad[0]!r}; choose from {', '.join(allowed)}")
    out = Path(args.out)
    seeds = list(range(args.trials))
    records = []
    conditions = [(t, s, p, m) for t in tasks for s in shapes for p in params for m in methods]
    for i, (t, s, p, m) in enumerate(conditions):
        if not args.quiet:
            print(f"[{i + 1}/{len(conditions)}] {condition_name(t, s, p, m)}", file=sys.stderr, flush=True)
        records += run_condition(out / "conditions" / f"{condition_name(t, s, p, m)}.json", t, s, p, m, seeds,
                                 max_steps=args.max_steps, progress=not args.quiet)
    meta = {"command": f"dexpush bench --tasks {args.tasks} --shapes {args.shapes} --params {args.params} "
                       f"--methods {args.methods} --trials {args.trials} --out {args.out}",
            "date": datetime.date.today().isoformat(),
            "machine": f"{platform.machine()}, {os.cpu_count()} CPUs"}
    files = write_tables(out, records, meta)
    ok = sum(r["success"] for r in records)
    return {"conditions": len(conditions), "trials": len(records), "successes": ok,
            "success_rate": round(ok / len(records), 4), "files": files}


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
    sub = p.add_subparsers(dest="command", required=True)

    def episode_args(sp: argparse.ArgumentParser, out: str) -> None:
        sp.add_argument("--out", default=out, help=f"output folder (default {out})")
        sp.add_argument("--max-steps", type=_positive_int, default=MAX_STEPS,
                        help=f"control steps before giving up (default {MAX_STEPS})")
        sp.add_argument("--samples", type=_positive_int, default=1024, help="MPPI samples K (default 1024)")
        sp.add_argument("--no-animation", action="store_true", help="skip the GIF")
        sp.add_argument("--quiet", action="store_true", help="no progress bar")

    demo = sub.add_parser("demo", help="closed-loop demo: Task I, rect, known parameters, MPPI")
    episode_args(demo, "out/demo")
    demo.set_defaults(task="I", shape="rect", params="known", method="mppi", seed=0, func=_cmd_run)

    run = sub.add_parser("run", help="one episode of a benchmark task")
    run.add_argument("--task", default="I", help="I, II or III (default I)")
    run.add_argument("--shape", default="rect", choices=SHAPES)
    run.add_argument("--params", default="known", choices=tuple(PARAMS),
                     help="λ_pred = λ_true (known) or [15, 0, 0] (unknown)")
    run.add_argument("--method", default="mppi", choices=METHODS,
                     help="MPPI with fixed λ_pred, or with the UKF estimating λ online")
    run.add_argument("--seed", type=_seed, default=0)
    run.add_argument("--plant", default="model", choices=["model"], help="the world (default model)")
    episode_args(run, "out/run")
    run.set_defaults(func=_cmd_run)

    bench = sub.add_parser("bench", help="the paper's Sec. IV-B table (resumable; trials run one by one)")
    bench.add_argument("--tasks", default="I,II,III")
    bench.add_argument("--shapes", default="rect,tee")
    bench.add_argument("--params", default="known,unknown")
    bench.add_argument("--methods", default="mppi,mppi-ukf")
    bench.add_argument("--trials", type=_positive_int, default=30, help="seeds 0 … trials−1 (default 30)")
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
    try:
        summary = args.func(args)
    except ValueError as exc:  # bad input: one clear line, no traceback
        print(f"dexpush: error: {exc}", file=sys.stderr)
        return 2
    print(json.dumps(summary))
    return 1 if summary.get("success") is False else 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
