"""``PushingController``: what a robot's control loop calls (docs/conventions.md#public-api).

    ctrl = PushingController(shape, goal=(0.6, 0.3, 0.0), params=(25.0, -0.01, 0.02))
    ctrl.reset(object_pose, pusher_xy)
    while ...:
        vx, vy = ctrl.command(object_pose, pusher_xy)   # at 10–50 Hz

Each ``command`` runs one MPPI iteration (warm-started from the previous one, shifted by
the control period) over the C-GVMM with the controller's current parameter estimate
λ_pred, and returns the first input of the new nominal sequence. The result is always
finite and inside the per-axis limit ±v_max/√2. With ``estimate_params`` the observation
first goes to the UKF window estimator (:mod:`dexpush.control.estimator`), whose estimate becomes λ_pred.

The loop body is one pure function, :func:`dexpush.control.policy.policy_step` (state, observation) →
(state, command), which :class:`PushingController` wraps for a robot and
:mod:`dexpush.experiments.simulate` scans and vmaps over whole batches of simulated episodes: the
benchmark and a robot run the very same controller. Its settings and pure parts are
re-exported here, where a user looks for them.
"""

from __future__ import annotations

import warnings
from dataclasses import replace
from functools import partial

import jax
import jax.numpy as jnp
import numpy as np

from dexpush.common.checks import check_params, check_positive, checked_seed, checked_vector
from dexpush.common.interfaces import Observation
from dexpush.common.se2 import footprint_shift
from dexpush.control.mppi import MPPIResult
from dexpush.control.policy import (
    ControllerSettings,
    ControllerState,
    estimate_step,
    plan_step,
    policy_init,
    policy_step,
    watch_progress,
)
from dexpush.model.cgvmm import LAMBDA_TRUE, Contour, integrate
from dexpush.model.shape import Shape
from dexpush.problem.problem import Problem
from dexpush.problem.scene import Scene
from dexpush.problem.weights import CostWeights

#: commands the controller keeps to predict a late frame to the present: 16 control periods (0.64 s at
#: 25 Hz) bridge a camera's latency and a few lost frames
HISTORY = 16

__all__ = ["HISTORY", "ControllerSettings", "ControllerState", "CostWeights", "PushingController", "estimate_step",
           "footprint_shift", "plan_step", "policy_init", "policy_step", "watch_progress"]


@partial(jax.jit, static_argnames="settings")
def _estimate_jit(state: ControllerState, observation: jnp.ndarray, contour: Contour,
                  settings: ControllerSettings, frame_period: jnp.ndarray) -> ControllerState:
    return estimate_step(state, observation, settings.estimate_params, contour=contour, settings=settings,
                         frame_period=frame_period)


@partial(jax.jit, static_argnames="settings")
def _plan_jit(state: ControllerState, x: jnp.ndarray, contour: Contour, scene: Scene,
              settings: ControllerSettings,
              predicted_m: jnp.ndarray) -> tuple[ControllerState, jnp.ndarray, MPPIResult]:
    return plan_step(state, x, contour=contour, scene=scene, settings=settings, predicted_m=predicted_m)


@partial(jax.jit, static_argnames="substeps")
def _predict_jit(contour: Contour, x: jnp.ndarray, u: jnp.ndarray, duration: jnp.ndarray, params: jnp.ndarray,
                 mu: jnp.ndarray, substeps: int) -> jnp.ndarray:
    return integrate(contour, x, u, duration, params, mu, substeps)


class PushingController:
    """Goal-oriented pushing with long-horizon MPPI over the C-GVMM.

    Args:
        problem: the :class:`dexpush.problem.problem.Problem` to solve (object, goal, obstacles, cost
            weights), or the pushed object's :class:`Shape`, with ``goal`` and ``obstacles`` beside it.
        goal: with a shape: the goal pose (x, y, θ) in the world frame.
        params: λ_pred = [β, x_bf, y_bf] the model assumes (update with :meth:`set_params`);
            without it the controller warns and uses the paper's λ_true for its box.
        obstacles: with a shape: disc obstacles (c_x, c_y, radius) to avoid with object and pusher.
        settings: :class:`ControllerSettings` (MPPI knobs, μ_c, the UKF; with a shape, the cost weights).
        seed: seeds the MPPI sampling; equal seeds and observations give equal commands.
    """

    def __init__(self, problem: Problem | Shape, goal: object = None, params: object = None,
                 obstacles: object = (), settings: ControllerSettings | None = None,
                 seed: int = 0) -> None:
        if settings is not None and not isinstance(settings, ControllerSettings):
            raise ValueError(f"settings must be a ControllerSettings, got {settings!r}")
        settings = settings or ControllerSettings()
        if isinstance(problem, Problem):
            if goal is not None or len(obstacles):
                raise ValueError("a Problem holds the goal and the obstacles: pass them to Problem, not beside it")
            if settings.weights not in (CostWeights(), problem.weights):
                raise ValueError("settings.weights differs from problem.weights: the Problem's weights are the "
                                 "cost the controller plans with; set them there")
        elif isinstance(problem, Shape):
            if goal is None:
                raise ValueError("goal is needed: PushingController(shape, goal=(x, y, θ), ...)")
            problem = Problem(problem, goal, obstacles, settings.weights)
        else:
            raise TypeError(f"problem must be a dexpush Problem or Shape, got {type(problem).__name__}")
        self.problem = problem
        self.shape = problem.shape
        self.settings = replace(settings, weights=problem.weights)
        self._goal = np.asarray(problem.goal, dtype=np.float64)
        # the compiled steps see the controller's frame, whose origin is the goal (Problem.local_scene)
        self._origin = problem.origin
        self._heading_ref = float(problem.goal[2])
        self.scene = problem.local_scene
        self.contour = problem.contour
        self._vertices = np.asarray(self.shape.edges[0], dtype=np.float64)   # the footprint's corners in {B}
        self._seed = checked_seed(seed)
        if params is None:
            warnings.warn("PushingController: no params given, so it plans with the paper's λ_true = "
                          f"{LAMBDA_TRUE} (its 0.20 × 0.12 m box). Pass params=(β, x_bf, y_bf) for your object "
                          "(a guess such as (15, 0, 0) with estimate_params=True works).", UserWarning, stacklevel=2)
            params = LAMBDA_TRUE
        p = checked_vector("params", params, 3)
        check_params(p)
        self._initial_params = p
        self.reset()

    @property
    def goal(self) -> np.ndarray:
        """The goal pose (x, y, θ) in the world frame."""
        return self._goal.copy()

    def _local(self, q: np.ndarray, p: np.ndarray) -> jnp.ndarray:
        """World observation → the controller's frame: positions relative to the goal, heading within π of
        the goal's (float64 arithmetic, then float32)."""
        q = q - self._origin
        q[2] = self._heading_ref + (q[2] - self._heading_ref + np.pi) % (2 * np.pi) - np.pi
        return jnp.asarray(np.concatenate([q, p - self._origin[:2]]), jnp.float32)

    @property
    def rejected_frames(self) -> int:
        """Frames the estimator's gate rejected since :meth:`reset` (non-finite, or an impossible jump)."""
        return int(self.state.estimator.rejected)

    @property
    def estimator_updates(self) -> int:
        """Informative windows that updated the λ estimate since :meth:`reset`."""
        return int(self.state.estimator.updates)

    @property
    def gated_windows(self) -> int:
        """Of those, windows the innovation gate down-weighted (NIS/m above ``UKFSettings.nis_gate``)."""
        return int(self.state.estimator.gated)

    @property
    def stall_resets(self) -> int:
        """Planner restarts after a stall since :meth:`reset` (``ControllerSettings.stall.after_s``)."""
        return int(self.state.stalls)

    @property
    def push_plans(self) -> int | None:
        """Pushes chosen after a stall since :meth:`reset` (``ControllerSettings.push_plan``); None when off."""
        return int(self.state.push.started) if self.settings.push_plan.enabled else None

    @property
    def estimator_resets(self) -> int:
        """Times the estimator's state turned non-finite and was reset to the prior since :meth:`reset`."""
        return int(self.state.estimator.resets)

    def _check_estimator(self) -> None:
        if not self._warned and self.settings.estimate_params and self.estimator_resets:
            self._warned = True
            warnings.warn("PushingController: the λ estimator's state turned non-finite and was reset to its prior "
                          "(see estimator_resets); commands continue.", RuntimeWarning, stacklevel=3)

    @property
    def planning_state(self) -> np.ndarray | None:
        """The state [x_b, y_b, θ, x_c, y_c] (world frame) the last command was planned from: the
        observation, or with :meth:`act` the newest frame predicted to the present; None before the
        first command. With :attr:`last` (the new nominal sequence) it says what the plan expects."""
        if self._predicted is None:
            return None
        x = np.asarray(self._predicted, dtype=np.float64)
        return x + np.concatenate([self._origin, self._origin[:2]])

    @property
    def prediction_shift_m(self) -> float:
        """How far (m) the object's footprint moved (its farthest point, :func:`footprint_shift`) in the
        prediction from the newest frame to :attr:`planning_state` for the last :meth:`act`; 0 for
        :meth:`command`. The plan's obstacle margin grows with it (``prediction_margin_gain``)."""
        return self._shift

    @property
    def params(self) -> np.ndarray:
        """The λ_pred the model currently uses."""
        return np.asarray(self.state.params, dtype=np.float64)

    @property
    def mu(self) -> float:
        """The μ_c the model currently uses (``settings.mu``, or its estimate with ``UKFSettings.estimate_mu``)."""
        return float(self.state.mu)

    def set_params(self, params: object) -> None:
        """Replace λ_pred (e.g. with an online estimate); takes effect at the next command."""
        p = checked_vector("params", params, 3)
        check_params(p)
        self.state = self.state._replace(params=jnp.asarray(p, jnp.float32))

    def reset(self, object_pose: object | None = None, pusher_xy: object | None = None,
              seed: int | None = None) -> None:
        """Forget the warm start and the estimate (and optionally reseed).

        Given the first observation (``object_pose`` and ``pusher_xy``), it also compiles
        the controller's programs on it, so the first :meth:`command` or :meth:`act` does
        not pay the compile time (several seconds) inside a control loop. The state after
        ``reset`` is the same either way.
        """
        q = None if object_pose is None else checked_vector("object_pose", object_pose, 3)
        p = None if pusher_xy is None else checked_vector("pusher_xy", pusher_xy, 2)
        if seed is not None:
            self._seed = checked_seed(seed)
        if q is not None and p is not None:
            self._warm_up(self._local(q, p))
        self.state = policy_init(self._initial_params, self.settings, self._seed, self.shape.footprint_box)
        self.last: MPPIResult | None = None
        self._clock = 0.0                                  # start of the next control period (s)
        self._history: list[tuple[float, np.ndarray]] = []  # (issue time, command)
        self._predicted: jnp.ndarray | None = None
        self._frame: jnp.ndarray | None = None              # the newest frame, in the controller's frame
        self._shift = 0.0
        self._warned = False
        self._frame_time: float | None = None               # capture time of the newest frame
        self._bad_times = 0
        self._warned_latency = False

    def _warm_up(self, obs: jnp.ndarray) -> None:
        """Run (and so compile) estimate, plan and predict once on ``obs``; results are discarded."""
        state = policy_init(self._initial_params, self.settings, self._seed, self.shape.footprint_box)
        state = _estimate_jit(state, obs, self.contour, self.settings,
                              jnp.float32(self.settings.mppi.control_period))
        state, u, _ = _plan_jit(state, obs, self.contour, self.scene, self.settings, jnp.float32(0.0))
        x = _predict_jit(self.contour, obs, u, jnp.float32(self.settings.mppi.control_period), state.params,
                         jnp.float32(self.settings.mu), 10)
        jax.block_until_ready(x)

    def command(self, object_pose: object, pusher_xy: object) -> np.ndarray:
        """Pusher velocity (v_x, v_y) in m/s for an exact, current observation."""
        q = checked_vector("object_pose", object_pose, 3)
        p = checked_vector("pusher_xy", pusher_xy, 2)
        obs = self._local(q, p)
        st = _estimate_jit(self.state, obs, self.contour,
                           self.settings, jnp.float32(self.settings.mppi.control_period))
        self._frame, self._shift = obs, 0.0          # an exact observation: the newest frame, nothing predicted
        self.state, u, self.last = _plan_jit(st, obs, self.contour, self.scene, self.settings, jnp.float32(0.0))
        self._check_estimator()
        return self._issue(u, obs)

    def act(self, frame: Observation | None, frame_period: float | None = None) -> np.ndarray:
        """Pusher velocity for the next control period from what the sensor delivered, if anything.

        ``frame`` is the newest frame that arrived during the last period (``None`` when
        none did: a slow camera or a dropped frame); ``frame.time`` is its capture time on
        the clock that started at :meth:`reset` (time 0), advancing one control period per
        call. The controller

        * updates the UKF only from frames (``frame_period``: the camera's period, used by
          the window replay);
        * predicts the state at the present from the newest frame by replaying the
          commands issued since its capture through the C-GVMM with λ_pred (latency), or,
          without a new frame, one more period from its last prediction (hold and predict);
        * plans from that predicted state.
        """
        T = self.settings.mppi.control_period
        period = T if frame_period is None else check_positive("frame_period", frame_period, "s")
        if frame is not None:
            if not all(hasattr(frame, k) for k in ("object_pose", "pusher_xy", "time")):
                raise ValueError(f"frame must be an Observation (object_pose, pusher_xy, time) or None, got "
                                 f"{type(frame).__name__}")
            since = float(checked_vector("frame.time", [frame.time], 1)[0])
            q = checked_vector("object_pose", frame.object_pose, 3)
            p = checked_vector("pusher_xy", frame.pusher_xy, 2)
            frame = self._timely(frame, since)
        if frame is not None:
            obs = self._local(q, p)
            self._frame_time = since
            self.state = _estimate_jit(self.state, obs, self.contour,
                                       self.settings, jnp.float32(period))
            x = self._frame = obs
            segments = [(max(t0, since), t0 + T, u) for t0, u in self._history if t0 + T > since]
        elif self._predicted is not None:
            x, segments = self._predicted, ([(0.0, T, self._history[-1][1])] if self._history else [])
        else:
            raise ValueError("the first call of act() needs a frame (the reset observation)")
        lam, mu = self.state.params, self.state.mu
        for t0, t1, u in segments:
            if t1 - t0 > 1e-9:
                x = _predict_jit(self.contour, x, jnp.asarray(u, jnp.float32), jnp.float32(t1 - t0), lam, mu, 10)
        self._shift = 0.0 if self._frame is None else footprint_shift(self._vertices, np.asarray(self._frame[:3]),
                                                                       np.asarray(x[:3]))
        self.state, u, self.last = _plan_jit(self.state, x, self.contour, self.scene, self.settings,
                                             jnp.float32(self._shift))
        self._check_estimator()
        return self._issue(u, x)

    def _timely(self, frame: Observation, since: float) -> Observation | None:
        """``frame``, or None (counted in :attr:`rejected_frame_times`) when its capture time is not after
        the newest frame's (a repeated or out-of-order frame) or lies ahead of the controller's clock by
        more than a control period (a clock in other units, or another clock); a frame older than the
        commands the controller keeps is used, with a warning that its prediction starts late."""
        T = self.settings.mppi.control_period
        reason = None
        if self._frame_time is not None and since <= self._frame_time:
            reason = f"its time {since:.6g} s is not after the newest frame's ({self._frame_time:.6g} s)"
        elif since > self._clock + T:
            reason = (f"its time {since:.6g} s is ahead of the controller's clock ({self._clock:.6g} s since reset, "
                      "one control period per act): frame times are seconds on the clock that started at reset")
        if reason is not None:
            if self._predicted is None:
                raise ValueError(f"the first call of act() needs a usable frame: {reason}")
            self._bad_times += 1
            if self._bad_times == 1:
                warnings.warn(f"PushingController.act: a frame was set aside, {reason} (counted in "
                              "rejected_frame_times)", RuntimeWarning, stacklevel=3)
            return None
        covered = (self._history[0][0] if self._history else 0.0)
        if since < covered - 1e-9 and not self._warned_latency:
            self._warned_latency = True
            warnings.warn(f"PushingController.act: a frame {self._clock - since:.3g} s old is beyond the "
                          f"{HISTORY * T:.3g} s of commands the controller keeps; it is predicted to the present "
                          "from the oldest command kept, less accurately", RuntimeWarning, stacklevel=3)
        return frame

    @property
    def rejected_frame_times(self) -> int:
        """Frames :meth:`act` set aside since :meth:`reset` for their capture time: not after the newest
        frame's, or ahead of the controller's clock by more than a control period."""
        return self._bad_times

    def _issue(self, u: jnp.ndarray, x: jnp.ndarray) -> np.ndarray:
        c = self.settings.mppi.v_clip     # float32 rounding may sit a hair past the float64 bound
        cmd = np.clip(np.asarray(u, dtype=np.float64), -c, c)
        self._predicted = x
        self._history.append((self._clock, cmd))
        self._history = self._history[-HISTORY:]
        self._clock += self.settings.mppi.control_period
        return cmd
