"""The state cost of the paper's MPPI (eq. 9) and the collision test of Task III.

    StateCost = φ(x_T) + Σ_t [ l(x_t) + P(x_t) ]                                  (9a)
    φ(x)  = q_f · d²(q_sb, q_g)                                                     (9b)
    l(x)  = q_r1 · d²(q_sb, q_g) + q_r2 · ReLU(‖p_sc − p_sb‖ − r_s)                (9c, 9d)
    P(x)  = C_pen if isCollision(x) else C_margin · Σ_i clip(1 − g_i / m, 0, 1)    (9e, graded margin)
    d²(q₁, q₂) = ‖Δp‖² + c · (1 − cos Δθ)        ("decoupled distance")

Obstacles are discs ``(c_x, c_y, radius)``. ``isCollision`` covers both the object's
footprint (not inflated) and the pusher disc (docs/conventions.md#controller): a touch costs
C_pen. The planner also keeps a margin m (``CostWeights.obstacle_margin_m``, default 1 cm)
for prediction error on a plant that is not the model: a state clear of the discs but
within m of disc i at the gap g_i costs C_margin · (1 − g_i/m) rather than C_pen, so that a
state already inside it (a noisy frame, a push that turned more than predicted) has a way
out that costs less than going on in (docs/controller.md#the-margin). The reported
collisions (and a failed Task III trial) use the discs as given.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import jax
import jax.numpy as jnp
import numpy as np

from dexpush.common import fastmath
from dexpush.common.checks import check_nonnegative, check_positive
from dexpush.model.cgvmm import State, components
from dexpush.model.shape import Shape

__all__ = ["CostWeights", "Scene", "clearance", "clearance_jit", "collides",
           "collides_jit", "decoupled_distance_sq", "detour_length_sq",
           "goal_distance_sq", "obstacle_cost", "plan_margin", "running_cost", "terminal_cost"]


@dataclass(frozen=True)
class CostWeights:
    """Gains and constants of eq. (9), defaults from the paper's Table II."""

    q_f: float = 5000.0   #: terminal gain
    q_r1: float = 100.0   #: running gain on the decoupled distance
    q_r2: float = 1e4     #: gain of the pusher-proximity ReLU
    c: float = 0.1        #: heading weight in the decoupled distance (m²)
    r_s: float = 0.2      #: pusher may roam this far (m) from the object's reference for free
    C_pen: float = 1e13   #: collision penalty
    #: raise r_s to R_max + r_s_clearance (m) for objects whose inflated contour reaches
    #: beyond r_s − r_s_clearance; None keeps r_s as given. See :meth:`Scene.make`.
    r_s_clearance: float | None = 0.05
    #: the planner keeps object and pusher this far (m) from obstacles: the collision test of the
    #: cost (9e) uses discs grown by it, so a prediction error of up to this much at the obstacle does
    #: not become a touch. A trial still fails only on a real touch (radius as given).
    obstacle_margin_m: float = 0.01
    #: measure the goal distance of d² round the obstacles (:func:`detour_length_sq`) instead of
    #: straight through them (default); False is the paper's eq. (9) as written.
    #: See docs/controller.md#going-round-obstacles-detour.
    detour: bool = True
    #: inside the margin, clear of the disc, a state costs C_margin per obstacle times its depth into the
    #: margin as a fraction of it (:func:`obstacle_cost`); None charges C_pen there, as the discs grown by
    #: the margin in (9e) would (the planner until 2026-12-01). See docs/controller.md#the-margin.
    C_margin: float | None = 1e9

    def __post_init__(self) -> None:
        for name in ("q_f", "q_r1", "q_r2", "c"):
            check_nonnegative(name, getattr(self, name))
        if self.C_margin is not None:
            check_positive("C_margin", self.C_margin, "or None")
            if self.C_margin * 100 > self.C_pen:
                raise ValueError(f"C_margin must be far below C_pen (a touch must cost more than 25 slots inside "
                                 f"the margin): got C_margin={self.C_margin:g}, C_pen={self.C_pen:g}")
        for name in ("r_s", "C_pen"):
            check_positive(name, getattr(self, name))
        check_nonnegative("obstacle_margin_m", self.obstacle_margin_m, "m")
        if self.r_s_clearance is not None:
            check_nonnegative("r_s_clearance", self.r_s_clearance, "m, or None")


@dataclass(frozen=True)
class Scene:
    """What the cost needs to know about the world: goal, obstacles and the object's footprint.

    Built with :meth:`make`; the arrays are jnp so that a Scene can be passed into jit.
    """

    goal: jnp.ndarray            #: (3,) goal pose [x, y, θ]
    obstacles: jnp.ndarray       #: (M, 3) discs [c_x, c_y, radius]; M may be 0
    edge_a: jnp.ndarray          #: (E, 2) footprint edge starts in {B}
    edge_b: jnp.ndarray          #: (E, 2) footprint edge ends in {B}
    r_s: jnp.ndarray             #: the effective free-roaming radius of the pusher (m)
    pusher_radius: float
    #: (M,) radius ρ_m (m) of the disc around obstacle m that the goal distance detours round
    #: (:func:`detour_length_sq`); empty without ``CostWeights.detour``
    detour_radius: jnp.ndarray = None  # type: ignore[assignment]
    #: the margin (m) this plan keeps from the obstacles: ``CostWeights.obstacle_margin_m``, or less
    #: where the object or the pusher is already nearer (:func:`plan_margin`)
    margin: jnp.ndarray = None  # type: ignore[assignment]

    @staticmethod
    def make(shape: Shape, goal: object, obstacles: object = (), weights: CostWeights | None = None) -> Scene:
        """The cost's view of a task.

        The effective r_s is max(r_s, R_max + r_s_clearance), R_max the largest radius of
        the inflated contour. Table II's r_s = 0.2 m suits the paper's objects, but the
        standard T reaches 0.187 m from its reference: with r_s = 0.2 the ReLU term (9d)
        charges q_r2 = 1e4 per metre and step for walking around the stem, which traps
        the pusher on one side of it. Measured (docs/controller.md): the three tee
        episodes of seeds 0–4 that failed with 0.2 all succeed with 0.237.
        """
        w = weights or CostWeights()
        g = np.asarray(goal, dtype=np.float64)
        if g.shape != (3,) or not np.all(np.isfinite(g)):
            raise ValueError(f"goal must be a finite pose (x, y, θ), got {goal!r}")
        obs = obstacle_array(obstacles)
        a, b = shape.edges
        r_s = w.r_s if w.r_s_clearance is None else max(w.r_s, shape.bounding_radius + w.r_s_clearance)
        rho = np.zeros(0)
        if w.detour and len(obs):
            # no orientation of the footprint reaches an obstacle while the reference stays this far
            # from it; capped at the goal's distance, so that the goal itself is never inside a detour disc
            reach = float(np.max(np.hypot(a[:, 0], a[:, 1])))
            rho = np.minimum(obs[:, 2] + w.obstacle_margin_m + reach, np.hypot(*(g[None, :2] - obs[:, :2]).T))
        return Scene(jnp.asarray(g), jnp.asarray(obs), jnp.asarray(a), jnp.asarray(b), jnp.asarray(r_s),
                     shape.pusher_radius, jnp.asarray(rho), jnp.asarray(w.obstacle_margin_m))


jax.tree_util.register_dataclass(
    Scene, data_fields=["goal", "obstacles", "edge_a", "edge_b", "r_s", "detour_radius", "margin"],
    meta_fields=["pusher_radius"])


def obstacle_array(obstacles: object) -> np.ndarray:
    """Disc obstacles as a float64 (M, 3) array [c_x, c_y, radius]; one disc may be given as (3,).
    Anything else (e.g. (x, y) pairs) is refused with a ``ValueError``."""
    try:
        obs = np.asarray(obstacles, dtype=np.float64) if len(obstacles) else np.zeros((0, 3))
    except (TypeError, ValueError) as exc:
        raise ValueError(f"obstacles must be discs (c_x, c_y, radius), got {obstacles!r}") from exc
    obs = obs[None] if obs.shape == (3,) else obs
    if obs.ndim != 2 or obs.shape[1] != 3:
        raise ValueError(f"obstacles must be discs (c_x, c_y, radius): an (M, 3) array, got shape {obs.shape}")
    if not np.all(np.isfinite(obs)) or np.any(obs[:, 2] <= 0):
        raise ValueError(f"obstacles must be finite discs (c_x, c_y, radius > 0), got {obstacles!r}")
    return obs


def _distance_sq(x: jnp.ndarray, y: jnp.ndarray, th: jnp.ndarray, goal: jnp.ndarray, c: float) -> jnp.ndarray:
    dx, dy = x - goal[0], y - goal[1]
    return dx * dx + dy * dy + c * (1.0 - fastmath.cos(th - goal[2]))


def decoupled_distance_sq(q: jnp.ndarray, goal: jnp.ndarray, c: float) -> jnp.ndarray:
    """d² = ‖Δp‖² + c·(1 − cos Δθ) for poses q (..., 3) against a goal (3,)."""
    return _distance_sq(q[..., 0], q[..., 1], q[..., 2], goal, c)


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


def _obstacle_distances(x: State, scene: Scene):
    """Per obstacle m, squared distances without square roots: (m, r_m, d²_m from the disc centre to
    the footprint's edges, whether the centre lies inside the footprint, d²_m from the centre to the
    pusher's centre). The footprint part is exact for a disc that crosses the outline; a disc wholly
    inside the footprint is caught by a crossing-number test of its centre, written without
    divisions (valid for the union shapes because their pieces only touch or overlap inside)."""
    xb, yb, th, xc, yc = components(x)
    s, c = fastmath.sincos(th)
    a, b = scene.edge_a, scene.edge_b
    # obstacles and edges are few and static: unrolled, so XLA fuses it all (no reductions)
    for m in range(scene.obstacles.shape[0]):
        ox, oy, r = scene.obstacles[m, 0], scene.obstacles[m, 1], scene.obstacles[m, 2]
        dx, dy = ox - xb, oy - yb
        px, py = c * dx + s * dy, -s * dx + c * dy                   # centre in {B}
        d2 = jnp.full(jnp.shape(xb), jnp.inf, dtype=px.dtype)
        inside = jnp.zeros(jnp.shape(xb), dtype=bool)
        for e in range(a.shape[0]):
            ax, ay, ex, ey = a[e, 0], a[e, 1], b[e, 0] - a[e, 0], b[e, 1] - a[e, 1]
            apx, apy = px - ax, py - ay
            t = jnp.clip((apx * ex + apy * ey) / (ex * ex + ey * ey), 0.0, 1.0)
            qx, qy = apx - t * ex, apy - t * ey
            d2 = jnp.minimum(d2, qx * qx + qy * qy)
            crosses = (ay > py) != (ay + ey > py)
            left = (apx * ey - apy * ex) * jnp.sign(ey) < 0           # x < x_intersection, no division
            inside = inside ^ (crosses & left)
        pdx, pdy = xc - ox, yc - oy
        yield m, r, d2, inside, pdx * pdx + pdy * pdy


def collides(x: State, scene: Scene, margin: float = 0.0) -> jnp.ndarray:
    """isCollision (9e): object footprint or pusher disc overlaps an obstacle disc grown by
    ``margin`` (m); (...,) bool.

    It runs in every rollout step, so it avoids square roots and reductions (measured at
    K = 1024: Task III iterations went from 15–24 ms with a vectorised (K, M, E) version to
    the same time as the obstacle-free Task I).
    """
    hit = jnp.zeros(jnp.shape(components(x)[0]), dtype=bool)
    for _, r, d2, inside, pd2 in _obstacle_distances(x, scene):
        hit = hit | _overlaps(r + margin, d2, inside, pd2, scene.pusher_radius)
    return hit


def _overlaps(r: jnp.ndarray, d2: jnp.ndarray, inside: jnp.ndarray, pd2: jnp.ndarray,
              pusher_radius: float) -> jnp.ndarray:
    """Whether a disc of radius r overlaps the footprint or the pusher, from :func:`_obstacle_distances`."""
    return (d2 < r * r) | inside | (pd2 < (r + pusher_radius) ** 2)


def clearance(x: State, scene: Scene) -> jnp.ndarray:
    """The smallest gap (m) between any obstacle disc and the object's footprint or the pusher's disc;
    (...,). Zero or less is a touch (a disc wholly inside the footprint counts as −radius); +inf
    without obstacles."""
    gap = jnp.full(jnp.shape(components(x)[0]), jnp.inf, dtype=jnp.result_type(components(x)[0], jnp.float32))
    for _, r, d2, inside, pd2 in _obstacle_distances(x, scene):
        body = jnp.where(inside, -r, jnp.sqrt(d2) - r)
        gap = jnp.minimum(gap, jnp.minimum(body, jnp.sqrt(pd2) - r - scene.pusher_radius))
    return gap


#: :func:`collides` compiled once, for checking logged trajectories on the host (the batched
#: simulator's chunks, the records of finished trials)
collides_jit = jax.jit(collides)
#: :func:`clearance` compiled once, for the trial records
clearance_jit = jax.jit(clearance)


def goal_distance_sq(x: State, scene: Scene, c: float) -> jnp.ndarray:
    """d²(q_sb, q_g) of eq. (9b–9c) for states x: the decoupled distance, whose position part is
    ℓ² (:func:`detour_length_sq`) when the scene has detour discs."""
    xb, yb, th, *_ = components(x)
    return _goal_distance_sq(xb, yb, th, scene, c)


def _goal_distance_sq(xb: jnp.ndarray, yb: jnp.ndarray, th: jnp.ndarray, scene: Scene, c: float) -> jnp.ndarray:
    if scene.detour_radius is None or scene.detour_radius.shape[0] == 0:
        return _distance_sq(xb, yb, th, scene.goal, c)
    return detour_length_sq(xb, yb, scene) + c * (1.0 - fastmath.cos(th - scene.goal[2]))


#: the least margin (m) a plan keeps (:func:`plan_margin`): below it the depth fraction is too steep
MIN_PLAN_MARGIN_M = 1e-4


def plan_margin(x: State, scene: Scene, w: CostWeights, extra: jnp.ndarray | float = 0.0) -> Scene:
    """The scene for a plan that starts from state x: its margin is ``obstacle_margin_m`` + ``extra``
    (m; the controller's allowance for the error of a state predicted from a late frame), or the
    state's own clearance where that is less (at least :data:`MIN_PLAN_MARGIN_M`), so that a plan
    from inside the margin is charged only for coming nearer than it already is. Unchanged without
    ``C_margin`` (the binary margin of before 2026-12-01) or without obstacles."""
    if w.C_margin is None or w.obstacle_margin_m <= 0 or scene.obstacles.shape[0] == 0:
        return scene
    m = jnp.clip(clearance(x, scene), MIN_PLAN_MARGIN_M, w.obstacle_margin_m + extra)
    return dataclasses.replace(scene, margin=m.astype(scene.obstacles.dtype))


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
    disc if need be (docs/controller.md#the-margin).
    """
    xb = components(x)[0]
    touch = jnp.zeros(jnp.shape(xb), dtype=bool)
    depth = jnp.zeros(jnp.shape(xb), dtype=jnp.result_type(xb, jnp.float32))
    rp = scene.pusher_radius
    graded = w.C_margin is not None and w.obstacle_margin_m > 0
    for _, r, d2, inside, pd2 in _obstacle_distances(x, scene):
        touch = touch | _overlaps(r if graded else r + w.obstacle_margin_m, d2, inside, pd2, rp)
        if graded:
            gap = jnp.minimum(jnp.sqrt(d2) - r, jnp.sqrt(pd2) - r - rp)
            depth = depth + jnp.clip(1.0 - gap / scene.margin, 0.0, 1.0)
    cost = jnp.where(touch, w.C_pen, 0.0)
    return cost + w.C_margin * depth if graded else cost


def running_cost(x: State, scene: Scene, w: CostWeights) -> jnp.ndarray:
    """l(x) + P(x) of eq. (9c–9e) (P: :func:`obstacle_cost`) for states x ((..., 5) array or 5-tuple)."""
    xb, yb, th, xc, yc = components(x)
    d2 = _goal_distance_sq(xb, yb, th, scene, w.c)
    gap = jnp.sqrt((xc - xb) ** 2 + (yc - yb) ** 2)
    cost = w.q_r1 * d2 + w.q_r2 * jnp.maximum(gap - scene.r_s, 0.0)
    if scene.obstacles.shape[0] == 0:
        return cost
    return cost + obstacle_cost(x, scene, w)


def terminal_cost(x: State, scene: Scene, w: CostWeights) -> jnp.ndarray:
    """φ(x_T) of eq. (9b)."""
    xb, yb, th, *_ = components(x)
    return w.q_f * _goal_distance_sq(xb, yb, th, scene, w.c)
