"""The controller's online λ estimator run over recorded pushes (``dexpush validate-mit --online``).

Per object, the pushes are taken in file order as one session, as a robot that pushes the
same object again and again would see them: the UKF of :mod:`dexpush.control.estimator`, with the
controller's settings, observes every 25 Hz sample; its window is emptied between pushes (the
replay needs consecutive frames) and its state carries over to the next push; λ_pred follows
the filter's mean within the rate limit, as :func:`dexpush.control.policy.estimate_step` does. As
in :func:`dexpush.data.validation.validate`, a pusher observed within ``separation_mm`` of the contour
is put onto it (the tip/Vicon calibration offset).

Reported per object (``docs/validation.md#online-estimation``):

* λ_pred over the session, the filter's informative and gated windows;
* convergence: the first push after which ln β stays within ±0.2 (±22 %) of its value at the
  end of the session and p_bf within 5 mm;
* the whole-push prediction error (mm, deg): each push replayed open loop with λ_pred as it
  stood *before* that push (what a planner would have had), against the prior λ₀;
* NMSE of the one-step (40 ms) object displacement, as Bauza & Rodriguez (2017) report it
  (their analytical model 0.72, their learned VHGP 0.37): per output Δx, Δy, Δθ the mean
  squared prediction error over the variance of the observed displacements, averaged over
  the three; with λ_pred before each push, and with λ₀.
"""

from __future__ import annotations

from functools import partial

import jax
import jax.numpy as jnp
import numpy as np

from dexpush.common.se2 import wrap_angle
from dexpush.control.estimator import EstimatorState, UKFSettings, estimator_init, estimator_observe, rate_limited
from dexpush.data.fitting import one_step, whole_push_errors
from dexpush.data.labelling import samples, snap_contact
from dexpush.data.push import RATE_HZ, Push
from dexpush.model.cgvmm import Contour
from dexpush.model.shape import Shape

__all__ = ["nmse", "online_session"]

#: convergence bands: ln β within ±0.2, p_bf within 5 mm of the session's last estimate
SETTLE_LOG_BETA, SETTLE_M = 0.2, 0.005


@partial(jax.jit, static_argnames=("settings", "substeps"))
def _scan(est: EstimatorState, lam: jnp.ndarray, contour: Contour, X: jnp.ndarray, valid: jnp.ndarray,
          mu: jnp.ndarray, settings: UKFSettings, substeps: int) -> tuple[jnp.ndarray, jnp.ndarray]:
    dt = jnp.float32(1.0 / RATE_HZ)

    def body(carry, inp):
        est, lam = carry                      # lam: λ_pred, and the planner's μ_c last with estimate_mu
        x, ok = inp
        est, updated = estimator_observe(est, x, ok, contour, settings, lam[3] if settings.estimate_mu else mu,
                                         dt, substeps)
        lam = rate_limited(lam, est.filter.mean, dt, settings)
        return (est, lam), (lam, updated, est.gated)

    return jax.lax.scan(body, (est, lam), (X, valid))[1]


def nmse(predicted: np.ndarray, observed: np.ndarray) -> float:
    """Mean over the columns of mean((predicted − observed)²) / var(observed) (Bauza & Rodriguez's NMSE)."""
    err = np.mean((predicted - observed) ** 2, axis=0)
    return float(np.mean(err / np.var(observed, axis=0)))


def online_session(pushes: list[Push], shape: Shape, prior: tuple[float, float, float] = (25.0, 0.0, 0.0),
                   mu: float = 0.25, settings: UKFSettings | None = None, separation_mm: float = 3.0,
                   substeps: int = 10) -> tuple[dict, tuple[np.ndarray, np.ndarray]]:
    """Run the estimator over ``pushes`` of one object in order; returns (summary, (time, λ_pred))."""
    if not pushes:
        raise ValueError("no pushes to estimate from")
    settings = settings or UKFSettings()
    contour = Contour.of(shape)
    frames, valid, first = [], [], []
    for p in pushes:                                  # a dropped frame before each push empties the window
        first.append(len(frames))
        frames.append(np.zeros(5))
        valid.append(False)
        frames.extend(snap_contact(contour, p.states, separation_mm))
        valid.extend([True] * len(p.states))
    est = estimator_init(jnp.asarray(prior, jnp.float32), settings, box=shape.footprint_box, mu=mu)
    lam0 = est.filter.mean                            # [β, x_bf, y_bf] (and μ_c with settings.estimate_mu)
    lam, updated, gated = (np.asarray(a) for a in _scan(est, lam0, contour, jnp.asarray(np.array(frames), jnp.float32),
                                                       jnp.asarray(valid), jnp.float32(mu), settings, substeps))
    lam = lam.astype(np.float64)
    before = [np.asarray(lam0, np.float64) if i == 0 else lam[first[i] - 1] for i in range(len(pushes))]
    after = [lam[(first[i + 1] if i + 1 < len(pushes) else len(lam)) - 1] for i in range(len(pushes))]
    final = after[-1]
    settled = next((i for i in range(len(pushes))
                    if all(abs(np.log(a[0] / final[0])) <= SETTLE_LOG_BETA and np.all(np.abs(a[1:3] - final[1:3])
                                                                                     <= SETTLE_M)
                           for a in after[i:])), len(pushes) - 1)
    mu_of = (lambda a: float(a[3])) if settings.estimate_mu else (lambda a: mu)
    online = [whole_push_errors(contour, [p], b[:3], mu_of(b)) for p, b in zip(pushes, before)]
    prior_err = whole_push_errors(contour, pushes, np.asarray(prior), mu)
    # one-step displacements: each sample predicted with λ_pred before its push
    smp = samples(pushes, shape, separation_mm, stick_ratio=0.1, min_speed_mm_s=5.0)   # validate()'s defaults
    lam_smp = np.stack([before[i][:3] for i in smp.push_index])
    mu_smp = np.array([mu_of(before[i]) for i in smp.push_index])
    observed = _displacement(smp.next_pose, smp.states)
    pred_online = _displacement(one_step(contour, smp.states, smp.inputs, lam_smp, mu_smp), smp.states)
    pred_prior = _displacement(one_step(contour, smp.states, smp.inputs, np.asarray(prior), mu), smp.states)
    summary = {
        "pushes": len(pushes), "prior": [float(v) for v in prior], "mu_c": mu,
        "lambda_final": [round(float(v), 5) for v in final[:3]],
        **({"mu_c_final": round(float(final[3]), 4),
            "mu_c_after_each_push": [round(float(a[3]), 3) for a in after]} if settings.estimate_mu else {}),
        "beta_after_each_push": [round(float(a[0]), 2) for a in after],
        "settled_after_push": int(settled) + 1,
        "updates": int(updated.sum()), "gated_windows": int(gated[-1]),
        "whole_push_error_mm_online": round(float(np.mean([e[0] for e in online])), 2),
        "whole_push_error_deg_online": round(float(np.mean([e[1] for e in online])), 2),
        "whole_push_error_deg_each": [round(float(e[1]), 2) for e in online],
        "whole_push_error_mm_prior": round(prior_err[0], 2), "whole_push_error_deg_prior": round(prior_err[1], 2),
        "nmse_online": round(nmse(pred_online, observed), 3), "nmse_prior": round(nmse(pred_prior, observed), 3),
    }
    return summary, (np.arange(len(lam)) / RATE_HZ, lam)


def _displacement(next_pose: np.ndarray, states: np.ndarray) -> np.ndarray:
    d = np.asarray(next_pose, np.float64)[:, :3] - states[:, :3]
    d[:, 2] = wrap_angle(d[:, 2])
    return d
