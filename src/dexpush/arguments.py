"""The command line's argument types (argparse ``type=`` callables): each turns one flag's text
into a value or fails with a message that says what the flag expects."""

from __future__ import annotations

import argparse
import math

__all__ = ["floats", "positive_int", "seed", "seed_list", "stall_time"]


def floats(count: int, what: str):
    """An argparse type: ``count`` comma-separated numbers (the last may end in ``deg``)."""
    def parse(text: str) -> tuple[float, ...]:
        parts = [t.strip() for t in text.split(",")]
        try:
            if len(parts) != count:
                raise ValueError
            vals = [float(t[:-3]) if t.endswith("deg") else float(t) for t in parts]
            if parts[-1].endswith("deg"):
                vals[-1] = math.radians(vals[-1])
        except ValueError:
            raise argparse.ArgumentTypeError(f"{what}: expected {count} comma-separated numbers, got {text!r}") \
                from None
        if not all(math.isfinite(v) for v in vals):
            raise argparse.ArgumentTypeError(f"{what}: numbers must be finite, got {text!r}")
        return tuple(vals)
    return parse


def seed_list(text: str) -> list[int]:
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


def stall_time(text: str) -> float | str:
    """``--stall-after``: seconds > 0, or "off"."""
    if text.strip().lower() in ("off", "never", "none"):
        return "off"
    try:
        v = float(text)
    except ValueError:
        v = float("nan")
    if not v > 0 or v == float("inf"):
        raise argparse.ArgumentTypeError(f"must be a time in seconds > 0, or off; got {text!r}")
    return v


def positive_int(text: str) -> int:
    v = int(text)
    if v < 1:
        raise argparse.ArgumentTypeError(f"must be a positive integer, got {text}")
    return v


def seed(text: str) -> int:
    v = int(text)
    if v < 0:
        raise argparse.ArgumentTypeError(f"seed must be >= 0, got {text}")
    return v
