"""Input checks of the public entry points: one code path, one message style.

Every public function and settings class validates what a user hands it with these
helpers, so a wrong input fails at once with a ``ValueError`` that names the argument and
says what was expected, instead of a NaN or a traceback deep inside a compiled rollout.
"""

from __future__ import annotations

import numpy as np

__all__ = ["MAX_BETA", "MAX_MAGNITUDE", "check_nonnegative", "check_params", "check_positive", "check_values",
           "checked_seed", "checked_vector"]


#: the largest magnitude a coordinate, velocity or parameter may have: the model computes in
#: float32, whose resolution at 1e6 is 6 cm (and which overflows past 3.4e38)
MAX_MAGNITUDE = 1e6


def checked_vector(name: str, value: object, size: int, batch: bool = False) -> np.ndarray:
    """``value`` as a finite float64 array of shape (size,), or (..., size) with ``batch``.

    Raises ``ValueError`` naming the argument for wrong shapes, non-numeric input, NaN,
    infinity, or a magnitude above :data:`MAX_MAGNITUDE`.
    """
    try:
        a = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be numeric, got {value!r}") from exc
    ok = (a.ndim >= 1 and a.shape[-1] == size) if batch else a.shape == (size,)
    if not ok:
        raise ValueError(f"{name} must have shape {f'(..., {size})' if batch else f'({size},)'}, got {a.shape}")
    return check_values(name, a)


def check_values(name: str, a: np.ndarray) -> np.ndarray:
    """``a`` if every value is finite and at most :data:`MAX_MAGNITUDE` in magnitude, else a ``ValueError``."""
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} contains NaN or infinite values: {a}")
    if np.any(np.abs(a) > MAX_MAGNITUDE):
        raise ValueError(f"{name} has a value of magnitude {np.max(np.abs(a)):.3g}, above {MAX_MAGNITUDE:g}: dexpush "
                         "computes in float32 (SI units: metres, radians, m/s)")
    return a


def _number(name: str, value: object) -> float:
    if isinstance(value, bool | str | bytes):
        raise ValueError(f"{name} must be a number, got {value!r}")
    try:
        return float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be a number, got {value!r}") from exc


def check_positive(name: str, value: object, unit: str = "") -> float:
    """``value`` as a float that is finite and > 0, else a ``ValueError`` naming it."""
    v = _number(name, value)
    if not (np.isfinite(v) and v > 0):
        raise ValueError(f"{name} must be a positive finite number{f' ({unit})' if unit else ''}, got {value!r}")
    return v


def check_nonnegative(name: str, value: object, unit: str = "") -> float:
    """``value`` as a float that is finite and >= 0, else a ``ValueError`` naming it."""
    v = _number(name, value)
    if not (np.isfinite(v) and v >= 0):
        raise ValueError(f"{name} must be a finite number >= 0{f' ({unit})' if unit else ''}, got {value!r}")
    return v


#: the largest β (1/m) accepted: f_max/m_max of an object 0.1 mm across
MAX_BETA = 1e4


def check_whole(name: str, value: object, low: int, high: int | None = None) -> int:
    """``value`` as an int in [low, high] (no upper bound when ``high`` is None), else a ``ValueError`` naming
    it. A whole number is an ``int`` (or a numpy integer), never a bool or a float such as 3.0: settings read
    from files are converted before they get here (``dexpush.cli.settings_file``), and a float count would
    fail later, deep inside, as an array size."""
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < low \
            or (high is not None and value > high):
        bounds = f">= {low}" if high is None else f"from {low} to {high}"
        raise ValueError(f"{name} must be a whole number {bounds}, got {value!r}")
    return int(value)


def check_params(params: object) -> None:
    """Reject λ = [β, x_bf, y_bf] outside the model's valid range: β in (0, 1e4] 1/m (β = 0 makes the
    limit surface degenerate; β = 1e4 is an object 0.1 mm across) and |x_bf|, |y_bf| ≤ 1 m."""
    p = np.asarray(params)
    beta = p[..., 0]
    if np.any(beta <= 0) or np.any(beta > MAX_BETA):
        raise ValueError(f"β (params[..., 0]) must be in (0, {MAX_BETA:g}] (1/m), got {beta}")
    if np.any(np.abs(p[..., 1:]) > 1.0):
        raise ValueError(f"the centre of friction (params[..., 1:], metres from the reference point) must be within "
                         f"1 m, got {p[..., 1:]}")


def checked_seed(seed: object) -> int:
    """``seed`` as an int in [0, 2³²): JAX's and numpy's generators take 32 bits, so larger seeds
    would silently repeat smaller ones."""
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer):
        if isinstance(seed, float | np.floating) and float(seed).is_integer():
            seed = int(seed)
        else:
            raise ValueError(f"seed must be a whole number, got {seed!r}")
    if not 0 <= int(seed) < 2**32:
        raise ValueError(f"seed must be in [0, 2**32), got {seed}")
    return int(seed)
