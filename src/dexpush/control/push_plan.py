"""A push chosen after a stall: where to stand, which way round to walk there, how far to push.

MPPI's horizon sees a few seconds ahead, and its terminal cost, the cost-to-go V of the object
(:mod:`dexpush.problem.guidance`), does not know where the pusher stands. When the pusher must walk
half round the object before a push can lower V, and a wall or the table's edge blocks the short way,
no sample within the horizon shows the gain, and the planner stalls
(docs/workspaces.md#a-push-plan-after-a-stall-2026-12-07).
After a stall restart (:func:`dexpush.control.policy.watch_progress`) :func:`search_push` looks further:
for J contact azimuths φ_j in {B}, both ways round and L push lengths D_l, it takes

    walk_{j,w}:  the pusher's curve of :func:`dexpush.control.proposals.walk_curve`, the object standing
                 still; it is open when every point of it keeps the pusher out of the obstacles'
                 margin (P(x) of eq. 9e at most ``tolerance``·C_margin);
    push_{j,l}:  from the walk's end, the pusher along the inward normal n(φ_j), fixed in {W}, for
                 c + D_l (c: the walk's clearance) at speed v, rolled through the C-GVMM with λ_pred in
                 ``push_slots`` slots; it is clear when every slot's state is (the same test);
    score:       d(x_end) + w_t·(s_walk + c + D_l),    d = √d²(q_sb, q_g) of eq. (9b), along V

and chooses the lowest score among the open and clear ones, if its d(x_end) is at least ``min_gain_m``
below d(x) now. :func:`follow_push` then carries it out: the walk recomputed from each new state
(targets are fixed in {B}, so a knocked object is walked round where it is), the push along the
direction the target's normal has when the walk ends. Each command is checked one period ahead
through the model against the margin the plan was chosen with (the search's test: its quarter may be
used), and the plan is given up, MPPI's command taking over, where that period would go further in, or
when the plan has run 1.5 times its length plus a second. MPPI plans on beside it every period and takes
over when the push is done.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from dexpush.common.checks import check_nonnegative, check_positive
from dexpush.control.proposals import inward_normal, pusher_in_body, walk_and_push, walk_curve
from dexpush.model.cgvmm import Contour, contact_gap, integrate
from dexpush.problem.cost import goal_distance_sq, obstacle_cost
from dexpush.problem.scene import Scene
from dexpush.problem.weights import CostWeights

__all__ = ["PushCandidates", "PushPlan", "PushPlanSettings", "follow_push", "idle_push", "push_candidates",
           "push_plan_init", "search_push"]

#: the walk is done when the pusher is within this turn (rad) of its target ...
AT_TARGET_RAD = 0.05
#: ... and within this (m) of the walk's distance from the contour
AT_TARGET_M = 0.005
#: substeps of the model per push slot
PUSH_SUBSTEPS = 4


@dataclass(frozen=True)
class PushPlanSettings:
    """A push chosen after a stall restart (:mod:`dexpush.control.push_plan`): ``targets`` contact azimuths,
    both ways round, ``lengths_m`` push lengths, judged through the model and the cost-to-go and carried out
    past MPPI's horizon; ``enabled`` False restarts MPPI alone after a stall."""

    enabled: bool = True
    targets: int = 16                  #: contact azimuths, evenly spaced round the object
    lengths_m: tuple[float, ...] = (0.03, 0.06, 0.12)   #: the push lengths tried (m), after the clearance
    clearance_m: float = 0.015         #: the walk's distance from the inflated contour (m)
    push_slots: int = 8                #: slots of each push's rollout
    #: a walk or push is blocked where P(x) (eq. 9e) exceeds this fraction of C_margin in one state
    tolerance: float = 0.25
    travel_weight: float = 0.05        #: metres of goal distance one metre of the pusher's travel costs
    min_gain_m: float = 0.01           #: the push must bring the object this much nearer the goal (m, along V)

    def __post_init__(self) -> None:
        if not isinstance(self.enabled, bool | np.bool_):
            raise ValueError(f"push_plan.enabled must be true or false, got {self.enabled!r}")
        for name, low in (("targets", 2), ("push_slots", 1)):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int | np.integer) or v < low:
                raise ValueError(f"push_plan.{name} must be a whole number >= {low}, got {v!r}")
        lengths = self.lengths_m
        if not isinstance(lengths, tuple | list) or not lengths or not all(
                isinstance(v, int | float) and not isinstance(v, bool) and 0 < v < float("inf") for v in lengths):
            raise ValueError(f"push_plan.lengths_m must be a non-empty list of positive lengths (m), got {lengths!r}")
        object.__setattr__(self, "lengths_m", tuple(float(v) for v in lengths))
        check_positive("push_plan.clearance_m", self.clearance_m, "m")
        check_positive("push_plan.tolerance", self.tolerance)
        check_nonnegative("push_plan.travel_weight", self.travel_weight)
        check_nonnegative("push_plan.min_gain_m", self.min_gain_m, "m")


class PushPlan(NamedTuple):
    """The push being carried out (a pytree in :class:`dexpush.control.policy.ControllerState`)."""

    active: jnp.ndarray      #: bool: a plan is being carried out
    pushing: jnp.ndarray     #: bool: the walk is done
    target: jnp.ndarray      #: φ_j, the contact azimuth in {B}
    way: jnp.ndarray         #: +1 counter-clockwise round the object, −1 clockwise
    direction: jnp.ndarray   #: (2,) the push's unit direction in {W}, set when the walk ends
    left_m: jnp.ndarray      #: push length still to go (m)
    time_left: jnp.ndarray   #: s before the plan is given up
    started: jnp.ndarray     #: int32: plans started since the controller's reset
    margin: jnp.ndarray      #: the plan's obstacle margin when it was chosen (m; ``Scene.margin``)
    pusher_margin: jnp.ndarray   #: ... and the pusher's from bounds of its own (``Scene.pusher_margin``)


def push_plan_init() -> PushPlan:
    """No plan."""
    f = jnp.float32(0.0)
    return PushPlan(jnp.bool_(False), jnp.bool_(False), f, jnp.float32(1.0), jnp.zeros(2, jnp.float32), f, f,
                    jnp.int32(0), f, f)


def _blocked(states: tuple, scene: Scene, weights: CostWeights, tolerance: float) -> jnp.ndarray:
    """Whether P(x) (eq. 9e) of states exceeds ``tolerance``·C_margin (a touch with the binary margin)."""
    limit = weights.C_pen * 0.5 if weights.C_margin is None else tolerance * weights.C_margin
    return obstacle_cost(states, scene, weights) > limit


def _distance(x: tuple | jnp.ndarray, scene: Scene, weights: CostWeights) -> jnp.ndarray:
    return jnp.sqrt(goal_distance_sq(x, scene, weights.c))


class PushCandidates(NamedTuple):
    """Every push :func:`search_push` weighs (J targets, 2 ways round, L lengths)."""

    targets: jnp.ndarray      #: (J,) contact azimuths φ_j in {B}
    turns: jnp.ndarray        #: (J, 2) the walk's signed turn (rad): the short way, the long way
    walk_open: jnp.ndarray    #: (J, 2) bool: the walk keeps out of the obstacles' margin
    walk_m: jnp.ndarray       #: (J, 2) the walk's length (m)
    travel_m: jnp.ndarray     #: (L,) each push's travel: the walk's clearance and the push length
    push_clear: jnp.ndarray   #: (J, L) bool: the push's rollout keeps out of the margin
    states: jnp.ndarray       #: (J, L, P, 5) the push's rollout, each slot's end
    d_end: jnp.ndarray        #: (J, L) d after the push (m, eq. 9b along V)
    d_now: jnp.ndarray        #: d now
    score: jnp.ndarray        #: (J, 2, L) d_end + w_t · travel; inf where blocked


def push_candidates(x: jnp.ndarray, contour: Contour, scene: Scene, weights: CostWeights, params: jnp.ndarray,
                    mu: jnp.ndarray, settings: PushPlanSettings, speed: float) -> PushCandidates:
    """The walks and pushes of the module docstring from state ``x`` (5,), judged. ``scene`` is the plan's
    (:func:`dexpush.problem.cost.plan_margin`). Pure and jit-able."""
    dtype = jnp.float32
    J, clearance = settings.targets, settings.clearance_m
    lengths = jnp.asarray(settings.lengths_m, dtype)                                  # (L,)
    xb, yb, c, s, bx, by = pusher_in_body(x, dtype)
    th = x[2]
    phi0 = jnp.arctan2(by, bx)
    targets = jnp.asarray(2 * np.pi * np.arange(J) / J - np.pi, dtype)               # (J,)
    short = jnp.arctan2(jnp.sin(targets - phi0), jnp.cos(targets - phi0))
    long = short - 2 * jnp.pi * jnp.where(short >= 0, 1.0, -1.0)
    turns = jnp.concatenate([short, long])                                            # (2J,): short, then long
    walk, arc, inward = walk_curve(x, contour, jnp.concatenate([targets, targets]), turns, clearance)
    wx = xb + c * walk[..., 0] - s * walk[..., 1]                                     # (2J, M) in {W}
    wy = yb + s * walk[..., 0] + c * walk[..., 1]
    still = tuple(jnp.broadcast_to(v, wx.shape) for v in (xb, yb, th))
    walk_open = ~jnp.any(_blocked((*still, wx, wy), scene, weights, settings.tolerance), axis=1)   # (2J,)
    # the pushes, one per target and length, from the walk's end along the inward normal fixed in {W}
    end = walk[:J, -1]                                                                # (J, 2) in {B}
    p0 = jnp.stack([xb + c * end[:, 0] - s * end[:, 1], yb + s * end[:, 0] + c * end[:, 1]], -1)
    n_w = jnp.stack([c * inward[:J, 0] - s * inward[:J, 1], s * inward[:J, 0] + c * inward[:J, 1]], -1)
    travel = clearance + lengths                                                      # (L,)
    slot = travel / (speed * settings.push_slots)                                     # (L,) s

    def push(p: jnp.ndarray, n: jnp.ndarray, dt: jnp.ndarray) -> jnp.ndarray:
        x0 = jnp.concatenate([x[:3], p]).astype(dtype)

        def one(xi: jnp.ndarray, _: None) -> tuple[jnp.ndarray, jnp.ndarray]:
            xn = integrate(contour, xi, speed * n, dt, params, mu, PUSH_SUBSTEPS)
            return xn, xn
        _, states = jax.lax.scan(one, x0, None, length=settings.push_slots)
        return states                                                                 # (P, 5)

    states = jax.vmap(lambda p, n: jax.vmap(lambda dt: push(p, n, dt))(slot))(p0, n_w)   # (J, L, P, 5)
    push_clear = ~jnp.any(_blocked(tuple(states[..., i] for i in range(5)), scene, weights, settings.tolerance),
                          axis=-1)                                                    # (J, L)
    d_end = _distance(tuple(states[:, :, -1, i] for i in range(5)), scene, weights)   # (J, L)
    d_now = _distance(tuple(x[i] for i in range(5)), scene, weights)
    walk_m = arc[:, -1].reshape(2, J).T                                               # (J, 2)
    walk_open = walk_open.reshape(2, J).T
    ok = walk_open[:, :, None] & push_clear[:, None, :]                               # (J, 2, L)
    score = d_end[:, None, :] + settings.travel_weight * (walk_m[:, :, None] + travel[None, None, :])
    return PushCandidates(targets, turns.reshape(2, J).T, walk_open, walk_m, travel, push_clear, states, d_end,
                          d_now, jnp.where(ok, score, jnp.inf))


def search_push(x: jnp.ndarray, contour: Contour, scene: Scene, weights: CostWeights, params: jnp.ndarray,
                mu: jnp.ndarray, settings: PushPlanSettings, speed: float) -> tuple[jnp.ndarray, PushPlan]:
    """(found, plan) from state ``x`` (5,): the lowest score of :func:`push_candidates`, and whether its push
    brings the object ``settings.min_gain_m`` nearer the goal. Pure and jit-able."""
    k = push_candidates(x, contour, scene, weights, params, mu, settings, speed)
    L = k.travel_m.shape[0]
    best = jnp.argmin(k.score.reshape(-1))
    j, w, l_ = best // (2 * L), (best // L) % 2, best % L
    found = jnp.isfinite(k.score.reshape(-1)[best]) & (k.d_end[j, l_] <= k.d_now - settings.min_gain_m)
    way = jnp.sign(k.turns[j, w])
    way = jnp.where(way == 0, 1.0, way).astype(jnp.float32)
    duration = (k.walk_m[j, w] + k.travel_m[l_]) / speed
    plan = PushPlan(found, jnp.bool_(False), k.targets[j], way, jnp.zeros(2, jnp.float32), k.travel_m[l_],
                    (1.5 * duration + 1.0).astype(jnp.float32), jnp.int32(0),
                    jnp.asarray(scene.margin, jnp.float32), jnp.asarray(scene.pusher_margin, jnp.float32))
    return found, plan


def follow_push(plan: PushPlan, x: jnp.ndarray, contour: Contour, scene: Scene, weights: CostWeights,
                params: jnp.ndarray, mu: jnp.ndarray, settings: PushPlanSettings, speed: float,
                period: float) -> tuple[PushPlan, jnp.ndarray, jnp.ndarray]:
    """(plan, command, whether to use it) for one control period from state ``x`` (5,). Pure and jit-able."""
    dtype = jnp.float32
    _, _, c, s, bx, by = pusher_in_body(x, dtype)
    phi = jnp.arctan2(by, bx)
    # the turn still to make, the plan's way round; a small overshoot counts as a small turn back
    ahead = jnp.mod(plan.way * (plan.target - phi), 2 * jnp.pi)
    ahead = jnp.where(ahead > 2 * jnp.pi - 0.2, ahead - 2 * jnp.pi, ahead)
    arrived = (jnp.abs(ahead) < AT_TARGET_RAD) & (contact_gap(contour, x) < settings.clearance_m + AT_TARGET_M)
    start_push = plan.active & ~plan.pushing & arrived
    inward = inward_normal(contour, plan.target[None])[0]
    n_w = jnp.stack([c * inward[0] - s * inward[1], s * inward[0] + c * inward[1]])
    direction = jnp.where(start_push, n_w, plan.direction)
    pushing = plan.pushing | start_push
    walk_u = walk_and_push(x, contour, jnp.full((2,), period, dtype), plan.target[None],
                           (plan.way * ahead)[None], speed, settings.clearance_m, plan.left_m)[0, 0]
    u = jnp.where(pushing, speed * direction, walk_u)
    left = jnp.where(pushing, plan.left_m - speed * period, plan.left_m)
    x1 = integrate(contour, x.astype(dtype), u, jnp.asarray(period, dtype), params, mu, PUSH_SUBSTEPS)
    # against the margin the plan was chosen with, not the present state's (which follows the object in)
    held = replace(scene, margin=plan.margin.astype(scene.margin.dtype),
                   pusher_margin=plan.pusher_margin.astype(scene.pusher_margin.dtype))
    safe = ~_blocked(tuple(x1[i] for i in range(5)), held, weights, settings.tolerance)
    use = plan.active & safe & (plan.time_left > 0) & jnp.all(jnp.isfinite(u))
    active = use & (left > 0)
    new = PushPlan(active, pushing & active, plan.target, plan.way, direction, left,
                   plan.time_left - period, plan.started, plan.margin, plan.pusher_margin)
    return new, jnp.where(use, u, 0.0), use


def idle_push(plan: PushPlan, period: float) -> tuple[PushPlan, jnp.ndarray, jnp.ndarray]:
    """What :func:`follow_push` gives for an inactive ``plan`` (which is never pushing), without its model step: for
    a ``lax.cond`` that follows only while a plan is active. Pure and jit-able."""
    off = jnp.bool_(False)
    return (plan._replace(active=off, pushing=off, time_left=plan.time_left - jnp.float32(period)),
            jnp.zeros(2, jnp.float32), off)
