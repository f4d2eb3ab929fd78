"""Random test scenes: the object at a random pose, the pusher at given body-frame points."""

from __future__ import annotations

import numpy as np

from dexpush.common.se2 import rotate


def scenes_with_pusher_at(rng: np.random.Generator, r: np.ndarray, beta: tuple[float, float] = (5, 50),
                          offset: float = 0.02) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """States x (n, 5) with the pusher centre at the body-frame points r (n, 2), heading uniform in
    (−π, π] and position in [−1, 1]²; inputs u (n, 2) ~ N(0, 0.05²); λ with β uniform in ``beta`` and
    each CoF coordinate uniform in ±``offset``. Draws in that order."""
    n = len(r)
    th = rng.uniform(-np.pi, np.pi, n)
    pb = rng.uniform(-1, 1, (n, 2))
    x = np.concatenate([pb, th[:, None], pb + rotate(r, th)], -1)
    u = rng.normal(size=(n, 2)) * 0.05
    lam = np.stack([rng.uniform(*beta, n), rng.uniform(-offset, offset, n), rng.uniform(-offset, offset, n)], -1)
    return x, u, lam
