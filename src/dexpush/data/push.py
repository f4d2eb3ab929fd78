"""A recorded push (:class:`Push`: object pose and pusher position sampled at 25 Hz) and the
resampling of a raw log onto that rate."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["RATE_HZ", "Push", "resample"]


RATE_HZ = 25.0


_RAW_HZ = 250.0


@dataclass
class Push:
    """One push resampled to 25 Hz: time (T,), object pose (T, 3), pusher centre (T, 2)."""

    name: str
    shape: str
    time: np.ndarray
    object_pose: np.ndarray
    pusher_xy: np.ndarray
    meta: dict = field(default_factory=dict)

    @property
    def states(self) -> np.ndarray:
        return np.concatenate([self.object_pose, self.pusher_xy], -1)


def resample(t_raw: np.ndarray, y: np.ndarray, t0: float, t1: float) -> tuple[np.ndarray, np.ndarray]:
    """Uniform 250 Hz, zero-phase Gaussian low-pass (σ = 20 ms), every 10th sample (25 Hz).

    Times are taken relative to t0 first: Unix timestamps (~1.5e9 s) lose the sub-µs
    resolution a uniform grid needs.
    """
    grid = np.arange(int(np.floor((t1 - t0) * _RAW_HZ)) + 1) / _RAW_HZ
    yi = np.stack([np.interp(grid, t_raw - t0, y[:, j]) for j in range(y.shape[1])], -1)
    sigma = 0.020 * _RAW_HZ
    k = np.arange(-int(4 * sigma), int(4 * sigma) + 1)
    w = np.exp(-0.5 * (k / sigma) ** 2)
    w /= w.sum()
    pad = len(k) // 2
    padded = np.concatenate([np.repeat(yi[:1], pad, 0), yi, np.repeat(yi[-1:], pad, 0)])
    ys = np.stack([np.convolve(padded[:, j], w, mode="valid") for j in range(y.shape[1])], -1)
    step = round(_RAW_HZ / RATE_HZ)
    return grid[::step], ys[::step]
