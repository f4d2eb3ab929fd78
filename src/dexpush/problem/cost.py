"""The state cost of the paper's MPPI, eq. (9).

    StateCost = φ(x_T) + Σ_t [ l(x_t) + P(x_t) ]                                  (9a)
    φ(x)  = q_f · d²(q_sb, q_g)                                                     (9b)
    l(x)  = q_r1 · d²(q_sb, q_g) + q_r2 · ReLU(‖p_sc − p_sb‖ − r_s)                (9c, 9d)
    P(x)  = C_pen if isCollision(x) else C_margin · Σ_i clip(1 − g_i / m, 0, 1)    (9e, graded margin)
    d²(q₁, q₂) = ‖Δp‖² + c · (1 − cos Δθ)        ("decoupled distance")

``isCollision`` is :func:`dexpush.problem.obstacles.collides`: a touch costs C_pen. The planner
also keeps a margin m (``CostWeights.obstacle_margin_m``, default 1 cm) for prediction error on
a plant that is not the model: a state clear of the discs but within m of disc i at the gap g_i
costs C_margin · (1 − g_i/m) rather than C_pen, so that a state already inside it (a noisy
frame, a push that turned more than predicted) has a way out that costs less than going on in
(docs/controller.md#the-margin).
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp

from dexpush.common import fastmath
from dexpush.model.cgvmm import State, components
from dexpush.problem.goal_region import region_distance_sq
from dexpush.problem.guidance import GRID_STRETCH
from dexpush.problem.obstacles import (
    clearance,
    nearest_obstacle_distances,
    overlaps,
    pusher_bound_clearance,
    pusher_bound_gaps,
    region_gaps,
)
from dexpush.problem.scene import Scene
from dexpush.problem.weights import CostWeights

__all__ = ["MIN_PLAN_MARGIN_M", "REGION_COST_CORNERS",
           "detour_length_sq", "goal_distance_sq", "guided_length_sq", "obstacle_cost",
           "plan_margin", "running_cost", "terminal_cost"]


def _distance_sq(x: jnp.ndarray, y: jnp.ndarray, th: jnp.ndarray, goal: jnp.ndarray, c: float) -> jnp.ndarray:
    dx, dy = x - goal[0], y - goal[1]
    return dx * dx + dy * dy + c * (1.0 - fastmath.cos(th - goal[2]))




def detour_length_sq(x: jnp.ndarray, y: jnp.ndarray, scene: Scene) -> jnp.ndarray:
    """ℓ², the squared length of the shortest path from the reference (x, y) to the goal that
    goes round every detour disc (centre o_m, radius ρ_m = ``scene.detour_radius``); ‖Δp‖²
    where no disc is in the way.

    For one disc, with a = p − o, b = g − o, tangent lengths t_a = √(|a|² − ρ²),
    t_b = √(|b|² − ρ²), tangent angles α = atan2(t_a, ρ), β = atan2(t_b, ρ) and
    γ = ∠(a, b) ∈ [0, π]:

        ℓ = |p − g|                          if γ ≤ α + β   (the segment misses the disc)
        ℓ = t_a + t_b + ρ·(γ − α − β)        otherwise      (tangent, arc, tangent)

    A reference inside a disc is first moved radially onto its rim, which adds ρ − |a|.
    ℓ is continuous in p, and a path that follows it never brings the footprint within
    ``CostWeights.obstacle_margin_m`` of the obstacle (ρ_m ≥ r_m + margin + the footprint's
    reach), so it has no minimum but the goal where d² through the obstacle has one
    behind it. With several discs, ℓ is the largest of the one-disc lengths (exact when
    one disc is in the way).
    """
    gx, gy = scene.goal[0], scene.goal[1]
    dx, dy = x - gx, y - gy
    best = dx * dx + dy * dy
    for m in range(scene.detour_radius.shape[0]):
        ox, oy, rho = scene.obstacles[m, 0], scene.obstacles[m, 1], scene.detour_radius[m]
        ax, ay, bx, by = x - ox, y - oy, gx - ox, gy - oy
        ra2 = ax * ax + ay * ay
        ra = jnp.sqrt(jnp.maximum(ra2, 1e-12))
        out = jnp.maximum(ra, rho)                                  # on or outside the rim
        px, py = ox + ax * (out / ra), oy + ay * (out / ra)         # p moved onto the rim if inside
        t_a = jnp.sqrt(jnp.maximum(out * out - rho * rho, 0.0))
        t_b = jnp.sqrt(jnp.maximum(bx * bx + by * by - rho * rho, 0.0))
        gamma = jnp.abs(fastmath.atan2(ax * by - ay * bx, ax * bx + ay * by))
        wrap = gamma - fastmath.atan2(t_a, rho) - fastmath.atan2(t_b, rho)
        ex, ey = px - gx, py - gy
        straight = ex * ex + ey * ey
        around = t_a + t_b + rho * jnp.maximum(wrap, 0.0)
        inside = out - ra
        ell = jnp.where(wrap > 0, around, jnp.sqrt(straight)) + inside
        best = jnp.maximum(best, ell * ell)
    return best



def guided_length_sq(x: jnp.ndarray, y: jnp.ndarray, th: jnp.ndarray, scene: Scene) -> jnp.ndarray:
    """ℓ², ℓ = max(‖p − g‖, (V(p, θ) − h)/(1 + κ)): the goal distance along the cost-to-go V of
    :mod:`dexpush.problem.guidance` (``scene.guide``; h its grid spacing, κ = ``GRID_STRETCH``), which
    is the straight-line distance wherever the straight way is free (in the goal's heading, where V counts
    the turn to it) and the way round otherwise.

    V is bilinear between the grid's nodes, linear between its heading layers θ_k = 2πk/K where it has
    K > 1 (with one it holds for every heading), and, beyond the grid, V at its nearest edge point (there
    the straight distance, which grows, takes over). Four gathers per state and layer read: the same work
    for any number of obstacles.
    """
    v = scene.guide
    n_k, n_x, n_y = v.shape
    h = scene.guide_cell
    u = jnp.clip((x - scene.guide_lo[0]) / h, 0.0, n_x - 1.0)
    w = jnp.clip((y - scene.guide_lo[1]) / h, 0.0, n_y - 1.0)
    i = jnp.minimum(jnp.floor(u), n_x - 2.0)
    j = jnp.minimum(jnp.floor(w), n_y - 2.0)
    fu, fw = u - i, w - j
    flat = v.reshape(-1)

    def layer(k: jnp.ndarray | int) -> jnp.ndarray:
        at = k * (n_x * n_y) + i.astype(jnp.int32) * n_y + j.astype(jnp.int32)
        return ((1 - fu) * ((1 - fw) * flat[at] + fw * flat[at + 1])
                + fu * ((1 - fw) * flat[at + n_y] + fw * flat[at + n_y + 1]))

    if n_k == 1:
        val = layer(0)
    else:
        t = jnp.mod(th * (n_k / (2 * jnp.pi)), float(n_k))
        k0 = jnp.minimum(jnp.floor(t), n_k - 1.0)
        ft = t - k0
        k0 = k0.astype(jnp.int32)
        val = (1 - ft) * layer(k0) + ft * layer((k0 + 1) % n_k)
    dx, dy = x - scene.goal[0], y - scene.goal[1]
    ell = jnp.maximum((val - h) / (1.0 + GRID_STRETCH), 0.0)
    return jnp.maximum(dx * dx + dy * dy, ell * ell)


def goal_distance_sq(x: State, scene: Scene, c: float, guided: bool = True) -> jnp.ndarray:
    """d²(q_sb, q_g) of eq. (9b–9c) for states x: the decoupled distance, whose position part is
    ℓ² along the cost-to-go (:func:`guided_length_sq`) when the scene has one (with one layer, the larger of
    it and the detour where the scene also has discs and the object has no bounds of its own), round the detour
    discs (:func:`detour_length_sq`) when it has those alone, and straight otherwise. For a goal region
    (:mod:`dexpush.problem.goal_region`) the position part is the squared distance to its aimed part
    (:func:`dexpush.problem.goal_region.region_distance_sq`), and the heading part counts only where the region
    has a heading. ``guided`` False leaves the cost-to-go out (round the detour discs, or straight)."""
    xb, yb, th, *_ = components(x)
    return _goal_distance_sq(xb, yb, th, scene, c, guided)


def _goal_distance_sq(xb: jnp.ndarray, yb: jnp.ndarray, th: jnp.ndarray, scene: Scene, c: float,
                      guided: bool = True) -> jnp.ndarray:
    if scene.has_region:
        # the footprint's own corners, every k-th of a long outline (at most REGION_COST_CORNERS): their support
        # is never more than the footprint's, so the aim is kept (the ellipse's inscribed 32-gon: within 0.5 mm)
        corners = scene.region_corners[::-(-scene.region_corners.shape[0] // REGION_COST_CORNERS)]
        length_sq = region_distance_sq(xb, yb, th, scene.reach, scene.keep, scene.keep_point, corners, jnp)
        return length_sq + scene.heading_weight * c * (1.0 - fastmath.cos(th - scene.goal[2]))
    has_detour = scene.detour_radius is not None and scene.detour_radius.shape[0] > 0
    if guided and scene.guide is not None and scene.guide.shape[0] > 0:
        length_sq = guided_length_sq(xb, yb, th, scene)
        # with one layer V lets the footprint turn to fit anywhere: round discs the detour keeps the object a
        # footprint's reach away, so that it passes in the heading it is pushed in; not where the object has
        # bounds of its own (a robot's reach), which the detour's circles ignore; a V with heading layers knows
        # the heading (docs/workspaces.md#discs-keep-their-detour-2026-12-04)
        if has_detour and scene.guide.shape[0] == 1 and (scene.object_bounds is None
                                                          or scene.object_bounds.shape[0] == 0):
            length_sq = jnp.maximum(length_sq, detour_length_sq(xb, yb, scene))
    elif has_detour:
        length_sq = detour_length_sq(xb, yb, scene)
    else:
        return _distance_sq(xb, yb, th, scene.goal, c)
    return length_sq + c * (1.0 - fastmath.cos(th - scene.goal[2]))


#: the most footprint corners a goal region's cost reads (:func:`goal_distance_sq`)
REGION_COST_CORNERS = 32

#: the least margin (m) a plan keeps (:func:`plan_margin`): below it the depth fraction is too steep
MIN_PLAN_MARGIN_M = 1e-4


def plan_margin(x: State, scene: Scene, w: CostWeights, extra: jnp.ndarray | float = 0.0) -> Scene:
    """The scene for a plan that starts from state x: its margin is ``obstacle_margin_m`` + ``extra``
    (m; the controller's allowance for the error of a state predicted from a late frame), or the
    state's own clearance where that is less (at least :data:`MIN_PLAN_MARGIN_M`), so that a plan
    from inside the margin is charged only for coming nearer than it already is; likewise the pusher's
    margin from bounds of its own, ``pusher_bound_margin_m`` (no allowance: the pusher goes where it is
    commanded). Unchanged without ``C_margin`` (the binary margin) or without obstacles."""
    if w.C_margin is None or w.obstacle_margin_m <= 0 or not scene.has_obstacles:
        return scene
    m = jnp.clip(clearance(x, scene, pusher_bounds=False), MIN_PLAN_MARGIN_M, w.obstacle_margin_m + extra)
    m_p = jnp.clip(pusher_bound_clearance(x, scene), MIN_PLAN_MARGIN_M, w.pusher_bound_margin_m)
    return dataclasses.replace(scene, margin=m.astype(scene.margin.dtype),
                               pusher_margin=m_p.astype(scene.pusher_margin.dtype))


def obstacle_cost(x: State, scene: Scene, w: CostWeights) -> jnp.ndarray:
    """P(x) of eq. (9e) with the planner's margin m (``scene.margin``), for states x (...,).

    A touch (object footprint or pusher disc overlapping a disc as given) costs C_pen. A state
    clear of every disc but within m of disc i, at the gap g_i (the nearer of footprint and pusher,
    :func:`clearance`), costs C_margin · Σ_i (m − g_i)/m: as stiff a barrier as C_pen against
    planning into the margin (C_margin = 1e9 ≫ any goal cost), but graded, and a touch never pays
    (C_pen = 1e13 is more than 25 slots at full depth). A plan from a state already inside the
    margin gets m = that state's clearance (:func:`plan_margin`): it may go along the obstacle, or
    away, but not nearer. With ``C_margin`` None every state within ``obstacle_margin_m`` costs
    C_pen, the collision test of (9e) on discs grown by it: from inside the margin every sample
    then cost C_pen per slot until out, and the planner took the quickest way out, through the
    disc if need be (docs/controller.md#the-margin). The pusher's gaps to bounds of its own
    (:func:`dexpush.problem.obstacles.pusher_bound_gaps`: a robot's reach) are charged in the same way
    against its own margin, ``scene.pusher_margin`` (docs/robot.md#the-pushers-margin-at-the-reach).
    """
    xb = components(x)[0]
    touch = jnp.zeros(jnp.shape(xb), dtype=bool)
    depth = jnp.zeros(jnp.shape(xb), dtype=jnp.result_type(xb, jnp.float32))
    rp = scene.pusher_radius
    graded = w.C_margin is not None and w.obstacle_margin_m > 0

    def discs(touch: jnp.ndarray, depth: jnp.ndarray) -> tuple[jnp.ndarray, jnp.ndarray]:
        for r, d2, inside, pd2 in nearest_obstacle_distances(x, scene):
            touch = touch | overlaps(r if graded else r + w.obstacle_margin_m, d2, inside, pd2, rp)
            if graded:
                gap = jnp.minimum(jnp.sqrt(d2) - r, jnp.sqrt(pd2) - r - rp)
                depth = depth + jnp.clip(1.0 - gap / scene.margin, 0.0, 1.0)
        return touch, depth

    if scene.obstacles.shape[0] and scene.polygons.shape[0]:
        # the discs' terms in a computation of their own (a cond whose two branches are the same): fused
        # into one loop with the polygons' gaps, three or more discs made the whole ten times slower than
        # its parts (benchmarks/obstacle_cost_parts.py; docs/performance.md). The predicate is the goal's,
        # which a batch of controllers shares (the margin is per state): a batched one makes it a select
        touch, depth = jax.lax.cond(jnp.isfinite(scene.goal[0]), discs, discs, touch, depth)
    else:
        touch, depth = discs(touch, depth)
    for body, pusher in region_gaps(x, scene):       # polygons and the workspace: separating-axis gaps
        gap = jnp.minimum(body, pusher)
        touch = touch | (gap < (0.0 if graded else w.obstacle_margin_m))
        if graded:
            depth = depth + jnp.clip(1.0 - gap / scene.margin, 0.0, 1.0)
    for gap in pusher_bound_gaps(x, scene):          # the pusher's own bounds (a robot's reach): its own margin
        touch = touch | (gap < (0.0 if graded else w.pusher_bound_margin_m))
        if graded:
            depth = depth + jnp.clip(1.0 - gap / scene.pusher_margin, 0.0, 1.0)
    cost = jnp.where(touch, w.C_pen, 0.0)
    return cost + w.C_margin * depth if graded else cost


def running_cost(x: State, scene: Scene, w: CostWeights, other: State | None = None) -> jnp.ndarray:
    """l(x) + P(x) of eq. (9c–9e) (P: :func:`obstacle_cost`) for states x ((..., 5) array or 5-tuple). Its goal
    distance is the straight one, or the detour round discs; along the cost-to-go too with
    ``w.guidance_running``. With ``other`` (the same samples' states under a second model), P is the larger of
    P(x) and P(other)."""
    xb, yb, th, xc, yc = components(x)
    d2 = _goal_distance_sq(xb, yb, th, scene, w.c, guided=w.guidance_running)
    gap = jnp.sqrt((xc - xb) ** 2 + (yc - yb) ** 2)
    cost = w.q_r1 * d2 + w.q_r2 * jnp.maximum(gap - scene.r_s, 0.0)
    if not scene.has_obstacles:
        return cost
    if other is None:
        return cost + obstacle_cost(x, scene, w)
    return cost + jnp.maximum(obstacle_cost(x, scene, w), obstacle_cost(other, scene, w))


def terminal_cost(x: State, scene: Scene, w: CostWeights) -> jnp.ndarray:
    """φ(x_T) of eq. (9b)."""
    xb, yb, th, *_ = components(x)
    return w.q_f * _goal_distance_sq(xb, yb, th, scene, w.c)
