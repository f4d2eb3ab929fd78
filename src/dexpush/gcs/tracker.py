"""Closed-loop execution of GCS plans: :class:`GCSTracker`, the baseline's controller."""

from __future__ import annotations

import time

import numpy as np

from dexpush.common.checks import checked_vector
from dexpush.common.interfaces import CONTROL_PERIOD_S
from dexpush.common.se2 import pose_error
from dexpush.gcs.planner import plan_push
from dexpush.gcs.problem import Plan
from dexpush.gcs.settings import GCSSettings, PlanningError
from dexpush.model.cgvmm import MU_C
from dexpush.model.shape import Shape

__all__ = ["GCSTracker"]


class GCSTracker:
    """Execute GCS plans in closed loop at the control rate (the baseline's controller).

    Each control step commands the pusher velocity that brings the pusher to the plan's
    next reference point, ``u = (p_ref[i+1] − p)/Δt`` clipped per axis to ``±v_max/√2``
    (feedback on the pusher). The object is not steered between plans: when its pose
    strays from the plan's by more than ``replan_m`` or ``replan_deg``, or the plan ends
    short of the goal, the tracker replans from the measured state (object pose and
    pusher), at most ``max_replans`` times (default 40). It gives up (:attr:`gave_up`, zero
    velocity from then on) when a plan fails, or when the last allowed plan has run out.

    A control loop drives it like :class:`dexpush.control.controller.PushingController`::

        tracker.reset(object_pose, pusher_xy)     # the offline plan, before the clock starts
        while ...:
            vx, vy = tracker.act(frame)           # frame: .object_pose, .pusher_xy; None: no new one

    or with :meth:`plan` and :meth:`command` directly.

    Attributes after use: ``plans`` (every plan made), ``planning_s`` (the wall time of every
    planning attempt, failed ones included), ``failures`` (why the failed ones failed).
    """

    def __init__(self, shape: Shape, goal: object, params: object, mu: float = MU_C,
                 settings: GCSSettings | None = None, control_period: float = CONTROL_PERIOD_S, v_max: float = 0.1,
                 replan_m: float = 0.01, replan_deg: float = 4.0, max_replans: int = 40) -> None:
        self.shape, self.goal = shape, checked_vector("goal", goal, 3)
        self._params, self.mu = checked_vector("params", params, 3), float(mu)
        self.settings = settings or GCSSettings()
        self.dt, self.u_max = float(control_period), float(v_max) / np.sqrt(2)
        self.replan_m, self.replan_deg = float(replan_m), float(replan_deg)
        self.max_replans = int(max_replans)
        self.plans: list[Plan] = []
        self.planning_s: list[float] = []
        self.failures: list[str] = []
        self._plan: Plan | None = None
        self._i = 0
        self._frame: tuple[np.ndarray, np.ndarray] | None = None      # the last frame act() saw

    @property
    def params(self) -> np.ndarray:
        """The λ = [β, x_bf, y_bf] every plan uses (float64, shape (3,); read-only, a copy is returned)."""
        return self._params.copy()

    def reset(self, object_pose: object | None = None, pusher_xy: object | None = None) -> None:
        """Start a new episode: forget the plans, their times and failures, the progress along
        the current plan and the last frame :meth:`act` saw.

        With both ``object_pose`` (3,) and ``pusher_xy`` (2,) it then makes the offline plan
        from them (:meth:`plan`), so that the slow planning happens before the caller's clock
        starts; without them the first :meth:`command` or :meth:`act` plans. Giving only one
        of the two is a ``ValueError`` (nothing is forgotten then).
        """
        if (object_pose is None) != (pusher_xy is None):
            raise ValueError("reset needs both object_pose and pusher_xy, or neither")
        if object_pose is not None:
            object_pose = checked_vector("object_pose", object_pose, 3)
            pusher_xy = checked_vector("pusher_xy", pusher_xy, 2)
        self.plans = []
        self.planning_s = []
        self.failures = []
        self._plan, self._i, self._frame = None, 0, None
        if object_pose is not None:
            self.plan(object_pose, pusher_xy)

    def act(self, frame: object | None, frame_period: float | None = None) -> np.ndarray:
        """The pusher velocity for the next control period from what the sensor delivered, if anything.

        ``frame`` is an observation with ``.object_pose`` (3,) and ``.pusher_xy`` (2,) (a
        :class:`dexpush.common.interfaces.Observation` or :class:`dexpush.world.sensing.Frame`): the result is
        exactly :meth:`command` on it. ``None`` means no new observation arrived: the last
        frame seen is used again (``ValueError`` if no frame came since construction or
        :meth:`reset`). ``frame_period`` is accepted for symmetry with
        :meth:`dexpush.control.controller.PushingController.act` and ignored: the tracker neither
        estimates nor predicts, and the frame's time is not used either.
        """
        del frame_period        # ignored, see the docstring
        if frame is None:
            if self._frame is None:
                raise ValueError("the first call of act() needs a frame (no observation seen since reset)")
            pose, pusher = self._frame
        else:
            pose = checked_vector("object_pose", frame.object_pose, 3).copy()
            pusher = checked_vector("pusher_xy", frame.pusher_xy, 2).copy()
        u = self.command(pose, pusher)
        self._frame = (pose, pusher)
        return u

    def plan(self, pose: object, pusher: object) -> Plan | None:
        """Plan from the measured object pose and pusher position; the new plan (or ``None``
        when the planner fails, with the reason appended to ``failures``) replaces the current one."""
        pose, pusher = checked_vector("pose", pose, 3), checked_vector("pusher", pusher, 2)
        t0 = time.perf_counter()
        try:
            self._plan = plan_push(self.shape, pose, pusher, self.goal, self._params, self.mu, self.settings,
                                   self.dt)
            self.plans.append(self._plan)
        except PlanningError as exc:
            self._plan = None
            self.failures.append(str(exc))
        self.planning_s.append(time.perf_counter() - t0)
        self._i = 0
        return self._plan

    @property
    def gave_up(self) -> bool:
        """Nothing left to execute: the last planning attempt failed (planning again from the
        same resting state would fail again), or the plan has run out and no replans are left."""
        if not self.planning_s:
            return False
        if self._plan is None:
            return True
        return self._i >= len(self._plan.times) - 1 and len(self.planning_s) > self.max_replans

    def command(self, pose: object, pusher: object) -> np.ndarray:
        """The pusher velocity for the measured object pose and pusher position (plans on the
        first call unless :meth:`plan` was called; zero once the tracker has given up)."""
        pose, pusher = checked_vector("pose", pose, 3), checked_vector("pusher", pusher, 2)
        if not self.planning_s:
            self.plan(pose, pusher)
        plan = self._plan
        if plan is not None:
            pos_err, head_err = pose_error(pose, plan.poses[min(self._i, len(plan.times) - 1)])
            strayed = pos_err > self.replan_m or head_err > self.replan_deg
            ended = self._i >= len(plan.times) - 1
            if (strayed or ended) and len(self.planning_s) <= self.max_replans:
                plan = self.plan(pose, pusher)
            elif ended:
                plan = None
        if plan is None:
            return np.zeros(2)
        i = min(self._i + 1, len(plan.times) - 1)
        self._i += 1
        return np.clip((plan.pusher[i] - pusher) / self.dt, -self.u_max, self.u_max)
