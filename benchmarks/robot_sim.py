"""Pushing on the simulated Franka FR3 (franky-sim over the libfranka protocol, loopback): success, time
to goal, tip tracking, limit checks and real-time factor per task and shape (docs/robot.md#results).

    python benchmarks/robot_sim.py --out docs/results/robot [--tasks I,II,III,IV] [--shapes rect]
                                   [--seeds 0-29] [--max-steps 1500]
                                   [--camera rendered [--camera-setup two]] [--without-arm]
                                   [--with-filter] [--object-watch] [--reach R_MIN,R_MAX] [--traces]
                                   [planner flags of `dexpush bench`: --spread-cap C|off, --guidance-turn M|off, ...]

With ``--without-arm`` the same placed and bounded problems run on the physics plant with no robot (the
pusher moves as commanded; no filter, no guard, no robot clock; seconds an episode): what fails there is
the planner's in the arm's band, what fails only on the robot is the arm's
(docs/robot.md#the-arms-problem-without-the-arm).

MPPI with the UKF from λ_pred = [15, 0, 0] (unknown λ), the noise-model camera (15 Hz, 1 mm / 0.5°,
60 ms, 5 % drops) on the robot plant, the planner behind the frame guard and the safety filter, the
planner and the filter bounded alike by the task's area and the arm's reach (``robot_area``). Task
IV is the paper's confined re-arrangement (Fig. 9: a walled 0.7 × 0.5 m area, three discs between
start and goal, the object moved to the far side and turned). Each finished
episode is appended to ``records.jsonl`` at once, so a stopped run resumes where it stopped;
``table.md`` is rewritten after each; with ``--traces`` each episode's trajectory, commands and planner events
(stall restarts, push plans) go to ``traces/TASK_SHAPE_SEED.npz`` beside them, for a look at a failure that
the arm will not repeat. Needs ``pip install 'dexpush[franka]'``; run it alone (the
real-time factor times the machine).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from pathlib import Path

import numpy as np

from dexpush.cli.config import default_config
from dexpush.cli.flags import add_planner_flags, planner_overrides
from dexpush.common.files import atomic_path
from dexpush.experiments.records import Episode
from dexpush.experiments.registry import make_shape
from dexpush.experiments.robot_trial import RobotSettings, run_arm_problem, run_robot_episode
from dexpush.experiments.scenarios import MAX_STEPS, get_task
from dexpush.robot.driver import DriverSettings, RobotError, StartError
from dexpush.robot.object_watch import ObjectWatchSettings
from dexpush.world.rendered_camera import SETUPS, RenderSettings
from dexpush.world.sensing import SensorSettings


def seeds(text: str) -> list[int]:
    if "-" in text:
        a, b = text.split("-")
        return list(range(int(a), int(b) + 1))
    return [int(s) for s in text.split(",")]


def reach_pair(text: str) -> tuple[float, float]:
    try:
        r_min, r_max = (float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected R_MIN,R_MAX in m, e.g. 0.36,0.80; got {text!r}") from None
    if not 0 <= r_min < r_max:
        raise argparse.ArgumentTypeError(f"expected 0 <= R_MIN < R_MAX, got {text!r}")
    return r_min, r_max


def setup_of(record: dict) -> dict:
    """What a results folder must hold alike: the plant, whether the safety filter was on, the arm's reach, the
    object's band and the task's default area (records written before these keys were the robot's own, with the
    filter on and the default reach; before the band was the annulus, docs/robot.md#the-band-is-an-annulus, they
    kept no bent way's room; before docs/robot.md#the-tasks-area-round-the-disc, the area's margin was 0.25 m;
    before docs/robot.md#the-objects-clearance, the filter had no object watch; before
    docs/robot.md#libfrankas-filter, the arm's stream went through libfranka's 100-Hz low-pass; without the arm
    there is no stream to filter; before docs/workspaces.md#the-endgame-push-2026-12-07 there was no endgame
    push; every record names its method, MPPI with the UKF unless ``--method`` said otherwise; records without
    ``obstacles_under_start`` ran without it)."""
    filtered = record.get("filtered", record["plant"] != "physics")
    annulus = "bent_way_room_m" in record or "bent_way_room_m" in record.get("robot", {})
    return {"plant": record["plant"], "filter": "on" if filtered else "off",
            "reach": tuple(record.get("reach", RobotSettings().driver.reach)),
            "band": "annulus" if annulus else "chord", "area margin": record.get("workspace_margin", 0.25),
            "object watch": "on" if record.get("object_watch", False) else "off",
            "libfranka cutoff": None if record["plant"] == "physics" else record.get("cutoff_frequency", 100.0),
            "endgame push": "on" if record.get("endgame_push", False) else "off", "method": record["method"],
            "obstacles under start": "on" if record.get("obstacles_under_start", False) else "off"}


def least_clearance_mm(records: list[dict]) -> str:
    """The least object–obstacle clearance over ``records`` in mm (``clearance_m``; negative: a touch's depth), "–"
    where no record has an obstacle."""
    values = [r["clearance_m"] for r in records if r.get("clearance_m") is not None]
    return f"{1000 * min(values):.1f}" if values else "–"


def row(records: list[dict]) -> dict:
    ok = [r for r in records if r["success"]]
    rob = [r["robot"] for r in records]
    def med(key: str, rs: list[dict]) -> float:
        return float(np.median([r[key] for r in rs])) if rs else float("nan")
    return {"trials": len(records), "success": len(ok), "time_s": med("time_s", ok),
            "track_med_mm": med("tracking_error_mm_median", rob),
            "track_p99_mm": float(np.max([r["tracking_error_mm_p99"] for r in rob])) if rob else float("nan"),
            "reflex": int(sum(r["reflex_limit_steps"] for r in rob)),
            "joint": int(sum(r["joint_limit_steps"] for r in rob)),
            "violations": int(sum(r["workspace_exits"] + r["speed_limit_exceeded"] for r in rob)),
            "touches": int(sum(r["collisions"] > 0 for r in records)), "least_mm": least_clearance_mm(records),
            "late": int(sum(r["late_steps"] for r in rob)), "rtf": med("real_time_factor", rob),
            "planning_ms": med("planning_ms_median", records),
            "max_acc": float(max(r["max_commanded_acceleration"] for r in rob)) if rob else float("nan"),
            "max_jerk": float(max(r["max_commanded_jerk"] for r in rob)) if rob else float("nan")}


def arm_free_table(records: list[dict]) -> str:
    """The table of ``--without-arm`` records: no robot side, the failures' distances to the goal instead."""
    keys = sorted({(r["task"], r["shape"]) for r in records})
    lines = ["| task | shape | success | time to goal (s, median) | touches | least clearance (mm) | "
             "failures end (cm from the goal) | straight way's room in the band (cm, median) | "
             "bent way's room (cm, median) |", "|" + "---|" * 9]
    for task, shape in keys:
        rs = [x for x in records if (x["task"], x["shape"]) == (task, shape)]
        ok = [x["time_s"] for x in rs if x["success"]]
        ends = ", ".join(f"{100 * x['final_error_m']:.1f}" for x in sorted(rs, key=lambda x: x["final_error_m"])
                         if not x["success"]) or "–"
        room, bent = ([x[k] for x in rs if k in x] for k in ("way_room_m", "bent_way_room_m"))
        lines.append(f"| {task} | {shape} | {len(ok)}/{len(rs)} | {np.median(ok) if ok else float('nan'):.1f} | "
                     f"{sum(x['collisions'] > 0 for x in rs)} | {least_clearance_mm(rs)} | {ends} | "
                     f"{100 * np.median(room) if room else float('nan'):.1f} | "
                     f"{100 * np.median(bent) if bent else float('nan'):.1f} |")
    return "\n".join(lines) + "\n"


def table(records: list[dict]) -> str:
    keys = sorted({(r["task"], r["shape"]) for r in records})
    lines = ["| task | shape | success | time to goal (s, median) | tip tracking error (mm, median / worst p99) | "
             "reflex-level steps | joint-limit steps | filter violations | touches | least clearance (mm) | late "
             "steps | planning (ms, median) | max commanded acc. (m/s²) / jerk (m/s³) | real-time factor |",
             "|" + "---|" * 14]
    for task, shape in keys:
        r = row([x for x in records if (x["task"], x["shape"]) == (task, shape)])
        time_s = "–" if not r["success"] else f"{r['time_s']:.1f}"     # (no success: no time to goal)
        lines.append(f"| {task} | {shape} | {r['success']}/{r['trials']} | {time_s} | "
                     f"{r['track_med_mm']:.2f} / {r['track_p99_mm']:.2f} | {r['reflex']} | {r['joint']} | "
                     f"{r['violations']} | {r['touches']} | {r['least_mm']} | {r['late']} | {r['planning_ms']:.1f} | "
                     f"{r['max_acc']:.1f} / {r['max_jerk']:.0f} | {r['rtf']:.2f} |")
    return "\n".join(lines) + "\n"


def save_trace(path: Path, episode: Episode) -> None:
    """One episode's ``trajectory.npz`` (:meth:`dexpush.experiments.records.Episode.arrays`), written atomically."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp, open(tmp, "wb") as fh:
        np.savez_compressed(fh, **episode.arrays())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default="out/robot_sim", help="results folder (default out/robot_sim)")
    ap.add_argument("--tasks", default="I,II,III,IV", help="comma-separated: I, II, III, IV, C (default I,II,III,IV)")
    ap.add_argument("--shapes", default="rect", help="comma-separated: rect, ellipse, tee (default rect)")
    ap.add_argument("--seeds", type=seeds, default=seeds("0-29"), help="e.g. 0-29 or 0,3,7 (default 0-29)")
    ap.add_argument("--camera", choices=["realistic", "rendered"], default="realistic",
                    help="the noise-model camera (default) or markers read from rendered images of the simulated world")
    ap.add_argument("--camera-setup", choices=list(SETUPS), default="oblique",
                    help="the rendered cameras' set-up (docs/perception.md#the-rendered-camera; default oblique)")
    ap.add_argument("--max-steps", type=int, default=MAX_STEPS,
                    help=f"control steps before giving up (default {MAX_STEPS}, the benchmark's N_max)")
    ap.add_argument("--reach", type=reach_pair, default=None, metavar="R_MIN,R_MAX",
                    help="the arm's pushing reach from its base's axis (m; default that of DriverSettings, the FR3's "
                         "with a 5 cm tool at table height)")
    ap.add_argument("--without-arm", action="store_true",
                    help="the arm's problem on the physics plant with no robot (the pusher moves as commanded)")
    ap.add_argument("--with-filter", action="store_true",
                    help="with --without-arm: the planner behind the robot's frame guard and safety filter")
    ap.add_argument("--object-watch", action="store_true",
                    help="the filter with the object's watch, off by default (docs/robot.md#the-objects-clearance)")
    ap.add_argument("--method", choices=["mppi-ukf", "mppi"], default="mppi-ukf",
                    help="MPPI with the UKF from λ_pred = [15, 0, 0] (default), or MPPI planning with that λ_pred "
                         "throughout (no estimation)")
    ap.add_argument("--traces", action="store_true",
                    help="save each episode's states, commands and planner events to OUT/traces/TASK_SHAPE_SEED.npz")
    ap.add_argument("--cutoff-frequency", type=float, default=DriverSettings().cutoff_frequency, metavar="HZ",
                    help="libfranka's low-pass on the velocity stream (Hz; 1000 turns it off; default "
                         f"{DriverSettings().cutoff_frequency:g})")
    add_planner_flags(ap)     # --spread-cap C|off, --guidance-turn M|off, ...: the planner's defaults otherwise
    args = ap.parse_args()
    settings = default_config(planner_overrides(args)[0]).controller
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    path = out / "records.jsonl"
    records = [json.loads(line) for line in path.read_text().splitlines()] if path.exists() else []
    if args.with_filter and not args.without_arm:
        raise SystemExit("error: --with-filter goes with --without-arm (on the robot the filter is always on)")
    if args.object_watch and args.without_arm and not args.with_filter:
        raise SystemExit("error: --object-watch is the filter's: with --without-arm give --with-filter too")
    robot = RobotSettings(object_watch=ObjectWatchSettings()) if args.object_watch else RobotSettings()
    try:
        driver = dataclasses.replace(robot.driver, cutoff_frequency=args.cutoff_frequency,
                                     **({} if args.reach is None else {"reach": args.reach}))
    except ValueError as exc:
        raise SystemExit(f"error: {exc}") from None
    robot = dataclasses.replace(robot, driver=driver)
    filtered = args.with_filter or not args.without_arm
    kept = {"endgame_push": settings.push_plan.enabled and settings.push_plan.endgame.enabled,   # in every record
            "obstacles_under_start": settings.obstacles_under_start, "reach": list(robot.driver.reach),
            "cutoff_frequency": None if args.without_arm else robot.driver.cutoff_frequency,
            "workspace_margin": robot.workspace_margin, "filtered": filtered,
            "object_watch": filtered and robot.object_watch is not None}
    setup = setup_of({**kept, "plant": "physics" if args.without_arm else "franka-sim", "method": args.method,
                      "bent_way_room_m": None})       # what this run's records will say, as setup_of reads them
    other = sorted({k for r in records for k, v in setup_of(r).items() if v != setup[k]})
    if other:
        raise SystemExit(f"error: {path} holds episodes with another {' and '.join(other)} than this run's "
                         f"({', '.join(f'{k} {setup[k]}' for k in other)}): use another --out")
    done = {(r["task"], r["shape"], r["seed"]) for r in records}
    refused: list[str] = []
    write_table = arm_free_table if args.without_arm else table
    sensor = RenderSettings(setup=args.camera_setup) if args.camera == "rendered" else SensorSettings.realistic(seed=0)
    for shape_name in args.shapes.split(","):
        shape = make_shape(shape_name)
        for key in args.tasks.split(","):
            task = get_task(key)
            for seed in args.seeds:
                if (task.key, shape_name, seed) in done:
                    continue
                t0 = time.perf_counter()
                if args.without_arm:
                    episode, side = run_arm_problem(task, shape, params="unknown", method=args.method, seed=seed,
                                                    sensor=sensor, robot=robot, settings=settings,
                                                    max_steps=args.max_steps, filtered=args.with_filter)
                else:
                    try:
                        episode, report = run_robot_episode(task, shape, params="unknown", method=args.method,
                                                            seed=seed, sensor=sensor, robot=robot, settings=settings,
                                                            max_steps=args.max_steps)
                    except StartError as exc:      # the arm never reached the start: nothing recorded; a re-run retries
                        print(f"{task.key} {shape_name} seed {seed}: the robot could not start, not recorded: {exc}",
                              file=sys.stderr, flush=True)
                        refused.append(f"{task.key} {shape_name} {seed}")
                        continue
                    except RobotError as exc:      # stopped mid-episode: a robot failure, not the planner's
                        raise SystemExit(f"error: {task.key} {shape_name} seed {seed}: the robot stopped the episode: "
                                         f"{exc} (the episodes before it are recorded in {path})") from None
                    side = {"robot": report}
                rec = {**dataclasses.asdict(episode.record), "shape": shape_name, **side,
                       "spread_cap": settings.mppi.spread_cap, "guidance_turn_m": settings.weights.guidance_turn_m,
                       "guidance_goal_heading": settings.weights.guidance_goal_heading,
                       "push_plan": settings.push_plan.enabled, **kept,
                       "wall_s": round(time.perf_counter() - t0, 1)}
                if args.traces:
                    save_trace(out / "traces" / f"{task.key}_{shape_name}_{seed}.npz", episode)
                with open(path, "a") as fh:
                    fh.write(json.dumps(rec) + "\n")
                records.append(rec)
                print(f"{task.key} {shape_name} seed {seed}: {'success' if rec['success'] else 'failure'} in "
                      f"{rec['steps']} steps, {rec['wall_s']} s wall", flush=True)
                with atomic_path(out / "table.md") as tmp:
                    tmp.write_text(write_table(records))
    with atomic_path(out / "table.md") as tmp:
        tmp.write_text(write_table(records))
    print(write_table(records))
    print(json.dumps({"records": len(records), "folder": str(out), "could_not_start": refused}))
    if refused:
        raise SystemExit(f"error: {len(refused)} episode(s) could not start on the robot and are not recorded "
                         f"({', '.join(refused)}): run the same command again to retry them")


if __name__ == "__main__":
    main()
