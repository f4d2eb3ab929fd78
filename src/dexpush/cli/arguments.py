"""The command line's argument types (argparse ``type=`` callables): each turns one flag's text
into a value or fails with a message that says what the flag expects."""

from __future__ import annotations

import argparse
import math

__all__ = [
    "at_least_one",
    "floats",
    "nonnegative_float",
    "out_folder",
    "positive_float",
    "positive_int",
    "positive_or_off",
    "seed",
    "seed_list",
    "stall_time",
]


def floats(count: int | tuple[int, int], what: str, angle_last: bool = False):
    """An argparse type: ``count`` comma-separated numbers (or (fewest, most), the optional last one an
    angle); with ``angle_last`` the last is an angle, in radians or in degrees with ``deg`` (``30deg``)."""
    fewest, most = (count, count) if isinstance(count, int) else count
    expected = f"{fewest}" if fewest == most else f"{fewest} or {most}"

    def parse(text: str) -> tuple[float, ...]:
        parts = [t.strip() for t in text.split(",")]
        try:
            if not fewest <= len(parts) <= most:
                raise ValueError
            degrees = angle_last and len(parts) == most and parts[-1].endswith("deg")
            vals = [float(t) for t in parts[:-1]] + [float(parts[-1][:-3] if degrees else parts[-1])]
            if degrees:
                vals[-1] = math.radians(vals[-1])
        except ValueError:
            raise argparse.ArgumentTypeError(f"{what}: expected {expected} comma-separated numbers, got {text!r}") \
                from None
        if not all(math.isfinite(v) for v in vals):
            raise argparse.ArgumentTypeError(f"{what}: numbers must be finite, got {text!r}")
        return tuple(vals)
    return parse


def out_folder(text: str) -> str:
    """An output folder: a non-empty path (an empty one would write into the working folder)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("must be a folder, got an empty path")
    return text


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


def positive_or_off(what: str):
    """An argparse type: a finite number > 0 (``what`` says which), or "off"."""
    def parse(text: str) -> float | str:
        if text.strip().lower() in ("off", "never", "none"):
            return "off"
        try:
            return positive_float(text)
        except argparse.ArgumentTypeError:
            raise argparse.ArgumentTypeError(f"must be {what} > 0, or off; got {text!r}") from None
    return parse


#: ``--stall-after``: seconds > 0, or "off"
stall_time = positive_or_off("a time in seconds")


def _finite(text: str, low: float, inclusive: bool) -> float:
    """A finite number above ``low`` (or equal to it, ``inclusive``); anything else an ``ArgumentTypeError``."""
    try:
        v = float(text)
    except ValueError:
        v = float("nan")
    if not ((low <= v) if inclusive else (low < v)) or not v < float("inf"):
        raise argparse.ArgumentTypeError(f"must be a number {'>=' if inclusive else '>'} {low:g}, got {text!r}")
    return v


def positive_float(text: str) -> float:
    """A finite number > 0."""
    return _finite(text, 0.0, inclusive=False)


def nonnegative_float(text: str) -> float:
    """A finite number >= 0."""
    return _finite(text, 0.0, inclusive=True)


def at_least_one(text: str) -> float:
    """A finite number >= 1 (a scale that only stretches)."""
    return _finite(text, 1.0, inclusive=True)


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
