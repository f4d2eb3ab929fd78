"""``PushingController``: what a robot's control loop calls (docs/conventions.md#public-api).

    ctrl = PushingController(shape, goal=(0.6, 0.3, 0.0), params=(25.0, -0.01, 0.02))
    ctrl.reset(object_pose, pusher_xy)
    while ...:
        vx, vy = ctrl.command(object_pose, pusher_xy)   # at 10–50 Hz

Each ``command`` runs one MPPI iteration (warm-started from the previous one, shifted by
the control period) over the C-GVMM with the controller's current parameter estimate
λ_pred, and returns the first input of the new nominal sequence. The result is always
finite and inside the per-axis limit ±v_max/√2. With ``estimate_params`` the observation
first goes to the UKF window estimator (:mod:`dexpush.estimator`), whose estimate becomes λ_pred.

The loop body is one pure function, :func:`policy_step` (state, observation) → (state,
command), which :class:`PushingController` wraps for a robot and
:mod:`dexpush.simulate` scans and vmaps over whole batches of simulated episodes: the
benchmark and a robot run the very same controller.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from functools import partial
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from dexpush.checks import check_nonnegative, check_params, check_positive, checked_seed, checked_vector
from dexpush.cost import CostWeights, Scene, goal_distance_sq, obstacle_array, plan_margin, running_cost, terminal_cost
from dexpush.estimator import EstimatorState, UKFSettings, estimator_init, estimator_observe, rate_limited
from dexpush.geometry import Shape
from dexpush.interfaces import Observation
from dexpush.model import LAMBDA_TRUE, Contour, contact_gap, integrate, step
from dexpush.mppi import MPPIResult, MPPISettings, mppi_iteration, shift_in_time, slot_durations
from dexpush.proposals import contact_proposals
from dexpush.se2 import wrap_angle

__all__ = ["ControllerSettings", "ControllerState", "PushingController", "estimate_step", "plan_step", "policy_init",
           "policy_step", "watch_progress"]


@dataclass(frozen=True)
class ControllerSettings:
    """Everything the controller needs besides the shape and goal."""

    mppi: MPPISettings = field(default_factory=MPPISettings)
    weights: CostWeights = field(default_factory=CostWeights)
    mu: float = 0.3               #: pusher–object friction μ_c assumed by the model
    estimate_params: bool = False #: run the UKF (paper Fig. 5) and plan with its estimate
    ukf: UKFSettings = field(default_factory=UKFSettings)
    ukf_substeps: int = 10        #: Euler substeps per period in the UKF's window replay
    #: restart the planner (zero warm start) when the object has come no closer to the goal, in
    #: position or in heading, for this long (s) out of contact; None never does.
    #: See docs/controller.md#stalls.
    stall_after_s: float | None = 4.0
    #: progress is an improvement of the position error by this much (m) or of the heading error by
    #: ``stall_progress_deg``, whichever of the two errors is the larger in these units
    stall_progress_m: float = 0.005
    stall_progress_deg: float = 2.0
    #: the stall clock runs only while the pusher is farther than this (m) from the contour ...
    stall_contact_gap_m: float = 0.005
    #: ... and the object is not within both of these of the goal (m, degrees): the final approach
    #: to the success tolerances (8 mm, 3°) is slow by nature
    stall_min_distance_m: float = 0.015
    stall_min_heading_deg: float = 5.0
    #: each restart without progress since the last one makes the next wait this many times longer
    stall_backoff: float = 2.0
    #: after a stall the planner looks this many times further ahead (every slot Δt_k stretched),
    #: until the object comes closer again; 1 (default) keeps the paper's horizon (measured:
    #: docs/controller.md#stalls)
    stall_horizon_scale: float = 1.0
    #: MPPI's relative temperature τ while the object is within ``endgame_distance_m`` of the goal
    #: (position error, round the obstacles); None keeps ``mppi.temperature`` everywhere. A last
    #: push of 1–3 cm is found by few samples, and at τ = 0.02 their weight was shared with many that
    #: hover (docs/controller.md#the-endgame-temperature)
    endgame_temperature: float | None = 0.005
    endgame_distance_m: float = 0.04
    #: this many of MPPI's exploring samples are contact proposals (:mod:`dexpush.proposals`): walks
    #: round the object to J evenly spaced contact points, then a push; 0 samples only noise
    #: (docs/controller.md#contact-proposals)
    contact_proposals: int = 0
    proposal_clearance_m: float = 0.015   #: the walks' radial distance from the inflated contour

    def __post_init__(self) -> None:
        for name, kind in (("mppi", MPPISettings), ("weights", CostWeights), ("ukf", UKFSettings)):
            if not isinstance(getattr(self, name), kind):
                raise ValueError(f"{name} must be a {kind.__name__}, got {getattr(self, name)!r}")
        check_positive("mu", self.mu, "pusher–object friction coefficient")
        if not isinstance(self.estimate_params, bool | np.bool_):
            raise ValueError(f"estimate_params must be True or False, got {self.estimate_params!r}")
        if int(self.ukf_substeps) != self.ukf_substeps or self.ukf_substeps < 1:
            raise ValueError(f"ukf_substeps must be a whole number >= 1, got {self.ukf_substeps!r}")
        if self.stall_after_s is not None:
            check_positive("stall_after_s", self.stall_after_s, "s, or None")
        for name in ("stall_progress_m", "stall_contact_gap_m"):
            check_positive(name, getattr(self, name), "m")
        check_positive("stall_progress_deg", self.stall_progress_deg, "degrees")
        check_nonnegative("stall_min_distance_m", self.stall_min_distance_m, "m")
        check_nonnegative("stall_min_heading_deg", self.stall_min_heading_deg, "degrees")
        if not self.stall_backoff >= 1.0:
            raise ValueError(f"stall_backoff must be >= 1, got {self.stall_backoff!r}")
        if not self.stall_horizon_scale >= 1.0:
            raise ValueError(f"stall_horizon_scale must be >= 1, got {self.stall_horizon_scale!r}")
        if self.endgame_temperature is not None:
            check_positive("endgame_temperature", self.endgame_temperature, "or None")
        check_nonnegative("endgame_distance_m", self.endgame_distance_m, "m")
        if int(self.contact_proposals) != self.contact_proposals or not (
                0 <= self.contact_proposals <= self.mppi.num_samples - round(self.mppi.refine_fraction
                                                                             * self.mppi.num_samples) - 1):
            raise ValueError(f"contact_proposals must be a whole number from 0 to the exploring samples less one, "
                             f"got {self.contact_proposals!r}")
        check_positive("proposal_clearance_m", self.proposal_clearance_m, "m")


class ControllerState(NamedTuple):
    """What the controller carries from one control period to the next (a pytree)."""

    sequence: jnp.ndarray        #: (N_p, 2) nominal input sequence, already shifted for the next call
    key: jax.Array               #: PRNG key of the MPPI sampling
    params: jnp.ndarray          #: (3,) λ_pred the next iteration plans with
    estimator: EstimatorState    #: the UKF's λ estimate and observation window
    mu: jnp.ndarray              #: μ_c the model assumes (the estimate, with ``UKFSettings.estimate_mu``)
    #: the smallest error E (:func:`watch_progress`) planned from so far, less progress since
    best: jnp.ndarray
    idle: jnp.ndarray            #: time (s) the stall clock has run since the last progress or restart
    stalls: jnp.ndarray          #: planner restarts after a stall (``ControllerSettings.stall_after_s``)
    streak: jnp.ndarray          #: restarts since the last progress (the clock's backoff exponent)
    stretch: jnp.ndarray         #: the horizon's current scale: 1, or ``stall_horizon_scale`` after a stall


def policy_init(params: object, settings: ControllerSettings, seed: int | jnp.ndarray,
                box: object = None) -> ControllerState:
    """Fresh state: zero nominal sequence, PRNG key from ``seed``, λ_pred = ``params``; ``box``, the
    footprint's bounding box (``Shape.footprint_box``), bounds the estimator's CoF
    (:func:`dexpush.estimator.estimator_init`)."""
    lam = jnp.asarray(params, jnp.float32)
    return ControllerState(jnp.zeros((settings.mppi.horizon, 2), jnp.float32), jax.random.PRNGKey(seed), lam,
                           estimator_init(lam, settings.ukf, box, settings.mu), jnp.float32(settings.mu),
                           jnp.float32(jnp.inf), jnp.float32(0.0), jnp.int32(0), jnp.int32(0),
                           jnp.float32(1.0))


def estimate_step(state: ControllerState, observation: jnp.ndarray, estimate: jnp.ndarray | bool, *,
                  contour: Contour, settings: ControllerSettings,
                  frame_period: jnp.ndarray | float | None = None) -> ControllerState:
    """With ``estimate``: the observation enters the UKF window, an informative full window
    updates the filter (:func:`dexpush.estimator.estimator_observe`), and λ_pred follows the
    filter's mean within the rate limit (:func:`dexpush.estimator.rate_limited`). Pure and jit-able.

    ``estimate`` is a Python bool (the branch is chosen when tracing) or a traced boolean, e.g.
    one per lane under ``vmap``; a traced flag computes the update and keeps it where true.

    ``frame_period`` is the time between observations (s; default: the control period).
    It may be a traced value: a camera whose period jitters costs no recompilation.
    """
    obs = jnp.asarray(observation, jnp.float32)
    dt = jnp.asarray(settings.mppi.control_period if frame_period is None else frame_period, jnp.float32)

    def observe(s: ControllerState) -> tuple[EstimatorState, jnp.ndarray, jnp.ndarray]:
        est, _ = estimator_observe(s.estimator, obs, jnp.bool_(True), contour, settings.ukf, s.mu, dt,
                                   settings.ukf_substeps)
        if settings.ukf.estimate_mu:
            new = rate_limited(jnp.append(s.params, s.mu), est.filter.mean, dt, settings.ukf)
            return est, new[:3], new[3]
        return est, rate_limited(s.params, est.filter.mean, dt, settings.ukf), s.mu

    if isinstance(estimate, bool | np.bool_):     # known at trace time: only the chosen branch is compiled
        if not estimate:
            return state
        est, lam, mu = observe(state)
    else:
        # a traced flag (one per lane in dexpush.simulate): compute the update and select it. A lax.cond
        # turns into a select of both branches under vmap anyway, and that form measured ~9× slower than
        # this one (26 against 3 ms for 8 lanes of the T: docs/performance.md#the-estimators-switch)
        on = jnp.asarray(estimate)
        est, lam, mu = jax.tree.map(lambda a, b: jnp.where(on, a, b), observe(state),
                                    (state.estimator, state.params, state.mu))
    return state._replace(estimator=est, params=lam, mu=mu)


def watch_progress(state: ControllerState, x: jnp.ndarray, *, contour: Contour, scene: Scene,
                   settings: ControllerSettings) -> tuple[ControllerState, jnp.ndarray]:
    """Stall detection, once per control period: (state, whether to restart the planner now).

    A stall is no progress toward the goal and no contact for a while (issue 15). Progress is
    measured in the success test's own terms, position and heading each in its own unit: with
    the position error e_p (the length of the path to the goal, round the obstacles with
    ``CostWeights.detour``: :func:`dexpush.cost.goal_distance_sq` with c = 0) and the heading
    error e_θ = |θ − θ_g|, the error is

        E = max(e_p / stall_progress_m, e_θ / stall_progress_deg),

    and progress is a new best E, lower by at least 1 than the best so far: 5 mm closer, or
    2° less turned where the heading is the larger error (a slow final turn is progress,
    though it hardly moves d of eq. 9b). Progress restarts the clock ``idle``, which
    otherwise runs while the pusher is more than ``stall_contact_gap_m`` off the contour and
    the object is not within both ``stall_min_distance_m`` and ``stall_min_heading_deg`` of
    the goal. When ``idle`` reaches ``stall_after_s`` · ``stall_backoff``^streak (streak:
    restarts since the last progress, so that a walk round the object that takes longer
    than one stall time is not cut short again and again), the planner restarts from a zero
    warm start with its horizon stretched ``stall_horizon_scale`` times
    (:func:`dexpush.mppi.slot_durations`: a push that needs a long walk round the object
    first comes into view), and the clock restarts. The horizon is the paper's again at the
    next progress, or as soon as the object is near the goal (the endgame needs the fine
    slots). Pure and jit-able.
    """
    if settings.stall_after_s is None:
        return state, jnp.bool_(False)
    T = settings.mppi.control_period
    e_p = jnp.sqrt(goal_distance_sq(x, scene, 0.0))
    e_th = jnp.abs(wrap_angle(x[2] - scene.goal[2], jnp))
    error = jnp.maximum(e_p / settings.stall_progress_m, e_th / np.radians(settings.stall_progress_deg))
    improved = error <= state.best - 1.0
    near = (e_p <= settings.stall_min_distance_m) & (e_th <= np.radians(settings.stall_min_heading_deg))
    away = (contact_gap(contour, x) > settings.stall_contact_gap_m) & ~near
    idle = jnp.where(improved, 0.0, state.idle + jnp.where(away, T, 0.0))
    streak = jnp.where(improved, 0, state.streak)
    patience = settings.stall_after_s * jnp.float32(settings.stall_backoff) ** streak.astype(jnp.float32)
    stalled = idle >= patience - 0.5 * T    # (float32 sums of T)
    scale = jnp.float32(settings.stall_horizon_scale)
    stretch = jnp.where(stalled, scale, jnp.where(improved | near, 1.0, state.stretch))
    restarts = stalled.astype(jnp.int32)
    return state._replace(best=jnp.where(improved, error, state.best), idle=jnp.where(stalled, 0.0, idle),
                          stalls=state.stalls + restarts, streak=streak + restarts, stretch=stretch), stalled


def _temperature(x: jnp.ndarray, scene: Scene, settings: ControllerSettings) -> jnp.ndarray | None:
    """τ for this iteration: ``endgame_temperature`` within ``endgame_distance_m`` of the goal."""
    if settings.endgame_temperature is None:
        return None
    near = goal_distance_sq(x, scene, 0.0) <= settings.endgame_distance_m ** 2
    return jnp.where(near, jnp.float32(settings.endgame_temperature), jnp.float32(settings.mppi.temperature))


def plan_step(state: ControllerState, x: jnp.ndarray, *, contour: Contour, scene: Scene,
              settings: ControllerSettings) -> tuple[ControllerState, jnp.ndarray, MPPIResult]:
    """One MPPI iteration (eq. 9–10) from state ``x`` with λ_pred. Pure and jit-able.

    The command is the first input of the new sequence, clipped to ±v_max/√2 (zero, and a
    reset sequence, should it ever be non-finite); the sequence is shifted by the control
    period as the next warm start. A stall (:func:`watch_progress`) zeroes the warm start first.
    Within ``endgame_distance_m`` of the goal the iteration weights its samples with
    ``endgame_temperature``. From a state inside the obstacle margin the plan may not come nearer
    than that state (:func:`dexpush.cost.plan_margin`).
    """
    mp = settings.mppi
    x = jnp.asarray(x, jnp.float32)
    stretch = 1.0   # a Python constant keeps the slots constants of the program: a traced per-lane
    if settings.stall_after_s is not None:      # scale made the batched step 2.2x slower (performance.md)
        state, stalled = watch_progress(state, x, contour=contour, scene=scene, settings=settings)
        state = state._replace(sequence=jnp.where(stalled, 0.0, state.sequence))
        if settings.stall_horizon_scale != 1.0:
            stretch = state.stretch
    key, sub = jax.random.split(state.key)
    weights, mu = settings.weights, state.mu
    plan_scene = plan_margin(x, scene, weights)     # from inside the margin: no nearer than now
    durations = slot_durations(mp, stretch)
    result = mppi_iteration(
        sub, state.sequence, tuple(x[i] for i in range(5)), state.params, plan_scene,   # rollouts carry a tuple
        dynamics=lambda xs, u, dt, p: step(contour, xs, u, dt, p, mu),
        running_cost=lambda xs, sc: running_cost(xs, sc, weights),
        terminal_cost=lambda xs, sc: terminal_cost(xs, sc, weights), settings=mp, horizon_scale=stretch,
        temperature=_temperature(x, scene, settings),
        proposals=contact_proposals(x, contour, durations, settings.contact_proposals,
                                    mp.v_clip, settings.proposal_clearance_m) if settings.contact_proposals else None)
    finite = jnp.all(jnp.isfinite(result.sequence))
    u = jnp.where(finite, jnp.clip(result.sequence[0], -mp.v_clip, mp.v_clip), 0.0)
    shifted = jnp.where(finite, shift_in_time(result.sequence, durations, mp.control_period), 0.0)
    return state._replace(sequence=shifted, key=key), u, result


def policy_step(state: ControllerState, observation: jnp.ndarray, estimate: jnp.ndarray | bool, *,
                contour: Contour, scene: Scene,
                settings: ControllerSettings) -> tuple[ControllerState, jnp.ndarray, MPPIResult]:
    """One control period on a fresh, exact observation [x_b, y_b, θ, x_c, y_c] (paper Fig. 5):
    :func:`estimate_step`, then :func:`plan_step` from the observed state. Pure and jit-able."""
    state = estimate_step(state, observation, estimate, contour=contour, settings=settings)
    return plan_step(state, observation, contour=contour, scene=scene, settings=settings)


@partial(jax.jit, static_argnames="settings")
def _estimate_jit(state: ControllerState, observation: jnp.ndarray, contour: Contour,
                  settings: ControllerSettings, frame_period: jnp.ndarray) -> ControllerState:
    return estimate_step(state, observation, settings.estimate_params, contour=contour, settings=settings,
                         frame_period=frame_period)


@partial(jax.jit, static_argnames="settings")
def _plan_jit(state: ControllerState, x: jnp.ndarray, contour: Contour, scene: Scene,
              settings: ControllerSettings) -> tuple[ControllerState, jnp.ndarray, MPPIResult]:
    return plan_step(state, x, contour=contour, scene=scene, settings=settings)


@partial(jax.jit, static_argnames="substeps")
def _predict_jit(contour: Contour, x: jnp.ndarray, u: jnp.ndarray, duration: jnp.ndarray, params: jnp.ndarray,
                 mu: jnp.ndarray, substeps: int) -> jnp.ndarray:
    return integrate(contour, x, u, duration, params, mu, substeps)


class PushingController:
    """Goal-oriented pushing with long-horizon MPPI over the C-GVMM.

    Args:
        shape: the pushed object.
        goal: goal pose (x, y, θ) in the world frame.
        params: λ_pred = [β, x_bf, y_bf] the model assumes (update with :meth:`set_params`);
            without it the controller warns and uses the paper's λ_true for its box.
        obstacles: disc obstacles (c_x, c_y, radius) to avoid with object and pusher.
        settings: :class:`ControllerSettings` (MPPI knobs, cost weights, μ_c, the UKF).
        seed: seeds the MPPI sampling; equal seeds and observations give equal commands.
    """

    def __init__(self, shape: Shape, goal: object, params: object = None,
                 obstacles: object = (), settings: ControllerSettings | None = None,
                 seed: int = 0) -> None:
        if not isinstance(shape, Shape):
            raise TypeError(f"shape must be a dexpush.Shape, got {type(shape).__name__}")
        if settings is not None and not isinstance(settings, ControllerSettings):
            raise ValueError(f"settings must be a ControllerSettings, got {settings!r}")
        self.shape = shape
        self.settings = settings or ControllerSettings()
        world_goal = checked_vector("goal", goal, 3)
        self._goal = world_goal
        # a local origin at the goal: float32 keeps its resolution wherever the robot's world frame is;
        # ``scene`` (goal, obstacles) is in that frame, and so is everything the compiled steps see
        self._origin = np.array([world_goal[0], world_goal[1], 0.0])
        self._heading_ref = float(world_goal[2])
        discs = obstacle_array(obstacles) - self._origin * [1.0, 1.0, 0.0]
        self.scene = Scene.make(shape, world_goal - self._origin, discs, self.settings.weights)
        self.contour = Contour.of(shape)
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
        """Planner restarts after a stall since :meth:`reset` (``ControllerSettings.stall_after_s``)."""
        return int(self.state.stalls)

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
        self._warned = False

    def _warm_up(self, obs: jnp.ndarray) -> None:
        """Run (and so compile) estimate, plan and predict once on ``obs``; results are discarded."""
        state = policy_init(self._initial_params, self.settings, self._seed, self.shape.footprint_box)
        state = _estimate_jit(state, obs, self.contour, self.settings,
                              jnp.float32(self.settings.mppi.control_period))
        state, u, _ = _plan_jit(state, obs, self.contour, self.scene, self.settings)
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
        self.state, u, self.last = _plan_jit(st, obs, self.contour, self.scene, self.settings)
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
            since = float(checked_vector("frame.time", [frame.time], 1)[0])
            q = checked_vector("object_pose", frame.object_pose, 3)
            p = checked_vector("pusher_xy", frame.pusher_xy, 2)
            obs = self._local(q, p)
            self.state = _estimate_jit(self.state, obs, self.contour,
                                       self.settings, jnp.float32(period))
            x = obs
            segments = [(max(t0, since), t0 + T, u) for t0, u in self._history if t0 + T > since]
        elif self._predicted is not None:
            x, segments = self._predicted, ([(0.0, T, self._history[-1][1])] if self._history else [])
        else:
            raise ValueError("the first call of act() needs a frame (the reset observation)")
        lam, mu = self.state.params, self.state.mu
        for t0, t1, u in segments:
            if t1 - t0 > 1e-9:
                x = _predict_jit(self.contour, x, jnp.asarray(u, jnp.float32), jnp.float32(t1 - t0), lam, mu, 10)
        self.state, u, self.last = _plan_jit(self.state, x, self.contour, self.scene, self.settings)
        self._check_estimator()
        return self._issue(u, x)

    def _issue(self, u: jnp.ndarray, x: jnp.ndarray) -> np.ndarray:
        c = self.settings.mppi.v_clip     # float32 rounding may sit a hair past the float64 bound
        cmd = np.clip(np.asarray(u, dtype=np.float64), -c, c)
        self._predicted = x
        self._history.append((self._clock, cmd))
        self._history = self._history[-16:]   # enough to bridge 0.6 s of latency and lost frames
        self._clock += self.settings.mppi.control_period
        return cmd
