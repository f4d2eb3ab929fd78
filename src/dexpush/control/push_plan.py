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

Near the goal (a stall within ``endgame.distance_m``) the gain left is a centimetre or two, the push
must not turn the object it nearly has, and the T or the ellipse has few contact points that push it
straight: :func:`search_endgame_push` weighs finer targets (J = 48), the push turned by α_a from the
inward normal (within the friction cone, |α| < atan μ_c), short lengths and a closer walk
(:class:`EndgamePushSettings`; the lengths of one target and turn share one rollout, a slot from each length's
end to the next), and scores each by the stall watch's error (:func:`dexpush.control.policy.watch_progress`),
in the success test's terms:

    E(x) = max(e_p / u_p, e_θ / u_θ),   e_p = √d²(q_sb, q_g) with c = 0 (not along V),  e_θ = |θ − θ_g|

(u_p, u_θ: ``stall.progress_m``, ``stall.progress_deg``), chosen if E(x_end) is at least ``min_gain`` below
E(x) now. One push seldom ends the trial; the next stall searches again from where it ended
(docs/workspaces.md#the-endgame-push-2026-12-07).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from dexpush.common.checks import check_nonnegative, check_positive, check_whole
from dexpush.common.se2 import wrap_angle
from dexpush.control.proposals import inward_normal, pusher_in_body, walk_and_push, walk_curve
from dexpush.model.cgvmm import MU_C, Contour, contact_gap, integrate
from dexpush.problem.cost import goal_distance_sq, obstacle_cost
from dexpush.problem.scene import Scene
from dexpush.problem.weights import CostWeights

__all__ = ["EndgamePushSettings", "PushCandidates", "PushPlan", "PushPlanSettings", "endgame_candidates",
           "follow_push", "goal_errors", "idle_push", "progress_error", "push_candidates", "push_plan_init",
           "search_endgame_push", "search_push"]

#: the walk is done when the pusher is within this turn (rad) of its target ...
AT_TARGET_RAD = 0.05
#: ... and within this (m) of the walk's distance from the contour
AT_TARGET_M = 0.005
#: substeps of the model per push slot
PUSH_SUBSTEPS = 4


def _lengths(where: str, lengths: object) -> tuple[float, ...]:
    if not isinstance(lengths, tuple | list) or not lengths or not all(
            isinstance(v, int | float) and not isinstance(v, bool) and 0 < v < float("inf") for v in lengths):
        raise ValueError(f"{where} must be a non-empty list of positive lengths (m), got {lengths!r}")
    return tuple(float(v) for v in lengths)


@dataclass(frozen=True)
class EndgamePushSettings:
    """The push searched after a stall within ``endgame.distance_m`` of the goal (:func:`search_endgame_push`):
    finer targets, the push turned within the friction cone, short lengths and a closer walk, scored by the stall
    watch's error E; ``enabled`` False searches there as far from the goal."""

    enabled: bool = True
    targets: int = 48                  #: contact azimuths, evenly spaced round the object
    #: the push's turn α from the inward normal (rad), each within the friction cone atan μ_c (0.29 at μ_c = 0.3)
    angles_rad: tuple[float, ...] = (-0.2, 0.0, 0.2)
    lengths_m: tuple[float, ...] = (0.003, 0.006, 0.01, 0.015, 0.02, 0.03)   #: push lengths (m), after the clearance
    clearance_m: float = 0.006         #: the walk's distance from the inflated contour (m)
    #: E (in the stall watch's units: ``stall.progress_m``, ``stall.progress_deg``) must fall by this much
    min_gain: float = 0.5

    def __post_init__(self) -> None:
        if not isinstance(self.enabled, bool | np.bool_):
            raise ValueError(f"push_plan.endgame.enabled must be true or false, got {self.enabled!r}")
        check_whole("push_plan.endgame.targets", self.targets, 2)
        angles = self.angles_rad
        cone = float(np.arctan(MU_C))
        if not isinstance(angles, tuple | list) or not angles or not all(
                isinstance(v, int | float) and not isinstance(v, bool) and abs(v) < cone for v in angles):
            raise ValueError(f"push_plan.endgame.angles_rad must be a non-empty list of turns within the friction "
                             f"cone (|α| < atan μ_c = {cone:.3f} rad), got {angles!r}")
        object.__setattr__(self, "angles_rad", tuple(float(v) for v in angles))
        # ascending: the lengths share one rollout (:func:`endgame_candidates`)
        object.__setattr__(self, "lengths_m", tuple(sorted(_lengths("push_plan.endgame.lengths_m", self.lengths_m))))
        check_positive("push_plan.endgame.clearance_m", self.clearance_m, "m")
        check_nonnegative("push_plan.endgame.min_gain", self.min_gain)


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
    endgame: EndgamePushSettings = field(default_factory=EndgamePushSettings)   #: the search near the goal

    def __post_init__(self) -> None:
        if not isinstance(self.enabled, bool | np.bool_):
            raise ValueError(f"push_plan.enabled must be true or false, got {self.enabled!r}")
        for name, low in (("targets", 2), ("push_slots", 1)):
            check_whole(f"push_plan.{name}", getattr(self, name), low)
        object.__setattr__(self, "lengths_m", _lengths("push_plan.lengths_m", self.lengths_m))
        if not isinstance(self.endgame, EndgamePushSettings):
            raise ValueError(f"push_plan.endgame must be an EndgamePushSettings, got {self.endgame!r}")
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
    angle: jnp.ndarray       #: α, the push's turn from the target's inward normal (rad)
    clearance: jnp.ndarray   #: the walk's distance from the inflated contour (m)


def push_plan_init() -> PushPlan:
    """No plan."""
    f = jnp.float32(0.0)
    return PushPlan(jnp.bool_(False), jnp.bool_(False), f, jnp.float32(1.0), jnp.zeros(2, jnp.float32), f, f,
                    jnp.int32(0), f, f, f, f)


def goal_errors(x: tuple | jnp.ndarray, scene: Scene, guided: bool = True) -> tuple[jnp.ndarray, jnp.ndarray]:
    """(e_p, e_θ) for states ``x`` (leading axis 5): the position error round the obstacles
    (:func:`dexpush.problem.cost.goal_distance_sq` with c = 0, m; along the cost-to-go unless ``guided`` is False,
    whose length with heading layers counts the turn too) and the heading error (rad; 0 for a goal region without
    a heading). Pure and jit-able."""
    e_p = jnp.sqrt(goal_distance_sq(x, scene, 0.0, guided))
    return e_p, jnp.abs(wrap_angle(x[2] - scene.goal[2], jnp)) * scene.heading_weight


def progress_error(x: tuple | jnp.ndarray, scene: Scene, unit_m: float, unit_rad: float,
                   guided: bool = True) -> jnp.ndarray:
    """E = max(e_p / u_p, e_θ / u_θ) of the module docstring for states ``x`` (leading axis 5), with
    :func:`goal_errors`. Pure and jit-able."""
    e_p, e_th = goal_errors(x, scene, guided)
    return jnp.maximum(e_p / unit_m, e_th / unit_rad)


def _blocked(states: tuple, scene: Scene, weights: CostWeights, tolerance: float) -> jnp.ndarray:
    """Whether P(x) (eq. 9e) of states exceeds ``tolerance``·C_margin (a touch with the binary margin)."""
    limit = weights.C_pen * 0.5 if weights.C_margin is None else tolerance * weights.C_margin
    return obstacle_cost(states, scene, weights) > limit


def _distance(x: tuple | jnp.ndarray, scene: Scene, weights: CostWeights) -> jnp.ndarray:
    return jnp.sqrt(goal_distance_sq(x, scene, weights.c))


class PushCandidates(NamedTuple):
    """Every push a search weighs (J targets, 2 ways round, A turns, L lengths)."""

    targets: jnp.ndarray      #: (J,) contact azimuths φ_j in {B}
    turns: jnp.ndarray        #: (J, 2) the walk's signed turn (rad): the short way, the long way
    walk_open: jnp.ndarray    #: (J, 2) bool: the walk keeps out of the obstacles' margin
    walk_m: jnp.ndarray       #: (J, 2) the walk's length (m)
    angles: jnp.ndarray       #: (A,) the push's turn α from the inward normal (rad)
    travel_m: jnp.ndarray     #: (L,) each push's travel: the walk's clearance and the push length
    push_clear: jnp.ndarray   #: (J, A, L) bool: the push's rollout keeps out of the margin
    ends: jnp.ndarray         #: (J, A, L, 5) the state at each push's end
    end: jnp.ndarray          #: (J, A, L) the measure after the push: d (m, eq. 9b along V), or E near the goal
    now: jnp.ndarray          #: the measure now
    score: jnp.ndarray        #: (J, 2, A, L) the end's measure (and the far search's w_t · travel); inf where blocked


def _candidates(x: jnp.ndarray, contour: Contour, scene: Scene, weights: CostWeights, params: jnp.ndarray,
                mu: jnp.ndarray, targets: int, angles: tuple[float, ...], lengths: tuple[float, ...], clearance: float,
                slots: int | None, tolerance: float, speed: float) -> tuple[jnp.ndarray, ...]:
    """The walks and pushes of the module docstring from state ``x`` (5,), judged for the margin:
    (targets, turns, walk_open, walk_m, angles, travel, push_clear, ends) as in :class:`PushCandidates`. Each push
    is rolled out in ``slots`` slots of its own; with ``slots`` None the lengths (ascending) of one target and turn
    share one rollout, a slot from each length's end to the next, and a push is clear where every slot up to its
    length is."""
    dtype = jnp.float32
    J = targets
    xb, yb, c, s, bx, by = pusher_in_body(x, dtype)
    th = x[2]
    phi0 = jnp.arctan2(by, bx)
    phis = jnp.asarray(2 * np.pi * np.arange(J) / J - np.pi, dtype)                  # (J,)
    short = jnp.arctan2(jnp.sin(phis - phi0), jnp.cos(phis - phi0))
    long = short - 2 * jnp.pi * jnp.where(short >= 0, 1.0, -1.0)
    turns = jnp.concatenate([short, long])                                            # (2J,): short, then long
    walk, arc, inward = walk_curve(x, contour, jnp.concatenate([phis, phis]), turns, clearance)
    wx = xb + c * walk[..., 0] - s * walk[..., 1]                                     # (2J, M) in {W}
    wy = yb + s * walk[..., 0] + c * walk[..., 1]
    still = tuple(jnp.broadcast_to(v, wx.shape) for v in (xb, yb, th))
    walk_open = ~jnp.any(_blocked((*still, wx, wy), scene, weights, tolerance), axis=1)   # (2J,)
    # the pushes, one per target, turn and length, from the walk's end along the turned inward normal, fixed in {W}
    end = walk[:J, -1]                                                                # (J, 2) in {B}
    p0 = jnp.stack([xb + c * end[:, 0] - s * end[:, 1], yb + s * end[:, 0] + c * end[:, 1]], -1)
    alpha = jnp.asarray(angles, dtype)                                                # (A,)
    n_b = _turned(inward[:J, None, :], alpha[None, :])                                # (J, A, 2) in {B}
    n_w = jnp.stack([c * n_b[..., 0] - s * n_b[..., 1], s * n_b[..., 0] + c * n_b[..., 1]], -1)
    travel = clearance + jnp.asarray(lengths, dtype)                                  # (L,)
    x_obj = x[:3].astype(dtype)

    def rollout(p: jnp.ndarray, n: jnp.ndarray, dts: jnp.ndarray) -> jnp.ndarray:
        def one(xi: jnp.ndarray, dt: jnp.ndarray) -> tuple[jnp.ndarray, jnp.ndarray]:
            xn = integrate(contour, xi, speed * n, dt, params, mu, PUSH_SUBSTEPS)
            return xn, xn
        return jax.lax.scan(one, jnp.concatenate([x_obj, p]), dts)[1]                 # (slots, 5)

    def blocked(states: jnp.ndarray) -> jnp.ndarray:
        return _blocked(tuple(states[..., i] for i in range(5)), scene, weights, tolerance)

    if slots is None:       # one rollout per target and turn, its slots ending at the lengths
        dts = jnp.diff(travel, prepend=jnp.zeros(1, dtype)) / speed                   # (L,)
        ends = jax.vmap(jax.vmap(rollout, in_axes=(None, 0, None)), in_axes=(0, 0, None))(p0, n_w, dts)   # (J, A, L, 5)
        push_clear = jnp.cumsum(blocked(ends), axis=2) == 0                           # (J, A, L)
    else:
        per_length = jax.vmap(lambda p, n, t: rollout(p, n, jnp.full((slots,), t / (speed * slots), dtype)),
                              in_axes=(None, None, 0))
        states = jax.vmap(jax.vmap(per_length, in_axes=(None, 0, None)), in_axes=(0, 0, None))(p0, n_w, travel)
        push_clear = ~jnp.any(blocked(states), axis=-1)                               # (J, A, L)
        ends = states[..., -1, :]
    return (phis, turns.reshape(2, J).T, walk_open.reshape(2, J).T, arc[:, -1].reshape(2, J).T, alpha, travel,
            push_clear, ends)


def _turned(n: jnp.ndarray, alpha: jnp.ndarray) -> jnp.ndarray:
    """The vectors ``n`` (..., 2) turned by ``alpha`` (rad, counter-clockwise); exact for α = 0."""
    ca, sa = jnp.cos(alpha), jnp.sin(alpha)
    return jnp.stack([ca * n[..., 0] - sa * n[..., 1], sa * n[..., 0] + ca * n[..., 1]], -1)


def _judged(parts: tuple, end: jnp.ndarray, now: jnp.ndarray, travel_weight: float) -> PushCandidates:
    targets, turns, walk_open, walk_m, angles, travel, push_clear, ends = parts
    ok = walk_open[:, :, None, None] & push_clear[:, None, :, :]                      # (J, 2, A, L)
    score = end[:, None] + travel_weight * (walk_m[:, :, None, None] + travel[None, None, None, :])
    return PushCandidates(targets, turns, walk_open, walk_m, angles, travel, push_clear, ends, end, now,
                          jnp.where(ok, score, jnp.inf))


def push_candidates(x: jnp.ndarray, contour: Contour, scene: Scene, weights: CostWeights, params: jnp.ndarray,
                    mu: jnp.ndarray, settings: PushPlanSettings, speed: float) -> PushCandidates:
    """The walks and pushes of the module docstring from state ``x`` (5,), judged by d along V (one turn, α = 0).
    ``scene`` is the plan's (:func:`dexpush.problem.cost.plan_margin`). Pure and jit-able."""
    parts = _candidates(x, contour, scene, weights, params, mu, settings.targets, (0.0,), settings.lengths_m,
                        settings.clearance_m, settings.push_slots, settings.tolerance, speed)
    ends = parts[-1]
    end = _distance(tuple(ends[..., i] for i in range(5)), scene, weights)            # (J, 1, L)
    now = _distance(tuple(x[i] for i in range(5)), scene, weights)
    return _judged(parts, end, now, settings.travel_weight)


def endgame_candidates(x: jnp.ndarray, contour: Contour, scene: Scene, weights: CostWeights, params: jnp.ndarray,
                       mu: jnp.ndarray, settings: PushPlanSettings, speed: float,
                       units: tuple[float, float]) -> PushCandidates:
    """The endgame's walks and pushes (``settings.endgame``) from state ``x`` (5,), judged by E
    (:func:`progress_error` in ``units`` = (u_p m, u_θ rad)). Pure and jit-able."""
    eg = settings.endgame
    parts = _candidates(x, contour, scene, weights, params, mu, eg.targets, eg.angles_rad, eg.lengths_m,
                        eg.clearance_m, None, settings.tolerance, speed)
    ends = parts[-1]     # (near the goal e_p is the success test's: not along V, whose layers count the turn)
    end = progress_error(tuple(ends[..., i] for i in range(5)), scene, *units, guided=False)   # (J, A, L)
    now = progress_error(tuple(x[i] for i in range(5)), scene, *units, guided=False)
    return _judged(parts, end, now, 0.0)


def _chosen(k: PushCandidates, min_gain: float, scene: Scene, clearance: float,
            speed: float) -> tuple[jnp.ndarray, PushPlan]:
    """(found, plan): the lowest score of ``k``, if its end is ``min_gain`` below now."""
    A, L = k.angles.shape[0], k.travel_m.shape[0]
    flat = k.score.reshape(-1)
    best = jnp.argmin(flat)
    j, w, a, l_ = best // (2 * A * L), (best // (A * L)) % 2, (best // L) % A, best % L
    found = jnp.isfinite(flat[best]) & (k.end[j, a, l_] <= k.now - min_gain)
    way = jnp.sign(k.turns[j, w])
    way = jnp.where(way == 0, 1.0, way).astype(jnp.float32)
    duration = (k.walk_m[j, w] + k.travel_m[l_]) / speed
    f32 = jnp.float32
    plan = PushPlan(found, jnp.bool_(False), k.targets[j], way, jnp.zeros(2, f32), k.travel_m[l_],
                    (1.5 * duration + 1.0).astype(f32), jnp.int32(0),
                    jnp.asarray(scene.margin, f32), jnp.asarray(scene.pusher_margin, f32), k.angles[a],
                    jnp.asarray(clearance, f32))
    return found, plan


def search_push(x: jnp.ndarray, contour: Contour, scene: Scene, weights: CostWeights, params: jnp.ndarray,
                mu: jnp.ndarray, settings: PushPlanSettings, speed: float) -> tuple[jnp.ndarray, PushPlan]:
    """(found, plan) from state ``x`` (5,): the lowest score of :func:`push_candidates`, and whether its push
    brings the object ``settings.min_gain_m`` nearer the goal. Pure and jit-able."""
    k = push_candidates(x, contour, scene, weights, params, mu, settings, speed)
    return _chosen(k, settings.min_gain_m, scene, settings.clearance_m, speed)


def search_endgame_push(x: jnp.ndarray, contour: Contour, scene: Scene, weights: CostWeights, params: jnp.ndarray,
                        mu: jnp.ndarray, settings: PushPlanSettings, speed: float,
                        units: tuple[float, float]) -> tuple[jnp.ndarray, PushPlan]:
    """(found, plan) from state ``x`` (5,) near the goal: the lowest E of :func:`endgame_candidates`, and whether it
    is ``settings.endgame.min_gain`` below E now. Pure and jit-able."""
    k = endgame_candidates(x, contour, scene, weights, params, mu, settings, speed, units)
    return _chosen(k, settings.endgame.min_gain, scene, settings.endgame.clearance_m, speed)


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
    arrived = (jnp.abs(ahead) < AT_TARGET_RAD) & (contact_gap(contour, x) < plan.clearance + AT_TARGET_M)
    start_push = plan.active & ~plan.pushing & arrived
    n_b = _turned(inward_normal(contour, plan.target[None])[0], plan.angle)
    n_w = jnp.stack([c * n_b[0] - s * n_b[1], s * n_b[0] + c * n_b[1]])
    direction = jnp.where(start_push, n_w, plan.direction)
    pushing = plan.pushing | start_push
    walk_u = walk_and_push(x, contour, jnp.full((2,), period, dtype), plan.target[None],
                           (plan.way * ahead)[None], speed, plan.clearance, plan.left_m)[0, 0]
    u = jnp.where(pushing, speed * direction, walk_u)
    left = jnp.where(pushing, plan.left_m - speed * period, plan.left_m)
    x1 = integrate(contour, x.astype(dtype), u, jnp.asarray(period, dtype), params, mu, PUSH_SUBSTEPS)
    # against the margin the plan was chosen with, not the present state's (which follows the object in)
    held = replace(scene, margin=plan.margin.astype(scene.margin.dtype),
                   pusher_margin=plan.pusher_margin.astype(scene.pusher_margin.dtype))
    safe = ~_blocked(tuple(x1[i] for i in range(5)), held, weights, settings.tolerance)
    use = plan.active & safe & (plan.time_left > 0) & jnp.all(jnp.isfinite(u))
    active = use & (left > 0)
    new = plan._replace(active=active, pushing=pushing & active, direction=direction, left_m=left,
                        time_left=plan.time_left - period)
    return new, jnp.where(use, u, 0.0), use


def idle_push(plan: PushPlan, period: float) -> tuple[PushPlan, jnp.ndarray, jnp.ndarray]:
    """What :func:`follow_push` gives for an inactive ``plan`` (which is never pushing), without its model step: for
    a ``lax.cond`` that follows only while a plan is active. Pure and jit-able."""
    off = jnp.bool_(False)
    return (plan._replace(active=off, pushing=off, time_left=plan.time_left - jnp.float32(period)),
            jnp.zeros(2, jnp.float32), off)
