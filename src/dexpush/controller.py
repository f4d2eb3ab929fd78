"""``PushingController``: what a robot's control loop calls (SPEC §8).

    ctrl = PushingController(shape, goal=(0.6, 0.3, 0.0))
    ctrl.reset(object_pose, pusher_xy)
    while ...:
        vx, vy = ctrl.command(object_pose, pusher_xy)   # at 10–50 Hz

Each ``command`` runs one MPPI iteration (warm-started from the previous one, shifted by
the control period) over the C-GVMM with the controller's current parameter estimate
λ_pred, and returns the first input of the new nominal sequence. The result is always
finite and inside the per-axis limit ±v_max/√2. With ``estimate_params`` the observation
first goes to a :class:`dexpush.ukf.WindowEstimator`, whose estimate becomes λ_pred.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import jax
import jax.numpy as jnp
import numpy as np

from dexpush.cost import CostWeights, Scene, running_cost, terminal_cost
from dexpush.geometry import Shape
from dexpush.model import LAMBDA_TRUE, Contour, check_params, checked_vector, step
from dexpush.mppi import MPPI, MPPIResult, MPPISettings
from dexpush.ukf import UKFSettings, WindowEstimator

__all__ = ["ControllerSettings", "PushingController"]


@dataclass(frozen=True)
class ControllerSettings:
    """Everything the controller needs besides the shape and goal."""

    mppi: MPPISettings = field(default_factory=MPPISettings)
    weights: CostWeights = field(default_factory=CostWeights)
    mu: float = 0.3               #: pusher–object friction μ_c assumed by the model
    estimate_params: bool = False #: run the UKF (paper Fig. 5) and plan with its estimate
    ukf: UKFSettings = field(default_factory=UKFSettings)


class PushingController:
    """Goal-oriented pushing with long-horizon MPPI over the C-GVMM.

    Args:
        shape: the pushed object.
        goal: goal pose (x, y, θ) in the world frame.
        params: λ_pred = [β, x_bf, y_bf] the model assumes (update with :meth:`set_params`).
        obstacles: disc obstacles (c_x, c_y, radius) to avoid with object and pusher.
        settings: :class:`ControllerSettings` (MPPI knobs, cost weights, μ_c).
        seed: seeds the MPPI sampling; equal seeds and observations give equal commands.
    """

    def __init__(self, shape: Shape, goal: object, params: object = LAMBDA_TRUE,
                 obstacles: object = (), settings: ControllerSettings | None = None,
                 seed: int = 0) -> None:
        if not isinstance(shape, Shape):
            raise TypeError(f"shape must be a dexpush.Shape, got {type(shape).__name__}")
        self.shape = shape
        self.settings = settings or ControllerSettings()
        self.scene = Scene.make(shape, goal, obstacles, self.settings.weights)
        self.contour = Contour.of(shape)
        mu, weights = self.settings.mu, self.settings.weights
        contour = self.contour

        def dynamics(x: jnp.ndarray, u: jnp.ndarray, dt: jnp.ndarray, lam: jnp.ndarray) -> jnp.ndarray:
            return step(contour, x, u, dt, lam, mu)

        self.planner = MPPI(dynamics,
                            lambda x, scene: running_cost(x, scene, weights),
                            lambda x, scene: terminal_cost(x, scene, weights),
                            self.settings.mppi)
        self._seed = int(seed)
        self._initial_params = params
        self.set_params(params)
        self.reset()

    @property
    def goal(self) -> np.ndarray:
        return np.asarray(self.scene.goal)

    @property
    def params(self) -> np.ndarray:
        """The λ_pred the model currently uses."""
        return np.asarray(self._params, dtype=np.float64)

    def set_params(self, params: object) -> None:
        """Replace λ_pred (e.g. with an online estimate); takes effect at the next command."""
        p = checked_vector("params", params, 3)
        check_params(p)
        self._params = jnp.asarray(p, jnp.float32)

    def reset(self, object_pose: object | None = None, pusher_xy: object | None = None,
              seed: int | None = None) -> None:
        """Forget the warm start (and optionally reseed). Poses are accepted for symmetry
        with :meth:`command` and validated, but the first command re-plans from scratch."""
        if object_pose is not None:
            checked_vector("object_pose", object_pose, 3)
        if pusher_xy is not None:
            checked_vector("pusher_xy", pusher_xy, 2)
        if seed is not None:
            self._seed = int(seed)
        self._key = jax.random.PRNGKey(self._seed)
        self._U = self.planner.initial_sequence()
        self.last: MPPIResult | None = None
        self.estimator: WindowEstimator | None = None
        if self.settings.estimate_params:
            self.set_params(self._initial_params)
            self.estimator = WindowEstimator(self.contour, self._initial_params, self.settings.ukf,
                                             mu=self.settings.mu, dt=self.settings.mppi.control_period)

    def command(self, object_pose: object, pusher_xy: object) -> np.ndarray:
        """Pusher velocity (v_x, v_y) in m/s for the observed object pose and pusher position."""
        q = checked_vector("object_pose", object_pose, 3)
        p = checked_vector("pusher_xy", pusher_xy, 2)
        if self.estimator is not None:
            self.estimator.observe(q, p)
            self._params = jnp.asarray(self.estimator.params, jnp.float32)
        x0 = tuple(jnp.float32(v) for v in np.concatenate([q, p]))  # rollouts carry a tuple
        self._key, sub = jax.random.split(self._key)
        result = self.planner.optimize(sub, self._U, x0, self._params, self.scene)
        u = np.asarray(result.sequence[0], dtype=np.float64)
        if not np.all(np.isfinite(u)):  # cannot happen for finite inputs; never send NaN to a robot
            u = np.zeros(2)
            self._U = self.planner.initial_sequence()
        else:
            self._U = self.planner.shift(result.sequence)
        self.last = result
        c = self.settings.mppi.v_clip
        return np.clip(u, -c, c)
