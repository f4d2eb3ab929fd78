"""A planar pose from marker corners on the table plane, and the fusion of several estimates.

Each marker corner seen in an image is a ray; the ray meets the plane the marker lies on at a
known height (the table-plane constraint: :meth:`dexpush.perception.camera_model.CameraModel.on_plane`),
which gives the corner's table (x, y) whatever the camera's angle, without the depth error of a
perspective-n-point solve. The object pose is the rigid motion that best maps the markers' corners
in the object frame, ``p_i``, onto those points, ``q_i`` (2-D Kabsch):

    θ = atan2(Σ p̃_i × q̃_i, Σ p̃_i · q̃_i),   t = q̄ − R(θ) p̄,

with ``p̃ = p − p̄``, ``q̃ = q − q̄``. Its residual (RMS distance of the fitted corners) says whether
the corners are the marker's at all: a wrong size, a wrong calibration or a misread id shows there.

Fusion of estimates ``(x_k, y_k, θ_k)`` with position std ``σ_k`` and heading std ``s_k``:
inverse-variance weighted means, the heading as a weighted circular mean; estimates further than
``gate`` standard deviations from the consensus are dropped first (:func:`fuse`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["PoseEstimate", "fit_planar_pose", "fuse"]


@dataclass(frozen=True)
class PoseEstimate:
    """A planar pose (x, y, θ) with its standard deviations and the fit's residual (m)."""

    pose: np.ndarray
    pos_std_m: float
    heading_std_rad: float
    residual_m: float
    source: str = ""


def fit_planar_pose(body: np.ndarray, table: np.ndarray) -> tuple[np.ndarray, float]:
    """The pose (x, y, θ) mapping body-frame points (n, 2) onto table points (n, 2), n ≥ 2, and the
    RMS residual (m) of the fit (see the module docstring)."""
    p, q = np.asarray(body, np.float64), np.asarray(table, np.float64)
    pm, qm = p.mean(0), q.mean(0)
    pc, qc = p - pm, q - qm
    theta = math.atan2(float(np.sum(pc[:, 0] * qc[:, 1] - pc[:, 1] * qc[:, 0])), float(np.sum(pc * qc)))
    c, s = math.cos(theta), math.sin(theta)
    R = np.array([[c, -s], [s, c]])
    t = qm - R @ pm
    residual = float(np.sqrt(np.mean(np.sum((p @ R.T + t - q) ** 2, axis=1))))
    return np.array([t[0], t[1], theta]), residual


def _wrap(a: np.ndarray | float) -> np.ndarray:
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


def fuse(estimates: list[PoseEstimate], gate: float = 4.0, floor_m: float = 1e-3,
         floor_rad: float = math.radians(1.0)) -> tuple[PoseEstimate | None, int]:
    """One estimate from several (see the module docstring), and how many were dropped as outliers.

    An estimate is an outlier when its position or heading lies more than ``gate`` combined standard
    deviations (with the floors ``floor_m``, ``floor_rad`` added) from the weighted median. With two
    estimates that disagree no consensus exists: None is returned (both dropped)."""
    if not estimates:
        return None, 0
    if len(estimates) == 1:
        return estimates[0], 0
    P = np.stack([e.pose for e in estimates])
    sp = np.array([e.pos_std_m for e in estimates])
    sh = np.array([e.heading_std_rad for e in estimates])

    def disagree(i: int, j: int) -> bool:
        dp = np.linalg.norm(P[i, :2] - P[j, :2])
        dh = abs(float(_wrap(P[i, 2] - P[j, 2])))
        return (dp > gate * math.hypot(sp[i], sp[j], floor_m) or dh > gate * math.hypot(sh[i], sh[j], floor_rad))

    n = len(estimates)
    votes = np.array([sum(not disagree(i, j) for j in range(n) if j != i) for i in range(n)])
    keep = votes >= (n - 1) / 2 if n > 2 else votes == n - 1
    if n > 2 and keep.sum() < 2:
        keep[:] = False
    if not keep.any():
        return None, n
    w = 1.0 / sp[keep] ** 2
    wh = 1.0 / sh[keep] ** 2
    xy = (P[keep, :2] * w[:, None]).sum(0) / w.sum()
    theta = math.atan2(float((np.sin(P[keep, 2]) * wh).sum()), float((np.cos(P[keep, 2]) * wh).sum()))
    fused = PoseEstimate(np.array([xy[0], xy[1], theta]), float(1 / math.sqrt(w.sum())),
                         float(1 / math.sqrt(wh.sum())), float(max(e.residual_m for e, k in zip(estimates, keep) if k)),
                         "+".join(e.source for e, k in zip(estimates, keep) if k))
    return fused, int(n - keep.sum())
