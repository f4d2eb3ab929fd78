"""Read a benchmark's results: the per-condition summary of ``dexpush bench`` as a table and a figure.

    python examples/read_results.py [docs/results/benchmark] [--out out/examples]

``benchmark.json`` holds ``meta`` (the command that made it), ``summary`` (one entry per
task × shape × params × method: success rate, path lengths, time to goal, planning time)
and ``trials`` (every trial's record). The condition files under ``conditions/`` hold
the same records, one file per condition, as the run wrote them.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("folder", nargs="?", default="docs/results/benchmark", help="a `dexpush bench --out` folder")
    ap.add_argument("--out", default="out/examples", help="output folder (default out/examples)")
    args = ap.parse_args()

    path = Path(args.folder) / "benchmark.json"
    if not path.exists():
        raise SystemExit(f"read_results: no {path}; run `dexpush bench --out {args.folder}` first")
    data = json.loads(path.read_text())
    print(f"made by: {data['meta'].get('command')}")
    rows = data["summary"]
    print(f"{'condition':34s} {'success':>9s} {'object path (m)':>16s} {'time to goal (s)':>17s}")
    for r in rows:
        name = f"{r['task']} {r['shape']} {r['params']} {r['method']}"
        tl = f"{r['object_path_m'][0]:.3f}" if r["object_path_m"] else "–"
        tg = f"{r['time_to_goal_s'][0]:.1f}" if r["time_to_goal_s"] else "–"
        print(f"{name:34s} {r['successes']:>4d}/{r['trials']:<4d} {tl:>16s} {tg:>17s}")

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    fig, ax = plt.subplots(figsize=(8, 0.25 * len(rows) + 1))
    labels = [f"{r['task']} {r['shape']} {r['params']} {r['method']}" for r in rows]
    ax.barh(labels, [100 * r["success_rate"] for r in rows], color="#4c72b0")
    ax.set_xlabel("success rate (%)")
    ax.set_xlim(0, 100)
    ax.invert_yaxis()
    ax.tick_params(axis="y", labelsize=7)
    fig.tight_layout()
    fig.savefig(out / "success_rates.png", dpi=110)
    ok = sum(r["successes"] for r in rows)
    n = sum(r["trials"] for r in rows)
    print(json.dumps({"conditions": len(rows), "trials": n, "successes": ok,
                      "figure": str(out / "success_rates.png")}))


if __name__ == "__main__":
    main()
