"""The model plant: the C-GVMM with λ_true as the world a controller pushes in.

A plant owns the true state and answers ``reset(object_pose, pusher_xy)`` and
``step(velocity, dt)`` with an :class:`dexpush.common.interfaces.Observation`: both plants
(this one and :class:`dexpush.world.physics_plant.PhysicsPlant`) satisfy the
:class:`dexpush.common.interfaces.Plant` protocol. The controller only ever sees observations.

:class:`ModelPlant` is the paper's numerical-experiment world (docs/conventions.md#plants): the C-GVMM with
the true parameters λ_true, integrated with ``substeps`` Euler steps per control period
and the penetration fix of :func:`dexpush.model.cgvmm.step`, so the pusher never ends a step
inside the inflated contour by more than numerical round-off (docs/conventions.md#plants allows 1 mm).
It works on one scene or a batch: give poses with a leading batch axis.
"""

from __future__ import annotations

from functools import partial

import jax
import jax.numpy as jnp
import numpy as np

from dexpush.common.checks import check_params, check_positive, checked_vector
from dexpush.common.interfaces import CONTROL_PERIOD_S, Observation
from dexpush.model.cgvmm import LAMBDA_TRUE, MU_C, Contour, contact_gap, integrate
from dexpush.model.shape import Shape

__all__ = ["ModelPlant"]


def check_no_tunnelling(velocity: np.ndarray, h: float, rho: float, knob: str) -> None:
    """Refuse a pusher speed that moves it more than its radius in one integration step: it could pass
    through a thin part of the object without ever being seen inside it."""
    speed = float(np.max(np.linalg.norm(np.atleast_2d(velocity), axis=-1)))
    if speed * h > rho:
        raise ValueError(f"a pusher speed of {speed:.3g} m/s moves the pusher {speed * h * 1e3:.3g} mm per "
                         f"integration step, more than its radius ({rho * 1e3:.3g} mm): it could pass through the "
                         f"object. Lower the speed (at most {rho / h:.3g} m/s) or refine {knob}.")


@partial(jax.jit, static_argnames="substeps")
def _advance(contour: Contour, x: jnp.ndarray, u: jnp.ndarray, dt: jnp.ndarray,
             params: jnp.ndarray, mu: jnp.ndarray, substeps: int) -> tuple[jnp.ndarray, jnp.ndarray]:
    x1 = integrate(contour, x, u, dt, params, mu, substeps)
    return x1, contact_gap(contour, x1)


class ModelPlant:
    """The C-GVMM as the world, with true parameters (docs/conventions.md#plants "model plant").

    Args:
        shape: the pushed object.
        params: true λ = [β, x_bf, y_bf]; default the paper's λ_true = [25, −0.01, 0.02].
        mu: true pusher–object friction μ_c.
        substeps: Euler substeps per ``step`` call (≥ 10, docs/conventions.md#plants).
    """

    def __init__(self, shape: Shape, params: object = LAMBDA_TRUE, mu: float = MU_C,
                 substeps: int = 10) -> None:
        if substeps < 10:
            raise ValueError(f"substeps must be >= 10 (docs/conventions.md#plants), got {substeps}")
        check_positive("mu", mu, "the pusher–object friction coefficient")
        self.shape = shape
        self.contour = Contour.of(shape)
        self.params = checked_vector("params", params, 3)
        check_params(self.params)
        lo, hi = shape.footprint_box[:2], shape.footprint_box[2:]
        if np.any(self.params[1:] < lo) or np.any(self.params[1:] > hi):
            raise ValueError(f"the centre of friction ({self.params[1]:g}, {self.params[2]:g}) m lies outside the "
                             f"footprint of {shape.name} (x in [{lo[0]:g}, {hi[0]:g}], y in [{lo[1]:g}, {hi[1]:g}] m "
                             "from its reference point): the support under the object holds it")
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

    def step(self, velocity: object, dt: float = CONTROL_PERIOD_S) -> Observation:
        """Hold the pusher velocity (m/s, world frame) for ``dt`` seconds; return the observation."""
        if self._x is None:
            raise RuntimeError("call reset() before step()")
        v = checked_vector("velocity", velocity, 2, batch=True)
        if v.shape[:-1] not in ((), self._x.shape[:-1]):
            raise ValueError(f"velocity batch shape {v.shape[:-1]} does not match the plant's "
                             f"{self._x.shape[:-1]}")
        dt = check_positive("dt", dt, "s")
        check_no_tunnelling(v, dt / self.substeps, self.shape.pusher_radius, "substeps")
        dtype = self._x.dtype
        u = jnp.broadcast_to(jnp.asarray(v, dtype), (*self._x.shape[:-1], 2))
        self._x, gap = _advance(self.contour, self._x, u, jnp.asarray(dt, dtype),
                                jnp.asarray(self.params, dtype), jnp.asarray(self.mu, dtype),
                                self.substeps)
        self.max_penetration = max(self.max_penetration, float(-np.min(gap)))
        self.time += dt
        return self.observe()
