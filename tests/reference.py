"""An independent, plain float64 reference of Algorithm 1 for the tests.

Written from the paper's matrices (eq. 1, 5, 7, 8) with numpy linear algebra, one
sample at a time, and closed-form contours (no tables): nothing here is shared with
``dexpush.model.cgvmm`` or ``dexpush.model.shape``.
"""

from __future__ import annotations

import math

import numpy as np


def rect_radius(phi: float, half_w: float, half_h: float, rho: float) -> float:
    """R(φ) of a w×h rectangle inflated by ρ (flat faces, corner arcs)."""
    c, s = abs(math.cos(phi)), abs(math.sin(phi))
    if c > 1e-12:
        t = (half_w + rho) / c
        if t * s <= half_h:
            return t
    if s > 1e-12:
        t = (half_h + rho) / s
        if t * c <= half_w:
            return t
    # corner circle about (w, h) with radius ρ: largest t with |t e − k| = ρ
    b = c * half_w + s * half_h
    return b + math.sqrt(b * b - half_w**2 - half_h**2 + rho**2)


def rect_on_face(phi: float, half_w: float, half_h: float, rho: float) -> bool:
    """True when the contour point at φ is on a flat face, not on a rounded corner."""
    R = rect_radius(phi, half_w, half_h, rho)
    x, y = abs(R * math.cos(phi)), abs(R * math.sin(phi))
    return x <= half_w or y <= half_h


def ellipse_radius(phi: float, a: float, b: float, rho: float) -> float:
    """R(φ) of the ellipse's parallel curve at distance ρ, by bisection on the parameter t."""
    def angle(t: float) -> float:
        n = np.array([b * math.cos(t), a * math.sin(t)])
        q = np.array([a * math.cos(t), b * math.sin(t)]) + rho * n / np.linalg.norm(n)
        return math.atan2(q[1], q[0]), q

    target = math.atan2(math.sin(phi), math.cos(phi))
    lo, hi = target - 1.0, target + 1.0  # the parameter is within 1 rad of the azimuth here
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        ang, _ = angle(mid)
        diff = math.atan2(math.sin(ang - target), math.cos(ang - target))
        if diff < 0:
            lo = mid
        else:
            hi = mid
    return float(np.linalg.norm(angle(0.5 * (lo + hi))[1]))


def contour(radius, phi: float, h: float = 1e-6) -> tuple[np.ndarray, np.ndarray]:
    """r(φ) and ∂φr (central finite difference)."""
    def r(p: float) -> np.ndarray:
        return radius(p) * np.array([math.cos(p), math.sin(p)])

    return r(phi), (r(phi + h) - r(phi - h)) / (2 * h)


def algorithm1(radius, x: np.ndarray, u: np.ndarray, lam: np.ndarray, mu: float,
               alpha: float = 1.0) -> tuple[np.ndarray, int]:
    """Algorithm 1, literally: returns (xdot, mode)."""
    xb, yb, th, xc, yc = x
    phi = math.atan2(yc - yb, xc - xb) - th
    r, dr = contour(radius, phi)
    N = np.array([[-dr[1], dr[0]], [dr[0], dr[1]]]) / np.linalg.norm(dr)     # eq. (1)
    Rot = np.array([[math.cos(th), -math.sin(th)], [math.sin(th), math.cos(th)]])
    beta, xbf, ybf = lam
    L = alpha**2 * np.diag([1.0, 1.0, beta**2])
    A = np.array([[1, 0, ybf], [0, 1, -xbf], [0, 0, 1.0]])
    J = np.array([[1, 0, -r[1]], [0, 1, r[0]]])
    C = A @ L @ A.T @ J.T @ N                                                # eq. (5)
    w = N @ Rot.T @ u                                                        # eq. (7)
    eta = N @ dr
    G = N @ J @ C
    Gi_w = np.linalg.solve(G, w)
    Gi_eta = np.linalg.solve(G, eta)
    mode, fpm = 3, np.zeros(2)
    if np.hypot(xc - xb, yc - yb) <= np.linalg.norm(r):
        c_stick = np.linalg.solve(np.array([[1, 1], [mu, -mu]]), Gi_w)
        c_ccw = np.linalg.solve(np.array([[1, Gi_eta[0]], [mu, Gi_eta[1]]]), Gi_w)
        c_cw = np.linalg.solve(np.array([[1, -Gi_eta[0]], [-mu, -Gi_eta[1]]]), Gi_w)
        if np.all(c_stick > 0):
            mode, fpm = 0, c_stick
        elif np.all(c_ccw >= 0):
            mode, fpm = 1, np.array([c_ccw[0], 0.0])
        elif np.all(c_cw >= 0):
            mode, fpm = 2, np.array([0.0, c_cw[0]])
    f = np.array([[1, 1], [mu, -mu]]) @ fpm
    V = C @ f
    Rz = np.eye(3)
    Rz[:2, :2] = Rot
    return np.concatenate([Rz @ V, u]), mode
