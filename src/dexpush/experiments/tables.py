"""The benchmark's tables: ``benchmark.json`` (records + per-condition summary), ``.csv`` and ``.md``."""

from __future__ import annotations

import csv
import json
import os
from pathlib import Path

from dexpush.common.files import atomic_path, write_json_atomic
from dexpush.experiments.records import CONDITION_KEYS, summarize

__all__ = ["write_tables"]


def write_tables(out: str | os.PathLike, records: list[dict], meta: dict) -> dict[str, str]:
    """benchmark.json (trials + per-condition summary), benchmark.csv and benchmark.md."""
    out = Path(out)
    groups: dict[tuple, list[dict]] = {}
    for r in records:
        groups.setdefault(tuple(r[k] for k in CONDITION_KEYS), []).append(r)
    summary = [dict(zip(CONDITION_KEYS, key)) | summarize(trials) for key, trials in groups.items()]
    files = {"json": str(out / "benchmark.json"), "csv": str(out / "benchmark.csv"),
             "markdown": str(out / "benchmark.md")}
    write_json_atomic(files["json"], {"meta": meta, "summary": summary, "trials": records})
    cols = list(dict.fromkeys(k for r in records for k in r))    # records written by older versions lack fields
    with atomic_path(files["csv"]) as tmp, open(tmp, "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=cols, restval="")
        writer.writeheader()
        for r in records:
            writer.writerow({k: json.dumps(v) if isinstance(v, list | dict) else v for k, v in r.items()})

    def fmt(ms: list[float] | None) -> str:
        return f"{ms[0]:.3f} ± {ms[1]:.3f}" if ms else "–"

    lines = [f"Produced by `{meta.get('command', '')}` on {meta.get('date', '')} ({meta.get('machine', '')})."
             + (f" {meta['note']}." if meta.get("note") else ""), "",
             "| task | shape | params | method | SR | object TL (m) | pusher TL (m) | time to goal (s) "
             "| planning ms per step (median / max) | offline plan s (median / max) | replans (mean) "
             "| stall restarts (mean) | clearance mm (least / median) | frames withheld |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for s in summary:
        lines.append(f"| {s['task']} | {s['shape']} | {s['params']} | {s['method']} | "
                     f"{s['successes']}/{s['trials']} ({100 * s['success_rate']:.0f} %)"
                     + (f", {s['drops']} dropped" if s.get("drops") is not None else "")
                     + f" | {fmt(s['object_path_m'])} | "
                     f"{fmt(s['pusher_path_m'])} | {fmt(s['time_to_goal_s'])} | "
                     f"{s['planning_ms_median']:.1f} / {s['planning_ms_max']:.0f} | "
                     + (f"{s['offline_plan_s'][0]:.1f} / {s['offline_plan_s'][1]:.1f} | {s['replans_mean']:.1f} |"
                        if s["offline_plan_s"] else "– | – |")
                     + (f" {s['stall_resets_mean']:.1f} |" if s.get("stall_resets_mean") is not None else " – |")
                     + (f" {1e3 * s['clearance_m'][0]:.1f} / {1e3 * s['clearance_m'][1]:.1f} |"
                        if s.get("clearance_m") else " – |")
                     + (f" {100 * s['frames_withheld']:.1f} % |" if s.get("frames_withheld") is not None else " – |"))
    with atomic_path(files["markdown"]) as tmp:
        tmp.write_text("\n".join(lines) + "\n")
    return files
