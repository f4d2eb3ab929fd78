"""Progress on stderr: a live bar on a terminal, plain lines elsewhere (a log file, a pipe, CI).

A bar redraws its line with carriage returns, which in a log or a pipe glue every update, and the
summary printed after it, into one line; there :func:`progress_bar` prints a plain line now and
then instead, each ending in a newline.
"""

from __future__ import annotations

import sys
import time
from typing import Any

from tqdm import tqdm

__all__ = ["PlainProgress", "progress_bar"]


class PlainProgress:
    """The part of tqdm's interface the package uses, as a line every ``interval_s`` seconds and one at the end."""

    def __init__(self, total: int, desc: str, unit: str, interval_s: float = 30.0) -> None:
        self.total, self.desc, self.unit, self.interval_s = total, desc, unit, interval_s
        self.n, self._postfix, self._t0 = 0, "", time.monotonic()
        self._last = self._t0

    def _line(self) -> None:
        elapsed = time.monotonic() - self._t0
        print(f"{self.desc}: {self.n}/{self.total} {self.unit}s, {elapsed:.0f} s{self._postfix}", file=sys.stderr,
              flush=True)

    def update(self, n: int = 1) -> None:
        self.n += n
        if time.monotonic() - self._last >= self.interval_s:
            self._last = time.monotonic()
            self._line()

    def set_postfix(self, refresh: bool = False, **values: Any) -> None:
        self._postfix = "".join(f", {k} {v}" for k, v in values.items())

    def close(self) -> None:
        if self.n:
            self._line()


def progress_bar(total: int, desc: str, unit: str, enabled: bool, position: int = 0) -> tqdm | PlainProgress:
    """A tqdm bar when ``enabled`` and stderr is a terminal; plain lines when ``enabled`` elsewhere;
    a silent bar when not ``enabled``."""
    if enabled and not sys.stderr.isatty():
        return PlainProgress(total, desc, unit)
    return tqdm(total=total, desc=desc, unit=unit, disable=not enabled, leave=False, position=position)
