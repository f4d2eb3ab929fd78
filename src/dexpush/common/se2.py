"""Planar rigid-body (SE(2)) helpers shared by every layer: angle wrapping, rotations, pose error.

A pose is (x, y, θ) in metres and radians, θ measured counter-clockwise from the world x
axis. Angles are wrapped to (−π, π] only where two are compared (docs/conventions.md#units-and-frames). Every function
takes an array module ``xp``: numpy (default; results in float64) or ``jax.numpy`` inside
jit, so the same definition serves plotting, bookkeeping and compiled rollouts.
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["footprint_shift", "pose_error", "rotate", "wrap_angle"]


def wrap_angle(angle: Any, xp: Any = np) -> Any:
    """``angle`` wrapped to (−π, π] (elementwise): atan2(sin a, cos a)."""
    return xp.arctan2(xp.sin(angle), xp.cos(angle))


def rotate(vector: Any, theta: Any, xp: Any = np) -> Any:
    """R(θ)·v for vectors (..., 2), broadcasting θ over the leading axes."""
    v = xp.asarray(vector)
    c, s = xp.cos(theta), xp.sin(theta)
    return xp.stack([c * v[..., 0] - s * v[..., 1], s * v[..., 0] + c * v[..., 1]], -1)


def pose_error(object_pose: object, goal: object, xp: Any = np) -> tuple[Any, Any]:
    """Position error (m) and absolute heading error (deg, wrapped) of poses (..., 3) against ``goal``
    (3,), or against goals (..., 3) one per pose.

    With numpy the arithmetic is float64 whatever the input dtype.
    """
    q = xp.asarray(object_pose)
    g = xp.asarray(goal, dtype=q.dtype)
    if xp is np:
        q, g = q.astype(np.float64), g.astype(np.float64)
    pos = xp.sqrt(xp.sum((q[..., :2] - g[..., :2]) ** 2, axis=-1))
    return pos, xp.degrees(xp.abs(wrap_angle(q[..., 2] - g[..., 2], xp)))


def footprint_shift(vertices: np.ndarray, q0: object, q1: object) -> float:
    """The farthest any point of a footprint moves (m) between poses q0 and q1 (x, y, θ):
    max over its corners v (n ≥ 1, in {B}) of ‖R(θ₁)v + p₁ − R(θ₀)v − p₀‖ (the distance is convex
    in v, so a corner attains it over each convex piece)."""
    q0, q1 = np.asarray(q0, np.float64), np.asarray(q1, np.float64)
    moved = rotate(vertices, q1[2]) + q1[:2] - rotate(vertices, q0[2]) - q0[:2]
    return float(np.max(np.hypot(moved[:, 0], moved[:, 1])))
