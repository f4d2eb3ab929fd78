"""The pushing-and-grasping demonstration (the paper's Sec. IV-D) on the simulated Franka, seed by seed: the cup
and the block picked into the bin, the plate pushed with the closed fingers until it overhangs the table's edge,
grasped by its rim, lifted 5 cm and dropped into the bin (docs/goal_regions.md#the-demonstration-on-the-franka).

    python benchmarks/clearing.py --out docs/results/clearing [--seeds 0-29] [planner flags of `dexpush bench`]

MPPI with the UKF from λ_pred = [15, 0, 0] (unknown λ) and the default planner, the noise-model camera
(15 Hz, 1 mm / 0.5°, 60 ms, 5 % drops) during the push. Each finished seed is appended to ``records.jsonl`` at
once, so a stopped run resumes where it stopped; ``table.md`` is rewritten after each (and by a run with nothing
left to do). Needs ``pip install 'dexpush[franka]'``; run it alone (the simulator keeps to the wall clock) and
in a loopback-only namespace (``make`` does both for the tests:
``unshare -rn sh -c 'ip link set lo up; python benchmarks/clearing.py ...'``).
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from dexpush.cli.arguments import seed_list
from dexpush.cli.config import default_config
from dexpush.cli.flags import add_planner_flags, planner_overrides
from dexpush.common.files import atomic_path
from dexpush.experiments.clearing import run_clearing
from dexpush.world.sensing import SensorSettings


def table(records: list[dict]) -> str:
    n = len(records)

    def count(key: str) -> int:
        return sum(bool(r[key]) for r in records)

    reached = sum(bool(r["overhang"]) and not r["dropped"] for r in records)
    props = sum(all(r["props_in_bin"].values()) for r in records)
    times = [r["plate_time_s"] for r in records if r["plate_in_bin"] and r["plate_time_s"] is not None]
    push = [r["push"]["time_s"] for r in records if r.get("push") and r["overhang"]]
    robot = [r["robot"] for r in records if r.get("robot")]
    lines = ["| seeds | overhang, no drop | drops | plate grasped and lifted | plate in the bin | cup and block in "
             "the bin | whole clearing | time per plate (s, median) | push (s, median) | reflex-level steps | "
             "touches |", "|---|---|---|---|---|---|---|---|---|---|---|",
             f"| {n} | {reached}/{n} | {count('dropped')} | {count('lifted')}/{n} | {count('plate_in_bin')}/{n} | "
             f"{props}/{n} | {count('success')}/{n} | {np.median(times) if times else float('nan'):.1f} | "
             f"{np.median(push) if push else float('nan'):.1f} | {sum(r['reflex_limit_steps'] for r in robot)} | "
             f"{sum(r['push']['collisions'] > 0 for r in records if r.get('push'))} |"]
    if robot:
        rtf = [r["real_time_factor"] for r in robot]
        lines += ["", "| pushes | filter violations (workspace exits, speed limit) | joint-limit steps | late steps | "
                  "watchdog stops | real-time factor (median, least) | tip tracking error (mm, median of the "
                  "medians; worst p99) |", "|---|---|---|---|---|---|---|",
                  f"| {len(robot)} | {sum(r['workspace_exits'] + r['speed_limit_exceeded'] for r in robot)} | "
                  f"{sum(r['joint_limit_steps'] for r in robot)} | {sum(r['late_steps'] for r in robot)} | "
                  f"{sum(r['watchdog_stops'] for r in robot)} | {np.median(rtf):.2f}, {min(rtf):.2f} | "
                  f"{np.median([r['tracking_error_mm_median'] for r in robot]):.2f}; "
                  f"{max(r['tracking_error_mm_p99'] for r in robot):.1f} |"]
    failed = [r for r in records if not r["success"]]
    if failed:
        lines += ["", "Failures:", ""]
        for r in failed:
            why = r["error"] or ("the push ended short" if not r["overhang"] else "dropped in the push" if r["dropped"]
                                 else "the grasp missed" if not r["grasped"] else "the plate slipped in the lift"
                                 if not r["lifted"] else "the plate missed the bin" if not r["plate_in_bin"]
                                 else "a prop missed the bin")
            lines.append(f"- seed {r['seed']}: {why}")
    return "\n".join(lines) + "\n"


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", required=True, type=Path)
    p.add_argument("--seeds", type=seed_list, default=seed_list("0-29"), help="e.g. 0-29 or 0,3,7 (default 0-29)")
    p.add_argument("--video-seed", type=int, default=None, help="film this seed (video.gif or .mp4 in --out)")
    add_planner_flags(p)      # --spread-cap C|off, ...: the planner's defaults otherwise
    args = p.parse_args()
    settings = default_config(planner_overrides(args)[0]).controller
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / "records.jsonl"
    done = [json.loads(line) for line in path.read_text().splitlines()] if path.exists() else []
    have = {r["seed"] for r in done}
    for seed in args.seeds:
        if seed in have:
            continue
        t = time.time()
        video = args.out / "video.mp4" if seed == args.video_seed else None
        record = run_clearing(seed, settings=settings, sensor=SensorSettings.realistic(seed), video=video)
        record["wall_s"], record["spread_cap"] = round(time.time() - t, 1), settings.mppi.spread_cap
        done.append(record)
        with path.open("a") as f:
            f.write(json.dumps(record, default=float) + "\n")
        with atomic_path(args.out / "table.md") as tmp:
            tmp.write_text(table(done))
        error = f" {record['error']}" if record["error"] else ""
        print(f"seed {seed}: {'cleared' if record['success'] else 'not cleared'} "
              f"(plate {record['plate_time_s']} s, {record['wall_s']} s wall){error}", flush=True)
    with atomic_path(args.out / "table.md") as tmp:      # a finished folder: its table again
        tmp.write_text(table(done))
    print(table(done))


if __name__ == "__main__":
    main()
