"""A calibrated camera: pinhole intrinsics with Brown–Conrady distortion, and its pose in the table frame.

Conventions (docs/perception.md#conventions): pixel ``(u, v)`` with the centre of the top-left
pixel at (0, 0), as OpenCV; the camera frame is OpenCV's (x right, y down, z along the optical
axis); the table frame is the world frame of dexpush (z up, the table top at z = 0).

A table point ``X`` is seen at ``x_c = Rᵀ (X − t)`` (``R``, ``t``: the camera's orientation and
position in the table frame), normalised ``(a, b) = (x_c/z_c, y_c/z_c)``, distorted with
``r² = a² + b²``::

    a_d = a (1 + k₁r² + k₂r⁴ + k₃r⁶) + 2p₁ab + p₂(r² + 2a²)
    b_d = b (1 + k₁r² + k₂r⁴ + k₃r⁶) + p₁(r² + 2b²) + 2p₂ab

and ``u = f_x a_d + c_x``, ``v = f_y b_d + c_y`` (OpenCV's model with five coefficients).
Everything here is numpy: no OpenCV needed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

__all__ = ["CameraModel", "look_at"]


def look_at(position: object, target: object, up: object = (0.0, 0.0, 1.0)) -> np.ndarray:
    """The rotation (columns: the camera's x, y, z axes in the table frame) of a camera at ``position``
    whose optical axis points at ``target``; image "up" (−y) leans towards ``up``."""
    p, t, u = (np.asarray(v, dtype=np.float64) for v in (position, target, up))
    z = t - p
    if np.linalg.norm(z) < 1e-9:
        raise ValueError("a camera cannot look at its own position")
    z /= np.linalg.norm(z)
    x = np.cross(z, u)
    if np.linalg.norm(x) < 1e-9:          # looking straight along `up`: pick image x along the table's x
        x = np.cross(z, (0.0, 1.0, 0.0)) if abs(z[1]) < 0.9 else np.cross(z, (1.0, 0.0, 0.0))
        x = -x if x[0] < 0 else x
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    return np.stack([x, y, z], axis=1)


@dataclass(frozen=True)
class CameraModel:
    """One camera (see the module docstring for the equations).

    Args:
        width, height: image size (pixels).
        fx, fy, cx, cy: focal lengths and principal point (pixels).
        distortion: (k₁, k₂, p₁, p₂, k₃).
        rotation: 3×3, the camera's axes (OpenCV frame) as columns in the table frame.
        position: the camera's optical centre in the table frame (m).
        name: a label used in messages and camera files.
        reprojection_error_px: the calibration's RMS reprojection error, when known.
    """

    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float
    distortion: tuple[float, float, float, float, float] = (0.0, 0.0, 0.0, 0.0, 0.0)
    rotation: np.ndarray = field(default_factory=lambda: np.diag([1.0, -1.0, -1.0]))
    position: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))
    name: str = "camera"
    reprojection_error_px: float | None = None

    def __post_init__(self) -> None:
        for key in ("width", "height"):
            v = getattr(self, key)
            if isinstance(v, bool) or not isinstance(v, int | np.integer) or not 8 <= v <= 16384:
                raise ValueError(f"camera {self.name!r}: {key} must be a whole number of pixels in [8, 16384], "
                                 f"got {v!r}")
        for key in ("fx", "fy", "cx", "cy"):
            v = getattr(self, key)
            if isinstance(v, bool) or not isinstance(v, int | float | np.floating) or not math.isfinite(v):
                raise ValueError(f"camera {self.name!r}: {key} must be a finite number of pixels, got {v!r}")
        if self.fx <= 0 or self.fy <= 0:
            raise ValueError(f"camera {self.name!r}: focal lengths must be > 0 pixels, got fx={self.fx}, "
                             f"fy={self.fy}")
        dist = np.asarray(self.distortion, dtype=np.float64)
        if dist.shape != (5,) or not np.all(np.isfinite(dist)) or np.any(np.abs(dist) > 10):
            raise ValueError(f"camera {self.name!r}: distortion must be 5 finite numbers (k1, k2, p1, p2, k3) "
                             f"within ±10, got {self.distortion!r}")
        R = np.asarray(self.rotation, dtype=np.float64)
        if R.shape != (3, 3) or not np.all(np.isfinite(R)) or not np.allclose(R.T @ R, np.eye(3), atol=1e-4) \
                or np.linalg.det(R) < 0:
            raise ValueError(f"camera {self.name!r}: rotation must be a 3×3 rotation matrix (orthonormal, det +1)")
        t = np.asarray(self.position, dtype=np.float64)
        if t.shape != (3,) or not np.all(np.isfinite(t)) or np.any(np.abs(t) > 100):
            raise ValueError(f"camera {self.name!r}: position must be a finite [x, y, z] within ±100 m")
        object.__setattr__(self, "distortion", tuple(float(d) for d in dist))
        object.__setattr__(self, "rotation", R)
        object.__setattr__(self, "position", t)

    @staticmethod
    def from_fov(width: int, height: int, fovy_deg: float, position: object, target: object, *,
                 distortion: tuple[float, float, float, float, float] = (0.0, 0.0, 0.0, 0.0, 0.0),
                 name: str = "camera") -> CameraModel:
        """A square-pixel camera with vertical field of view ``fovy_deg`` and the principal point at the
        image centre, at ``position`` looking at ``target`` (MuJoCo's ``fovy`` camera)."""
        if not 1.0 <= fovy_deg <= 170.0:
            raise ValueError(f"fovy must be in [1, 170] degrees, got {fovy_deg!r}")
        f = 0.5 * height / math.tan(math.radians(fovy_deg) / 2)
        return CameraModel(width, height, f, f, (width - 1) / 2, (height - 1) / 2, distortion,
                           look_at(position, target), np.asarray(position, dtype=np.float64), name)

    @property
    def K(self) -> np.ndarray:
        """The 3×3 intrinsic matrix."""
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    @property
    def fovy_deg(self) -> float:
        return math.degrees(2 * math.atan(0.5 * self.height / self.fy))

    def _distort(self, ab: np.ndarray) -> np.ndarray:
        k1, k2, p1, p2, k3 = self.distortion
        a, b = ab[..., 0], ab[..., 1]
        r2 = a * a + b * b
        radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
        return np.stack([a * radial + 2 * p1 * a * b + p2 * (r2 + 2 * a * a),
                         b * radial + p1 * (r2 + 2 * b * b) + 2 * p2 * a * b], -1)

    def undistort_normalised(self, pixels: object, iterations: int = 20) -> np.ndarray:
        """Normalised undistorted coordinates (a, b) of ``pixels`` (..., 2), by fixed-point iteration
        (as OpenCV's ``undistortPoints``)."""
        px = np.asarray(pixels, dtype=np.float64)
        d = np.stack([(px[..., 0] - self.cx) / self.fx, (px[..., 1] - self.cy) / self.fy], -1)
        if not any(self.distortion):
            return d
        ab = d.copy()
        for _ in range(iterations):
            ab = ab + (d - self._distort(ab))
        return ab

    def project(self, points: object) -> np.ndarray:
        """Pixels (..., 2) of table-frame points (..., 3); points behind the camera give NaN."""
        X = np.asarray(points, dtype=np.float64)
        xc = (X - self.position) @ self.rotation
        z = xc[..., 2:3]
        ab = np.where(z > 1e-9, xc[..., :2] / np.where(z > 1e-9, z, 1.0), np.nan)
        ad = self._distort(ab)
        return np.stack([self.fx * ad[..., 0] + self.cx, self.fy * ad[..., 1] + self.cy], -1)

    def rays(self, pixels: object) -> np.ndarray:
        """Unit directions (..., 3) in the table frame of the rays through ``pixels``."""
        ab = self.undistort_normalised(pixels)
        d = np.concatenate([ab, np.ones_like(ab[..., :1])], -1) @ self.rotation.T
        return d / np.linalg.norm(d, axis=-1, keepdims=True)

    def on_plane(self, pixels: object, z: float) -> np.ndarray:
        """Table-frame (x, y) (..., 2) where the rays through ``pixels`` meet the horizontal plane at
        height ``z``; NaN where a ray runs away from the plane (the table-plane constraint)."""
        d = self.rays(pixels)
        s = (z - self.position[2]) / np.where(np.abs(d[..., 2]) > 1e-9, d[..., 2], np.nan)
        s = np.where(s > 0, s, np.nan)
        return self.position[:2] + s[..., None] * d[..., :2]

    def metres_per_pixel(self, xy: object, z: float) -> np.ndarray:
        """The table-plane length one pixel spans at table point(s) ``xy`` (..., 2) on the plane at
        height ``z`` (the geometric mean of the two image directions): a pose's uncertainty scale."""
        p = np.asarray(xy, dtype=np.float64)
        X = np.concatenate([p, np.full_like(p[..., :1], z)], -1)
        xc = (X - self.position) @ self.rotation
        depth = np.linalg.norm(xc, axis=-1)
        cos = np.abs(xc[..., 2]) / depth           # the ray against the optical axis
        tilt = np.abs((self.position[2] - z) / depth)   # the ray against the plane's normal
        return depth / np.sqrt(self.fx * self.fy) / np.sqrt(np.maximum(cos * tilt, 1e-6))
