"""Online estimation of the model parameters λ = [β, x_bf, y_bf] (paper Sec. III-C, Fig. 5).

A :func:`dexpush.ukf.ukf_update` whose measurement is a window of observations: the last
M observed object poses q_{t−M+1..t} against a replay of the C-GVMM with λ from the first
observed state of the window, s_{t−M}, driven by the recorded pusher displacements (not
the commands, so delay and tracking error of a real robot are in the data). Residual
headings are wrapped. A window in which the pusher never came within ``contact_gap_m`` of
the contour, or the object moved less than ``min_motion_m``, carries no information about
λ and is skipped (only the random-walk prediction). The estimator is pure:
:func:`estimator_init` gives its state, :func:`estimator_observe` takes one observation;
:class:`dexpush.PushingController` and the batched simulator both call it.

Settings (:class:`UKFSettings`), and why:

* ``window`` M = 10 steps (0.4 s at 25 Hz): long enough for the object to move several
  millimetres while pushed, short enough that the replay from s_{t−M} stays close.
* ``process_std`` = (0.5 1/m, 0.5 mm, 0.5 mm) a step: lets β move by ~±15 1/m over a
  1-s window of contact, so an initial guess of 15 reaches 25 within seconds.
* ``meas_pos_std`` = 1 mm, ``meas_heading_std`` = 0.5°: observation noise of a motion
  capture or camera system (docs/conventions.md#plants) plus the model's own replay error.
* α = 1, β_ut = 2, κ = 0: sigma points at ±√3·σ; small α would probe λ only
  infinitesimally, where the piecewise (mode-switching) model is not smooth.
* bounds β ∈ [2, 200] 1/m, |x_bf|, |y_bf| ≤ 5 cm: physical (β = f_max/m_max of objects of
  5–50 cm; the CoF lies inside the footprint).
* prior: the controller's λ_pred with σ = (10 1/m, 1 cm, 1 cm).
* frame gate: 0.5 m/s and 5 rad/s between frames, plus 1 cm and 0.1 rad: five times the
  pusher's speed limit and ten times the camera noise, so real motion always passes and a
  glitched frame (the pusher or object half a metre off for one frame) never does.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from dexpush.checks import check_positive
from dexpush.model import Contour, contact_gap, replay
from dexpush.se2 import wrap_angle
from dexpush.ukf import SigmaPoints, UKFState, clean_covariance, ukf_update

__all__ = ["EstimatorState", "UKFSettings", "estimator_init", "estimator_observe", "frame_gate", "prior_covariance",
           "window_update"]


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
    gate_speed_m_s: float = 0.5       #: frame gate: object or pusher moving faster than this between
    gate_margin_m: float = 0.01       #: two frames (plus this margin) is an outlier, not motion
    gate_turn_rad_s: float = 5.0      #: likewise for the object's heading (rad/s) ...
    gate_margin_rad: float = 0.1      #: ... plus this margin

    def __post_init__(self) -> None:
        if int(self.window) != self.window or self.window < 1:
            raise ValueError(f"window must be a whole number >= 1, got {self.window!r}")
        for name in ("process_std", "init_std", "lower", "upper"):
            v = np.asarray(getattr(self, name), dtype=np.float64)
            if v.shape != (3,) or not np.all(np.isfinite(v)):
                raise ValueError(f"{name} must be 3 finite numbers (β, x_bf, y_bf), got {getattr(self, name)!r}")
        for name in ("meas_pos_std", "meas_heading_std", "alpha", "min_var", "contact_gap_m", "min_motion_m",
                     "gate_speed_m_s", "gate_margin_m", "gate_turn_rad_s", "gate_margin_rad"):
            check_positive(name, getattr(self, name))
        for name in ("beta_ut", "kappa"):
            if not np.isfinite(getattr(self, name)):
                raise ValueError(f"{name} must be finite, got {getattr(self, name)!r}")
        if any(s <= 0 for s in (*self.process_std, *self.init_std)):
            raise ValueError("standard deviations must be > 0 (process_std, init_std)")
        if any(lo >= hi for lo, hi in zip(self.lower, self.upper)) or self.lower[0] <= 0:
            raise ValueError(f"bounds must satisfy 0 < β_lower and lower < upper, got {self.lower}, {self.upper}")

    @property
    def sigma_points(self) -> SigmaPoints:
        """The UKF's sigma-point parameters (α, β_ut, κ)."""
        return SigmaPoints(self.alpha, self.beta_ut, self.kappa)


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
    new = ukf_update(state, observed.ravel(), h, Q, jnp.diag(r), points=settings.sigma_points,
                     lower=jnp.asarray(settings.lower), upper=jnp.asarray(settings.upper), cov_cap=prior_cov,
                     min_var=settings.min_var)
    touched = jnp.any(contact_gap(contour, window) <= settings.contact_gap_m)
    moved = jnp.max(jnp.linalg.norm(window[1:, :2] - window[:1, :2], axis=-1)) >= settings.min_motion_m
    informative = touched & moved
    # no information: only the random-walk prediction
    skipped = UKFState(state.mean, clean_covariance(state.cov + Q, prior_cov, settings.min_var))
    out = jax.tree.map(lambda a, b: jnp.where(informative, a, b), new, skipped)
    return out, informative


class EstimatorState(NamedTuple):
    """Everything the online estimator carries between observations (a pytree)."""

    filter: UKFState          #: λ mean and covariance
    window: jnp.ndarray       #: (M+1, 5) the last observed states, oldest first
    count: jnp.ndarray        #: consecutive observations held in ``window`` (0 … M+1)
    prior: jnp.ndarray        #: (3,) the prior mean, which a reset returns to
    rejected: jnp.ndarray     #: frames the gate rejected (non-finite, or an impossible jump)
    resets: jnp.ndarray       #: times a non-finite filter state was reset to the prior


def estimator_init(initial: jnp.ndarray, settings: UKFSettings) -> EstimatorState:
    """The prior: mean ``initial`` clipped into the bounds, covariance diag(init_std)², empty window."""
    mean = jnp.clip(jnp.asarray(initial, jnp.float32), jnp.asarray(settings.lower, jnp.float32),
                    jnp.asarray(settings.upper, jnp.float32))
    zero = jnp.zeros((), jnp.int32)
    return EstimatorState(UKFState(mean, prior_covariance(settings)),
                          jnp.zeros((settings.window + 1, 5), jnp.float32), zero, mean, zero, zero)


def frame_gate(last: jnp.ndarray, observation: jnp.ndarray, dt: jnp.ndarray, settings: UKFSettings) -> jnp.ndarray:
    """Whether ``observation`` (5,) may follow ``last`` (5,) after ``dt`` seconds: finite, and neither the
    object nor the pusher moved or turned faster than the gate allows (a glitched frame does)."""
    reach = settings.gate_speed_m_s * dt + settings.gate_margin_m
    turn = settings.gate_turn_rad_s * dt + settings.gate_margin_rad
    d = observation - last
    return (jnp.all(jnp.isfinite(observation)) & (jnp.hypot(d[0], d[1]) <= reach)
            & (jnp.abs(wrap_angle(d[2], jnp)) <= turn) & (jnp.hypot(d[3], d[4]) <= reach))


def estimator_observe(state: EstimatorState, observation: jnp.ndarray, valid: jnp.ndarray, contour: Contour,
                      settings: UKFSettings, mu: jnp.ndarray, dt: jnp.ndarray,
                      substeps: int) -> tuple[EstimatorState, jnp.ndarray]:
    """Add one observed state (5,) and update λ once the window is full. Pure and jit-able.

    ``valid`` False (a dropped frame) empties the window: the replay needs consecutive
    observations, so the next update waits for M+1 new ones. A frame that fails
    :func:`frame_gate` against the previous one (NaN, infinity, or a jump no pusher or object
    makes in ``dt``) is rejected the same way and counted in ``rejected``; it never reaches the
    filter. Should the filter's mean or covariance still turn non-finite, it is reset to the
    prior (counted in ``resets``). Returns the new state and whether λ was updated from an
    informative window.
    """
    M1 = settings.window + 1
    finite = jnp.all(jnp.isfinite(observation))
    passes = jnp.where(state.count > 0, frame_gate(state.window[-1], observation, dt, settings), finite)
    rejected = state.rejected + (valid & ~passes).astype(jnp.int32)
    valid = valid & passes
    window = jnp.concatenate([state.window[1:], jnp.where(valid, observation, 0.0)[None]])
    count = jnp.where(valid, jnp.minimum(state.count + 1, M1), 0)
    updated, informative = window_update(state.filter, contour, window, dt, mu, settings, substeps)
    ready = count >= M1
    filt = jax.tree.map(lambda a, b: jnp.where(ready, a, b), updated, state.filter)
    sound = jnp.all(jnp.isfinite(filt.mean)) & jnp.all(jnp.isfinite(filt.cov))
    prior = UKFState(state.prior, prior_covariance(settings))
    filt = jax.tree.map(lambda a, b: jnp.where(sound, a, b), filt, prior)
    resets = state.resets + (~sound).astype(jnp.int32)
    return EstimatorState(filt, window, count, state.prior, rejected, resets), ready & informative & sound
