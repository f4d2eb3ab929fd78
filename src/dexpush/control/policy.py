"""The controller's loop body as pure functions: settings, state, estimate, watch, plan (paper Fig. 5).

    state = policy_init(λ_pred, settings, seed)
    state, command, result = policy_step(state, observation, estimate, contour=..., scene=..., settings=...)

:func:`policy_step` is :func:`estimate_step` (the UKF window update, :mod:`dexpush.control.estimator`)
followed by :func:`plan_step` (the stall watch, :func:`watch_progress`, and one MPPI iteration
over the C-GVMM, :mod:`dexpush.control.mppi`). All are pure and jit-able:
:class:`dexpush.control.controller.PushingController` wraps them for a robot, and
:mod:`dexpush.experiments.simulate` scans and vmaps them over whole batches of simulated episodes,
so the benchmark and a robot run the very same controller.
"""

from __future__ import annotations

from dataclasses import replace
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from dexpush.control.estimator import EstimatorState, estimator_init, estimator_observe, rate_limited
from dexpush.control.mppi import MPPIResult, mppi_iteration, shift_in_time, slot_durations
from dexpush.control.proposals import contact_proposals
from dexpush.control.push_plan import (
    PushPlan,
    follow_push,
    goal_errors,
    idle_push,
    progress_error,
    push_plan_init,
    search_endgame_push,
    search_push,
)
from dexpush.control.settings import ControllerSettings
from dexpush.model.cgvmm import Contour, contact_gap, step
from dexpush.problem.cost import goal_distance_sq, plan_margin, running_cost, terminal_cost
from dexpush.problem.scene import Scene

__all__ = ["ControllerSettings", "ControllerState", "estimate_step", "plan_step", "policy_init", "policy_step",
           "watch_progress"]


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
    stalls: jnp.ndarray          #: planner restarts after a stall (``ControllerSettings.stall.after_s``)
    streak: jnp.ndarray          #: restarts since the last progress (the clock's backoff exponent)
    stretch: jnp.ndarray         #: the horizon's current scale: 1, or ``stall.horizon_scale`` after a stall
    push: PushPlan               #: the push being carried out after a stall (``ControllerSettings.push_plan``)
    start: jnp.ndarray           #: (3,) λ_pred at the start (``ControllerSettings.obstacles_under_start``)


def policy_init(params: object, settings: ControllerSettings, seed: int | jnp.ndarray,
                box: object = None) -> ControllerState:
    """Fresh state: zero nominal sequence, PRNG key from ``seed``, λ_pred = ``params``; ``box``, the
    footprint's bounding box (``Shape.footprint_box``), bounds the estimator's CoF
    (:func:`dexpush.control.estimator.estimator_init`)."""
    lam = jnp.asarray(params, jnp.float32)
    return ControllerState(jnp.zeros((settings.mppi.horizon, 2), jnp.float32), jax.random.PRNGKey(seed), lam,
                           estimator_init(lam, settings.ukf, box, settings.mu), jnp.float32(settings.mu),
                           jnp.float32(jnp.inf), jnp.float32(0.0), jnp.int32(0), jnp.int32(0),
                           jnp.float32(1.0), push_plan_init(), lam)


def estimate_step(state: ControllerState, observation: jnp.ndarray, estimate: jnp.ndarray | bool, *,
                  contour: Contour, settings: ControllerSettings,
                  frame_period: jnp.ndarray | float | None = None) -> ControllerState:
    """With ``estimate``: the observation enters the UKF window, an informative full window
    updates the filter (:func:`dexpush.control.estimator.estimator_observe`), and λ_pred follows the
    filter's mean within the rate limit (:func:`dexpush.control.estimator.rate_limited`). Pure and jit-able.

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
        # a traced flag (one per lane in dexpush.experiments.simulate): compute the update and select it. A
        # lax.cond turns into a select of both branches under vmap anyway, and a slower one
        # (docs/performance.md#the-estimators-switch)
        on = jnp.asarray(estimate)
        est, lam, mu = jax.tree.map(lambda a, b: jnp.where(on, a, b), observe(state),
                                    (state.estimator, state.params, state.mu))
    return state._replace(estimator=est, params=lam, mu=mu)


def watch_progress(state: ControllerState, x: jnp.ndarray, *, contour: Contour, scene: Scene,
                   settings: ControllerSettings) -> tuple[ControllerState, jnp.ndarray]:
    """Stall detection, once per control period: (state, whether to restart the planner now).

    A stall is no progress toward the goal and no contact for a while. Progress is
    measured in the success test's own terms, position and heading each in its own unit: with
    the position error e_p (the length of the path to the goal, round the obstacles with
    ``CostWeights.detour``: :func:`dexpush.problem.cost.goal_distance_sq` with c = 0) and the heading
    error e_θ = |θ − θ_g|, the error is

        E = max(e_p / stall.progress_m, e_θ / stall.progress_deg),

    and progress is a new best E, lower by at least 1 than the best so far: 5 mm closer, or
    2° less turned where the heading is the larger error (a slow final turn is progress,
    though it hardly moves d of eq. 9b). Progress restarts the clock ``idle``, which
    otherwise runs while the pusher is more than ``stall.contact_gap_m`` off the contour and
    the object is not within both ``stall.min_distance_m`` and ``stall.min_heading_deg`` of
    the goal. When ``idle`` reaches ``stall.after_s`` · ``stall.backoff``^streak (streak:
    restarts since the last progress, so that a walk round the object that takes longer
    than one stall time is not cut short again and again), the planner restarts from a zero
    warm start with its horizon stretched ``stall.horizon_scale`` times
    (:func:`dexpush.control.mppi.slot_durations`: a push that needs a long walk round the object
    first comes into view), and the clock restarts. The horizon is the paper's again at the
    next progress, and is not stretched within ``endgame.distance_m`` of the goal (the endgame
    needs the fine slots; a stall there searches the endgame's push, ``push_plan.endgame``).
    E is :func:`dexpush.control.push_plan.progress_error`. Pure and jit-able.
    """
    if settings.stall.after_s is None:
        return state, jnp.bool_(False)
    T = settings.mppi.control_period
    error = progress_error(x, scene, *progress_units(settings))
    improved = error <= state.best - 1.0
    e_p, e_th = goal_errors(x, scene)
    near = (e_p <= settings.stall.min_distance_m) & (e_th <= np.radians(settings.stall.min_heading_deg))
    away = (contact_gap(contour, x) > settings.stall.contact_gap_m) & ~near
    idle = jnp.where(improved, 0.0, state.idle + jnp.where(away, T, 0.0))
    streak = jnp.where(improved, 0, state.streak)
    patience = settings.stall.after_s * jnp.float32(settings.stall.backoff) ** streak.astype(jnp.float32)
    stalled = idle >= patience - 0.5 * T    # (float32 sums of T)
    scale = jnp.float32(settings.stall.horizon_scale)
    close = _in_endgame(x, scene, settings)       # the endgame's fine slots: no stretch there
    stretch = jnp.where(stalled & ~close, scale, jnp.where(improved | near | close, 1.0, state.stretch))
    restarts = stalled.astype(jnp.int32)
    return state._replace(best=jnp.where(improved, error, state.best), idle=jnp.where(stalled, 0.0, idle),
                          stalls=state.stalls + restarts, streak=streak + restarts, stretch=stretch), stalled


def progress_units(settings: ControllerSettings) -> tuple[float, float]:
    """(u_p m, u_θ rad): the stall watch's units of progress (``stall.progress_m``, ``stall.progress_deg``)."""
    return settings.stall.progress_m, float(np.radians(settings.stall.progress_deg))


def _in_endgame(x: jnp.ndarray, scene: Scene, settings: ControllerSettings) -> jnp.ndarray:
    """Whether the object is within ``endgame.distance_m`` of the goal (round the obstacles)."""
    return goal_distance_sq(x, scene, 0.0) <= settings.endgame.distance_m ** 2


def _temperature(x: jnp.ndarray, scene: Scene, settings: ControllerSettings) -> jnp.ndarray | None:
    """τ for this iteration: ``endgame.temperature`` within ``endgame.distance_m`` of the goal."""
    if settings.endgame.temperature is None:
        return None
    near = _in_endgame(x, scene, settings)
    return jnp.where(near, jnp.float32(settings.endgame.temperature), jnp.float32(settings.mppi.temperature))


def plan_step(state: ControllerState, x: jnp.ndarray, *, contour: Contour, scene: Scene,
              settings: ControllerSettings, predicted_m: jnp.ndarray | float = 0.0, batch_axis: str | None = None,
              estimating: jnp.ndarray | bool | None = None) -> tuple[ControllerState, jnp.ndarray, MPPIResult]:
    """One MPPI iteration (eq. 9–10) from state ``x`` with λ_pred. Pure and jit-able.

    The command is the first input of the new sequence, clipped to ±v_max/√2 (zero, and a
    reset sequence, should it ever be non-finite); the sequence is shifted by the control
    period as the next warm start. A stall (:func:`watch_progress`) zeroes the warm start first.
    Within ``endgame.distance_m`` of the goal the iteration weights its samples with
    ``endgame.temperature``. From a state inside the obstacle margin the plan may not come nearer
    than that state (:func:`dexpush.problem.cost.plan_margin`). With ``obstacles_under_start`` and the UKF
    (``estimating``: ``settings.estimate_params`` unless given; a traced flag, as in a batch whose members differ,
    counts as on) each sample is rolled out under λ_pred and under the start's λ, and its P of (9e) is the larger of
    the two (a member that does not estimate keeps λ_pred at its start, so both rollouts are the same).
    ``mppi.spread_cap`` acts only where the scene has something to keep clear of
    (docs/controller.md#the-temperature-beside-obstacles). ``predicted_m`` is
    how far (m) the object's footprint moved in the prediction that made ``x`` from the newest frame (0 for an
    observation); the margin grows by ``prediction_margin.gain`` times it, up to ``prediction_margin.max_m`` more.
    After a stall restart a push is searched and carried out past the horizon (``settings.push_plan``,
    :mod:`dexpush.control.push_plan`); ``batch_axis``, the name of a ``vmap`` axis this runs under, lets a batch
    search only in the periods where one of its members stalls.
    """
    mp = settings.mppi
    x = jnp.asarray(x, jnp.float32)
    stalled = jnp.bool_(False)
    stretch = 1.0   # without a possible stretch the scale is a Python constant; a traced one reaches the
    if settings.stall.after_s is not None:      # rollouts as a factor on the inputs (rate_independent below)
        state, stalled = watch_progress(state, x, contour=contour, scene=scene, settings=settings)
        state = state._replace(sequence=jnp.where(stalled, 0.0, state.sequence))
        if settings.stall.horizon_scale != 1.0:
            stretch = state.stretch
    key, sub = jax.random.split(state.key)
    weights, mu = settings.weights, state.mu
    extra = (jnp.minimum(settings.prediction_margin.gain * jnp.asarray(predicted_m, jnp.float32),
                         settings.prediction_margin.max_m) if settings.prediction_margin.gain else 0.0)
    plan_scene = plan_margin(x, scene, weights, extra)     # from inside the margin: no nearer than now
    durations = slot_durations(mp, stretch)
    x0 = tuple(x[i] for i in range(5))                       # rollouts carry a tuple
    estimating = settings.estimate_params if estimating is None else estimating
    no_estimate = isinstance(estimating, bool | np.bool_) and not estimating      # known off at trace time
    if settings.obstacles_under_start and scene.has_obstacles and not no_estimate:
        # each sample rolled out under the estimate and under the start: its obstacle cost is the larger
        x0, params = (x0, x0), (state.params, state.start)

        def dynamics(xs, u, dt, p):
            return step(contour, xs[0], u, dt, p[0], mu), step(contour, xs[1], u, dt, p[1], mu)

        def running(xs, sc):
            return running_cost(xs[0], sc, weights, xs[1])

        def terminal(xs, sc):
            return terminal_cost(xs[0], sc, weights)
    else:
        params = state.params

        def dynamics(xs, u, dt, p):
            return step(contour, xs, u, dt, p, mu)

        def running(xs, sc):
            return running_cost(xs, sc, weights)

        def terminal(xs, sc):
            return terminal_cost(xs, sc, weights)
    result = mppi_iteration(
        sub, state.sequence, x0, params, plan_scene, dynamics=dynamics, running_cost=running,
        terminal_cost=terminal, horizon_scale=stretch,
        settings=mp if scene.has_obstacles else replace(mp, spread_cap=None),   # no penalty to cap or check
        temperature=_temperature(x, scene, settings), rate_independent=True,   # quasi-static: see mppi_iteration
        proposals=contact_proposals(x, contour, durations, settings.proposals.count,
                                    mp.v_clip, settings.proposals.clearance_m) if settings.proposals.count else None)
    finite = jnp.all(jnp.isfinite(result.sequence))
    u = jnp.where(finite, jnp.clip(result.sequence[0], -mp.v_clip, mp.v_clip), 0.0)
    shifted = jnp.where(finite, shift_in_time(result.sequence, durations, mp.control_period), 0.0)
    if settings.push_plan.enabled and settings.stall.after_s is not None:
        state, u = _push_plan(state, x, u, stalled, contour=contour, scene=plan_scene, settings=settings,
                              batch_axis=batch_axis)
    return state._replace(sequence=shifted, key=key), u, result


def _push_plan(state: ControllerState, x: jnp.ndarray, u: jnp.ndarray, stalled: jnp.ndarray, *, contour: Contour,
               scene: Scene, settings: ControllerSettings,
               batch_axis: str | None) -> tuple[ControllerState, jnp.ndarray]:
    """After a stall restart, search a push (:func:`dexpush.control.push_plan.search_push`) and, while one is
    being carried out, command it instead of MPPI's ``u`` (:func:`dexpush.control.push_plan.follow_push`); the
    stall clock stands still meanwhile. Under ``vmap`` a per-member condition would be a select that searches
    (and follows) every period; with ``batch_axis`` the condition is whether any member needs a search (or
    follows a plan)."""
    pp, mp, w = settings.push_plan, settings.mppi, settings.weights
    args = (contour, scene, w, state.params, state.mu, pp, mp.v_clip)
    need = stalled & ~state.push.active

    def search() -> PushPlan:
        if pp.endgame.enabled:      # within endgame.distance_m the endgame's search
            found, plan = jax.lax.cond(_in_endgame(x, scene, settings),
                                       lambda: search_endgame_push(x, *args, progress_units(settings)),
                                       lambda: search_push(x, *args))
        else:
            found, plan = search_push(x, *args)
        return jax.tree.map(lambda a, b: jnp.where(need & found, a, b), plan, push_plan_init())

    run = need if batch_axis is None else jax.lax.psum(need.astype(jnp.int32), batch_axis) > 0
    fresh = jax.lax.cond(run, search, push_plan_init)
    plan = jax.tree.map(lambda a, b: jnp.where(fresh.active, a, b), fresh, state.push)
    plan = plan._replace(started=state.push.started + fresh.active.astype(jnp.int32))

    def follow() -> tuple[PushPlan, jnp.ndarray, jnp.ndarray]:
        return follow_push(plan, x, *args, mp.control_period)

    following = plan.active if batch_axis is None else jax.lax.psum(plan.active.astype(jnp.int32), batch_axis) > 0
    plan, u_plan, use = jax.lax.cond(following, follow, lambda: idle_push(plan, mp.control_period))
    u = jnp.where(use, jnp.clip(u_plan, -mp.v_clip, mp.v_clip), u)
    return state._replace(push=plan, idle=jnp.where(use, 0.0, state.idle)), u


def policy_step(state: ControllerState, observation: jnp.ndarray, estimate: jnp.ndarray | bool, *,
                contour: Contour, scene: Scene,
                settings: ControllerSettings, batch_axis: str | None = None
                ) -> tuple[ControllerState, jnp.ndarray, MPPIResult]:
    """One control period on a fresh, exact observation [x_b, y_b, θ, x_c, y_c] (paper Fig. 5):
    :func:`estimate_step`, then :func:`plan_step` from the observed state (``batch_axis``: see there). Pure and
    jit-able."""
    state = estimate_step(state, observation, estimate, contour=contour, settings=settings)
    return plan_step(state, observation, contour=contour, scene=scene, settings=settings, batch_axis=batch_axis,
                     estimating=estimate)
