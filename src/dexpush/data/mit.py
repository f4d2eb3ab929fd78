"""The MIT push dataset (Yu et al., IROS 2016): reading its pushes (their use, the C-GVMM validation of
Sec. IV-A, is :mod:`dexpush.data.validation`).

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

Validation (:func:`dexpush.data.validation.validate`), per 25 Hz sample k with x_k = [q_k, p_k] and the pusher
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
from pathlib import Path

import numpy as np

from dexpush.data.push import RATE_HZ, Push, resample
from dexpush.model.shape import Shape

__all__ = ["OBJECTS", "PUSHER_RADIUS", "load_folder", "load_push"]

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


