"""Batched closed-loop episodes on the model plant: many trials, one jitted step.

A simulated control period is the controller's pure :func:`dexpush.control.policy.policy_step`
(UKF window update, one MPPI iteration) followed by the model plant (the C-GVMM with
λ_true, ``substeps`` Euler steps, :func:`dexpush.model.cgvmm.integrate`). :func:`simulate`
``vmap``s that period over a fixed number of *lanes* and ``lax.scan``s it over a chunk
of control periods, so Python runs once per chunk, never per sample or per trial.

Lanes are slots, not trials: trials wait in a queue, and when one finishes (success, or
N_max steps) the next trial takes its lane at the next chunk boundary. The compiled
program therefore has one batch size for a whole run, and a lane's arithmetic never
depends on its neighbours: a trial's outcome does not depend on which trials shared its
batch or which lane it ran in (``tests/test_simulate.py`` checks this bit for bit), so
``dexpush bench`` on a subset of seeds, or ``dexpush run --lanes 16``, reproduces what
``dexpush bench`` recorded for a seed. A *different* lane count is a different XLA
program, which may round differently (XLA picks fusions and FMA contractions by shape):
episodes then agree to float32 round-off at first, and a closed loop may amplify that.

Touching an obstacle fails a trial (docs/conventions.md#benchmark-tasks): the logged states are checked after each
chunk and a trial that touched ends there, as a failure, its log cut at the touch.

A finished lane is frozen (``jnp.where(done, old, new)``) until it is refilled; under
``vmap`` it still costs its share of the arithmetic, which is why lanes are refilled
rather than left to idle until the slowest trial of a batch ends.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from functools import partial
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from dexpush.common.checks import check_params, checked_vector
from dexpush.common.progress import progress_bar
from dexpush.control.policy import ControllerSettings, ControllerState, policy_init, policy_step
from dexpush.experiments.scenarios import MAX_STEPS
from dexpush.model.cgvmm import LAMBDA_TRUE, MU_C, Contour, integrate
from dexpush.problem.problem import Problem, reached
from dexpush.problem.scene import Scene
from dexpush.world.model_plant import check_no_tunnelling

__all__ = ["ESTIMATOR_COUNTERS", "Starts", "TrialResult", "TrialSpec", "simulate"]


#: a trial's start from its seed: (object pose (3,), pusher position (2,))
Starts = Callable[[int], tuple[np.ndarray, np.ndarray]]


@dataclass(frozen=True)
class TrialSpec:
    """One trial: its seed (start perturbation and MPPI sampling), the λ_pred the
    controller starts from, and whether the UKF estimates λ online."""

    seed: int
    params: tuple[float, float, float] = LAMBDA_TRUE
    estimate: bool = False


#: the estimator's counters a :class:`TrialResult` carries (and the controller exposes under the same names)
ESTIMATOR_COUNTERS = ("rejected_frames", "estimator_resets", "estimator_updates", "gated_windows")


@dataclass
class TrialResult:
    """A finished trial and its trajectory."""

    spec: TrialSpec
    success: bool
    states: np.ndarray        #: (T+1, 5) true states, the start included
    commands: np.ndarray      #: (T, 2) pusher velocities
    params: np.ndarray        #: (T, 3) λ_pred planned with at each step
    step_ms: np.ndarray       #: (T,) wall time of each control step: the chunk's time / (lanes × chunk length)
    plan_s: tuple[float, ...] = ()   #: GCS baseline only: wall time of the offline plan, then of each replan
    rejected_frames: int | None = None    #: frames the estimator's gate rejected (controllers with an estimator)
    estimator_resets: int | None = None   #: times the estimator was reset to its prior after turning non-finite
    estimator_updates: int | None = None  #: informative windows that updated the estimate
    gated_windows: int | None = None      #: of those, windows the innovation gate down-weighted
    stall_resets: int | None = None       #: planner restarts after a stall (MPPI controllers)
    push_plans: int | None = None         #: pushes chosen after a stall (MPPI with ``push_plan.enabled``)
    frames: dict | None = None            #: what a camera did (:meth:`dexpush.world.sensing.Camera.counts`)
    #: (T, 2) after each step, the planner's stall restarts and push plans so far (``run_loop`` with a controller
    #: that counts them; None from the batched simulator): where a trajectory's stalls and plans fall
    events: np.ndarray | None = None

    @property
    def steps(self) -> int:
        return len(self.commands)


#: the name of the lanes' ``vmap`` axis: the controller searches a push plan only where a lane needs one
LANE_AXIS = "lanes"


class Lane(NamedTuple):
    """One lane's carry: true state, controller state, progress."""

    x: jnp.ndarray            #: (5,) true state [x_b, y_b, θ, x_c, y_c]
    policy: ControllerState
    steps: jnp.ndarray        #: control steps taken
    done: jnp.ndarray         #: success or N_max reached: frozen from now on
    success: jnp.ndarray


def _lane_step(lane: Lane, estimate: jnp.ndarray, max_steps: jnp.ndarray, contour: Contour, scene: Scene,
               plant_params: jnp.ndarray, plant_mu: jnp.ndarray, settings: ControllerSettings,
               substeps: int, tolerance: tuple[float, float]) -> tuple[Lane, tuple[jnp.ndarray, ...]]:
    policy, u, _ = policy_step(lane.policy, lane.x, estimate, contour=contour, scene=scene, settings=settings,
                               batch_axis=LANE_AXIS)
    x1 = integrate(contour, lane.x, u, jnp.float32(settings.mppi.control_period), plant_params, plant_mu,
                   substeps)
    ok = reached(x1[:3], scene, *tolerance)
    steps = lane.steps + 1
    new = Lane(x1, policy, steps, ok | (steps >= max_steps), ok)
    out = jax.tree.map(lambda old, nxt: jnp.where(lane.done, old, nxt), lane, new)
    return out, (x1, u, policy.params, ~lane.done)


@partial(jax.jit, static_argnames=("settings", "length", "substeps", "tolerance"))
def _advance(lanes: Lane, estimate: jnp.ndarray, max_steps: jnp.ndarray, contour: Contour, scene: Scene,
             plant_params: jnp.ndarray, plant_mu: jnp.ndarray, *, settings: ControllerSettings, length: int,
             substeps: int, tolerance: tuple[float, float]) -> tuple[Lane, tuple[jnp.ndarray, ...]]:
    """``length`` control periods of every lane: (lanes, logs (length, B, ...))."""
    one = partial(_lane_step, max_steps=max_steps, contour=contour, scene=scene, plant_params=plant_params,
                  plant_mu=plant_mu, settings=settings, substeps=substeps, tolerance=tolerance)
    batched = jax.vmap(one, axis_name=LANE_AXIS)
    return jax.lax.scan(lambda c, _: batched(c, estimate), lanes, None, length=length)


def _new_lane(problem: Problem, starts: Starts, spec: TrialSpec, settings: ControllerSettings) -> Lane:
    pose, pusher = starts(spec.seed)
    x0 = np.concatenate([pose, pusher]).astype(np.float32)
    ok = bool(problem.success(x0[:3]))
    policy = policy_init(spec.params, settings, spec.seed, problem.shape.footprint_box)
    return Lane(jnp.asarray(x0), policy, jnp.int32(0), jnp.bool_(ok), jnp.bool_(ok))


def _set_lane(lanes: Lane, i: int, lane: Lane) -> Lane:
    return jax.tree.map(lambda all_, one: all_.at[i].set(one), lanes, lane)


def simulate(problem: Problem, trials: Sequence[TrialSpec], settings: ControllerSettings | None = None, *,
             starts: Starts, max_steps: int = MAX_STEPS, lanes: int = 32, chunk: int = 25,
             plant_params: object = LAMBDA_TRUE,
             plant_mu: float = MU_C, substeps: int = 10,
             on_result: Callable[[TrialResult], None] | None = None, progress: bool = False,
             desc: str = "trials") -> list[TrialResult]:
    """Run ``trials`` of ``problem`` in closed loop on the model plant, batched.

    Args:
        problem: the object, goal, obstacles and cost (:class:`dexpush.problem.problem.Problem`).
        trials: the trials to run; results come back in the same order.
        settings: the controller's settings (``estimate_params`` is ignored: each
            :class:`TrialSpec` says whether its controller estimates λ; the cost weights are the
            problem's).
        starts: a trial's start from its seed, (object pose, pusher position), e.g.
            ``partial(task.trial_start, shape)`` (docs/conventions.md#benchmark-tasks).
        max_steps: N_max control steps per trial.
        lanes: trials advanced together (the vmapped batch). Idle lanes are padding, so a
            trial's outcome is the same for any queue run with the same ``lanes`` and
            ``chunk``; other values compile a different program whose float32 rounding
            (XLA's fusion and FMA choices depend on the batch shape) gives trajectories
            that agree only to the last bits, which a closed loop can amplify.
        chunk: control periods per compiled call (the granularity of refills and progress).
        plant_params, plant_mu, substeps: the model plant's true λ, μ_c and Euler substeps.
        on_result: called with each :class:`TrialResult` as soon as its trial ends
            (e.g. to save it: an interrupted run keeps every finished trial).
        progress: show a progress bar (trials finished, lanes busy) on stderr.
    """
    if not trials:
        return []
    # each TrialSpec says whether its controller estimates λ; the settings' flag is unused here,
    # so it is normalised to keep one compiled program for both methods
    settings = replace(settings or ControllerSettings(), estimate_params=False, weights=problem.weights)
    if max_steps < 1 or lanes < 1 or chunk < 1:
        raise ValueError(f"max_steps, lanes and chunk must be >= 1, got {max_steps}, {lanes}, {chunk}")
    if substeps < 10:
        raise ValueError(f"substeps must be >= 10 (docs/conventions.md#plants), got {substeps}")
    # the fastest command, held for one substep, must not carry the pusher through the object
    check_no_tunnelling(np.full(2, settings.mppi.v_clip), settings.mppi.control_period / substeps,
                        problem.shape.pusher_radius, "substeps (or shorten mppi.control_period)")
    for spec in trials:
        check_params(checked_vector("params", spec.params, 3))
        if int(spec.seed) < 0:
            raise ValueError(f"seed must be >= 0, got {spec.seed}")
    true_params = checked_vector("plant_params", plant_params, 3)
    check_params(true_params)
    contour, scene = problem.contour, problem.scene
    n_lanes = lanes        # never fewer, even for one trial: see the module docstring
    queue = list(range(len(trials)))
    first = _new_lane(problem, starts, trials[0], settings)
    batch = jax.tree.map(lambda a: jnp.stack([a] * n_lanes), first)
    batch = batch._replace(done=jnp.ones(n_lanes, bool))           # idle until filled
    estimate = np.zeros(n_lanes, bool)
    owner: list[int | None] = [None] * n_lanes
    logs: dict[int, dict[str, list]] = {}
    results: dict[int, TrialResult] = {}
    tolerance = (problem.tolerance_m, problem.tolerance_deg)
    args = (contour, scene, jnp.asarray(true_params, jnp.float32), jnp.float32(plant_mu))
    bar = progress_bar(len(trials), desc, "trial", progress)

    def finish(i: int, lane_success: bool, counts: tuple[int, ...] = (0, 0, 0, 0, 0, 0)) -> None:
        log = logs.pop(i)
        def cat(parts: list[np.ndarray], width: int) -> np.ndarray:
            return np.concatenate(parts).reshape(-1, width) if parts else np.zeros((0, width))

        res = TrialResult(trials[i], lane_success, np.concatenate([log["x0"], *log["x"]]), cat(log["u"], 2),
                          cat(log["lam"], 3), np.concatenate(log["ms"]) if log["ms"] else np.zeros(0),
                          rejected_frames=counts[0], estimator_resets=counts[1], estimator_updates=counts[2],
                          gated_windows=counts[3], stall_resets=counts[4],
                          push_plans=counts[5] if settings.push_plan.enabled else None)
        results[i] = res
        if on_result is not None:
            on_result(res)
        bar.update(1)

    warmed = False
    while queue or any(o is not None for o in owner):
        for k in range(n_lanes):                                     # refill idle lanes
            while owner[k] is None and queue:
                i = queue.pop(0)
                lane = _new_lane(problem, starts, trials[i], settings)
                logs[i] = {"x0": np.asarray(lane.x, np.float64)[None], "x": [], "u": [], "lam": [], "ms": []}
                if bool(lane.done):                                  # starts at the goal: nothing to do
                    finish(i, True)
                    continue
                batch = _set_lane(batch, k, lane)
                estimate[k] = trials[i].estimate
                owner[k] = i
        if not any(o is not None for o in owner):
            break
        if not warmed:   # compile outside the timed loop (a discarded call), and only if there is work
            jax.block_until_ready(_advance(batch, jnp.asarray(estimate), jnp.int32(max_steps), *args,
                                           settings=settings, length=chunk, substeps=substeps,
                                           tolerance=tolerance))
            warmed = True
        t0 = time.perf_counter()
        batch, (xs, us, lams, active) = _advance(batch, jnp.asarray(estimate), jnp.int32(max_steps), *args,
                                                 settings=settings, length=chunk, substeps=substeps,
                                           tolerance=tolerance)
        xs, us, lams, active = (np.asarray(a) for a in (xs, us, lams, active))
        done, success = np.asarray(batch.done), np.asarray(batch.success)
        est = batch.policy.estimator
        counters = np.stack([np.asarray(c) for c in (est.rejected, est.resets, est.updates, est.gated,
                                                     batch.policy.stalls, batch.policy.push.started)], -1)
        # each lane's share of the step's wall time: a trial pays for its own lane, not for idle ones
        ms = (time.perf_counter() - t0) * 1e3 / (n_lanes * chunk)
        # touching an obstacle ends a trial as a failure (conventions.md#benchmark-tasks); checked on the logged
        # states rather than inside the compiled step, whose program (and rounding) it would change
        hits = problem.collides(xs)
        for k, i in enumerate(owner):
            if i is None:
                continue
            m = active[:, k]
            n = int(m.sum())
            touched = np.flatnonzero(hits[m, k])
            if len(touched):
                n = int(touched[0]) + 1                        # keep the log up to the touch
            logs[i]["x"].append(xs[m, k][:n].astype(np.float64))
            logs[i]["u"].append(us[m, k][:n].astype(np.float64))
            logs[i]["lam"].append(lams[m, k][:n].astype(np.float64))
            logs[i]["ms"].append(np.full(n, ms))
            if len(touched) or done[k]:
                finish(i, bool(success[k]) and not len(touched), tuple(int(c) for c in counters[k]))
                owner[k] = None
                batch = batch._replace(done=batch.done.at[k].set(True))   # idle until refilled
        bar.set_postfix(busy=sum(o is not None for o in owner), refresh=False)
    bar.close()
    return [results[i] for i in range(len(trials))]

