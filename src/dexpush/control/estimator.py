"""Online estimation of the model parameters λ = [β, x_bf, y_bf] (paper Sec. III-C, Fig. 5).

A :func:`dexpush.control.ukf.ukf_update` whose measurement is a window of observations: the last
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

Robustness to a world that is not the model (docs/ukf.md#robustness):

* ``bounds_from_footprint``: x_bf, y_bf are bounded by the footprint's bounding box
  (the CoF of any pressure distribution lies inside the footprint's convex hull), not by
  the fixed ±5 cm, which a T's centroid (y = −42.9 mm) nearly touches.
* ``nis_gate`` g = 2: innovation gating (:func:`dexpush.control.ukf.ukf_update`). A window whose
  normalised innovation squared NIS/m exceeds g (m = 3M) has its innovation scaled back to
  the gate, so a window the model cannot explain moves λ no more than one at the gate.
  g = 2 is about the 99.9 % point of χ²₃₀/30 (1.99), the consistent filter's distribution.
  Gated windows are counted (``gated``).
* R holds each observed pose's noise and, correlated across the window, the noise of the
  first observed state, which the replay starts from: R = I_M ⊗ Σ + 1_M 1_Mᵀ ⊗ Σ with
  Σ = diag(σ_p², σ_p², σ_θ²). With the diagonal alone the filter was overconfident on its
  own model (median NIS/m 1.6–1.9 and NEES/3 9–20 instead of 1); with it, 1.0 and 2–3
  (``python benchmarks/ukf_consistency.py``, docs/ukf.md#robustness).
* ``prior_pull.time_s`` τ = 30 s: every observation that brings no informative window (no
  contact, no motion, an incomplete window) moves the mean toward the prior by
  1 − exp(−Δt/τ), so while the data are uninformative the estimate drifts back to the
  initial guess instead of keeping a stray value; informative windows are not biased.
* ``follow.rate`` = (0.35 in ln β, 1 cm, 1 cm) per second: λ_pred, what the planner uses
  (:func:`rate_limited`), follows the filter's mean no faster than this, so it cannot
  change β by a factor of 2 in under 2 s, nor move the CoF by more than 1 cm/s, without
  the filter holding it there that long.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from dexpush.common.checks import check_positive, check_whole
from dexpush.common.se2 import wrap_angle
from dexpush.common.settings import grouped
from dexpush.control.ukf import SigmaPoints, UKFState, clean_covariance, ukf_update
from dexpush.model.cgvmm import MU_C, Contour, contact_gap, replay

__all__ = ["EstimatorState", "Follow", "FrameGate", "PriorPull", "UKFSettings", "WindowUpdate", "estimator_init",
           "estimator_observe", "frame_gate", "prior_covariance", "rate_limited", "state_bounds", "window_update"]


@dataclass(frozen=True)
class FrameGate:
    """The frame gate (:func:`frame_gate`): an object or pusher that moved faster than ``speed_m_s``
    between two frames (plus ``margin_m``), or an object that turned faster than ``turn_rad_s`` (plus
    ``margin_rad``), is an outlier, not motion: the frame is rejected and counted."""

    speed_m_s: float = 0.5
    margin_m: float = 0.01
    turn_rad_s: float = 5.0
    margin_rad: float = 0.1

    def __post_init__(self) -> None:
        for name in ("speed_m_s", "margin_m", "turn_rad_s", "margin_rad"):
            check_positive(f"ukf.gate.{name}", getattr(self, name))


@dataclass(frozen=True)
class PriorPull:
    """Every observation that brings no informative window relaxes the filter's mean toward the
    prior with time constant ``time_s`` (s; None: never)."""

    time_s: float | None = 30.0

    def __post_init__(self) -> None:
        if self.time_s is not None:
            check_positive("ukf.prior_pull.time_s", self.time_s, "s, or None")


@dataclass(frozen=True)
class Follow:
    """How λ_pred, what the planner uses, follows the filter's mean (:func:`rate_limited`): no faster
    than ``rate`` per second in (ln β, x_bf m, y_bf m) (None: λ_pred is the mean), μ_c no faster than
    ``mu_rate`` per second."""

    rate: tuple[float, float, float] | None = (0.35, 0.01, 0.01)
    mu_rate: float = 0.05

    def __post_init__(self) -> None:
        if self.rate is not None:
            r = np.asarray(self.rate, dtype=np.float64)
            if r.shape != (3,) or not np.all(np.isfinite(r)) or np.any(r <= 0):
                raise ValueError(f"ukf.follow.rate must be 3 positive numbers (ln β, x_bf, y_bf per s) or None, "
                                 f"got {self.rate!r}")
        check_positive("ukf.follow.mu_rate", self.mu_rate, "per s")


@grouped({"gate_speed_m_s": ("gate", "speed_m_s"), "gate_margin_m": ("gate", "margin_m"),
          "gate_turn_rad_s": ("gate", "turn_rad_s"), "gate_margin_rad": ("gate", "margin_rad"),
          "prior_time_s": ("prior_pull", "time_s"), "rate_limit": ("follow", "rate"),
          "mu_rate_limit": ("follow", "mu_rate")})
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
    nis_gate: float | None = 2.0      #: NIS/m above which a window is down-weighted (None: no gating)
    bounds_from_footprint: bool = True  #: x_bf, y_bf bounds = the footprint's bounding box
    estimate_mu: bool = False         #: estimate the pusher–object friction μ_c too (a 4th state)
    mu_process_std: float = 0.005     #: μ_c's random walk per step
    mu_init_std: float = 0.1          #: μ_c's prior standard deviation
    mu_bounds: tuple[float, float] = (0.02, 1.0)  #: μ_c's bounds
    gate: FrameGate = field(default_factory=FrameGate)          #: which frames are outliers
    prior_pull: PriorPull = field(default_factory=PriorPull)    #: the mean's relaxation toward the prior
    follow: Follow = field(default_factory=Follow)              #: how λ_pred follows the filter's mean

    def __post_init__(self) -> None:
        check_whole("window", self.window, 1)
        for name in ("process_std", "init_std", "lower", "upper"):
            v = np.asarray(getattr(self, name), dtype=np.float64)
            if v.shape != (3,) or not np.all(np.isfinite(v)):
                raise ValueError(f"{name} must be 3 finite numbers (β, x_bf, y_bf), got {getattr(self, name)!r}")
        for name in ("meas_pos_std", "meas_heading_std", "alpha", "min_var", "contact_gap_m", "min_motion_m"):
            check_positive(name, getattr(self, name))
        if self.nis_gate is not None:
            check_positive("nis_gate", self.nis_gate, "or None")
        for name, kind in (("gate", FrameGate), ("prior_pull", PriorPull), ("follow", Follow)):
            if not isinstance(getattr(self, name), kind):
                raise ValueError(f"ukf.{name} must be a {kind.__name__}, got {getattr(self, name)!r}")
        for name in ("beta_ut", "kappa"):
            if not np.isfinite(getattr(self, name)):
                raise ValueError(f"{name} must be finite, got {getattr(self, name)!r}")
        for name in ("mu_process_std", "mu_init_std"):
            check_positive(name, getattr(self, name))
        if not 0 < self.mu_bounds[0] < self.mu_bounds[1]:
            raise ValueError(f"mu_bounds must satisfy 0 < low < high, got {self.mu_bounds!r}")
        if any(s <= 0 for s in (*self.process_std, *self.init_std)):
            raise ValueError("standard deviations must be > 0 (process_std, init_std)")
        if any(lo >= hi for lo, hi in zip(self.lower, self.upper)) or self.lower[0] <= 0:
            raise ValueError(f"bounds must satisfy 0 < β_lower and lower < upper, got {self.lower}, {self.upper}")

    @property
    def process(self) -> np.ndarray:
        """Per-step random-walk standard deviations of the filter's state ([β, x_bf, y_bf] or [.., μ_c])."""
        return np.asarray((*self.process_std, *((self.mu_process_std,) if self.estimate_mu else ())))

    @property
    def prior_std(self) -> np.ndarray:
        """Prior standard deviations of the filter's state."""
        return np.asarray((*self.init_std, *((self.mu_init_std,) if self.estimate_mu else ())))

    @property
    def sigma_points(self) -> SigmaPoints:
        """The UKF's sigma-point parameters (α, β_ut, κ)."""
        return SigmaPoints(self.alpha, self.beta_ut, self.kappa)


def prior_covariance(settings: UKFSettings) -> jnp.ndarray:
    """P₀ = diag(init_std)² (and mu_init_std² with ``estimate_mu``): the prior, and the cap on every
    later covariance."""
    return jnp.diag(jnp.asarray(settings.prior_std, jnp.float32) ** 2)


class WindowUpdate(NamedTuple):
    """What :func:`window_update` returns."""

    filter: UKFState          #: the updated λ mean and covariance (only the prediction if not informative)
    informative: jnp.ndarray  #: the pusher touched the object and the object moved in the window
    nis: jnp.ndarray          #: normalised innovation squared NIS/m of the window (m = 3M)
    gated: jnp.ndarray        #: NIS/m exceeded ``nis_gate``, so the window was down-weighted


def window_update(state: UKFState, contour: Contour, window: jnp.ndarray, dt: jnp.ndarray, mu: jnp.ndarray,
                  settings: UKFSettings, substeps: int, lower: jnp.ndarray | None = None,
                  upper: jnp.ndarray | None = None) -> WindowUpdate:
    """UKF step on one window of observed states (M+1, 5) within the bounds ``lower``/``upper``
    (default: :func:`state_bounds` without a footprint). Pure."""
    prior_cov = prior_covariance(settings)
    if lower is None or upper is None:
        lower, upper = state_bounds(settings)
    x0 = window[0]
    moves = (window[1:, 3:] - window[:-1, 3:]) / dt            # recorded pusher velocities
    observed = window[1:, :3]

    def predicted_poses(x: jnp.ndarray) -> jnp.ndarray:
        q = replay(contour, x0, moves, dt, x[:3], x[3] if settings.estimate_mu else mu, substeps)[:, :3]
        # heading relative to the observation, so the residual is wrapped
        heading = observed[:, 2] + wrap_angle(q[:, 2] - observed[:, 2], jnp)
        return jnp.concatenate([q[:, :2], heading[:, None]], -1).ravel()

    h = jax.vmap(predicted_poses)
    M = observed.shape[0]
    # each observed pose's own noise, plus the first observed state's, which the replay starts
    # from and so carries into every predicted pose: R = I_M ⊗ Σ + 1_M 1_Mᵀ ⊗ Σ
    sigma = jnp.diag(jnp.asarray([settings.meas_pos_std**2, settings.meas_pos_std**2, settings.meas_heading_std**2]))
    R = jnp.kron(jnp.eye(M) + jnp.ones((M, M)), sigma)
    Q = jnp.diag(jnp.asarray(settings.process, jnp.float32) ** 2)
    new = ukf_update(state, observed.ravel(), h, Q, R, points=settings.sigma_points, lower=lower,
                     upper=upper, cov_cap=prior_cov, min_var=settings.min_var, gate=settings.nis_gate)
    touched = jnp.any(contact_gap(contour, window) <= settings.contact_gap_m)
    moved = jnp.max(jnp.linalg.norm(window[1:, :2] - window[:1, :2], axis=-1)) >= settings.min_motion_m
    informative = touched & moved
    # no information: only the random-walk prediction
    skipped = UKFState(state.mean, clean_covariance(state.cov + Q, prior_cov, settings.min_var))
    out = jax.tree.map(lambda a, b: jnp.where(informative, a, b), new.state, skipped)
    return WindowUpdate(out, informative, new.nis / (3 * M), new.weight < 1.0)


class EstimatorState(NamedTuple):
    """Everything the online estimator carries between observations (a pytree)."""

    filter: UKFState          #: mean and covariance of λ (and μ_c last, with ``estimate_mu``)
    window: jnp.ndarray       #: (M+1, 5) the last observed states, oldest first
    count: jnp.ndarray        #: consecutive observations held in ``window`` (0 … M+1)
    prior: jnp.ndarray        #: (n,) the prior mean, which a reset returns to
    rejected: jnp.ndarray     #: frames the gate rejected (non-finite, or an impossible jump)
    resets: jnp.ndarray       #: times a non-finite filter state was reset to the prior
    lower: jnp.ndarray        #: (n,) bounds on the filter's state
    upper: jnp.ndarray        #: (n,)
    updates: jnp.ndarray      #: informative windows that updated λ
    gated: jnp.ndarray        #: of those, windows down-weighted by the innovation gate
    nis: jnp.ndarray          #: NIS/m of the last informative window (0 before the first)


def state_bounds(settings: UKFSettings, box: object = None) -> tuple[jnp.ndarray, jnp.ndarray]:
    """Lower and upper bounds (n,) of the filter's state: ``lower``/``upper``, x_bf and y_bf replaced by
    the footprint's bounding box ``box`` (x_lo, y_lo, x_hi, y_hi) when given and ``bounds_from_footprint``,
    and μ_c's ``mu_bounds`` appended with ``estimate_mu``."""
    lower, upper = np.asarray(settings.lower, np.float64), np.asarray(settings.upper, np.float64)
    if box is not None and settings.bounds_from_footprint:
        b = np.asarray(box, dtype=np.float64)
        if b.shape != (4,) or not np.all(np.isfinite(b)) or np.any(b[2:] <= b[:2]):
            raise ValueError(f"box must be (x_lo, y_lo, x_hi, y_hi) with lo < hi, got {box!r}")
        lower[1:], upper[1:] = b[:2], b[2:]
    if settings.estimate_mu:
        lower, upper = np.append(lower, settings.mu_bounds[0]), np.append(upper, settings.mu_bounds[1])
    return jnp.asarray(lower, jnp.float32), jnp.asarray(upper, jnp.float32)


def estimator_init(initial: jnp.ndarray, settings: UKFSettings, box: object = None,
                   mu: float = MU_C) -> EstimatorState:
    """The prior: mean ``initial`` (λ; and ``mu`` with ``settings.estimate_mu``) clipped into the
    bounds, covariance :func:`prior_covariance`, empty window.

    ``box`` (x_lo, y_lo, x_hi, y_hi), the footprint's bounding box in {B} (``Shape.footprint_box``),
    bounds x_bf, y_bf when ``settings.bounds_from_footprint``; else ``lower``/``upper`` do.
    """
    lower, upper = state_bounds(settings, box)
    initial = jnp.asarray(initial, jnp.float32)
    if settings.estimate_mu:
        initial = jnp.append(initial, jnp.float32(mu))
    mean = jnp.clip(initial, lower, upper)
    zero = jnp.zeros((), jnp.int32)
    return EstimatorState(UKFState(mean, prior_covariance(settings)),
                          jnp.zeros((settings.window + 1, 5), jnp.float32), zero, mean, zero, zero, lower, upper,
                          zero, zero, jnp.zeros((), jnp.float32))


def rate_limited(previous: jnp.ndarray, target: jnp.ndarray, dt: jnp.ndarray, settings: UKFSettings) -> jnp.ndarray:
    """λ_pred (and μ_c, a 4th entry) moved from ``previous`` toward ``target`` (the filter's mean)
    by at most ``follow.rate``·dt: ln β, x_bf and y_bf each within its rate (μ_c within
    ``follow.mu_rate``·dt). Pure."""
    if settings.follow.rate is None:
        return target
    step = jnp.asarray((*settings.follow.rate, settings.follow.mu_rate)[:previous.shape[0]], jnp.float32) * dt
    log_beta = jnp.log(previous[0]) + jnp.clip(jnp.log(target[0]) - jnp.log(previous[0]), -step[0], step[0])
    rest = previous[1:] + jnp.clip(target[1:] - previous[1:], -step[1:], step[1:])
    return jnp.concatenate([jnp.exp(log_beta)[None], rest])


def frame_gate(last: jnp.ndarray, observation: jnp.ndarray, dt: jnp.ndarray, settings: UKFSettings) -> jnp.ndarray:
    """Whether ``observation`` (5,) may follow ``last`` (5,) after ``dt`` seconds: finite, and neither the
    object nor the pusher moved or turned faster than the gate allows (a glitched frame does)."""
    reach = settings.gate.speed_m_s * dt + settings.gate.margin_m
    turn = settings.gate.turn_rad_s * dt + settings.gate.margin_rad
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
    filter. Every call without an informative window, the mean relaxes toward the prior
    (``prior_pull.time_s``). Should the
    filter's mean or covariance still turn non-finite, it is reset to the prior (counted in
    ``resets``). Returns the new state and whether λ was updated from an informative window.
    """
    M1 = settings.window + 1
    finite = jnp.all(jnp.isfinite(observation))
    passes = jnp.where(state.count > 0, frame_gate(state.window[-1], observation, dt, settings), finite)
    rejected = state.rejected + (valid & ~passes).astype(jnp.int32)
    valid = valid & passes
    window = jnp.concatenate([state.window[1:], jnp.where(valid, observation, 0.0)[None]])
    count = jnp.where(valid, jnp.minimum(state.count + 1, M1), 0)
    new = window_update(state.filter, contour, window, dt, mu, settings, substeps, state.lower, state.upper)
    ready = count >= M1
    filt = jax.tree.map(lambda a, b: jnp.where(ready, a, b), new.filter, state.filter)
    if settings.prior_pull.time_s is not None:     # no information this time: relax toward the prior
        pull = jnp.where(ready & new.informative, 0.0, -jnp.expm1(-dt / settings.prior_pull.time_s))
        filt = UKFState(filt.mean + pull * (state.prior - filt.mean), filt.cov)
    sound = jnp.all(jnp.isfinite(filt.mean)) & jnp.all(jnp.isfinite(filt.cov))
    prior = UKFState(state.prior, prior_covariance(settings))
    filt = jax.tree.map(lambda a, b: jnp.where(sound, a, b), filt, prior)
    resets = state.resets + (~sound).astype(jnp.int32)
    updated = ready & new.informative & sound
    return EstimatorState(filt, window, count, state.prior, rejected, resets, state.lower, state.upper,
                          state.updates + updated.astype(jnp.int32),
                          state.gated + (updated & new.gated).astype(jnp.int32),
                          jnp.where(updated, new.nis, state.nis)), updated
