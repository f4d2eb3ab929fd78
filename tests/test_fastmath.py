"""dexpush.common.fastmath in float32 against float64 numpy (the reference tests run in float64, where it
falls back to the exact functions, so its approximation is only ever exercised here)."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from dexpush.common import fastmath

_atan2 = jax.jit(fastmath.atan2)
_sincos = jax.jit(fastmath.sincos)


def test_atan2_float32_is_within_a_few_ulp_everywhere() -> None:
    rng = np.random.default_rng(0)
    pts = np.concatenate([rng.normal(size=(200_000, 2)) * 10.0 ** rng.uniform(-6, 3, (200_000, 1)),
                          [[0.0, 1.0], [0.0, -1.0], [1.0, 0.0], [-1.0, 0.0], [1.0, 1.0], [-1.0, -1.0],
                           [1e-30, -1.0], [-1e-30, -1.0]]])
    y, x = pts[:, 0].astype(np.float32), pts[:, 1].astype(np.float32)
    out = _atan2(jnp.asarray(y), jnp.asarray(x))
    assert out.dtype == jnp.float32
    got = np.asarray(out, np.float64)
    ref = np.arctan2(y.astype(np.float64), x.astype(np.float64))
    err = np.abs(np.angle(np.exp(1j * (got - ref))))
    assert np.all(np.isfinite(got))
    assert err.max() < 1e-6, f"worst error {err.max():.2e} rad at {pts[err.argmax()]}"
    assert np.all((got > -np.pi - 1e-6) & (got <= np.pi + 1e-6))


def test_sincos_float32_error_is_float32_rounding_for_angles_the_model_meets() -> None:
    x = np.concatenate([np.linspace(-4 * np.pi, 4 * np.pi, 100_001), np.linspace(-1e3, 1e3, 100_001)])
    xf = x.astype(np.float32)
    s, c = (np.asarray(a, np.float64) for a in _sincos(jnp.asarray(xf)))
    x64 = xf.astype(np.float64)                 # the float32 input, evaluated exactly
    assert np.abs(s - np.sin(x64)).max() < 5e-7 and np.abs(c - np.cos(x64)).max() < 5e-7
    assert np.abs(s * s + c * c - 1).max() < 2e-6


def test_float64_input_uses_the_exact_functions() -> None:
    with jax.enable_x64(True):
        x = jnp.asarray(np.linspace(-10, 10, 1001))
        np.testing.assert_array_equal(np.asarray(fastmath.sincos(x)[0]), np.asarray(jnp.sin(x)))
        np.testing.assert_array_equal(np.asarray(fastmath.atan2(x, x[::-1])), np.asarray(jnp.arctan2(x, x[::-1])))
