"""The MIT push dataset (Yu et al., IROS 2016): loading and the C-GVMM validation of Sec. IV-A.

Files are the dataset's raw HDF5 (or JSON twin) pushes, named
``motion_surface=<surf>_shape=<obj>_a=<acc>_v=<vel>_i=<side>_s=<pos>_t=<angle>.h5``, each
holding ``object_pose``, ``tip_pose`` and ``ft_wrench`` as (N, 4) arrays ``[t, ...]`` at
~250 Hz. The data is third-party: dexpush never ships it; commands take the folder.

Preprocessing (:func:`load_push`), per stream: sort by time and drop repeated timestamps;
unwrap the orientation with period π/2 (the Vicon's symmetry jumps of ±π/2 and ±π, and
ordinary 2π wraps; no real rotation in 4 ms approaches π/4); then on the common time
window interpolate to a uniform 250 Hz grid, low-pass with a zero-phase Gaussian kernel
(σ = 20 ms, −3 dB at ≈ 9 Hz, below the 12.5 Hz Nyquist rate of the output) and take every
10th sample: 25 Hz, as in the paper.

Validation (:func:`validate`), per 25 Hz sample k with x_k = [q_k, p_k] and the pusher
velocity u_k = (p_{k+1} − p_k)/Δt:

* the mode-decision vector Γ⁻¹w and boundary Γ⁻¹η from :func:`dexpush.contact_solution`
  (μ_c = 0.25, p_bf = 0) and the predicted mode;
* only samples where the pusher moves (≥ ``min_speed_mm_s`` = 5 mm/s) count: pushes
  begin and end with the pusher at rest, where no mode is defined;
* the observed mode: *free* if the pusher centre is more than ``separation_mm`` = 3 mm
  outside the inflated contour at k or k+1 (the robot's tip and the Vicon object poses
  disagree by up to ~2 mm while in contact, real separations open to 5–30 mm); else *stick*
  if the contact point slides along the contour slower than ``stick_ratio`` = 10 % of the
  pusher speed (|∂φr|·|φ̇| from the observed φ_c), else CCW/CW by the sign of φ̇;
* in observed contact the pusher is put radially onto the contour before the model is
  evaluated, so the model's own contact test does not trip over the calibration offset;
* one-step pose prediction: :func:`dexpush.model.cgvmm.integrate` from x_k with u_k over Δt;
  whole-push prediction: the same chained from the first sample with the recorded pusher
  motion. β is fitted per object on the one-step errors (golden-section search on log β);
  the full λ = [β, x_bf, y_bf] by Levenberg–Marquardt on the same residuals.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from dexpush.data.fitting import RATE_HZ, Push, fit_beta, fit_lambda, resample, residuals, samples, whole_push_errors
from dexpush.model.cgvmm import MODE_NAMES, Contour, contact_solution
from dexpush.model.shape import Shape

__all__ = ["OBJECTS", "PUSHER_RADIUS", "Push", "ValidationResult", "load_folder", "load_push", "validate"]

PUSHER_RADIUS = 0.00475
_NUM = r"-?[0-9]+(?:\.[0-9]+)?"
_NAME = re.compile(rf"shape=(?P<shape>[a-z0-9]+)_a=(?P<a>{_NUM})_v=(?P<v>{_NUM})_i=(?P<i>{_NUM})"
                   rf"_s=(?P<s>{_NUM})_t=(?P<t>{_NUM})")


def _rect1() -> Shape:
    return Shape.rectangle(0.090, 0.090, pusher_radius=PUSHER_RADIUS, name="rect1")


def _ellip1() -> Shape:
    return Shape.ellipse(0.0525, 0.0525, pusher_radius=PUSHER_RADIUS, name="ellip1")


#: the dataset objects this module knows (IROS 2016, Table III), by their file-name key
OBJECTS = {"rect1": _rect1, "ellip1": _ellip1}


def _read_streams(path: Path) -> dict[str, np.ndarray]:
    if path.suffix == ".json":
        try:
            raw = json.loads(path.read_text())
        except (json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise ValueError(f"{path.name}: not a readable JSON push file ({exc})") from exc
        get = raw.get if isinstance(raw, dict) else (lambda k: None)
    else:
        import h5py

        try:
            fh = h5py.File(path, "r")
        except OSError as exc:
            raise ValueError(f"{path.name}: not a readable HDF5 file ({exc})") from exc
        with fh:
            raw = {k: fh[k][()] for k in fh.keys() if isinstance(fh[k], h5py.Dataset)}
        get = raw.get
    out = {}
    for key in ("object_pose", "tip_pose"):
        a = get(key)
        if a is None:
            raise ValueError(f"{path.name}: no '{key}' stream; is this an MIT push file?")
        a = np.asarray(a, dtype=np.float64)
        if a.ndim != 2 or a.shape[1] < 3 or a.shape[0] < 10:
            raise ValueError(f"{path.name}: '{key}' must be an (N ≥ 10, 4) array [t, x, y, θ], got {a.shape}")
        out[key] = a
    return out


def _clean(a: np.ndarray, name: str, key: str) -> np.ndarray:
    """Sort by time, drop repeated timestamps and non-finite rows; at least 10 rows must remain."""
    a = a[np.all(np.isfinite(a[:, :4] if a.shape[1] >= 4 else a), axis=1)]
    a = a[np.argsort(a[:, 0], kind="stable")]
    if len(a):
        a = a[np.concatenate([[True], np.diff(a[:, 0]) > 0])]
    if len(a) < 10:
        raise ValueError(f"{name}: '{key}' has {len(a)} finite samples with distinct times; at least 10 are needed")
    return a


def load_push(path: str | Path) -> Push:
    """Read, clean, synchronise and resample one push file (.h5 or .json) to 25 Hz."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"push file not found: {path}")
    m = _NAME.search(path.name)
    if m is None:
        raise ValueError(f"{path.name}: file name does not follow the dataset's "
                         "'motion_surface=..._shape=<obj>_a=..._v=..._i=..._s=..._t=...' scheme")
    shape = m["shape"]
    if shape not in OBJECTS:
        raise ValueError(f"{path.name}: unknown object '{shape}'; known: {', '.join(OBJECTS)}")
    streams = {k: _clean(v, path.name, k) for k, v in _read_streams(path).items()}
    obj, tip = streams["object_pose"], streams["tip_pose"]
    obj = obj.copy()
    obj[:, 3] = np.unwrap(obj[:, 3], period=np.pi / 2)
    t0, t1 = max(obj[0, 0], tip[0, 0]), min(obj[-1, 0], tip[-1, 0])
    if t1 - t0 < 4.0 / RATE_HZ:
        raise ValueError(f"{path.name}: object and pusher streams overlap for only {t1 - t0:.3f} s")
    t, q = resample(obj[:, 0], obj[:, 1:4], t0, t1)
    _, p = resample(tip[:, 0], tip[:, 1:3], t0, t1)
    meta = {k: float(m[k]) for k in ("a", "v", "i", "s", "t")}
    return Push(path.name, shape, t, q, p, meta)


def load_folder(folder: str | Path, objects: tuple[str, ...] = tuple(OBJECTS)) -> list[Push]:
    """Every push file (*.h5, *.json) for ``objects`` in ``folder``, sorted by name."""
    folder = Path(folder)
    if not folder.exists():
        raise ValueError(f"data folder not found: {folder}")
    if not folder.is_dir():
        raise ValueError(f"not a folder: {folder}")
    files = sorted(p for p in folder.iterdir() if p.suffix in (".h5", ".json") and p.name.startswith("motion_"))
    if not files:
        raise ValueError(f"no push files (motion_*.h5 or motion_*.json) in {folder}")
    pushes = [load_push(f) for f in files]
    pushes = [p for p in pushes if p.shape in objects]
    if not pushes:
        raise ValueError(f"no pushes of {', '.join(objects)} in {folder}")
    return pushes


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
