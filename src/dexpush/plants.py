"""Plants: the "world" a controller pushes in experiments.

A plant owns the true state and answers ``reset(object_pose, pusher_xy)`` and
``step(velocity, dt)`` with an :class:`Observation`. The controller only ever sees
observations.

:class:`ModelPlant` is the paper's numerical-experiment world (SPEC §3): the C-GVMM with
the true parameters λ_true, integrated with ``substeps`` Euler steps per control period
and the penetration fix of :func:`dexpush.model.step`, so the pusher never ends a step
inside the inflated contour by more than numerical round-off (the SPEC allows 1 mm).
It works on one scene or a batch: give poses with a leading batch axis.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial

import jax
import jax.numpy as jnp
import numpy as np

from dexpush.geometry import Shape
from dexpush.model import LAMBDA_TRUE, Contour, check_params, checked_vector, contact_gap, integrate

__all__ = ["ModelPlant", "Observation"]


@dataclass(frozen=True)
class Observation:
    """What a plant reports: object pose (..., 3) [x, y, θ], pusher centre (..., 2), time (s)."""

    object_pose: np.ndarray
    pusher_xy: np.ndarray
    time: float

    @property
    def state(self) -> np.ndarray:
        """The 5-vector (or batch) [x_b, y_b, θ, x_c, y_c]."""
        return np.concatenate([self.object_pose, self.pusher_xy], -1)


@partial(jax.jit, static_argnames="substeps")
def _advance(contour: Contour, x: jnp.ndarray, u: jnp.ndarray, dt: jnp.ndarray,
             params: jnp.ndarray, mu: jnp.ndarray, substeps: int) -> tuple[jnp.ndarray, jnp.ndarray]:
    x1 = integrate(contour, x, u, dt, params, mu, substeps)
    return x1, contact_gap(contour, x1)


class ModelPlant:
    """The C-GVMM as the world, with true parameters (SPEC §3 "model plant").

    Args:
        shape: the pushed object.
        params: true λ = [β, x_bf, y_bf]; default the paper's λ_true = [25, −0.01, 0.02].
        mu: true pusher–object friction μ_c.
        substeps: Euler substeps per ``step`` call (≥ 10, SPEC §3).
    """

    def __init__(self, shape: Shape, params: object = LAMBDA_TRUE, mu: float = 0.3,
                 substeps: int = 10) -> None:
        if substeps < 10:
            raise ValueError(f"substeps must be >= 10 (SPEC §3), got {substeps}")
        if not (np.isfinite(mu) and mu > 0):
            raise ValueError(f"mu must be > 0, got {mu!r}")
        self.shape = shape
        self.contour = Contour.of(shape)
        self.params = checked_vector("params", params, 3)
        check_params(self.params)
        self.mu = float(mu)
        self.substeps = int(substeps)
        self._x: jnp.ndarray | None = None
        self.time = 0.0
        self.max_penetration = 0.0  # deepest pusher penetration seen at the end of a step (m)

    @property
    def state(self) -> np.ndarray:
        """The true state(s) [x_b, y_b, θ, x_c, y_c] (the controller should not read this)."""
        if self._x is None:
            raise RuntimeError("call reset() before using the plant")
        return np.asarray(self._x, dtype=np.float64)

    def observe(self) -> Observation:
        x = self.state
        return Observation(x[..., :3], x[..., 3:], self.time)

    def reset(self, object_pose: object, pusher_xy: object) -> Observation:
        """Place the object and the pusher; the pusher must not start inside the object."""
        q = checked_vector("object_pose", object_pose, 3, batch=True)
        p = checked_vector("pusher_xy", pusher_xy, 2, batch=True)
        if q.shape[:-1] != p.shape[:-1]:
            raise ValueError(f"object_pose {q.shape} and pusher_xy {p.shape} batch shapes differ")
        x = jnp.asarray(np.concatenate([q, p], -1))
        gap = np.asarray(contact_gap(self.contour, x))
        if np.any(gap < -1e-3):
            raise ValueError(
                f"pusher starts {-gap.min() * 1000:.1f} mm inside the object; place it on or "
                "outside the pusher-inflated contour")
        self._x = x
        self.time = 0.0
        self.max_penetration = 0.0
        return self.observe()

    def step(self, velocity: object, dt: float = 0.04) -> Observation:
        """Hold the pusher velocity (m/s, world frame) for ``dt`` seconds; return the observation."""
        if self._x is None:
            raise RuntimeError("call reset() before step()")
        v = checked_vector("velocity", velocity, 2, batch=True)
        if v.shape[:-1] not in ((), self._x.shape[:-1]):
            raise ValueError(f"velocity batch shape {v.shape[:-1]} does not match the plant's "
                             f"{self._x.shape[:-1]}")
        if not (np.isfinite(dt) and dt > 0):
            raise ValueError(f"dt must be > 0, got {dt!r}")
        dtype = self._x.dtype
        u = jnp.broadcast_to(jnp.asarray(v, dtype), (*self._x.shape[:-1], 2))
        self._x, gap = _advance(self.contour, self._x, u, jnp.asarray(dt, dtype),
                                jnp.asarray(self.params, dtype), jnp.asarray(self.mu, dtype),
                                self.substeps)
        self.max_penetration = max(self.max_penetration, float(-np.min(gap)))
        self.time += dt
        return self.observe()
