"""Run `dexpush run` for tasks × shapes × seeds and tabulate the JSON summaries it prints.

    python benchmarks/cli_episodes.py --seeds 0-4 --out out/cli_episodes

Each episode is a separate `dexpush run ... --quiet --no-animation` process, so the
numbers are exactly what the CLI reports. Writes ``<out>.json`` (every summary) and
``<out>.md`` (a table with per-episode rows and per-condition means).
"""

from __future__ import annotations

import argparse
import datetime
import json
import platform
import subprocess
import sys
from pathlib import Path

import numpy as np

from dexpush.common.files import atomic_path, write_json_atomic


def seeds(text: str) -> list[int]:
    if "-" in text:
        a, b = text.split("-")
        return list(range(int(a), int(b) + 1))
    return [int(s) for s in text.split(",")]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--tasks", default="I,II,III")
    ap.add_argument("--shapes", default="rect,tee")
    ap.add_argument("--seeds", type=seeds, default=seeds("0-4"))
    ap.add_argument("--params", default="known", choices=["known", "unknown"])
    ap.add_argument("--out", default="out/cli_episodes")
    args = ap.parse_args()
    rows = []
    for task in args.tasks.split(","):
        for shape in args.shapes.split(","):
            for seed in args.seeds:
                cmd = [sys.executable, "-m", "dexpush.cli", "run", "--task", task, "--shape", shape,
                       "--params", args.params, "--seed", str(seed), "--quiet", "--no-animation",
                       "--out", f"out/episodes/{task}_{shape}_{args.params}_{seed}"]
                proc = subprocess.run(cmd, capture_output=True, text=True)
                if proc.returncode not in (0, 1):
                    raise SystemExit(f"{' '.join(cmd)} failed:\n{proc.stderr}")
                rec = json.loads(proc.stdout.strip().splitlines()[-1])
                rec.pop("files", None)
                rows.append(rec)
                print(f"task {task:3s} {shape:5s} seed {seed}: success={rec['success']} steps={rec['steps']} "
                      f"object {rec['object_path_m']:.3f} m, pusher {rec['pusher_path_m']:.3f} m", flush=True)
    meta = {"command": "python " + " ".join(sys.argv), "date": datetime.date.today().isoformat(),
            "machine": f"{platform.processor() or platform.machine()}, {platform.system()}"}
    write_json_atomic(Path(args.out).with_suffix(".json"), {"meta": meta, "episodes": rows})
    lines = [f"Produced by `{meta['command']}` on {meta['date']} ({meta['machine']}).", "",
             "| task | shape | seed | success | steps | time (s) | object path (m) | pusher path (m) "
             "| final error (mm, °) | contact switches | planning ms (median) |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['task']} | {r['shape']} | {r['seed']} | {'yes' if r['success'] else 'no'} | "
                     f"{r['steps']} | {r['time_s']:.1f} | {r['object_path_m']:.3f} | {r['pusher_path_m']:.3f} | "
                     f"{r['final_error_m'] * 1000:.1f}, {r['final_error_deg']:.1f} | {r['contact_switches']} | "
                     f"{r['planning_ms_median']:.2f} |")
    lines += ["", "| task | shape | success | steps (mean ± std, successes) | object path (m) | pusher path (m) |",
              "|---|---|---|---|---|---|"]
    for task in args.tasks.split(","):
        for shape in args.shapes.split(","):
            rs = [r for r in rows if r["task"] == task and r["shape"] == shape]
            ok = [r for r in rs if r["success"]]

            def ms(key: str, ok: list = ok) -> str:
                v = np.array([r[key] for r in ok], float)
                return f"{v.mean():.3f} ± {v.std():.3f}" if len(v) else "–"

            steps = np.array([r["steps"] for r in ok], float)
            st = f"{steps.mean():.0f} ± {steps.std():.0f}" if len(steps) else "–"
            lines.append(f"| {task} | {shape} | {len(ok)}/{len(rs)} | {st} | {ms('object_path_m')} | "
                         f"{ms('pusher_path_m')} |")
    with atomic_path(Path(args.out).with_suffix(".md")) as tmp:
        tmp.write_text("\n".join(lines) + "\n")
    print("\n".join(lines[-(3 + len(args.tasks.split(',')) * len(args.shapes.split(','))):]))


if __name__ == "__main__":
    main()
