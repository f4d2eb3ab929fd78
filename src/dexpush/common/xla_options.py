"""One thread for XLA's CPU client: dexpush's programs are many small loops.

An MPPI iteration runs ~60 fused loops over K = 1024 samples for each of its 25 steps, each
a few microseconds of work. XLA's CPU client hands independent loops to a pool with one thread
per core; on the 2-core machines we target the hand-offs cost more than the parallel work
saves, and the busy-waiting second thread takes a core from a benchmark worker or a robot
driver beside it (``benchmarks/mppi_speed.py`` measures both; docs/performance.md). The batched simulator
runs one worker process per core instead (``dexpush bench --workers``).

XLA sizes the pool from the environment variable ``NPROC`` when the first JAX backend starts
(its documented knob for CPU reservations). Importing this module (``import dexpush`` does,
first) sets ``NPROC=1`` unless ``NPROC`` is already set, ``DEXPUSH_XLA_OPTIONS=0`` is set, or a
JAX backend has already started (then XLA has read its settings: dexpush still works, with the
default pool; :func:`active` says which). Programs that run large matrix products in the same
process and want every core set ``NPROC`` themselves. On a GPU this changes nothing but the
host-side pool.

XLA's CPU multi-output fusion is left off: it speeds the rollout up but slows programs over
stacked (n, 5) states, such as the UKF's window replay, by orders of magnitude (docs/performance.md).
"""

from __future__ import annotations

import os

__all__ = ["active", "request"]

#: NPROC when the first JAX backend started (empty: not started yet)
_at_start: list[str | None] = []


def _record(_backend: object) -> None:
    if not _at_start:
        _at_start.append(os.environ.get("NPROC"))


def request() -> bool:
    """Set ``NPROC=1`` for XLA's CPU pool unless told otherwise; returns :func:`active`."""
    from jax._src import xla_bridge

    started = bool(xla_bridge.backends_are_initialized())
    xla_bridge.register_backend_initialization_hook(_record)   # runs at once if a backend already started
    if not started and os.environ.get("DEXPUSH_XLA_OPTIONS", "1") != "0" and "NPROC" not in os.environ:
        os.environ["NPROC"] = "1"
    return active()


def active() -> bool:
    """Whether XLA's CPU pool has (or, not started yet, will have) one thread."""
    value = _at_start[0] if _at_start else os.environ.get("NPROC")
    return value == "1"


request()
