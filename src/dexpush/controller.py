"""``PushingController``: what a robot's control loop calls (SPEC §8).

    ctrl = PushingController(shape, goal=(0.6, 0.3, 0.0))
    ctrl.reset(object_pose, pusher_xy)
    while ...:
        vx, vy = ctrl.command(object_pose, pusher_xy)   # at 10–50 Hz

Each ``command`` runs one MPPI iteration (warm-started from the previous one, shifted by
the control period) over the C-GVMM with the controller's current parameter estimate
λ_pred, and returns the first input of the new nominal sequence. The result is always
finite and inside the per-axis limit ±v_max/√2. With ``estimate_params`` the observation
first goes to the UKF window estimator (:mod:`dexpush.ukf`), whose estimate becomes λ_pred.

The loop body is one pure function, :func:`policy_step` (state, observation) → (state,
command), which :class:`PushingController` wraps for a robot and
:mod:`dexpush.simulate` scans and vmaps over whole batches of simulated episodes: the
benchmark and a robot run the very same controller.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import partial
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from dexpush.cost import CostWeights, Scene, running_cost, terminal_cost
from dexpush.geometry import Shape
from dexpush.model import LAMBDA_TRUE, Contour, check_params, checked_vector, step
from dexpush.mppi import MPPIResult, MPPISettings, mppi_iteration, shift_in_time
from dexpush.ukf import EstimatorState, UKFSettings, estimator_init, estimator_observe

__all__ = ["ControllerSettings", "ControllerState", "PushingController", "policy_init", "policy_step"]


@dataclass(frozen=True)
class ControllerSettings:
    """Everything the controller needs besides the shape and goal."""

    mppi: MPPISettings = field(default_factory=MPPISettings)
    weights: CostWeights = field(default_factory=CostWeights)
    mu: float = 0.3               #: pusher–object friction μ_c assumed by the model
    estimate_params: bool = False #: run the UKF (paper Fig. 5) and plan with its estimate
    ukf: UKFSettings = field(default_factory=UKFSettings)
    ukf_substeps: int = 10        #: Euler substeps per period in the UKF's window replay


class ControllerState(NamedTuple):
    """What the controller carries from one control period to the next (a pytree)."""

    sequence: jnp.ndarray        #: (N_p, 2) nominal input sequence, already shifted for the next call
    key: jax.Array               #: PRNG key of the MPPI sampling
    params: jnp.ndarray          #: (3,) λ_pred the next iteration plans with
    estimator: EstimatorState    #: the UKF's λ estimate and observation window


def policy_init(params: object, settings: ControllerSettings, seed: int | jnp.ndarray) -> ControllerState:
    """Fresh state: zero nominal sequence, PRNG key from ``seed``, λ_pred = ``params``."""
    lam = jnp.asarray(params, jnp.float32)
    return ControllerState(jnp.zeros((settings.mppi.horizon, 2), jnp.float32), jax.random.PRNGKey(seed), lam,
                           estimator_init(lam, settings.ukf))


def policy_step(state: ControllerState, observation: jnp.ndarray, estimate: jnp.ndarray | bool, *,
                contour: Contour, scene: Scene,
                settings: ControllerSettings) -> tuple[ControllerState, jnp.ndarray, MPPIResult]:
    """One control period (paper Fig. 5). Pure and jit-able; ``observation`` = [x_b, y_b, θ, x_c, y_c].

    1. with ``estimate``: the observation enters the UKF window; an informative full
       window updates λ_pred (:func:`dexpush.ukf.estimator_observe`);
    2. one MPPI iteration (eq. 9–10) from the observed state with λ_pred;
    3. the command is the first input of the new sequence, clipped to ±v_max/√2 (zero,
       and a reset sequence, should it ever be non-finite); the sequence is shifted by the
       control period as the next warm start.
    """
    mp = settings.mppi
    period = jnp.float32(mp.control_period)
    obs = jnp.asarray(observation, jnp.float32)

    def observe(s: ControllerState) -> tuple[EstimatorState, jnp.ndarray]:
        est, _ = estimator_observe(s.estimator, obs, jnp.bool_(True), contour, settings.ukf,
                                   jnp.float32(settings.mu), period, settings.ukf_substeps)
        return est, est.filter.mean

    # (under vmap with a per-trial flag this becomes a select: both branches run)
    est, lam = jax.lax.cond(jnp.asarray(estimate), observe, lambda s: (s.estimator, s.params), state)
    key, sub = jax.random.split(state.key)
    weights, mu = settings.weights, jnp.float32(settings.mu)
    result = mppi_iteration(
        sub, state.sequence, tuple(obs[i] for i in range(5)), lam, scene,   # rollouts carry a tuple
        dynamics=lambda x, u, dt, p: step(contour, x, u, dt, p, mu),
        running_cost=lambda x, sc: running_cost(x, sc, weights),
        terminal_cost=lambda x, sc: terminal_cost(x, sc, weights), settings=mp)
    finite = jnp.all(jnp.isfinite(result.sequence))
    u = jnp.where(finite, jnp.clip(result.sequence[0], -mp.v_clip, mp.v_clip), 0.0)
    durations = jnp.asarray(mp.step_durations(), jnp.float32)
    shifted = jnp.where(finite, shift_in_time(result.sequence, durations, mp.control_period), 0.0)
    return ControllerState(shifted, key, lam, est), u, result


@partial(jax.jit, static_argnames="settings")
def _policy_jit(state: ControllerState, observation: jnp.ndarray, estimate: jnp.ndarray, contour: Contour,
                scene: Scene, settings: ControllerSettings) -> tuple[ControllerState, jnp.ndarray, MPPIResult]:
    return policy_step(state, observation, estimate, contour=contour, scene=scene, settings=settings)


class PushingController:
    """Goal-oriented pushing with long-horizon MPPI over the C-GVMM.

    Args:
        shape: the pushed object.
        goal: goal pose (x, y, θ) in the world frame.
        params: λ_pred = [β, x_bf, y_bf] the model assumes (update with :meth:`set_params`).
        obstacles: disc obstacles (c_x, c_y, radius) to avoid with object and pusher.
        settings: :class:`ControllerSettings` (MPPI knobs, cost weights, μ_c, the UKF).
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
        self._seed = int(seed)
        p = checked_vector("params", params, 3)
        check_params(p)
        self._initial_params = p
        self.reset()

    @property
    def goal(self) -> np.ndarray:
        return np.asarray(self.scene.goal)

    @property
    def params(self) -> np.ndarray:
        """The λ_pred the model currently uses."""
        return np.asarray(self.state.params, dtype=np.float64)

    def set_params(self, params: object) -> None:
        """Replace λ_pred (e.g. with an online estimate); takes effect at the next command."""
        p = checked_vector("params", params, 3)
        check_params(p)
        self.state = self.state._replace(params=jnp.asarray(p, jnp.float32))

    def reset(self, object_pose: object | None = None, pusher_xy: object | None = None,
              seed: int | None = None) -> None:
        """Forget the warm start and the estimate (and optionally reseed). Poses are accepted
        for symmetry with :meth:`command` and validated, but the first command re-plans."""
        if object_pose is not None:
            checked_vector("object_pose", object_pose, 3)
        if pusher_xy is not None:
            checked_vector("pusher_xy", pusher_xy, 2)
        if seed is not None:
            self._seed = int(seed)
        self.state = policy_init(self._initial_params, self.settings, self._seed)
        self.last: MPPIResult | None = None

    def command(self, object_pose: object, pusher_xy: object) -> np.ndarray:
        """Pusher velocity (v_x, v_y) in m/s for the observed object pose and pusher position."""
        q = checked_vector("object_pose", object_pose, 3)
        p = checked_vector("pusher_xy", pusher_xy, 2)
        obs = jnp.asarray(np.concatenate([q, p]), jnp.float32)
        self.state, u, self.last = _policy_jit(self.state, obs, jnp.asarray(self.settings.estimate_params),
                                               self.contour, self.scene, self.settings)
        c = self.settings.mppi.v_clip     # float32 rounding may sit a hair past the float64 bound
        return np.clip(np.asarray(u, dtype=np.float64), -c, c)
