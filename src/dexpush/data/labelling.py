"""The samples a fit uses: the recorded states where the pusher touches the object, snapped onto
the contour, with their motions labelled (:func:`samples`, :func:`snap_contact`)."""

from __future__ import annotations

from dataclasses import dataclass

import jax.numpy as jnp
import numpy as np

from dexpush.common.se2 import wrap_angle
from dexpush.data.push import RATE_HZ, Push
from dexpush.model.cgvmm import FREE, SLIDE_CCW, SLIDE_CW, STICK, Contour
from dexpush.model.shape import Shape

__all__ = ["Samples", "samples", "snap_contact"]


@dataclass
class Samples:
    """Per-sample arrays of one object's pushes, concatenated (numpy)."""

    states: np.ndarray        #: (S, 5) x_k
    inputs: np.ndarray        #: (S, 2) u_k
    next_pose: np.ndarray     #: (S, 3) q_{k+1}
    observed: np.ndarray      #: (S,) observed mode
    push_index: np.ndarray    #: (S,) which push


def contact_geometry(contour: Contour, X: np.ndarray) -> tuple[np.ndarray, ...]:
    """For observed states X (T, 5): unwrapped φ_c, R(φ_c), R'(φ_c), the gap |p| − R, and
    the pusher centres moved radially onto the contour (the tip/Vicon offset removed)."""
    rel = X[:, 3:] - X[:, :2]
    c, s = np.cos(X[:, 2]), np.sin(X[:, 2])
    body = np.stack([c * rel[:, 0] + s * rel[:, 1], -s * rel[:, 0] + c * rel[:, 1]], -1)
    phi = np.unwrap(np.arctan2(body[:, 1], body[:, 0]))
    R, dR = (np.asarray(a, np.float64) for a in contour.lookup(jnp.asarray(wrap_angle(phi))))
    dist = np.linalg.norm(body, axis=-1)
    on_contour = X[:, :2] + (R / dist)[:, None] * rel
    return phi, R, dR, dist - R, on_contour


def samples(pushes: list[Push], shape: Shape, separation_mm: float, stick_ratio: float,
             min_speed_mm_s: float) -> Samples:
    contour = Contour.of(shape)
    dt = 1.0 / RATE_HZ
    parts = []
    for i, p in enumerate(pushes):
        X = p.states.copy()
        U = np.diff(p.pusher_xy, axis=0) / dt
        phi, R, dR, gap, on_contour = contact_geometry(contour, X)
        contact = gap <= separation_mm / 1000
        X[contact, 3:] = on_contour[contact]   # observed contact: pusher on the contour (as snap_contact)
        slide = np.hypot(R, dR)[:-1] * np.diff(phi) / dt        # contact-point speed along the contour
        speed = np.linalg.norm(U, axis=-1)
        obs = np.where(~(contact[:-1] & contact[1:]), FREE,
                       np.where(np.abs(slide) < stick_ratio * speed, STICK,
                                np.where(slide > 0, SLIDE_CCW, SLIDE_CW)))
        moving = speed * 1000 >= min_speed_mm_s
        parts.append((X[:-1][moving], U[moving], p.object_pose[1:][moving], obs[moving],
                      np.full(int(moving.sum()), i)))
    return Samples(*(np.concatenate([pp[j] for pp in parts]) for j in range(5)))


def snap_contact(contour: Contour, X: np.ndarray, separation_mm: float) -> np.ndarray:
    """Observed states X (T, 5) with every pusher within ``separation_mm`` of the contour (or inside it)
    moved radially onto it: the tip/Vicon calibration offset removed, as :func:`samples` does."""
    X = np.array(X, np.float64)
    _, _, _, gap, on_contour = contact_geometry(contour, X)
    contact = gap <= separation_mm / 1000
    X[contact, 3:] = on_contour[contact]
    return X
