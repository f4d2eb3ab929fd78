"""What the ROS 2 node decides, without ROS (:class:`NodeCore`): poses in, goals in, one command per control
period out, and what it reports.

The node (:mod:`dexpush.ros.node`) hands every message here with the ROS clock's time and nothing
else; this module never imports ``rclpy``, so its rules are tested in the base suite:

* **Poses.** The object's and the pusher's poses arrive separately, each stamped with its capture
  time. A pose with a NaN, in another frame than ``world_frame``, stamped more than ``future_s``
  ahead of the node's clock or older than ``max_age_s`` when it arrives, or not after the newest
  one, is rejected (counted per reason in :attr:`NodeCore.rejected`; the first of each kind is
  logged). A frame for the planner is the newest object pose with the pusher where it was at that
  instant (interpolated in the pusher's recent poses; within ``pair_s`` of one when not between two).
* **Time.** The controller's clock advances one control period T per ``act``
  (:meth:`dexpush.PushingController.act`); a frame captured at ROS time s is given to it at
  ``s − (now − k·T)`` on that clock, k the periods acted since the episode began, so the frame's
  age (the latency the controller predicts across) is ``now − s`` exactly, however the ticks jitter.
* **Goals.** A goal builds a new :class:`dexpush.problem.problem.Problem` at once; one whose
  footprint touches an obstacle or leaves the workspace is refused and logged. The planner takes it
  at its next period and plans for it from the current frame; the λ estimate carries over (the
  same object), :meth:`NodeCore.reset` forgets it.
* **Stopping.** The command is zero while there is no goal, once the observed pose is within
  ``reach_fraction`` of the goal's tolerance (``reached``), and while the newest object or pusher pose is older than
  ``stale_s`` (``stale``); :meth:`NodeCore.stream_target` is zero too when no command was made for
  ``watchdog_s`` (the planner hung or missed its deadline).

Every command passes the robot's guards (:class:`dexpush.robot.guarded.GuardedController`): the
frame guard, the safety filter (speed, acceleration, workspace, keep-out discs and polygons) and, with no frame
for ``frame_timeout_s``, a stop.
"""

from __future__ import annotations

import math
import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from dexpush.common.checks import check_positive
from dexpush.common.interfaces import Controller, Observation
from dexpush.common.se2 import pose_error
from dexpush.control.controller import ControllerSettings
from dexpush.model.shape import Shape
from dexpush.problem.problem import Problem
from dexpush.problem.scene_file import Layout
from dexpush.robot.guarded import FrameGuard, GuardedController
from dexpush.robot.safety import SafetySettings
from dexpush.robot.smoothing import SmoothingSettings

__all__ = ["TRIGGERS", "NodeCore", "NodeSettings", "Pose", "Tick"]

#: when the node plans: every control period (timer), or on each object pose (pose; a pose stream at the
#: control rate, e.g. a 25 Hz tracker: the command follows the pose by the planning time alone)
TRIGGERS = ("timer", "pose")


@dataclass(frozen=True)
class NodeSettings:
    """The node's frames, rates and timeouts (seconds, metres)."""

    world_frame: str = "world"         #: the frame of poses and goals (the table frame)
    twist_frame: str = ""              #: the twist's header frame ("" : world_frame)
    trigger: str = "timer"             #: one of :data:`TRIGGERS`
    stale_s: float = 0.5               #: newest object or pusher pose older than this: zero command
    max_age_s: float = 1.0             #: a pose this old when it arrives is rejected
    future_s: float = 0.05             #: a stamp this far ahead of the node's clock is rejected
    pair_s: float = 0.1                #: the pusher pose nearest the object's stamp, at most this far from it
    watchdog_s: float = 0.1            #: no command made for this long: the stream sends zero
    deadline_s: float = 0.02           #: a command made later than this after its period began is late
    #: the goal counts as reached (the node stops) when the observed errors are within this fraction of the
    #: goal's tolerance: a frame is noisy and a latency old, and a robot stopped on it should be on the goal
    reach_fraction: float = 0.5
    smoothing: SmoothingSettings | None = None   #: None: one twist per period; else a stream within limits
    stream_hz: float = 250.0           #: with smoothing: the stream's rate (Hz)
    status_hz: float = 5.0             #: status messages per second
    safety: SafetySettings = field(default_factory=lambda: SafetySettings())
    guard: FrameGuard | None = field(default_factory=FrameGuard)   #: None: frames reach the planner as they come
    frame_timeout_s: float = 0.5       #: no frame for this long: the guarded controller stops (s)

    def __post_init__(self) -> None:
        if self.trigger not in TRIGGERS:
            raise ValueError(f"trigger must be one of {', '.join(TRIGGERS)}, got {self.trigger!r}")
        if not self.world_frame:
            raise ValueError("world_frame must name a frame")
        if not 0 < self.reach_fraction <= 1:
            raise ValueError(f"reach_fraction must be in (0, 1], got {self.reach_fraction}")
        for name in ("stale_s", "max_age_s", "future_s", "pair_s", "watchdog_s", "deadline_s", "stream_hz",
                     "status_hz", "frame_timeout_s"):
            check_positive(name, getattr(self, name))


@dataclass(frozen=True)
class Pose:
    """A planar pose from a message: (x, y, θ) or (x, y) for the pusher, its stamp (s) and when it arrived."""

    value: np.ndarray
    stamp: float
    received: float


@dataclass(frozen=True)
class Tick:
    """One control period's result: the command (m/s, world frame), the mode, and the object pose's receipt
    time (the node's clock) when the command was planned from a new one (else None)."""

    command: np.ndarray
    mode: str
    received: float | None = None


def yaw_of(qx: float, qy: float, qz: float, qw: float) -> float:
    """The rotation about z of a unit quaternion (x, y, z, w)."""
    return math.atan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))


class NodeCore:
    """The node's logic (the module docstring).

    Args:
        shape: the pushed object.
        layout: what it must keep clear of (discs, polygons, a workspace:
            :class:`dexpush.problem.scene_file.Layout`).
        controller_for: builds the controller for a :class:`Problem` (a method's, e.g.
            ``lambda p: get_method("mppi-ukf").controller(p, params, seed, settings)``); a controller
            with ``set_params`` takes over the λ estimate of the one before it.
        settings: the controller's settings (its control period and cost weights).
        node: :class:`NodeSettings`.
        log: where one-line notes go.
        goal: the first goal (x, y, θ); None: wait for one on the goal topic.
        clock: the node's clock (s; the ROS clock's time): what stamps are compared with.
    """

    def __init__(self, shape: Shape, layout: Layout, controller_for: Callable[[Problem], Controller], *,
                 settings: ControllerSettings | None = None, node: NodeSettings | None = None,
                 log: Callable[[str], object] = print, goal: object = None,
                 clock: Callable[[], float] = time.time) -> None:
        self.shape = shape
        self.layout = layout
        self._controller_for = controller_for
        self.settings = settings or ControllerSettings()
        self.node = node or NodeSettings()
        self.T = self.settings.mppi.control_period
        self._log = log
        self.clock = clock
        self._lock = threading.Lock()
        self.rejected: dict[str, int] = {}
        self.late = 0
        self.periods = 0
        self.latencies_ms: deque[float] = deque(maxlen=2000)
        self._object: Pose | None = None
        self._pusher: deque[Pose] = deque(maxlen=64)
        self._fresh = False                    # an object pose arrived since the last tick
        self._pending: Problem | None = None
        self._forget = False
        self.problem: Problem | None = None
        self.controller: GuardedController | None = None
        self._started = False
        self._carry: np.ndarray | None = None    # the λ estimate a new goal's controller starts from
        self._frame_t = 0.0                      # the newest frame's time on the controller's clock
        self._k = 0
        self._reached = False
        self._command = np.zeros(2)
        self._command_at = -math.inf
        self.mode = "idle"
        self.error = np.full(2, np.nan)         # the observed position (m) and heading (deg) errors
        self.new_pose = threading.Event()      # set by each accepted object pose (the pose trigger)
        if goal is not None:
            self.set_goal(goal)

    # ------------------------------------------------------------------ messages in
    def _reject(self, reason: str, detail: str) -> bool:
        with self._lock:
            n = self.rejected[reason] = self.rejected.get(reason, 0) + 1
        if n == 1:
            self._log(f"dexpush: {detail} (rejected; further ones are counted in the status as {reason!r})")
        return False

    def _checked(self, what: str, value: np.ndarray, stamp: float, frame_id: str, now: float,
                 newest: float | None) -> bool:
        if not (np.all(np.isfinite(value)) and math.isfinite(stamp)):
            return self._reject(f"{what}_nan", f"a {what} pose with NaN or infinite values")
        if frame_id != self.node.world_frame:
            return self._reject(f"{what}_frame", f"a {what} pose in frame {frame_id!r}, not the world frame "
                                                 f"{self.node.world_frame!r}")
        if stamp > now + self.node.future_s:
            return self._reject(f"{what}_future", f"a {what} pose stamped {stamp - now:.3f} s ahead of the node's "
                                                  "clock (are the clocks synchronised?)")
        if now - stamp > self.node.max_age_s:
            return self._reject(f"{what}_old", f"a {what} pose {now - stamp:.3f} s old when it arrived (more than "
                                               f"{self.node.max_age_s:g} s)")
        if newest is not None and stamp <= newest:
            return self._reject(f"{what}_order", f"a {what} pose stamped {stamp:.6f} s, not after the newest one")
        return True

    def object_pose(self, x: float, y: float, theta: float, stamp: float, frame_id: str, now: float) -> bool:
        """The object's pose (world frame, capture time ``stamp``) arrived at ``now``; False when rejected."""
        q = np.array([x, y, theta], dtype=np.float64)
        newest = None if self._object is None else self._object.stamp
        if not self._checked("object", q, stamp, frame_id, now, newest):
            return False
        with self._lock:
            self._object = Pose(q, stamp, now)
            self._fresh = True
        self.new_pose.set()
        return True

    def pusher_pose(self, x: float, y: float, stamp: float, frame_id: str, now: float) -> bool:
        """The pusher's position (world frame, at ``stamp``) arrived at ``now``; False when rejected."""
        p = np.array([x, y], dtype=np.float64)
        newest = self._pusher[-1].stamp if self._pusher else None
        if not self._checked("pusher", p, stamp, frame_id, now, newest):
            return False
        with self._lock:
            self._pusher.append(Pose(p, stamp, now))
        return True

    def set_goal(self, goal: object, frame_id: str | None = None) -> bool:
        """A new goal (x, y, θ): checked now (a goal that touches an obstacle or leaves the workspace is
        refused and logged), taken by the planner at its next period; False when refused."""
        g = np.asarray(goal, dtype=np.float64).reshape(-1)
        if frame_id is not None and frame_id != self.node.world_frame:
            return self._reject("goal_frame", f"a goal in frame {frame_id!r}, not the world frame "
                                              f"{self.node.world_frame!r}")
        if g.shape != (3,) or not np.all(np.isfinite(g)):
            return self._reject("goal_nan", f"a goal with NaN or infinite values: {g.tolist()}")
        try:
            problem = Problem(self.shape, tuple(g), self.layout.obstacles, self.settings.weights,
                              polygons=self.layout.polygons, workspace=self.layout.workspace)
        except ValueError as exc:
            return self._reject("goal_refused", f"goal {np.round(g, 4).tolist()} refused: {exc}")
        with self._lock:
            self._pending = problem
        self._log(f"dexpush: goal ({g[0]:.3f}, {g[1]:.3f}, {math.degrees(g[2]):.1f} deg) taken")
        return True

    def reset(self) -> None:
        """Stop, forget the goal and the λ estimate; wait for a new goal."""
        with self._lock:
            self._pending = None
            self._forget = True

    # ------------------------------------------------------------------ the planner's period
    def _frame(self, now: float) -> tuple[Observation | None, float | None]:
        """The newest object pose with the pusher at its stamp, on the controller's clock (None: no new one)."""
        with self._lock:
            q, fresh, pushers = self._object, self._fresh, list(self._pusher)
            self._fresh = False
        if q is None or not fresh or not pushers:
            return None, None
        p = _pusher_at(pushers, q.stamp, self.node.pair_s)
        if p is None:
            self._reject("unpaired", f"an object pose with no pusher pose within {self.node.pair_s:g} s of its stamp")
            return None, None
        now = max(now, q.stamp)       # a pose that came in since ``now`` was read is the present
        t = q.stamp - (now - self._k * self.T)
        if not self._started:
            t = 0.0                   # the episode's first frame: nothing was commanded before it
        elif t <= self._frame_t:      # right after the start, a frame older than a period
            t = self._frame_t + 1e-6
        self._frame_t = t
        return Observation(q.value, p, t), q.received

    def _newest_pusher(self) -> np.ndarray:
        with self._lock:
            return self._pusher[-1].value.copy()

    def _start(self, problem: Problem) -> None:
        old = self.controller
        inner = self._controller_for(problem)
        if old is not None and hasattr(inner, "set_params") and getattr(old, "params", None) is not None:
            self._carry = np.asarray(old.params, dtype=np.float64)
        else:
            self._carry = None
        guard = None if self.node.guard is None else replace(self.node.guard)
        self.controller = GuardedController(inner, self.T, self._safety(problem), problem.obstacles,
                                            self.shape.pusher_radius, guard, position=self._newest_pusher,
                                            frame_timeout_s=self.node.frame_timeout_s, polygons=problem.polygons)
        self.problem, self._started, self._reached, self._k = problem, False, False, 0
        self.error = np.full(2, np.nan)

    def _safety(self, problem: Problem) -> SafetySettings:
        """The filter's settings with the problem's workspace when they have none (the filter keeps the pusher
        disc inside it)."""
        s = self.node.safety
        if s.workspace is None and problem.workspace is not None:
            s = replace(s, workspace=problem.workspace)
        return s

    def tick(self) -> Tick:
        """One control period, now: the command and why."""
        with self._lock:
            pending, self._pending = self._pending, None
            forget, self._forget = self._forget, False
        if forget:
            self.controller = self.problem = None
            self._reached = False
        if pending is not None:
            self._start(pending)
        now = self.clock()
        self.periods += 1
        if self.controller is None:
            return self._hold("idle")
        with self._lock:
            q, pushers = self._object, list(self._pusher)
        if q is None or not pushers or now - q.stamp > self.node.stale_s or now - pushers[-1].stamp > self.node.stale_s:
            return self._hold("stale" if q is not None and pushers else "waiting")
        if self._reached:
            return self._hold("reached")
        frame, received = self._frame(now)
        if not self._started:
            if frame is None:
                return self._hold("waiting")
            self.controller.reset(frame.object_pose, frame.pusher_xy)
            if self._carry is not None:
                self.controller.controller.set_params(self._carry)
            self._started = True
        u = np.asarray(self.controller.act(frame, None), dtype=np.float64)
        self._k += 1
        if frame is not None:
            pos, head = pose_error(frame.object_pose, np.asarray(self.problem.goal))
            self.error = np.array([float(pos), float(head)])
            f = self.node.reach_fraction
            if pos < f * self.problem.tolerance_m and head < f * self.problem.tolerance_deg:
                self._reached = True
                self._log(f"dexpush: goal reached (observed error {pos * 1e3:.1f} mm, {float(head):.2f} deg)")
                return self._hold("reached")
        return self._issue(u, "pushing", received)

    def _hold(self, mode: str) -> Tick:
        if self.controller is not None:
            self.controller.hold()
        return self._issue(np.zeros(2), mode, None)

    def _issue(self, u: np.ndarray, mode: str, received: float | None) -> Tick:
        with self._lock:
            self._command, self._command_at = u, self.clock()
        self.mode = mode
        return Tick(u, mode, received)

    def late_by(self, seconds: float) -> None:
        """The period's command went out ``seconds`` after the period began: counted when past the deadline."""
        self.late += seconds > self.node.deadline_s

    def stream_target(self, now: float) -> tuple[np.ndarray, bool]:
        """What the robot should follow at ``now``: the newest command, or zero (and True: the watchdog
        tripped) when none was made for ``watchdog_s``."""
        with self._lock:
            u, at = self._command.copy(), self._command_at
        if now - at > self.node.watchdog_s:
            return np.zeros(2), True
        return u, False

    # ------------------------------------------------------------------ what it reports
    def status(self) -> dict[str, Any]:
        """The status message's fields (a JSON object)."""
        c = self.controller
        lat = np.asarray(self.latencies_ms, dtype=np.float64)
        params = getattr(c, "params", None) if c is not None else None
        return {
            "mode": self.mode,
            "goal": None if self.problem is None else [round(v, 4) for v in self.problem.goal],
            "lambda": None if params is None else [round(float(v), 4) for v in np.ravel(params)],
            "distance_m": None if not np.isfinite(self.error[0]) else round(float(self.error[0]), 4),
            "heading_error_deg": None if not np.isfinite(self.error[1]) else round(float(self.error[1]), 2),
            "success": self._reached,
            "stall_restarts": int(getattr(c, "stall_resets", 0) or 0) if c is not None else 0,
            "rejected": dict(self.rejected),
            "frames_held": int(c.guard.held) if c is not None and c.guard is not None else 0,
            "filtered": int(c.filtered) if c is not None else 0,
            "late": self.late,
            "periods": self.periods,
            "latency_ms": None if not lat.size else {"median": round(float(np.median(lat)), 3),
                                                     "p99": round(float(np.percentile(lat, 99)), 3)},
        }


def _pusher_at(poses: list[Pose], t: float, pair_s: float) -> np.ndarray | None:
    """The pusher's position at time ``t``: interpolated between the two poses around it, else the nearest
    within ``pair_s``, else None."""
    stamps = np.array([p.stamp for p in poses])
    i = int(np.searchsorted(stamps, t))
    if 0 < i < len(poses):
        a, b = poses[i - 1], poses[i]
        w = (t - a.stamp) / (b.stamp - a.stamp)
        if b.stamp - a.stamp <= 2 * pair_s:
            return a.value + w * (b.value - a.value)
    j = int(np.argmin(np.abs(stamps - t)))
    return poses[j].value.copy() if abs(stamps[j] - t) <= pair_s else None
