"""Unscented Kalman filter for the model parameters λ = [β, x_bf, y_bf] (paper Sec. III-C, Fig. 5).

The filter (:func:`ukf_update`) is generic: a random-walk state with a measurement
function ``h`` evaluated on all sigma points in one batched call. Notation (filterpy's):

    n = 3 (state dimension), λ_ut = α²(n + κ) − n
    predict:   x⁻ = x,  P⁻ = P + Q                                   (random walk)
    sigma:     χ₀ = x⁻,  χ_i = x⁻ ± [√((n + λ_ut) P⁻)]_i,  i = 1 … n   (2n + 1 points)
               Wm₀ = λ_ut/(n + λ_ut),  Wc₀ = Wm₀ + (1 − α² + β_ut),  Wm_i = Wc_i = 1/(2(n + λ_ut))
    measure:   𝒴_i = h(χ_i),  ẑ = Σ Wm_i 𝒴_i
               S = Σ Wc_i (𝒴_i − ẑ)(𝒴_i − ẑ)ᵀ + R,  P_xz = Σ Wc_i (χ_i − x⁻)(𝒴_i − ẑ)ᵀ
    update:    K = P_xz S⁻¹,  x = clip(x⁻ + K (z − ẑ), lower, upper),  P = P⁻ − K S Kᵀ

Sigma points are clipped into the bounds before ``h`` sees them (β must stay positive).
After each update P is symmetrised and its eigenvalues floored at ``min_var`` (and capped
at the prior), so it stays symmetric positive definite whatever the measurement does.

The pushing measurement (:class:`WindowEstimator`): the last M observed object poses
q_{t−M+1..t} against a replay of the C-GVMM with λ from the first observed state of the
window, s_{t−M}, driven by the recorded pusher displacements (not the commands, so delay
and tracking error of a real robot are in the data). Residual headings are wrapped. A
window in which the pusher never came within ``contact_gap_m`` of the contour, or the
object moved less than ``min_motion_m``, carries no information about λ and is skipped.

Settings (:class:`UKFSettings`), and why:

* ``window`` M = 10 steps (0.4 s at 25 Hz): long enough for the object to move several
  millimetres while pushed, short enough that the replay from s_{t−M} stays close.
* ``process_std`` = (0.5 1/m, 0.5 mm, 0.5 mm) a step: lets β move by ~±15 1/m over a
  1-s window of contact, so an initial guess of 15 reaches 25 within seconds.
* ``meas_pos_std`` = 1 mm, ``meas_heading_std`` = 0.5°: observation noise of a motion
  capture or camera system (SPEC §3) plus the model's own replay error.
* α = 1, β_ut = 2, κ = 0: sigma points at ±√3·σ; small α would probe λ only
  infinitesimally, where the piecewise (mode-switching) model is not smooth.
* bounds β ∈ [2, 200] 1/m, |x_bf|, |y_bf| ≤ 5 cm: physical (β = f_max/m_max of objects of
  5–50 cm; the CoF lies inside the footprint).
* prior: the controller's λ_pred with σ = (10 1/m, 1 cm, 1 cm).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from dexpush.checks import checked_vector
from dexpush.model import Contour, contact_gap, replay
from dexpush.se2 import wrap_angle

__all__ = ["EstimatorState", "UKFSettings", "UKFState", "WindowEstimator", "estimator_init", "estimator_observe",
           "prior_covariance", "sigma_points", "ukf_update", "window_update"]


@dataclass(frozen=True)
class UKFSettings:
    """Knobs of the λ estimator (see the module docstring for the reasons)."""

    window: int = 10
    process_std: tuple[float, float, float] = (0.5, 5e-4, 5e-4)
    meas_pos_std: float = 1e-3
    meas_heading_std: float = float(np.radians(0.5))
    init_std: tuple[float, float, float] = (10.0, 0.01, 0.01)
    lower: tuple[float, float, float] = (2.0, -0.05, -0.05)
    upper: tuple[float, float, float] = (200.0, 0.05, 0.05)
    alpha: float = 1.0
    beta_ut: float = 2.0
    kappa: float = 0.0
    min_var: float = 1e-10
    contact_gap_m: float = 2e-3
    min_motion_m: float = 5e-4

    def __post_init__(self) -> None:
        if self.window < 1:
            raise ValueError(f"window must be >= 1, got {self.window}")
        if any(s <= 0 for s in (*self.process_std, *self.init_std, self.meas_pos_std, self.meas_heading_std)):
            raise ValueError("standard deviations must be > 0")
        if any(lo >= hi for lo, hi in zip(self.lower, self.upper)) or self.lower[0] <= 0:
            raise ValueError(f"bounds must satisfy 0 < β_lower and lower < upper, got {self.lower}, {self.upper}")


@dataclass(frozen=True)
class UKFState:
    """Mean x (3,) and covariance P (3, 3) of λ."""

    mean: jnp.ndarray
    cov: jnp.ndarray


jax.tree_util.register_dataclass(UKFState, data_fields=["mean", "cov"], meta_fields=[])


def sigma_points(mean: jnp.ndarray, cov: jnp.ndarray, s: UKFSettings) -> tuple[jnp.ndarray, ...]:
    """The 2n+1 sigma points (rows) and their mean/covariance weights."""
    n = mean.shape[0]
    lam = s.alpha**2 * (n + s.kappa) - n
    L = jnp.linalg.cholesky((n + lam) * cov)
    X = jnp.concatenate([mean[None], mean[None] + L.T, mean[None] - L.T])
    wm = jnp.full(2 * n + 1, 1.0 / (2 * (n + lam))).at[0].set(lam / (n + lam))
    wc = wm.at[0].add(1 - s.alpha**2 + s.beta_ut)
    return X, wm, wc


def _clean_cov(P: jnp.ndarray, cap: jnp.ndarray, min_var: float) -> jnp.ndarray:
    P = 0.5 * (P + P.T)
    w, V = jnp.linalg.eigh(P)
    w = jnp.clip(w, min_var, jnp.max(jnp.diag(cap)))
    return (V * w) @ V.T


def ukf_update(state: UKFState, z: jnp.ndarray, h: Callable[[jnp.ndarray], jnp.ndarray], Q: jnp.ndarray,
               R: jnp.ndarray, settings: UKFSettings, prior_cov: jnp.ndarray) -> UKFState:
    """One predict + update step (equations in the module docstring). ``h`` maps (2n+1, n) → (2n+1, m)."""
    lower, upper = jnp.asarray(settings.lower), jnp.asarray(settings.upper)
    P = state.cov + Q
    X, wm, wc = sigma_points(state.mean, P, settings)
    X = jnp.clip(X, lower, upper)
    Y = h(X)
    z_hat = wm @ Y
    dY, dX = Y - z_hat, X - state.mean
    S = (wc[:, None] * dY).T @ dY + R
    Pxz = (wc[:, None] * dX).T @ dY
    K = jnp.linalg.solve(S, Pxz.T).T
    mean = jnp.clip(state.mean + K @ (z - z_hat), lower, upper)
    cov = _clean_cov(P - K @ S @ K.T, prior_cov, settings.min_var)
    return UKFState(mean, cov)


def prior_covariance(settings: UKFSettings) -> jnp.ndarray:
    """P₀ = diag(init_std)²: the prior, and the cap on every later covariance."""
    return jnp.diag(jnp.asarray(settings.init_std, jnp.float32) ** 2)


def window_update(state: UKFState, contour: Contour, window: jnp.ndarray, dt: jnp.ndarray, mu: jnp.ndarray,
                  settings: UKFSettings, substeps: int) -> tuple[UKFState, jnp.ndarray]:
    """UKF step on one window of observed states (M+1, 5); returns (state, updated?). Pure."""
    prior_cov = prior_covariance(settings)
    x0 = window[0]
    moves = (window[1:, 3:] - window[:-1, 3:]) / dt            # recorded pusher velocities
    observed = window[1:, :3]

    def predicted_poses(lam: jnp.ndarray) -> jnp.ndarray:
        q = replay(contour, x0, moves, dt, lam, mu, substeps)[:, :3]
        # heading relative to the observation, so the residual is wrapped
        heading = observed[:, 2] + wrap_angle(q[:, 2] - observed[:, 2], jnp)
        return jnp.concatenate([q[:, :2], heading[:, None]], -1).ravel()

    h = jax.vmap(predicted_poses)
    M = observed.shape[0]
    r = jnp.tile(jnp.asarray([settings.meas_pos_std**2, settings.meas_pos_std**2, settings.meas_heading_std**2]), M)
    Q = jnp.diag(jnp.asarray(settings.process_std) ** 2)
    new = ukf_update(state, observed.ravel(), h, Q, jnp.diag(r), settings, prior_cov)
    touched = jnp.any(contact_gap(contour, window) <= settings.contact_gap_m)
    moved = jnp.max(jnp.linalg.norm(window[1:, :2] - window[:1, :2], axis=-1)) >= settings.min_motion_m
    informative = touched & moved
    # no information: only the random-walk prediction
    skipped = UKFState(state.mean, _clean_cov(state.cov + Q, prior_cov, settings.min_var))
    out = jax.tree.map(lambda a, b: jnp.where(informative, a, b), new, skipped)
    return out, informative


class EstimatorState(NamedTuple):
    """Everything the online estimator carries between observations (a pytree)."""

    filter: UKFState          #: λ mean and covariance
    window: jnp.ndarray       #: (M+1, 5) the last observed states, oldest first
    count: jnp.ndarray        #: consecutive observations held in ``window`` (0 … M+1)


def estimator_init(initial: jnp.ndarray, settings: UKFSettings) -> EstimatorState:
    """The prior: mean ``initial`` clipped into the bounds, covariance diag(init_std)², empty window."""
    mean = jnp.clip(jnp.asarray(initial, jnp.float32), jnp.asarray(settings.lower, jnp.float32),
                    jnp.asarray(settings.upper, jnp.float32))
    return EstimatorState(UKFState(mean, prior_covariance(settings)),
                          jnp.zeros((settings.window + 1, 5), jnp.float32), jnp.zeros((), jnp.int32))


def estimator_observe(state: EstimatorState, observation: jnp.ndarray, valid: jnp.ndarray, contour: Contour,
                      settings: UKFSettings, mu: jnp.ndarray, dt: jnp.ndarray,
                      substeps: int) -> tuple[EstimatorState, jnp.ndarray]:
    """Add one observed state (5,) and update λ once the window is full. Pure and jit-able.

    ``valid`` False (a dropped frame, or NaN in the observation) empties the window: the
    replay needs consecutive observations, so the next update waits for M+1 new ones.
    Returns the new state and whether λ was updated from an informative window.
    """
    M1 = settings.window + 1
    valid = valid & jnp.all(jnp.isfinite(observation))
    window = jnp.concatenate([state.window[1:], jnp.where(valid, observation, 0.0)[None]])
    count = jnp.where(valid, jnp.minimum(state.count + 1, M1), 0)
    updated, informative = window_update(state.filter, contour, window, dt, mu, settings, substeps)
    ready = count >= M1
    filt = jax.tree.map(lambda a, b: jnp.where(ready, a, b), updated, state.filter)
    return EstimatorState(filt, window, count), ready & informative


@partial(jax.jit, static_argnames=("settings", "substeps"))
def _observe_jit(state: EstimatorState, observation: jnp.ndarray, valid: jnp.ndarray, contour: Contour,
                 settings: UKFSettings, mu: jnp.ndarray, dt: jnp.ndarray,
                 substeps: int) -> tuple[EstimatorState, jnp.ndarray]:
    return estimator_observe(state, observation, valid, contour, settings, mu, dt, substeps)


class WindowEstimator:
    """Online λ estimation from the last M observations (the paper's Fig. 5, green block).

    Args:
        contour: the object's contour (``dexpush.model.Contour.of(shape)``).
        initial: the prior mean λ_pred.
        settings: :class:`UKFSettings`.
        mu: pusher–object friction μ_c used by the replay.
        dt: the observation period (s).
        substeps: Euler substeps of the replay per period.

    Call :meth:`observe` with every observation (object pose, pusher position); it updates
    :attr:`params` once a full window is available. Observations containing NaN are
    rejected with a ``ValueError``; pass ``None`` for a dropped frame (the window restarts).
    """

    def __init__(self, contour: Contour, initial: object, settings: UKFSettings | None = None, mu: float = 0.3,
                 dt: float = 0.04, substeps: int = 10) -> None:
        self.settings = settings or UKFSettings()
        self.contour = contour
        self.mu, self.dt, self.substeps = float(mu), float(dt), int(substeps)
        self._state = estimator_init(checked_vector("initial", initial, 3), self.settings)
        self.updates = 0
        self.skipped = 0

    @property
    def state(self) -> UKFState:
        return self._state.filter

    @property
    def params(self) -> np.ndarray:
        return np.asarray(self._state.filter.mean, np.float64)

    @property
    def std(self) -> np.ndarray:
        return np.sqrt(np.diag(np.asarray(self._state.filter.cov, np.float64)))

    @property
    def window_length(self) -> int:
        """Consecutive observations currently held (an update needs M + 1)."""
        return int(self._state.count)

    def observe(self, object_pose: object | None, pusher_xy: object | None = None) -> bool:
        """Add one observation; returns True when λ was updated from an informative window."""
        valid = object_pose is not None and pusher_xy is not None
        if valid:
            x = np.concatenate([checked_vector("object_pose", object_pose, 3),
                                checked_vector("pusher_xy", pusher_xy, 2)])
        else:
            x = np.zeros(5)  # a gap: the replay needs consecutive observations
        ready = valid and int(self._state.count) + 1 >= self.settings.window + 1
        self._state, informative = _observe_jit(self._state, jnp.asarray(x, jnp.float32), jnp.asarray(valid),
                                                self.contour, self.settings, jnp.float32(self.mu),
                                                jnp.float32(self.dt), self.substeps)
        if ready:
            if bool(informative):
                self.updates += 1
            else:
                self.skipped += 1
        return bool(informative)
