"""A dead-man's switch (:class:`Watchdog`): if nobody feeds it within its deadline, it calls ``stop``.

The robot loop feeds it once per control period, after a new command was sent. When frames stop
arriving, the planner hangs or the loop dies, the feeding stops and the watchdog stops the robot
within ``deadline_s + poll_s``. Feeding it again re-arms it (the loop resumes).
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

from dexpush.common.checks import check_positive

__all__ = ["Watchdog"]


class Watchdog:
    """Calls ``stop()`` once when :meth:`feed` was not called for ``deadline_s`` seconds.

    Args:
        deadline_s: the longest gap between feeds (s).
        stop: what stops the robot (called from the watchdog's thread; must be thread-safe).
        poll_s: how often the deadline is checked (s).
        clock: a monotonic clock (s).

    ``trips`` counts the stops; ``last_trip_late_s`` is how long after the deadline the last stop was called.
    Use as a context manager, or :meth:`start` / :meth:`close`.
    """

    def __init__(self, deadline_s: float, stop: Callable[[], object], poll_s: float = 0.005,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.deadline_s = check_positive("deadline_s", deadline_s, "s")
        self.poll_s = check_positive("poll_s", poll_s, "s")
        self._stop, self._clock = stop, clock
        self._fed = clock()
        self._armed = False
        self._closed = threading.Event()
        self._lock = threading.Lock()
        self._thread = threading.Thread(target=self._run, name="dexpush-watchdog", daemon=True)
        self.trips = 0
        self.last_trip_late_s = 0.0
        self.errors: list[str] = []

    def start(self) -> Watchdog:
        self._thread.start()
        return self

    def feed(self) -> None:
        """The loop is alive: push the deadline out (and re-arm after a trip)."""
        with self._lock:
            self._fed = self._clock()
            self._armed = True

    def pause(self) -> None:
        """Stop watching (the robot is stopped on purpose, e.g. while it moves to the start)."""
        with self._lock:
            self._armed = False

    def _run(self) -> None:
        while not self._closed.wait(self.poll_s):
            with self._lock:
                late = self._clock() - self._fed - self.deadline_s
                trip = self._armed and late >= 0
                if trip:
                    self._armed = False
            if trip:
                self.trips += 1
                self.last_trip_late_s = late
                try:
                    self._stop()
                except Exception as exc:      # the stop must not kill the watchdog; the loop reports it
                    self.errors.append(f"{type(exc).__name__}: {exc}")

    def close(self) -> None:
        self._closed.set()
        if self._thread.is_alive():
            self._thread.join(timeout=1.0)

    def __enter__(self) -> Watchdog:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()
