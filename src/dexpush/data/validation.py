"""The C-GVMM against recorded pushes (paper Sec. IV-A): mode agreement, one-step and whole-push
errors, and the fitted λ per object (:func:`validate`, ``dexpush validate-mit``)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from dexpush.data.fitting import fit_beta, fit_lambda, residuals, whole_push_errors
from dexpush.data.labelling import samples
from dexpush.data.mit import OBJECTS
from dexpush.data.push import Push
from dexpush.model.cgvmm import MODE_NAMES, Contour, contact_solution

__all__ = ["ValidationResult", "validate"]


# ---------------------------------------------------------------------------- validation
@dataclass
class ValidationResult:
    """Per-object numbers and the per-sample arrays behind the figures."""

    summary: dict
    per_object: dict = field(default_factory=dict)   #: name -> dict of arrays for plotting


def validate(pushes: list[Push], mu: float = 0.25, separation_mm: float = 3.0, stick_ratio: float = 0.1,
             min_speed_mm_s: float = 5.0, fit_full: bool = True) -> ValidationResult:
    """Mode agreement, confusion matrix and prediction errors per object (docs/conventions.md#model-validation)."""
    if not pushes:
        raise ValueError("no pushes to validate")
    summary: dict = {"pushes": len(pushes), "samples": 0, "mu_c": mu, "objects": {}}
    per_object = {}
    agree_total = 0
    for obj in sorted({p.shape for p in pushes}):
        ps = [p for p in pushes if p.shape == obj]
        shape = OBJECTS[obj]()
        contour = Contour.of(shape)
        smp = samples(ps, shape, separation_mm, stick_ratio, min_speed_mm_s)
        if len(smp.observed) == 0:
            raise ValueError(f"{obj}: none of its {len(ps)} push(es) has a sample with the pusher moving at least "
                             f"{min_speed_mm_s:g} mm/s; nothing to validate (is the pusher stream stationary?)")
        beta = fit_beta(contour, smp, mu)
        lam_beta = np.array([beta, 0.0, 0.0])
        sol = contact_solution(shape, smp.states, smp.inputs, lam_beta, mu=mu)
        predicted = np.asarray(sol.mode)
        confusion = np.zeros((4, 4), int)
        np.add.at(confusion, (smp.observed, predicted), 1)
        agree = int(np.trace(confusion))
        agree_total += agree
        r = residuals(contour, smp, lam_beta, mu).reshape(-1, 3)
        entry = {
            "pushes": len(ps), "samples": len(smp.observed), "beta_fit": round(beta, 3),
            "mode_agreement": round(agree / len(smp.observed), 4),
            "confusion_observed_by_predicted": confusion.tolist(), "modes": list(MODE_NAMES[:4]),
            "observed_counts": {MODE_NAMES[m]: int(np.sum(smp.observed == m)) for m in range(4)},
            "one_step_error_mm": round(float(np.mean(np.hypot(r[:, 0], r[:, 1]))) * 1000, 3),
            "one_step_error_deg": round(float(np.degrees(np.mean(np.abs(r[:, 2]) / 0.05))), 3),
        }
        wp = whole_push_errors(contour, ps, lam_beta, mu)
        entry["whole_push_error_mm"], entry["whole_push_error_deg"] = round(wp[0], 2), round(wp[1], 2)
        zero = np.array([25.0, 0.0, 0.0])  # reference point: the paper's numerical λ_true β with p_bf = 0
        wz = whole_push_errors(contour, ps, zero, mu)
        entry["whole_push_error_mm_beta25"], entry["whole_push_error_deg_beta25"] = round(wz[0], 2), round(wz[1], 2)
        if fit_full:
            lam = fit_lambda(contour, smp, mu, beta).lam
            rf = residuals(contour, smp, lam, mu).reshape(-1, 3)
            wf = whole_push_errors(contour, ps, lam, mu)
            entry["lambda_fit"] = [round(float(v), 5) for v in lam]
            entry["one_step_error_mm_full_fit"] = round(float(np.mean(np.hypot(rf[:, 0], rf[:, 1]))) * 1000, 3)
            entry["one_step_error_deg_full_fit"] = round(float(np.degrees(np.mean(np.abs(rf[:, 2]) / 0.05))), 3)
            entry["whole_push_error_mm_full_fit"], entry["whole_push_error_deg_full_fit"] = (
                round(wf[0], 2), round(wf[1], 2))
        summary["objects"][obj] = entry
        summary["samples"] += len(smp.observed)
        per_object[obj] = {"decision": np.asarray(sol.decision, np.float64), "boundary": np.asarray(sol.boundary),
                           "observed": smp.observed, "predicted": predicted, "confusion": confusion, "beta": beta}
    summary["mode_agreement"] = round(agree_total / summary["samples"], 4)
    for key in ("one_step_error_mm", "one_step_error_deg", "whole_push_error_mm", "whole_push_error_deg"):
        summary[key] = round(float(np.mean([e[key] for e in summary["objects"].values()])), 3)
    return ValidationResult(summary, per_object)
