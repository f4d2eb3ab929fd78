"""The same robot benchmark rows run twice, seed by seed: which seeds change outcome, and how far the time to goal
moves on the seeds that succeed in both (docs/robot.md#results: an episode on the simulated FR3 does not repeat);
for episodes on the arm also the largest commanded jerk and acceleration of each episode, their median and largest
over the seeds, and the reflex-level milliseconds (docs/robot.md#libfrankas-filter: two settings side by side).

    python benchmarks/robot_repeat.py docs/results/robot/pusher_margin docs/results/robot/pusher_margin_repeat \\
        --task III --shape tee

Reads each folder's ``records.jsonl`` (written by ``benchmarks/robot_sim.py``). The last line printed is JSON.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
from pathlib import Path

#: what the arm's records say of the commanded stream (``robot`` in a record of benchmarks/robot_sim.py)
STREAM = ("max_commanded_jerk", "max_commanded_acceleration")


def load(folder: Path, task: str, shape: str) -> dict[int, dict]:
    """The records of ``task`` and ``shape`` in ``folder``, by seed."""
    path = folder / "records.jsonl"
    if not path.is_file():
        sys.exit(f"robot_repeat.py: error: no records.jsonl in {folder}")
    records = (json.loads(line) for line in path.read_text().splitlines() if line.strip())
    return {r["seed"]: r for r in records if r["task"] == task and r["shape"] == shape}


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("first", type=Path, help="a results folder of benchmarks/robot_sim.py")
    p.add_argument("second", type=Path, help="another, the same rows run again")
    p.add_argument("--task", required=True, help="the task (I, II, III, IV)")
    p.add_argument("--shape", required=True, help="the shape (rect, tee, ellipse)")
    args = p.parse_args()
    a, b = load(args.first, args.task, args.shape), load(args.second, args.task, args.shape)
    seeds = sorted(set(a) & set(b))
    if not seeds:
        p.error(f"no seed of task {args.task} with {args.shape} is in both folders")
    changed = [s for s in seeds if a[s]["success"] != b[s]["success"]]
    moves = [abs(a[s]["time_s"] - b[s]["time_s"]) for s in seeds if a[s]["success"] and b[s]["success"]]
    arm = all("robot" in r for s in seeds for r in (a[s], b[s]))

    def jerk(r: dict) -> str:
        return f" {r['robot']['max_commanded_jerk']:6.0f} m/s³" if arm else ""

    for s in seeds:
        mark = "  changed" if s in changed else ""
        print(f"seed {s:3d}: {'success' if a[s]['success'] else 'failure'} {a[s]['time_s']:5.1f} s{jerk(a[s])} | "
              f"{'success' if b[s]['success'] else 'failure'} {b[s]['time_s']:5.1f} s{jerk(b[s])}{mark}")
    out = {"seeds": len(seeds), "successes": [sum(a[s]["success"] for s in seeds), sum(b[s]["success"] for s in seeds)],
           "changed_outcome": changed, "both_succeed": len(moves),
           "time_moved_s": {"mean": round(sum(moves) / len(moves), 1) if moves else None,
                            "min": round(min(moves), 1) if moves else None,
                            "max": round(max(moves), 1) if moves else None}}
    if arm:
        for key in STREAM:
            values = [sorted(r[s]["robot"][key] for s in seeds) for r in (a, b)]
            out[key] = {"median": [round(statistics.median(v), 1) for v in values], "max": [v[-1] for v in values]}
        out["reflex_limit_steps"] = [sum(r[s]["robot"]["reflex_limit_steps"] for s in seeds) for r in (a, b)]
    print(json.dumps(out))


if __name__ == "__main__":
    main()
