"""What the cost of eq. (9) knows about the world: the goal, the disc obstacles and the object's
footprint, as arrays that can be passed into jit (:class:`Scene`)."""

from __future__ import annotations

from dataclasses import dataclass

import jax
import jax.numpy as jnp
import numpy as np

from dexpush.model.shape import Shape
from dexpush.problem.weights import CostWeights

__all__ = ["Scene", "obstacle_array"]


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
    def make(shape: Shape, goal: object, obstacles: object = (), weights: CostWeights | None = None,
             max_edges: int | None = None) -> Scene:
        """The cost's view of a task; with ``max_edges``, the footprint's outline has at most that many
        edges where the footprint is convex (:meth:`dexpush.model.shape.Shape.outline_edges`).

        The effective r_s is max(r_s, R_max + r_s_clearance), R_max the largest radius of
        the inflated contour. Table II's r_s = 0.2 m suits the paper's objects, but the
        standard T reaches 0.187 m from its reference: with r_s = 0.2 the ReLU term (9d)
        charges q_r2 = 1e4 per metre and step for walking around the stem, which traps
        the pusher on one side of it (docs/controller.md).
        """
        w = weights or CostWeights()
        g = np.asarray(goal, dtype=np.float64)
        if g.shape != (3,) or not np.all(np.isfinite(g)):
            raise ValueError(f"goal must be a finite pose (x, y, θ), got {goal!r}")
        obs = obstacle_array(obstacles)
        a, b = shape.edges if max_edges is None else shape.outline_edges(max_edges)
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

