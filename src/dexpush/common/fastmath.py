"""Float32 atan2 and sin/cos as branch-free polynomials, for the batched rollouts.

XLA's CPU backend evaluates ``atan2`` at ~24 ns and ``sin``/``cos`` at ~7 ns an element
on the 2-core machines we target (``benchmarks/mppi_speed.py --ops`` measures it), while
a fused multiply-add costs ~0.3 ns; in a C-GVMM rollout step these calls were more than a
third of the time. The polynomials here are accurate to a few float32 ulp:

* ``atan2``: octant reduction and the degree-17 odd polynomial of Abramowitz & Stegun
  4.4.49 (|error| ≤ 2e-8 rad before float32 rounding);
* ``sincos``: Cody–Waite reduction by π/2 with a two-part constant and Taylor polynomials
  on [−π/4, π/4] (truncation error < 2e-9 there; valid for |x| ≲ 1e4 rad).

Float64 inputs use the exact ``jnp`` functions, so float64 reference tests see no
approximation at all.
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

__all__ = ["atan2", "cos", "materialize", "sincos", "traced_one"]

_ATAN = (-0.3333314528, 0.1999355085, -0.1420889944, 0.1065626393,
         -0.0752896400, 0.0429096138, -0.0161657367, 0.0028662257)
_PIO2_HI = np.float32(1.5707963705062866)
_PIO2_LO = np.float32(np.pi / 2 - 1.5707963705062866)


def _is_f64(x: jnp.ndarray) -> bool:
    return jnp.asarray(x).dtype == jnp.float64


def atan2(y: jnp.ndarray, x: jnp.ndarray) -> jnp.ndarray:
    """atan2(y, x) in (−π, π]; polynomial in float32, exact ``jnp.arctan2`` in float64."""
    if _is_f64(y) or _is_f64(x):
        return jnp.arctan2(y, x)
    ax, ay = jnp.abs(x), jnp.abs(y)
    hi, lo = jnp.maximum(ax, ay), jnp.minimum(ax, ay)
    z = lo / jnp.where(hi == 0, 1.0, hi)
    z2 = z * z
    p = _ATAN[-1]
    for c in _ATAN[-2::-1]:
        p = p * z2 + c
    a = z + z * z2 * p
    a = jnp.where(ay > ax, np.float32(np.pi / 2) - a, a)
    a = jnp.where(x < 0, np.float32(np.pi) - a, a)
    return jnp.where(y < 0, -a, a)


def sincos(x: jnp.ndarray) -> tuple[jnp.ndarray, jnp.ndarray]:
    """(sin x, cos x); polynomial in float32, exact ``jnp`` in float64."""
    if _is_f64(x):
        return jnp.sin(x), jnp.cos(x)
    k = jnp.round(x * np.float32(2 / np.pi))
    r = (x - k * _PIO2_HI) - k * _PIO2_LO
    r2 = r * r
    s = r + r * r2 * (-1 / 6 + r2 * (1 / 120 + r2 * (-1 / 5040 + r2 * (1 / 362880))))
    c = 1 + r2 * (-0.5 + r2 * (1 / 24 + r2 * (-1 / 720 + r2 * (1 / 40320 + r2 * (-1 / 3628800)))))
    q = k.astype(jnp.int32) & 3
    sin = jnp.where(q == 0, s, jnp.where(q == 1, c, jnp.where(q == 2, -s, -c)))
    cos = jnp.where(q == 0, c, jnp.where(q == 1, -s, jnp.where(q == 2, -c, s)))
    return sin, cos


def cos(x: jnp.ndarray) -> jnp.ndarray:
    """cos x (see :func:`sincos`)."""
    return sincos(x)[1]


def materialize(one: jnp.ndarray | float, *values: jnp.ndarray) -> tuple[jnp.ndarray, ...]:
    """``values`` divided by ``one``, a traced 1 (:func:`traced_one`): the same numbers, stored once.

    XLA's CPU backend fuses elementwise code into loops with one output each and copies
    cheap producers into every loop that uses them; a C-GVMM step shares a few dozen
    intermediates among several outputs, so its loops recomputed them, several times the
    multiplications of the program as written. A division is not copied: a value
    divided by a runtime 1 is computed in one loop, stored, and read by its users. Placed at
    the seams of the step (docs/performance.md lists them and the measurements) this makes an
    MPPI iteration much faster on the CPU. Division by 1 is exact, so results do not change beyond
    the rounding of fused multiply-adds. With a Python number for ``one`` (no jit-time value
    to divide by) the values are returned as they are.
    """
    if isinstance(one, int | float):
        return values
    return tuple(v / one for v in values)


def traced_one(x: jnp.ndarray | float) -> jnp.ndarray | float:
    """1 + 0·x: a 1 that XLA cannot fold when ``x`` is traced (a Python 1.0 when it is a number)."""
    return 1.0 + 0.0 * x
