"""Where the object and the pusher are against the obstacles and the workspace boundary: the
collision test of eq. (9e) (:func:`collides`) and the gap to the nearest obstacle (:func:`clearance`).

Obstacles are discs ``(c_x, c_y, radius)`` and convex polygons (boxes, walls; :mod:`dexpush.problem.regions`);
the workspace is a convex polygon that footprint and pusher must stay inside. A touch is the
object's footprint (not inflated) or the pusher disc overlapping an obstacle, or either leaving
the workspace (docs/conventions.md#controller); the planner's cost keeps a margin beyond it
(:mod:`dexpush.problem.cost`), the judge of a trial uses the obstacles as given.

Gaps to discs are exact. Gaps to polygons are separating-axis gaps: for two convex polygons A and B,

    gap(A, B) = max over the edge normals n of A and of B of [min_{a∈A} n·a − max_{b∈B} n·b]

which is negative exactly when they overlap (then −gap is the penetration depth), and otherwise the
distance where the nearest features are a corner and an edge, and less than it where they are two
corners: never more than the true gap. The footprint's gap is the least over its convex pieces; the
pusher's is the same with a point, less its radius. A workspace gap is exact: the least of
o − n·v over its half-planes and the footprint's corners v.
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp

from dexpush.common import fastmath
from dexpush.model.cgvmm import State, components
from dexpush.problem.regions import UNROLL_CORNERS, footprint_reach
from dexpush.problem.scene import Scene

#: the cost measures the footprint exactly against this many discs nearest each state, and by a lower
#: bound against any more (:func:`nearest_obstacle_distances`)
EXACT_NEAREST_DISCS = 3

__all__ = ["EXACT_NEAREST_DISCS", "UNROLL_CORNERS", "bound_gaps", "clearance", "clearance_jit", "collides",
           "collides_jit", "nearest_obstacle_distances", "obstacle_distances", "overlaps",
           "polygon_gaps", "pusher_bound_clearance", "pusher_bound_gaps", "region_gaps"]


def obstacle_distances(x: State, scene: Scene):
    """Per obstacle m, squared distances without square roots: (m, r_m, d²_m from the disc centre to
    the footprint's edges, whether the centre lies inside the footprint, d²_m from the centre to the
    pusher's centre). The footprint part is exact for a disc that crosses the outline; a disc wholly
    inside the footprint is caught by a crossing-number test of its centre, written without
    divisions (valid for the union shapes because their pieces only touch or overlap inside)."""
    xb, yb, th, xc, yc = components(x)
    s, c = fastmath.sincos(th)
    a, b = scene.edge_a, scene.edge_b
    # obstacles and edges are few and static: unrolled, so XLA fuses it all (no reductions); long
    # outlines (the judge's ellipse) are reduced as arrays, which compile in seconds rather than minutes
    for m in range(scene.obstacles.shape[0]):
        ox, oy, r = scene.obstacles[m, 0], scene.obstacles[m, 1], scene.obstacles[m, 2]
        d2, inside = _centre_to_outline(ox, oy, xb, yb, s, c, a, b)
        pdx, pdy = xc - ox, yc - oy
        yield m, r, d2, inside, pdx * pdx + pdy * pdy


def _centre_to_outline(ox: jnp.ndarray, oy: jnp.ndarray, xb: jnp.ndarray, yb: jnp.ndarray, s: jnp.ndarray,
                       c: jnp.ndarray, a: jnp.ndarray, b: jnp.ndarray):
    """(least d² from the point (ox, oy) to the outline's edges a → b of a footprint at (xb, yb) turned by θ,
    sin θ = s and cos θ = c; whether the point lies inside): unrolled over the edges, and for long outlines (the
    judge's ellipse) reduced as arrays, which compile in seconds rather than minutes."""
    dx, dy = ox - xb, oy - yb
    px, py = c * dx + s * dy, -s * dx + c * dy                       # the point in {B}
    if a.shape[0] > UNROLL_CORNERS:
        return _edge_distances(px[..., None], py[..., None], a, b)
    return _outline_distance(px, py, a, b)


def _outline_distance(px: jnp.ndarray, py: jnp.ndarray, a: jnp.ndarray, b: jnp.ndarray):
    """(least d² from the points (px, py) in {B} to the outline's edges a → b, whether they lie inside),
    unrolled over the edges into elementwise code."""
    d2 = jnp.full(jnp.shape(px), jnp.inf, dtype=px.dtype)
    inside = jnp.zeros(jnp.shape(px), dtype=bool)
    for e in range(a.shape[0]):
        ax, ay, ex, ey = a[e, 0], a[e, 1], b[e, 0] - a[e, 0], b[e, 1] - a[e, 1]
        apx, apy = px - ax, py - ay
        t = jnp.clip((apx * ex + apy * ey) / (ex * ex + ey * ey), 0.0, 1.0)
        qx, qy = apx - t * ex, apy - t * ey
        d2 = jnp.minimum(d2, qx * qx + qy * qy)
        crosses = (ay > py) != (ay + ey > py)
        left = (apx * ey - apy * ex) * jnp.sign(ey) < 0           # x < x_intersection, no division
        inside = inside ^ (crosses & left)
    return d2, inside


def nearest_obstacle_distances(x: State, scene: Scene, exact: int = EXACT_NEAREST_DISCS):
    """:func:`obstacle_distances` for the cost: exact for the ``exact`` discs nearest each state, and for
    the others a lower bound of the footprint part, so that the work per state grows with the number of
    discs only by a ranking. Yields tuples (r, d², inside, d² to the pusher) whose gaps, taken together,
    are each disc's: one per disc (the nearest masked out, d² = ∞) and one per rank below ``exact``.

    Nearest is by the gap between the disc and the footprint outline's bounding box in {B} (which holds
    the footprint: the gap is never more than the footprint's); a disc that is not among the nearest is
    given that box's d² and ``inside`` False, so its gap is under-stated, never over-stated: the cost
    may charge it a margin it has not entered, never miss a touch. The pusher part is exact for every
    disc. The ranking is elementwise (counts of nearer discs, ties broken by index). With at most ``exact``
    discs, or with polygons too, this is :func:`obstacle_distances` itself.
    """
    count = scene.obstacles.shape[0]
    # beside polygons the ranking is left out: where the discs' terms share one loop with the polygons' gaps
    # (a batch of controllers turns the cost's cond into a select), it made that loop ten times slower
    if count <= exact or scene.edge_a.shape[0] > UNROLL_CORNERS or scene.polygons.shape[0]:
        for _, r, d2, inside, pd2 in obstacle_distances(x, scene):
            yield r, d2, inside, pd2
        return
    xb, yb, th, xc, yc = components(x)
    s, c = fastmath.sincos(th)
    a, b = scene.edge_a, scene.edge_b
    lo, hi = jnp.min(a, axis=0), jnp.max(a, axis=0)
    px, py, box2, pd2, key = [], [], [], [], []
    for m in range(count):
        ox, oy, r = scene.obstacles[m, 0], scene.obstacles[m, 1], scene.obstacles[m, 2]
        dx, dy = ox - xb, oy - yb
        px.append(c * dx + s * dy)                                  # centre in {B}
        py.append(-s * dx + c * dy)
        qx = jnp.maximum(jnp.maximum(lo[0] - px[m], px[m] - hi[0]), 0.0)
        qy = jnp.maximum(jnp.maximum(lo[1] - py[m], py[m] - hi[1]), 0.0)
        box2.append(qx * qx + qy * qy)
        pdx, pdy = xc - ox, yc - oy
        pd2.append(pdx * pdx + pdy * pdy)
        key.append(jnp.sqrt(box2[m]) - r)
    zero = jnp.zeros(jnp.shape(xb), dtype=jnp.int32)
    rank = [functools.reduce(jnp.add, [(key[j] < key[m]).astype(jnp.int32) if j > m else
                                       (key[j] <= key[m]).astype(jnp.int32) for j in range(count) if j != m], zero)
            for m in range(count)]
    never = jnp.zeros(jnp.shape(xb), dtype=bool)
    for m in range(count):
        far = rank[m] >= exact
        yield scene.obstacles[m, 2], jnp.where(far, box2[m], jnp.inf), never, jnp.where(far, pd2[m], jnp.inf)
    for k in range(exact):
        def pick(values: list[jnp.ndarray], k: int = k) -> jnp.ndarray:
            return functools.reduce(jnp.add, [jnp.where(rank[m] == k, values[m], 0.0) for m in range(count)])
        r = pick([jnp.broadcast_to(scene.obstacles[m, 2], jnp.shape(xb)) for m in range(count)])
        d2, inside = _outline_distance(pick(px), pick(py), a, b)
        yield r, d2, inside, pick(pd2)


def _edge_distances(px: jnp.ndarray, py: jnp.ndarray, a: jnp.ndarray, b: jnp.ndarray):
    """The loop of :func:`obstacle_distances` over the outline's edges as array reductions: (least d² from
    the point to an edge, whether the point lies inside), for points (..., 1) and edges a, b (E, 2)."""
    ax, ay, ex, ey = a[:, 0], a[:, 1], b[:, 0] - a[:, 0], b[:, 1] - a[:, 1]
    apx, apy = px - ax, py - ay
    t = jnp.clip((apx * ex + apy * ey) / (ex * ex + ey * ey), 0.0, 1.0)
    qx, qy = apx - t * ex, apy - t * ey
    crosses = (ay > py) != (ay + ey > py)
    left = (apx * ey - apy * ex) * jnp.sign(ey) < 0
    inside = jnp.sum(crosses & left, -1) % 2 == 1
    return jnp.min(qx * qx + qy * qy, -1), inside


def polygon_gaps(x: State, scene: Scene):
    """Per obstacle polygon, the separating-axis gaps (m) of the footprint and of the pusher (the module
    docstring): (footprint gap, pusher gap), each (...,). Unrolled over polygons, pieces and corners
    into elementwise code, as :func:`obstacle_distances`."""
    if scene.pieces.shape[1] > UNROLL_CORNERS:
        yield from _polygon_gaps_vectorised(x, scene)
        return
    xb, yb, th, xc, yc = components(x)
    s, c = fastmath.sincos(th)
    pieces, piece_planes = scene.pieces, scene.piece_planes
    for p in range(scene.polygons.shape[0]):
        corners, planes = scene.polygons[p], scene.polygon_planes[p]
        k_count = corners.shape[0]
        # the polygon's corners in {B}, and its normals turned into {B} with their offsets from the reference
        wx = [c * (corners[k, 0] - xb) + s * (corners[k, 1] - yb) for k in range(k_count)]
        wy = [-s * (corners[k, 0] - xb) + c * (corners[k, 1] - yb) for k in range(k_count)]
        mx = [c * planes[k, 0] + s * planes[k, 1] for k in range(k_count)]
        my = [-s * planes[k, 0] + c * planes[k, 1] for k in range(k_count)]
        mo = [planes[k, 2] - planes[k, 0] * xb - planes[k, 1] * yb for k in range(k_count)]
        body = None
        for q in range(pieces.shape[0]):
            v, h = pieces[q], piece_planes[q]
            sep = None
            for i in range(v.shape[0]):               # the piece's axes: its corners against the polygon's
                near = functools.reduce(jnp.minimum, [h[i, 0] * wx[k] + h[i, 1] * wy[k] for k in range(k_count)])
                sep = _max(sep, near - h[i, 2])
            for k in range(k_count):                  # the polygon's axes
                near = functools.reduce(jnp.minimum, [mx[k] * v[i, 0] + my[k] * v[i, 1] for i in range(v.shape[0])])
                sep = jnp.maximum(sep, near - mo[k])
            body = sep if body is None else jnp.minimum(body, sep)
        pusher = functools.reduce(jnp.maximum, [planes[k, 0] * xc + planes[k, 1] * yc - planes[k, 2]
                                                for k in range(k_count)])
        yield body, pusher - scene.pusher_radius


def _polygon_gaps_vectorised(x: State, scene: Scene):
    """:func:`polygon_gaps` as array reductions over corners and pieces, for footprints whose pieces have
    more than :data:`UNROLL_CORNERS` corners (the judge's ellipse), where unrolled code would take minutes
    to compile."""
    xb, yb, th, xc, yc = (v[..., None] for v in components(x))
    s, c = fastmath.sincos(th)
    v, h = scene.pieces, scene.piece_planes                                     # (Q, V, 2), (Q, V, 3)
    for p in range(scene.polygons.shape[0]):
        corners, planes = scene.polygons[p], scene.polygon_planes[p]            # (K, 2), (K, 3)
        dx, dy = corners[:, 0] - xb, corners[:, 1] - yb                          # (..., K)
        wx, wy = c * dx + s * dy, -s * dx + c * dy
        mx, my = c * planes[:, 0] + s * planes[:, 1], -s * planes[:, 0] + c * planes[:, 1]
        mo = planes[:, 2] - planes[:, 0] * xb - planes[:, 1] * yb
        # the pieces' axes: (..., Q, V, K) projections of the polygon's corners, least over K, greatest over V
        proj = h[..., 0, None] * wx[..., None, None, :] + h[..., 1, None] * wy[..., None, None, :]
        own = jnp.max(jnp.min(proj, -1) - h[..., 2], -1)
        # the polygon's axes: (..., K, Q, V) projections of the pieces' corners, least over V, greatest over K
        proj = mx[..., :, None, None] * v[..., 0] + my[..., :, None, None] * v[..., 1]
        other = jnp.max(jnp.min(proj, -1) - mo[..., :, None], -2)
        body = jnp.min(jnp.maximum(own, other), -1)
        pusher = jnp.max(planes[:, 0] * xc + planes[:, 1] * yc - planes[:, 2], -1)
        yield body, pusher - scene.pusher_radius


def _max(a: jnp.ndarray | None, b: jnp.ndarray) -> jnp.ndarray:
    return b if a is None else jnp.maximum(a, b)


def bound_gaps(x: State, scene: Scene):
    """Per workspace half-plane n·p ≤ o, the gaps (m) of the footprint (the least o − n·v over its outline's
    corners v) and of the pusher: (footprint gap, pusher gap), each (...,); then per half-plane of the
    object's own bounds, (footprint gap, +inf), per half-plane of the table's edge the pusher alone keeps
    within (``scene.edge_bounds``), (+inf, pusher gap), and per keep-out disc (centre o, radius r_o),
    (d(o, outline) − r_o, or −r_o with o inside the footprint; +inf): a bound the footprint and the pusher stay
    out of, exact like a disc's gap. The pusher's gaps to its own bounds are :func:`pusher_bound_gaps`."""
    xb, yb, th, xc, yc = components(x)
    s, c = fastmath.sincos(th)
    a = scene.edge_a

    def footprint_gap(nx: jnp.ndarray, ny: jnp.ndarray, o: jnp.ndarray) -> jnp.ndarray:
        return o - nx * xb - ny * yb - footprint_reach(s, c, nx, ny, a, jnp)

    for h in range(scene.bounds.shape[0]):
        nx, ny, o = scene.bounds[h, 0], scene.bounds[h, 1], scene.bounds[h, 2]
        yield footprint_gap(nx, ny, o), o - nx * xc - ny * yc - scene.pusher_radius
    for h in range(scene.object_bounds.shape[0]):                     # the object's own bounds: no pusher
        body = footprint_gap(scene.object_bounds[h, 0], scene.object_bounds[h, 1], scene.object_bounds[h, 2])
        yield body, jnp.full_like(body, jnp.inf)
    for h in range(scene.edge_bounds.shape[0]):                       # the table's edge: no footprint
        nx, ny, o = scene.edge_bounds[h, 0], scene.edge_bounds[h, 1], scene.edge_bounds[h, 2]
        pusher = o - nx * xc - ny * yc - scene.pusher_radius
        yield jnp.full_like(pusher, jnp.inf), pusher
    for k in range(scene.keep_out.shape[0]):          # keep-out discs: the footprint's gap
        ox, oy, r_body = scene.keep_out[k, 0], scene.keep_out[k, 1], scene.keep_out[k, 2]
        d2, inside = _centre_to_outline(ox, oy, xb, yb, s, c, a, scene.edge_b)
        body = jnp.where(inside, -r_body, jnp.sqrt(d2) - r_body)
        yield body, jnp.full_like(body, jnp.inf)


def pusher_bound_gaps(x: State, scene: Scene):
    """The pusher's gaps (m) to bounds of its own, each (...,): per half-plane n·p ≤ o of ``scene.pusher_bounds``
    (a robot arm's reach) o − n·p_c − r, and per keep-out disc (centre o, pusher radius r_p; the arm's inner
    reach) ‖p_c − o‖ − r_p − r, r the pusher's radius. The planner keeps ``scene.pusher_margin`` from them."""
    _, _, _, xc, yc = components(x)
    for h in range(scene.pusher_bounds.shape[0]):
        nx, ny, o = scene.pusher_bounds[h, 0], scene.pusher_bounds[h, 1], scene.pusher_bounds[h, 2]
        yield o - nx * xc - ny * yc - scene.pusher_radius
    for k in range(scene.keep_out.shape[0]):
        ox, oy, r_pusher = scene.keep_out[k, 0], scene.keep_out[k, 1], scene.keep_out[k, 3]
        yield jnp.sqrt((xc - ox) ** 2 + (yc - oy) ** 2) - r_pusher - scene.pusher_radius


def region_gaps(x: State, scene: Scene):
    """The gaps of :func:`polygon_gaps` and then of :func:`bound_gaps`: (footprint gap, pusher gap) per
    polygon and per workspace half-plane."""
    yield from polygon_gaps(x, scene)
    yield from bound_gaps(x, scene)


def collides(x: State, scene: Scene, margin: float = 0.0) -> jnp.ndarray:
    """isCollision (9e): object footprint or pusher disc overlaps an obstacle grown by ``margin`` (m),
    or comes within ``margin`` of leaving the workspace; (...,) bool.

    It runs in every rollout step, so it avoids square roots and reductions: obstacles and
    edges are unrolled into elementwise code that XLA fuses (docs/performance.md).
    """
    hit = jnp.zeros(jnp.shape(components(x)[0]), dtype=bool)
    for _, r, d2, inside, pd2 in obstacle_distances(x, scene):
        hit = hit | overlaps(r + margin, d2, inside, pd2, scene.pusher_radius)
    for body, pusher in region_gaps(x, scene):
        hit = hit | (jnp.minimum(body, pusher) < margin)
    for pusher in pusher_bound_gaps(x, scene):
        hit = hit | (pusher < margin)
    return hit


def overlaps(r: jnp.ndarray, d2: jnp.ndarray, inside: jnp.ndarray, pd2: jnp.ndarray,
              pusher_radius: float) -> jnp.ndarray:
    """Whether a disc of radius r overlaps the footprint or the pusher, from :func:`obstacle_distances`."""
    return (d2 < r * r) | inside | (pd2 < (r + pusher_radius) ** 2)


def clearance(x: State, scene: Scene, pusher_bounds: bool = True) -> jnp.ndarray:
    """The smallest gap (m) between any obstacle and the object's footprint or the pusher's disc, or
    between either and the workspace's boundary, and (with ``pusher_bounds``) between the pusher and bounds of
    its own (:func:`pusher_bound_gaps`); (...,). Zero or less is a touch (a disc wholly inside the footprint
    counts as −radius); +inf without obstacles."""
    gap = jnp.full(jnp.shape(components(x)[0]), jnp.inf, dtype=jnp.result_type(components(x)[0], jnp.float32))
    for _, r, d2, inside, pd2 in obstacle_distances(x, scene):
        body = jnp.where(inside, -r, jnp.sqrt(d2) - r)
        gap = jnp.minimum(gap, jnp.minimum(body, jnp.sqrt(pd2) - r - scene.pusher_radius))
    for body, pusher in region_gaps(x, scene):
        gap = jnp.minimum(gap, jnp.minimum(body, pusher))
    if pusher_bounds:
        gap = jnp.minimum(gap, pusher_bound_clearance(x, scene))
    return gap


def pusher_bound_clearance(x: State, scene: Scene) -> jnp.ndarray:
    """The smallest of :func:`pusher_bound_gaps` (m), (...,); +inf where the pusher has no bounds of its own."""
    gap = jnp.full(jnp.shape(components(x)[0]), jnp.inf, dtype=jnp.result_type(components(x)[0], jnp.float32))
    for pusher in pusher_bound_gaps(x, scene):
        gap = jnp.minimum(gap, pusher)
    return gap


#: :func:`collides` compiled once, for checking logged trajectories on the host (the batched
#: simulator's chunks, the records of finished trials)
collides_jit = jax.jit(collides)
#: :func:`clearance` compiled once, for the trial records
clearance_jit = jax.jit(clearance)
