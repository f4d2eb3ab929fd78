"""Reading recorded pushes from your own logs (CSV or NPZ) and the MIT push files, for ``dexpush fit``.

A log is one or more pushes of one object, each a timed stream of the object's pose (its
*reference point*, the origin of the shape's body frame) and the pusher centre, in metres,
radians and seconds, in any fixed world frame:

* **CSV**: a header line naming the columns ``t, x, y, theta, px, py`` (any order, other
  columns ignored; ``#`` starts a comment line), one row per sample. An optional integer
  column ``push`` separates several pushes in one file.
* **NPZ** (``numpy.savez``): arrays ``t`` (T,), ``object_pose`` (T, 3) and ``pusher_xy``
  (T, 2), and optionally ``push`` (T,).
* **MIT push files** (``motion_*.h5`` / ``motion_*.json``): :func:`dexpush.data.mit.load_push`.

A folder reads every such file in it. Each push is sorted by time, cleared of repeated
timestamps and non-finite rows, its heading unwrapped, and resampled to 25 Hz with the
MIT loader's zero-phase low-pass (:func:`dexpush.data.push.resample`). The log's rate may be
anything from 25 Hz up; a push needs at least 0.5 s.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from dexpush.data.mit import load_push
from dexpush.data.push import Push, resample

__all__ = ["COLUMNS", "MAX_PUSH_S", "read_log"]

COLUMNS = ("t", "x", "y", "theta", "px", "py")
#: the longest push (s) a log may hold: one push is seconds long; a longer one is several pushes (a `push`
#: column splits them) or times in other units
MAX_PUSH_S = 600.0


def _push_from_arrays(name: str, t: np.ndarray, q: np.ndarray, p: np.ndarray) -> Push:
    rows = np.concatenate([t[:, None], q, p], -1)
    rows = rows[np.all(np.isfinite(rows), axis=1)]
    rows = rows[np.argsort(rows[:, 0], kind="stable")]
    if len(rows):
        rows = rows[np.concatenate([[True], np.diff(rows[:, 0]) > 0])]
    if len(rows) < 10 or rows[-1, 0] - rows[0, 0] < 0.5:
        raise ValueError(f"{name}: a push needs at least 10 finite samples over 0.5 s, got {len(rows)} "
                         f"over {rows[-1, 0] - rows[0, 0] if len(rows) else 0:.2f} s")
    span = rows[-1, 0] - rows[0, 0]
    if span > MAX_PUSH_S:
        unit = " (are the times in milliseconds or nanoseconds? they must be seconds)" if span > 1e4 else ""
        raise ValueError(f"{name}: a push spans {span:.3g} s, more than {MAX_PUSH_S:g} s{unit}; split the log into "
                         "pushes with a `push` column")
    if np.max(np.abs(rows[:, 3])) > 4 * np.pi and np.max(np.abs(np.diff(rows[:, 3]))) > np.pi:
        raise ValueError(f"{name}: theta jumps by up to {np.max(np.abs(np.diff(rows[:, 3]))):.3g} between samples; "
                         "it must be in radians (degrees?)")
    rows[:, 3] = np.unwrap(rows[:, 3])
    t0, t1 = rows[0, 0], rows[-1, 0]
    grid, q25 = resample(rows[:, 0], rows[:, 1:4], t0, t1)
    _, p25 = resample(rows[:, 0], rows[:, 4:6], t0, t1)
    return Push(name, "log", grid, q25, p25)


def _split(name: str, t: np.ndarray, q: np.ndarray, p: np.ndarray, push: np.ndarray | None) -> list[Push]:
    if push is None:
        return [_push_from_arrays(name, t, q, p)]
    return [_push_from_arrays(f"{name}[push {int(k)}]", t[push == k], q[push == k], p[push == k])
            for k in np.unique(push)]


def _read_csv(path: Path) -> list[Push]:
    with open(path, newline="") as fh:
        lines = [ln for ln in fh if ln.strip() and not ln.lstrip().startswith("#")]
    if not lines:
        raise ValueError(f"{path.name}: empty log")
    reader = csv.reader(lines)
    header = [h.strip() for h in next(reader)]
    missing = [c for c in COLUMNS if c not in header]
    if missing:
        raise ValueError(f"{path.name}: the header must name the columns {', '.join(COLUMNS)}; missing "
                         f"{', '.join(missing)} (header: {', '.join(header)})")
    try:
        data = np.array([[float(v) for v in row] for row in reader if row], dtype=np.float64)
    except ValueError as exc:
        raise ValueError(f"{path.name}: a value is not a number ({exc})") from None
    if data.ndim != 2 or data.shape[1] != len(header):
        raise ValueError(f"{path.name}: every row needs {len(header)} values, like the header")
    col = {h: data[:, i] for i, h in enumerate(header)}
    return _split(path.name, col["t"], np.stack([col["x"], col["y"], col["theta"]], -1),
                  np.stack([col["px"], col["py"]], -1), col.get("push"))


def _read_npz(path: Path) -> list[Push]:
    try:
        z = np.load(path)
    except (OSError, ValueError, EOFError) as exc:
        raise ValueError(f"{path.name}: not a readable .npz file ({exc})") from None
    if not isinstance(z, np.lib.npyio.NpzFile):
        raise ValueError(f"{path.name}: not an .npz archive (a single array, .npy?); save it with numpy.savez")
    with z:
        missing = [k for k in ("t", "object_pose", "pusher_xy") if k not in z]
        if missing:
            raise ValueError(f"{path.name}: needs arrays t, object_pose (T, 3), pusher_xy (T, 2); missing "
                             f"{', '.join(missing)}")
        t, q, p = (np.asarray(z[k], np.float64) for k in ("t", "object_pose", "pusher_xy"))
        push = np.asarray(z["push"]) if "push" in z else None
    if t.ndim != 1 or q.shape != (len(t), 3) or p.shape != (len(t), 2) or (push is not None and push.shape != t.shape):
        raise ValueError(f"{path.name}: shapes must be t (T,), object_pose (T, 3), pusher_xy (T, 2)"
                         f"{', push (T,)' if push is not None else ''}; got {t.shape}, {q.shape}, {p.shape}")
    return _split(path.name, t, q, p, push)


def read_log(path: str | Path) -> list[Push]:
    """The pushes in a log file, or in every log file of a folder (see the module docstring)."""
    path = Path(path)
    if not path.exists():
        raise ValueError(f"log not found: {path}")
    if path.is_dir():
        files = sorted(f for f in path.iterdir() if f.suffix in (".csv", ".npz", ".h5", ".json"))
        if not files:
            raise ValueError(f"no .csv, .npz, .h5 or .json logs in {path}")
        return [push for f in files for push in read_log(f)]
    if path.suffix == ".csv":
        return _read_csv(path)
    if path.suffix == ".npz":
        return _read_npz(path)
    if path.suffix in (".h5", ".json"):
        return [load_push(path)]
    raise ValueError(f"{path.name}: unknown log format; use .csv or .npz (or MIT motion_*.h5 / .json files)")
