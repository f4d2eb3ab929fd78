"""The counter-based Gaussian noise of MPPI (dexpush.control.noise), the partition median and fastmath.materialize."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats

from dexpush.common import fastmath
from dexpush.control import noise
from dexpush.control.mppi import _median


def test_draws_are_standard_normal() -> None:
    z = np.asarray(noise.normal(jax.random.PRNGKey(3), (200_000,)), np.float64)
    assert abs(z.mean()) < 0.01 and abs(z.std() - 1.0) < 0.01
    assert abs(stats.skew(z)) < 0.03 and abs(stats.kurtosis(z)) < 0.06
    assert stats.kstest(z, "norm").pvalue > 1e-3
    assert np.abs(z).max() < 5.8           # the smallest uniform 2⁻²⁴ bounds the tail


def test_draws_depend_on_key_and_offset_only() -> None:
    k = jax.random.PRNGKey(0)
    a = noise.normal(k, (64, 25, 2))
    np.testing.assert_array_equal(a, noise.normal(k, (64, 25, 2)))          # reproducible
    flat = noise.normal(k, (64 * 50 + 10,))
    np.testing.assert_array_equal(np.ravel(a), flat[: 64 * 50])               # element j is draw j
    np.testing.assert_array_equal(noise.normal(k, (10,), offset=64 * 50), flat[64 * 50:])
    assert noise.normal(jax.random.key(0), (4,)).shape == (4,)                 # typed keys too


def test_neighbours_and_keys_are_uncorrelated() -> None:
    z = np.asarray(noise.normal(jax.random.PRNGKey(1), (100_000,)), np.float64)
    for lag in (1, 2, 50):
        assert abs(np.corrcoef(z[:-lag], z[lag:])[0, 1]) < 0.015
    keys = jax.random.split(jax.random.PRNGKey(2), 8)
    Z = np.stack([np.asarray(noise.normal(k, (20_000,)), np.float64) for k in keys])
    C = np.corrcoef(Z)
    assert np.abs(C[~np.eye(8, dtype=bool)]).max() < 0.03
    # successive controller keys (split, as plan_step does) give fresh draws
    k0 = jax.random.PRNGKey(7)
    k1 = jax.random.split(k0)[0]
    assert abs(np.corrcoef(noise.normal(k0, (20_000,)), noise.normal(k1, (20_000,)))[0, 1]) < 0.03


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(-1e6, 1e6, width=32), min_size=1, max_size=64))
def test_partition_median_is_the_median(values: list[float]) -> None:
    S = jnp.asarray(values, jnp.float32)
    assert float(_median(S)) == pytest.approx(float(jnp.median(S)), rel=1e-6, abs=1e-6)


def test_materialize_changes_no_value() -> None:
    x = jnp.linspace(-3.0, 3.0, 101)

    @jax.jit
    def f(x, dt):
        one = fastmath.traced_one(dt)
        (y,) = fastmath.materialize(one, x * x + 1.0)
        return y

    np.testing.assert_allclose(f(x, jnp.float32(0.04)), x * x + 1.0, rtol=2e-7)   # up to an FMA's rounding
    assert fastmath.materialize(1.0, x)[0] is x          # a Python 1: nothing to do
