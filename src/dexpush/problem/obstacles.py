"""Where the object and the pusher are against disc obstacles: the collision test of eq. (9e) and
Task III (:func:`collides`) and the gap to the nearest obstacle (:func:`clearance`).

Obstacles are discs ``(c_x, c_y, radius)``. A touch is the object's footprint (not inflated) or
the pusher disc overlapping a disc (docs/conventions.md#controller); the planner's cost keeps a
margin beyond it (:mod:`dexpush.problem.cost`), the judge of a trial uses the discs as given.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from dexpush.common import fastmath
from dexpush.model.cgvmm import State, components
from dexpush.problem.scene import Scene

__all__ = ["clearance", "clearance_jit", "collides", "collides_jit", "obstacle_distances", "overlaps"]


def obstacle_distances(x: State, scene: Scene):
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

    It runs in every rollout step, so it avoids square roots and reductions: obstacles and
    edges are unrolled into elementwise code that XLA fuses (docs/performance.md).
    """
    hit = jnp.zeros(jnp.shape(components(x)[0]), dtype=bool)
    for _, r, d2, inside, pd2 in obstacle_distances(x, scene):
        hit = hit | overlaps(r + margin, d2, inside, pd2, scene.pusher_radius)
    return hit


def overlaps(r: jnp.ndarray, d2: jnp.ndarray, inside: jnp.ndarray, pd2: jnp.ndarray,
              pusher_radius: float) -> jnp.ndarray:
    """Whether a disc of radius r overlaps the footprint or the pusher, from :func:`obstacle_distances`."""
    return (d2 < r * r) | inside | (pd2 < (r + pusher_radius) ** 2)


def clearance(x: State, scene: Scene) -> jnp.ndarray:
    """The smallest gap (m) between any obstacle disc and the object's footprint or the pusher's disc;
    (...,). Zero or less is a touch (a disc wholly inside the footprint counts as −radius); +inf
    without obstacles."""
    gap = jnp.full(jnp.shape(components(x)[0]), jnp.inf, dtype=jnp.result_type(components(x)[0], jnp.float32))
    for _, r, d2, inside, pd2 in obstacle_distances(x, scene):
        body = jnp.where(inside, -r, jnp.sqrt(d2) - r)
        gap = jnp.minimum(gap, jnp.minimum(body, jnp.sqrt(pd2) - r - scene.pusher_radius))
    return gap


#: :func:`collides` compiled once, for checking logged trajectories on the host (the batched
#: simulator's chunks, the records of finished trials)
collides_jit = jax.jit(collides)
#: :func:`clearance` compiled once, for the trial records
clearance_jit = jax.jit(clearance)
