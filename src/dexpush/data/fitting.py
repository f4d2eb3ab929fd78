"""Fitting λ (and μ_c) to recorded pushes: the residuals, the fits and their uncertainty.

A recorded push (:class:`dexpush.data.push.Push`) is object poses and pusher positions on a uniform 25 Hz
grid (:func:`dexpush.data.push.resample` makes one from any timed stream). Per sample k, with x_k = [q_k, p_k]
and the pusher velocity u_k = (p_{k+1} − p_k)/Δt, the one-step residual is the C-GVMM's
prediction from x_k with u_k over Δt (:func:`dexpush.model.cgvmm.integrate`, 10 Euler substeps)
minus the recorded q_{k+1}, as [Δx, Δy, c·Δθ] with c = 0.05 m/rad (a 5-cm lever arm).

* :func:`fit_beta`: β with p_bf = 0, golden-section search on log β after a coarse grid;
* :func:`fit_lambda`: λ = [β, x_bf, y_bf] (and optionally μ_c) by Levenberg–Marquardt on
  the residuals, with the Gauss–Newton covariance σ²(JᵀJ)⁻¹, σ² = ‖r‖²/(n − p), as its
  uncertainty (a local, white-noise figure: it shrinks with more samples and ignores
  model error);
* :func:`whole_push_errors`: the open-loop replay of each whole push from its first sample.

:mod:`dexpush.data.mit` (the MIT pushes) and ``dexpush fit`` (your own logs) both use these.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from dexpush.common.checks import check_positive
from dexpush.common.se2 import pose_error, wrap_angle
from dexpush.data.labelling import Samples, contact_geometry, samples
from dexpush.data.push import RATE_HZ, Push
from dexpush.model.cgvmm import FREE, Contour, integrate, replay
from dexpush.model.shape import Shape

__all__ = ["MAX_FIT_SAMPLES", "FitResult", "LambdaFit", "fit_beta", "fit_lambda", "fit_pushes", "one_step",
           "replay_push", "residuals", "whole_push_errors"]


def one_step(contour: Contour, states: np.ndarray, inputs: np.ndarray, lam: np.ndarray,
             mu: float | np.ndarray) -> np.ndarray:
    """The model's states (S, 5) after one 25 Hz period from ``states`` with ``inputs``; ``lam`` is (3,)
    or one λ per sample (S, 3), ``mu`` one μ_c or one per sample (S,)."""
    n = len(states)
    lam = np.broadcast_to(np.asarray(lam, np.float32), (n, 3))
    mu = np.broadcast_to(np.asarray(mu, np.float32), (n,))
    return np.asarray(_one_step(contour, jnp.asarray(states, jnp.float32), jnp.asarray(inputs, jnp.float32),
                                jnp.asarray(lam), jnp.asarray(mu)), np.float64)


@jax.jit
def _one_step(contour: Contour, x: jnp.ndarray, u: jnp.ndarray, lam: jnp.ndarray, mu: jnp.ndarray) -> jnp.ndarray:
    return jax.vmap(lambda xi, ui, li, mi: integrate(contour, xi, ui, 1.0 / RATE_HZ, li, mi, 10))(x, u, lam, mu)


@jax.jit
def _replay_final(contour: Contour, x0: jnp.ndarray, U: jnp.ndarray, lam: jnp.ndarray, mu: jnp.ndarray) -> jnp.ndarray:
    return replay(contour, x0, U, 1.0 / RATE_HZ, lam, mu, 10)[-1]


def residuals(contour: Contour, smp: Samples, lam: np.ndarray, mu: float) -> np.ndarray:
    """One-step residuals [Δx, Δy, c·Δθ] (m), c = 0.05 m/rad (a 5-cm lever arm)."""
    pred = one_step(contour, smp.states, smp.inputs, lam, mu)[:, :3]
    d = pred - smp.next_pose
    d[:, 2] = 0.05 * wrap_angle(d[:, 2])
    return d.reshape(-1)


def fit_beta(contour: Contour, smp: Samples, mu: float, lo: float = 2.0, hi: float = 400.0) -> float:
    """β minimising the one-step residuals with p_bf = 0 (golden-section search on log β)."""
    def f(logb: float) -> float:
        return float(np.sum(residuals(contour, smp, np.array([np.exp(logb), 0.0, 0.0]), mu) ** 2))

    a, b = np.log(lo), np.log(hi)
    grid = np.linspace(a, b, 17)  # coarse bracket first: the objective need not be unimodal
    vals = [f(g) for g in grid]
    j = int(np.argmin(vals))
    a, b = grid[max(j - 1, 0)], grid[min(j + 1, len(grid) - 1)]
    g = (np.sqrt(5) - 1) / 2
    c, d = b - g * (b - a), a + g * (b - a)
    fc, fd = f(c), f(d)
    for _ in range(30):
        if fc < fd:
            b, d, fd = d, c, fc
            c = b - g * (b - a)
            fc = f(c)
        else:
            a, c, fc = c, d, fd
            d = a + g * (b - a)
            fd = f(d)
    return float(np.exp(0.5 * (a + b)))


class LambdaFit(NamedTuple):
    """A Levenberg–Marquardt fit: λ, μ_c, their 1-σ uncertainty, and the residual size."""

    lam: np.ndarray          #: (3,) λ = [β, x_bf, y_bf]
    mu: float                #: μ_c (fitted, or as given)
    std: np.ndarray          #: (3,) or (4,) 1-σ of [β, x_bf, y_bf(, μ_c)] from σ²(JᵀJ)⁻¹
    rms: float               #: root-mean-square residual (m)


def fit_lambda(contour: Contour, smp: Samples, mu: float, beta0: float, iters: int = 15,
               fit_mu: bool = False) -> LambdaFit:
    """λ = [β, x_bf, y_bf] (and μ_c with ``fit_mu``) by Levenberg–Marquardt on the one-step
    residuals, from [β₀, 0, 0] (and the given μ_c); finite-difference Jacobian; |p_bf| ≤ 5 cm,
    β ≥ 1, μ_c in [0.02, 2]. The uncertainty is the Gauss–Newton covariance at the optimum."""
    x = np.array([beta0, 0.0, 0.0, mu] if fit_mu else [beta0, 0.0, 0.0])
    scale = np.array([beta0 * 0.02, 1e-3, 1e-3, 0.01][:len(x)])

    def res(v: np.ndarray) -> np.ndarray:
        return residuals(contour, smp, v[:3], float(v[3]) if fit_mu else mu)

    def jacobian(v: np.ndarray, r: np.ndarray) -> np.ndarray:
        return np.stack([(res(v + scale * e) - r) / scale[i] for i, e in enumerate(np.eye(len(v)))], -1)

    r = res(x)
    damping = 1e-2
    for _ in range(iters):
        J = jacobian(x, r)
        A, g = J.T @ J, J.T @ r
        cand = x - np.linalg.solve(A + damping * np.diag(np.diag(A) + 1e-12), g)
        cand[0] = max(cand[0], 1.0)
        cand[1:3] = np.clip(cand[1:3], -0.05, 0.05)
        if fit_mu:
            cand[3] = np.clip(cand[3], 0.02, 2.0)
        rc = res(cand)
        if rc @ rc < r @ r:
            x, r, damping = cand, rc, damping * 0.3
        else:
            damping *= 10
    J = jacobian(x, r)
    dof = max(len(r) - len(x), 1)
    A = J.T @ J
    seen = np.diag(A) > 1e-12 * np.max(np.diag(A))          # a parameter the residuals do not depend on ...
    cov = np.full((len(x), len(x)), np.inf)
    cov[np.ix_(seen, seen)] = (r @ r / dof) * np.linalg.pinv(A[np.ix_(seen, seen)])
    return LambdaFit(x[:3].copy(), float(x[3]) if fit_mu else float(mu),   # ... has an infinite uncertainty
                     np.sqrt(np.maximum(np.diag(cov), 0.0)), float(np.sqrt(np.mean(r**2))))


def whole_push_errors(contour: Contour, pushes: list[Push], lam: np.ndarray, mu: float) -> tuple[float, float]:
    """Mean final-pose error (mm, deg) of open-loop replays from each push's first sample."""
    pos, head = [], []
    for p in pushes:
        x0 = p.states[0].copy()
        x0[3:] = contact_geometry(contour, x0[None])[4][0]   # pushes start in contact (dataset README)
        U = np.diff(p.pusher_xy, axis=0) * RATE_HZ
        x = _replay_final(contour, jnp.asarray(x0, jnp.float32), jnp.asarray(U, jnp.float32),
                          jnp.asarray(lam, jnp.float32), jnp.float32(mu))
        e_pos, e_head = pose_error(np.asarray(x[:3], np.float64), p.object_pose[-1])
        pos.append(e_pos * 1000)
        head.append(e_head)
    return float(np.mean(pos)), float(np.mean(head))


@jax.jit
def _replay_all(contour: Contour, x0: jnp.ndarray, U: jnp.ndarray, lam: jnp.ndarray, mu: jnp.ndarray) -> jnp.ndarray:
    return replay(contour, x0, U, 1.0 / RATE_HZ, lam, mu, 10)


def replay_push(contour: Contour, push: Push, lam: np.ndarray, mu: float) -> np.ndarray:
    """The model's open-loop replay (T, 5) of a whole push, from its first sample with the pusher put on
    the contour, driven by the recorded pusher motion (the trajectory behind :func:`whole_push_errors`)."""
    x0 = push.states[0].copy()
    x0[3:] = contact_geometry(contour, x0[None])[4][0]
    U = np.diff(push.pusher_xy, axis=0) * RATE_HZ
    X = _replay_all(contour, jnp.asarray(x0, jnp.float32), jnp.asarray(U, jnp.float32),
                    jnp.asarray(lam, jnp.float32), jnp.float32(mu))
    return np.asarray(X, np.float64)


@dataclass
class FitResult:
    """λ (and μ_c) fitted to recorded pushes of one object, with the fit's prediction errors."""

    lam: np.ndarray                  #: (3,) λ = [β, x_bf, y_bf]
    lam_std: np.ndarray              #: (3,) 1-σ
    mu: float                        #: μ_c (fitted when ``mu_std`` is not None)
    mu_std: float | None             #: inf when no sample slides (μ_c then does not show in the data)
    pushes: int
    samples: int                     #: 25 Hz samples with the pusher moving
    one_step_error_mm: float         #: mean one-step position error with the fitted λ
    one_step_error_deg: float
    whole_push_error_mm: float       #: mean final-pose error of whole-push open-loop replays
    whole_push_error_deg: float
    replays: list[np.ndarray] = field(default_factory=list, repr=False)   #: (T, 5) per push
    motion_mm: float = float("nan")  #: mean recorded object motion per sample, for scale

    @property
    def explains(self) -> bool:
        """Whether the model explains the motion: its one-step error is below half the motion per sample
        (a wrong shape, exchanged columns or degrees for radians give errors as large as the motion)."""
        return bool(self.one_step_error_mm < 0.5 * self.motion_mm)

    def summary(self) -> dict:
        return {"lambda": [round(float(v), 5) for v in self.lam],
                "lambda_std": [round(float(v), 5) if np.isfinite(v) else None for v in self.lam_std],
                "mu_c": round(self.mu, 4),
                "mu_c_std": None if self.mu_std is None or not np.isfinite(self.mu_std) else round(self.mu_std, 4),
                "pushes": self.pushes, "samples": self.samples,
                "one_step_error_mm": round(self.one_step_error_mm, 3),
                "one_step_error_deg": round(self.one_step_error_deg, 3),
                "whole_push_error_mm": round(self.whole_push_error_mm, 2),
                "whole_push_error_deg": round(self.whole_push_error_deg, 2),
                "motion_mm_per_sample": round(self.motion_mm, 3)}


#: the most contact samples a fit uses: more are thinned evenly (the fit's cost grows with the samples,
#: its estimate hardly moves past a few thousand); ``FitResult.samples`` says how many were used
MAX_FIT_SAMPLES = 20_000


def _local(push: Push, origin: np.ndarray) -> Push:
    """``push`` with its positions taken from ``origin`` (x, y): λ is in the body frame, so a fit is the same
    in any world frame, and positions near zero keep float32's resolution."""
    return dataclasses.replace(push, object_pose=push.object_pose - np.r_[origin, 0.0],
                               pusher_xy=push.pusher_xy - origin)


def _thinned(smp: Samples, keep: int) -> Samples:
    if len(smp.observed) <= keep:
        return smp
    idx = np.linspace(0, len(smp.observed) - 1, keep).round().astype(int)
    return Samples(*(np.asarray(a)[idx] for a in dataclasses.astuple(smp)))


def fit_pushes(pushes: list[Push], shape: Shape, mu: float = 0.25, fit_mu: bool = False,
               separation_mm: float = 3.0, stick_ratio: float = 0.1, min_speed_mm_s: float = 5.0) -> FitResult:
    """Fit λ (and μ_c) to ``pushes`` of ``shape``: β first (:func:`fit_beta`), then the full
    λ by :func:`fit_lambda` from there; the sample selection is :func:`samples`' (at most
    :data:`MAX_FIT_SAMPLES`, thinned evenly). Each push is fitted in a frame at its first pose."""
    if not pushes:
        raise ValueError("no pushes to fit")
    check_positive("mu", mu, "the pusher–object friction coefficient (its start value with fit_mu)")
    origins = [np.asarray(p.object_pose[0, :2], np.float64) for p in pushes]
    pushes = [_local(p, o) for p, o in zip(pushes, origins)]
    contour = Contour.of(shape)
    smp = _thinned(samples(pushes, shape, separation_mm, stick_ratio, min_speed_mm_s), MAX_FIT_SAMPLES)
    n_contact = int(np.sum(smp.observed != FREE))
    if n_contact < 10:
        raise ValueError(f"only {n_contact} samples with the pusher moving ≥ {min_speed_mm_s:g} mm/s in contact "
                         "(within 3 mm of the contour): too few to fit λ. Does the shape match the object, and the "
                         "pose refer to the shape's reference point?")
    beta = fit_beta(contour, smp, mu)
    if fit_mu:   # μ_c only shows in sliding samples, and the residuals are flat in it where all stick: grid first
        grid = np.geomspace(0.05, 1.5, 16)
        mu = float(grid[np.argmin([np.sum(residuals(contour, smp, np.array([beta, 0.0, 0.0]), m) ** 2)
                                   for m in grid])])
    fit = fit_lambda(contour, smp, mu, beta, fit_mu=fit_mu)
    r = residuals(contour, smp, fit.lam, fit.mu).reshape(-1, 3)
    wp = whole_push_errors(contour, pushes, fit.lam, fit.mu)
    motion = np.linalg.norm(smp.next_pose[:, :2] - smp.states[:, :2], axis=-1)
    replays = [replay_push(contour, p, fit.lam, fit.mu) + np.r_[o, 0.0, o] for p, o in zip(pushes, origins)]
    return FitResult(fit.lam, fit.std[:3], fit.mu, float(fit.std[3]) if fit_mu else None, len(pushes),
                     len(smp.observed), float(np.mean(np.hypot(r[:, 0], r[:, 1]))) * 1000,
                     float(np.degrees(np.mean(np.abs(r[:, 2]) / 0.05))), wp[0], wp[1], replays,
                     float(np.mean(motion)) * 1000)
