"""Two ``dexpush bench`` folders, trial by trial: how many records are the same, and per condition the success and the
mean time to goal in each.

    python benchmarks/bench_diff.py OLD NEW

``OLD`` and ``NEW`` are results folders (each with ``benchmark.json``); trials are paired by task, shape, params,
method and seed. A trial is *the same* when its outcome and path (success, steps, time, both path lengths, final
errors, least clearance) are equal; planning times are wall clock and are not compared. Prints a markdown table,
one row per condition present in both, and a last line of JSON.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

#: the fields that make two records of one trial the same (wall-clock fields are left out)
OUTCOME = ("success", "steps", "time_s", "object_path_m", "pusher_path_m", "final_error_m", "final_error_deg",
           "collisions", "clearance_m")
KEY = ("task", "shape", "params", "method")


def load_trials(folder: Path) -> dict[tuple, dict]:
    """``folder/benchmark.json``'s trials keyed by (task, shape, params, method, seed)."""
    path = folder / "benchmark.json"
    try:
        trials = json.loads(path.read_text())["trials"]
        return {(*(t[k] for k in KEY), t["seed"]): t for t in trials}
    except FileNotFoundError:
        raise SystemExit(f"error: {path} not found: give a dexpush bench results folder") from None
    except (json.JSONDecodeError, KeyError, TypeError) as exc:
        raise SystemExit(f"error: {path} is not a dexpush benchmark file ({exc})") from None


def compare(old: dict[tuple, dict], new: dict[tuple, dict]) -> tuple[list[dict], dict]:
    """Per-condition rows and the totals over the trials both folders hold."""
    both = sorted(set(old) & set(new))
    rows: dict[tuple, dict] = {}
    for key in both:
        a, b = old[key], new[key]
        row = rows.setdefault(key[:4], {"condition": " ".join(key[:4]), "trials": 0, "same": 0, "old_ok": 0,
                                        "new_ok": 0, "old_t": [], "new_t": []})
        row["trials"] += 1
        row["same"] += all(a.get(f) == b.get(f) for f in OUTCOME)
        for tag, t in (("old", a), ("new", b)):
            if t["success"]:
                row[f"{tag}_ok"] += 1
                row[f"{tag}_t"].append(t["time_s"])
    out = []
    for row in rows.values():
        old_t, new_t = row.pop("old_t"), row.pop("new_t")
        row["old_time_s"] = sum(old_t) / len(old_t) if old_t else None
        row["new_time_s"] = sum(new_t) / len(new_t) if new_t else None
        out.append(row)
    totals = {"paired": len(both), "same": sum(r["same"] for r in out), "only_old": len(set(old) - set(new)),
              "only_new": len(set(new) - set(old)), "old_success": sum(r["old_ok"] for r in out),
              "new_success": sum(r["new_ok"] for r in out)}
    return out, totals


def table(rows: list[dict]) -> str:
    lines = ["| condition | same records | success (old → new) | mean time to goal, s (old → new) | change |",
             "|---|---|---|---|---|"]
    for r in rows:
        a, b = r["old_time_s"], r["new_time_s"]
        change = f"{100 * (b - a) / a:+.1f} %" if a and b else "–"
        times = f"{a:.3f} → {b:.3f}" if a and b else "–"
        lines.append(f"| {r['condition']} | {r['same']}/{r['trials']} | {r['old_ok']} → {r['new_ok']} | {times} | "
                     f"{change} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("old", type=Path, help="the earlier results folder")
    ap.add_argument("new", type=Path, help="the later results folder")
    args = ap.parse_args(argv)
    rows, totals = compare(load_trials(args.old), load_trials(args.new))
    if not totals["paired"]:
        raise SystemExit("error: the two folders hold no trial in common")
    print(table(rows))
    print(json.dumps(totals))
    return 0


if __name__ == "__main__":
    sys.exit(main())
