"""A generic unscented Kalman filter step (filterpy's notation), with the measurement and residual injected.

The state is a random walk; the measurement function ``h`` is evaluated on all sigma
points in one batched call, so a costly ``h`` (dexpush replays the C-GVMM) runs vmapped.

    n = dim x,  λ_ut = α²(n + κ) − n                         (Merwe's scaled sigma points)
    predict:   x⁻ = x,  P⁻ = P + Q                                           (random walk)
    sigma:     χ₀ = x⁻,  χ_i = x⁻ ± [√((n + λ_ut) P⁻)]_i,  i = 1 … n        (2n + 1 points)
               Wm₀ = λ_ut/(n + λ_ut),  Wc₀ = Wm₀ + (1 − α² + β_ut),  Wm_i = Wc_i = 1/(2(n + λ_ut))
    measure:   𝒴_i = h(χ_i),  ẑ = Σ Wm_i 𝒴_i
               S = Σ Wc_i r(𝒴_i, ẑ) r(𝒴_i, ẑ)ᵀ + R,  P_xz = Σ Wc_i (χ_i − x⁻) r(𝒴_i, ẑ)ᵀ
    gate:      ν = r(z, ẑ),  NIS = νᵀ S⁻¹ ν,  w = min(1, √(m·g / NIS))          (m = dim z, g = gate)
    update:    K = P_xz S⁻¹,  x = clip(x⁻ + w K ν, lower, upper),  P = P⁻ − w K S Kᵀ

The gate is a robust (Huber-like) down-weighting: while the normalised innovation squared
NIS/m stays below g, the update is the plain UKF's; beyond it the innovation is scaled back
to the gate's Mahalanobis length and the covariance shrinks by the same fraction, so an
innovation the filter cannot explain (a model error, not noise) moves x no further than one
at the gate would, and teaches it proportionally less. (Inflating R instead does little when
the sigma points' own spread S_𝒴 dominates S.) ``gate=None`` turns it off.

``r`` is the residual function (default ``a − b``; pass one that wraps angles when the
measurement holds headings). Sigma points are clipped into the bounds before ``h`` sees
them. After each update P is symmetrised and its eigenvalues are floored at ``min_var``
and capped at the largest prior variance (:func:`clean_covariance`), so it stays
symmetric positive definite whatever the measurement does.

The pushing estimator built on it (the window of observations, the C-GVMM replay, the
settings) is :mod:`dexpush.control.estimator`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import NamedTuple

import jax
import jax.numpy as jnp

__all__ = ["SigmaPoints", "UKFState", "UKFUpdate", "clean_covariance", "sigma_points", "ukf_update"]


@dataclass(frozen=True)
class UKFState:
    """Mean x (n,) and covariance P (n, n) of the filter's state."""

    mean: jnp.ndarray
    cov: jnp.ndarray


jax.tree_util.register_dataclass(UKFState, data_fields=["mean", "cov"], meta_fields=[])


@dataclass(frozen=True)
class SigmaPoints:
    """Merwe's scaled sigma points: spread ``alpha``, prior-knowledge ``beta`` (2 for a Gaussian), ``kappa``."""

    alpha: float = 1.0
    beta: float = 2.0
    kappa: float = 0.0


def sigma_points(mean: jnp.ndarray, cov: jnp.ndarray, s: SigmaPoints) -> tuple[jnp.ndarray, ...]:
    """The 2n+1 sigma points (rows) and their mean/covariance weights (Wm, Wc)."""
    n = mean.shape[0]
    lam = s.alpha**2 * (n + s.kappa) - n
    L = jnp.linalg.cholesky((n + lam) * cov)
    X = jnp.concatenate([mean[None], mean[None] + L.T, mean[None] - L.T])
    wm = jnp.full(2 * n + 1, 1.0 / (2 * (n + lam))).at[0].set(lam / (n + lam))
    wc = wm.at[0].add(1 - s.alpha**2 + s.beta)
    return X, wm, wc


def clean_covariance(P: jnp.ndarray, cap: jnp.ndarray, min_var: float) -> jnp.ndarray:
    """P symmetrised, its eigenvalues clipped to [min_var, max diag(cap)]."""
    P = 0.5 * (P + P.T)
    w, V = jnp.linalg.eigh(P)
    w = jnp.clip(w, min_var, jnp.max(jnp.diag(cap)))
    return (V * w) @ V.T


class UKFUpdate(NamedTuple):
    """What :func:`ukf_update` returns: the new state and the innovation's consistency."""

    state: UKFState
    nis: jnp.ndarray        #: νᵀ S⁻¹ ν with the unscaled S (χ² with m degrees of freedom when consistent)
    weight: jnp.ndarray     #: w ≤ 1, the weight the gate gave the innovation (1: not gated)


def _subtract(a: jnp.ndarray, b: jnp.ndarray) -> jnp.ndarray:
    return a - b


def ukf_update(state: UKFState, z: jnp.ndarray, h: Callable[[jnp.ndarray], jnp.ndarray], Q: jnp.ndarray,
               R: jnp.ndarray, *, points: SigmaPoints, lower: jnp.ndarray, upper: jnp.ndarray,
               cov_cap: jnp.ndarray, min_var: float = 1e-10, gate: float | None = None,
               residual: Callable[[jnp.ndarray, jnp.ndarray], jnp.ndarray] = _subtract) -> UKFUpdate:
    """One predict + update step (equations in the module docstring). Pure and jit-able.

    Args:
        state: x (n,) and P (n, n).
        z: the measurement (m,).
        h: maps sigma points (2n+1, n) to predicted measurements (2n+1, m).
        Q, R: process (n, n) and measurement (m, m) noise covariances.
        points: the sigma-point parameters.
        lower, upper: bounds on x (sigma points and the updated mean are clipped).
        cov_cap: P's eigenvalues are capped at the largest diagonal entry of this matrix.
        min_var: and floored at this.
        gate: g, the largest NIS/m taken at face value (None: no gate).
        residual: r(a, b), the difference of two measurements.
    """
    P = state.cov + Q
    X, wm, wc = sigma_points(state.mean, P, points)
    X = jnp.clip(X, lower, upper)
    Y = h(X)
    z_hat = wm @ Y
    dY, dX = residual(Y, z_hat), X - state.mean
    S = (wc[:, None] * dY).T @ dY + R
    Pxz = (wc[:, None] * dX).T @ dY
    nu = residual(z, z_hat)
    nis = nu @ jnp.linalg.solve(S, nu)
    w = jnp.ones_like(nis) if gate is None else jnp.minimum(1.0, jnp.sqrt(gate * z.shape[0] / nis))
    K = jnp.linalg.solve(S, Pxz.T).T
    mean = jnp.clip(state.mean + w * (K @ nu), lower, upper)
    cov = clean_covariance(P - w * (K @ S @ K.T), cov_cap, min_var)
    return UKFUpdate(UKFState(mean, cov), nis, w)
