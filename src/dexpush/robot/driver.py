"""What a robot driver offers the pushing loop (:class:`PusherDriver`), where the pusher works
(:class:`DriverSettings`: the table frame in the robot's base frame, the tip's height, the tool),
and the robot as a plant (:class:`RobotPlant`), so that every loop that runs a plant runs a robot.

The loop sees the table frame (docs/conventions.md#units-and-frames); the driver converts to the
robot's base frame. Time is the robot's clock: on a real robot the wall clock, in a simulator the
simulated time, however fast the simulator runs.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Protocol, runtime_checkable

import numpy as np

from dexpush.common.checks import check_nonnegative, check_positive, checked_vector
from dexpush.common.interfaces import Observation
from dexpush.common.se2 import rotate, wrap_angle
from dexpush.robot.watchdog import Watchdog

__all__ = ["DriverSettings", "PoseSource", "PusherDriver", "RobotError", "RobotPlant", "StartError"]


class RobotError(RuntimeError):
    """The robot refused or stopped a motion (a reflex, a lost connection, a limit): the message says which."""


class StartError(RobotError):
    """The robot could not carry the pusher to an episode's start: nothing was pushed yet."""


@dataclass(frozen=True)
class DriverSettings:
    """Where the pusher works and how the driver moves it (metres, radians, seconds).

    The table frame's origin lies at ``table_origin`` in the robot's base frame, turned by
    ``table_yaw`` about the vertical; the table surface is at ``table_z``. The pusher tip is
    ``tool_offset`` beyond the end-effector frame along its z axis (pointing down while pushing);
    the driver holds the tip at ``table_z + tip_height`` and the tool vertical.
    """

    table_origin: tuple[float, float] = (0.55, 0.0)   #: table frame origin in the base frame (m)
    table_yaw: float = 0.0                            #: table frame's x axis from the base's (rad)
    table_z: float = 0.0                              #: the table surface in the base frame (m)
    tip_height: float = 0.004                         #: the tip's lowest point above the table (m)
    tool_offset: float = 0.05                         #: tip beyond the end-effector frame along its z (m)
    approach_height: float = 0.08                     #: travel height between pushes (m above the table)
    dynamics_factor: float = 0.2                      #: fraction of the Franka's velocity/acceleration/jerk limits
    command_hold_s: float = 0.1                       #: a command not renewed within this stops the robot (s)
    #: libfranka's first-order low-pass on the streamed velocity (Hz): 1000, its maximum, turns it off (franky's
    #: generator already limits the jerk); 100 is libfranka's default. See docs/robot.md#libfrankas-filter.
    cutoff_frequency: float = 1000.0
    height_gain: float = 5.0                          #: vertical correction (1/s) holding the tip height
    tilt_gain: float = 5.0                            #: rotational correction (1/s) holding the tool vertical
    max_correction: float = 0.05                      #: the corrections' cap (m/s, rad/s)
    #: where the tip can go with the tool vertical: r_min to r_max (m) from the base's vertical axis (a
    #: Franka FR3 with a 5 cm tool at table height; nearer it folds, further it stretches, to joint limits)
    reach: tuple[float, float] = (0.36, 0.80)

    def __post_init__(self) -> None:
        checked_vector("table_origin", self.table_origin, 2)
        for name in ("tool_offset", "approach_height", "dynamics_factor", "command_hold_s", "height_gain",
                     "tilt_gain", "max_correction"):
            check_positive(name, getattr(self, name))
        check_nonnegative("tip_height", self.tip_height, "m")
        if not (0 <= self.reach[0] < self.reach[1]):
            raise ValueError(f"reach is (r_min, r_max) in m with 0 <= r_min < r_max, got {self.reach!r}")
        if not (0 < self.cutoff_frequency <= 1000):
            raise ValueError(f"cutoff_frequency is in (0, 1000] Hz (1000 turns libfranka's filter off), "
                             f"got {self.cutoff_frequency}")
        if self.dynamics_factor > 1:
            raise ValueError(f"dynamics_factor is a fraction of the robot's limits (0, 1], got {self.dynamics_factor}")

    def facing(self, start: object, goal: object, centre: tuple[float, float] | None = None) -> DriverSettings:
        """These settings with the table frame placed for one task: the midpoint of ``start`` and ``goal``
        (table-frame points, m) at ``centre`` in the base frame and the direction from start to goal across
        the robot's front (along the base's y axis).

        By default ``centre`` lies on the base's x axis at c = ((r_min + r_max)² − h²) / (2 (r_min + r_max)),
        h half the start-to-goal distance: the nearest point of the path (its middle, at c) lies as far
        inside r_min as its ends (at √(c² + h²)) lie inside r_max, so the band the work sweeps sits in the
        middle of the reach (0.58 m for a turn on the spot, 0.53 m for a 0.67 m push with the default reach).
        """
        a, b = checked_vector("start", start, 2), checked_vector("goal", goal, 2)
        d = b - a
        if centre is None:
            s, h = self.reach[0] + self.reach[1], np.hypot(*d) / 2
            centre = ((s * s - h * h) / (2 * s), 0.0)
        yaw = float(wrap_angle(np.pi / 2 - np.arctan2(d[1], d[0]))) if np.hypot(*d) > 0.05 else 0.0
        origin = np.asarray(centre, dtype=np.float64) - rotate((a + b) / 2, yaw)
        return replace(self, table_origin=(float(origin[0]), float(origin[1])), table_yaw=yaw)

    def reach_in_table(self) -> tuple[float, float, float, float]:
        """The reach limit for :class:`dexpush.robot.safety.SafetySettings`: the base's axis in the table
        frame, r_min, r_max."""
        b = self.to_table(np.zeros(2))
        return float(b[0]), float(b[1]), float(self.reach[0]), float(self.reach[1])

    def reach_halfplanes(self, margin: float = 0.02, sides: int = 16, inscribed: bool = True) -> np.ndarray:
        """The reach's outer circle as half-plane rows [n_x, n_y, o] (n·p ≤ o inside, table frame), a convex region
        for a planner: the regular ``sides``-gon inscribed in the circle of radius r_max − ``margin`` about the
        base's axis (or, not ``inscribed``, circumscribed about it: its edges touch that circle). The inner circle
        is a keep-out disc (:attr:`dexpush.problem.problem.Problem.keep_out`)."""
        bx, by, _, r_max = self.reach_in_table()
        ang = 2 * np.pi * np.arange(sides) / sides
        n = np.stack([np.cos(ang), np.sin(ang)], 1)
        return np.c_[n, n @ np.array([bx, by]) + (r_max - margin) * (np.cos(np.pi / sides) if inscribed else 1.0)]

    def to_base(self, xy: object) -> np.ndarray:
        """Table-frame point(s) (..., 2) in the base frame."""
        return self.vector_to_base(xy) + self.table_origin

    def to_table(self, xy: object) -> np.ndarray:
        """Base-frame point(s) (..., 2) in the table frame."""
        return rotate(np.asarray(xy, dtype=np.float64) - self.table_origin, -self.table_yaw)

    def vector_to_base(self, v: object) -> np.ndarray:
        """Table-frame vector(s) (..., 2), e.g. a velocity, in the base frame."""
        return rotate(np.asarray(v, dtype=np.float64), self.table_yaw)


@runtime_checkable
class PusherDriver(Protocol):
    """A robot that moves a pusher tip over the table (table frame, m, m/s; the robot's clock, s).

    ``move_to(xy)`` carries the tip to ``xy`` at the working height (lifting over whatever is in
    between) and blocks; ``send(v)`` streams a planar velocity, held for at most
    ``DriverSettings.command_hold_s`` unless renewed (then the robot stops on its own); ``stop()``
    brings it to rest within its limits (thread-safe: the watchdog calls it); ``tip()`` is the
    tip's (x, y, z) in the table frame, z above the table; ``time()`` the robot's clock;
    ``recover()`` clears a robot error when that is safe and says whether it did.
    """

    settings: DriverSettings

    def move_to(self, xy: object) -> None: ...

    def send(self, velocity: object) -> None: ...

    def stop(self) -> None: ...

    def tip(self) -> np.ndarray: ...

    def time(self) -> float: ...

    def recover(self) -> bool: ...

    def close(self) -> None: ...


@runtime_checkable
class PoseSource(Protocol):
    """Where the object is: ``object_pose()`` (x, y, θ) in the table frame now (a simulator's truth, or a
    camera's newest trusted pose); ``place(pose)`` puts it there if the source can (a simulator), else raises."""

    def object_pose(self) -> np.ndarray: ...

    def place(self, pose: object) -> None: ...


class RobotPlant:
    """A robot and a pose source as a :class:`dexpush.common.interfaces.Plant`.

    ``step(v, dt)`` sends ``v`` and returns at the next tick of the robot's clock (ticks ``dt``
    apart from the first step's start): the time the caller spent planning is part of the period,
    as on a robot. A step whose command goes out more than ``deadline_s`` after its tick missed
    the planner's deadline (counted in ``late_steps``; the command still goes out at once, and the
    next ones until the loop has caught up; a stall longer than the driver's command hold or the
    watchdog's deadline stops the robot). ``observe()``
    reports the pose source's object pose and the robot's tip, stamped with the robot's time
    since the first step (0 until then: the robot holds still while the caller prepares).

    A :class:`dexpush.robot.watchdog.Watchdog` stops the robot when no step sent a command for
    ``watchdog_s`` of wall time (a hung planner or loop; ``watchdog_stops``); :meth:`close` stops
    the robot and the watchdog (use the plant as a context manager).

    Args:
        driver: a :class:`PusherDriver`.
        poses: a :class:`PoseSource`.
        deadline_s: the planner's deadline (s): a step whose command goes out later than this after
            its tick is late.
        watchdog_s: the watchdog's deadline (s), or None for none.
    """

    def __init__(self, driver: PusherDriver, poses: PoseSource, deadline_s: float = 0.02,
                 watchdog_s: float | None = 0.15) -> None:
        self.driver = driver
        self.poses = poses
        self.deadline_s = check_positive("deadline_s", deadline_s, "s")
        self.watchdog = None if watchdog_s is None else Watchdog(watchdog_s, self._watchdog_stop).start()
        self.watchdog_stops = 0           #: stops the watchdog made
        self.last_watchdog_stop_at: float | None = None
        self._sent_at = -np.inf
        self.late_steps = 0
        self.steps = 0
        self._closed = False
        self._ready = False
        self._t0: float | None = None
        self._tick = 0.0

    @property
    def time(self) -> float:
        if not self._ready:
            raise RuntimeError("call reset() before using the robot plant")
        return 0.0 if self._t0 is None else self.driver.time() - self._t0

    def reset(self, object_pose: object, pusher_xy: object) -> Observation:
        """Put the object at ``object_pose`` if the pose source can (a simulator) and carry the tip to ``pusher_xy``."""
        q = checked_vector("object_pose", object_pose, 3)
        p = checked_vector("pusher_xy", pusher_xy, 2)
        if self.watchdog is not None:
            self.watchdog.pause()
        self.driver.stop()
        self.poses.place(q)
        try:
            self.driver.move_to(p)
        except RobotError as exc:
            raise StartError(str(exc)) from exc
        self._ready = True
        self._t0 = None
        self._tick = 0.0
        self.late_steps = self.steps = 0
        return self.observe()

    def observe(self) -> Observation:
        return Observation(np.asarray(self.poses.object_pose(), dtype=np.float64),
                           np.asarray(self.driver.tip()[:2], dtype=np.float64), self.time)

    @property
    def state(self) -> np.ndarray:
        """[x_b, y_b, θ, x_c, y_c]: the pose source's object pose and the robot's tip."""
        return self.observe().state

    def step(self, velocity: object, dt: float) -> Observation:
        v = checked_vector("velocity", velocity, 2)
        dt = check_positive("dt", dt, "s")
        if not self._ready:
            raise RuntimeError("call reset() before step()")
        if self._t0 is None:
            self._t0 = self.driver.time()
        if self.time > self._tick + self.deadline_s:
            self.late_steps += 1
        self.driver.send(v)
        self._sent_at = self.driver.time()
        if self.watchdog is not None:
            self.watchdog.feed()
        self._tick += dt
        wait_until(self.driver, self._t0 + self._tick)
        self.steps += 1
        return self.observe()

    def _watchdog_stop(self) -> None:
        """The watchdog's stop: brake now (the command hold would stop the robot too, later)."""
        self.watchdog_stops += 1
        self.last_watchdog_stop_at = self.driver.time() - (self._t0 or 0.0)   # on the plant's clock
        self.driver.stop()

    def close(self) -> None:
        """Stop the robot (softly) and the watchdog (again: does nothing more)."""
        if self.watchdog is not None:
            self.watchdog.pause()
            self.watchdog.close()
        if not self._closed:
            self._closed = True
            self.driver.stop()

    def __enter__(self) -> RobotPlant:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def wait_until(driver: PusherDriver, robot_time: float, poll_s: float = 0.001, stalled_s: float = 1.0) -> None:
    """Block until the robot's clock reaches ``robot_time`` (s); a :class:`RobotError` when the clock has not
    moved for ``stalled_s`` of wall time (the connection is lost: the robot's states stopped coming)."""
    import time

    last, since = driver.time(), time.monotonic()
    while last < robot_time:
        time.sleep(poll_s)
        now = driver.time()
        if now != last:
            last, since = now, time.monotonic()
        elif time.monotonic() - since > stalled_s:
            driver.stop()
            raise RobotError(f"the robot's clock stopped at {last:.3f} s for {stalled_s:g} s: the connection to the "
                             "robot is lost")
