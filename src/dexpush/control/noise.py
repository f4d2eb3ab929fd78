"""Counter-based Gaussian noise for MPPI: a keyed integer hash of each sample's index, then Box–Muller.

MPPI draws ~28,000 standard normals an iteration (K = 1024, N_p = 25). On the CPU,
``jax.random.normal``'s threefry generator costs a sizeable share of the iteration, and the
``rbg`` generators more (``benchmarks/mppi_speed.py --noise`` prints the comparison). Here each normal costs
four evaluations of a 32-bit integer hash and a Box–Muller transform:

    h_j(i) = mix(mix(2i + j + k₀) ⊕ k₁),  j = 0, 1                   (k₀, k₁: the key's 2 words)
    u₁ = (⌊h₀/2⁸⌋ + 1)·2⁻²⁴ ∈ (0, 1],  u₂ = ⌊h₁/2⁸⌋·2⁻²⁴ ∈ [0, 1)
    z = √(−2 ln u₁)·cos 2πu₂                                      (one draw per index i)

``mix`` is the ``lowbias32`` finaliser (C. Wellons, "Prospecting for hash functions", 2018):
x ⊕= x ≫ 16; x ·= 0x7feb352d; x ⊕= x ≫ 15; x ·= 0x846ca68b; x ⊕= x ≫ 16, a bijection of the
32-bit integers with low avalanche bias. The draws are a pure function of (key, index), like
JAX's own counter-based generators, so a run reproduces by seed; the smallest u₁ = 2⁻²⁴ bounds
|z| by 5.8 (the normal's mass beyond is 7·10⁻⁹). ``tests/test_noise.py`` checks the moments,
the distribution (Kolmogorov–Smirnov), independence across keys and between neighbours.
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np

from dexpush.common import fastmath

__all__ = ["normal"]


def _mix(x: jnp.ndarray) -> jnp.ndarray:
    """lowbias32: a bijective 32-bit integer hash."""
    x = x ^ (x >> 16)
    x = x * np.uint32(0x7FEB352D)
    x = x ^ (x >> 15)
    x = x * np.uint32(0x846CA68B)
    return x ^ (x >> 16)


def normal(key: jax.Array, shape: tuple[int, ...], dtype: jnp.dtype = jnp.float32, offset: int = 0) -> jnp.ndarray:
    """Standard normal draws of ``shape``, a pure function of ``key`` (any JAX PRNG key) and the
    index; element j (C order) is draw ``offset + j`` of the key's stream, so one key serves several
    arrays without ``jax.random.split`` (itself a threefry call).

    Each element uses the cosine half of its own Box–Muller pair: the same operations for every
    element, so XLA fuses the generator into its consumer as one vectorised loop (pairing the
    cosine and sine halves would halve the hashing but split the loop into slower branches).
    Float64 requests get float32-quality draws (24-bit uniforms) cast to float64.
    """
    words = jax.random.key_data(key) if jnp.issubdtype(key.dtype, jax.dtypes.prng_key) else key
    words = jnp.ravel(words).astype(jnp.uint32)
    k0, k1 = words[0], words[-1] ^ np.uint32(0x9E3779B9)
    i = (jax.lax.iota(jnp.uint32, math.prod(shape)).reshape(shape) + np.uint32(offset)) * np.uint32(2) + k0
    h0 = _mix(_mix(i) ^ k1)
    h1 = _mix(_mix(i + np.uint32(1)) ^ k1)
    scale = np.float32(2.0**-24)
    u1 = ((h0 >> 8).astype(jnp.float32) + 1.0) * scale
    u2 = (h1 >> 8).astype(jnp.float32) * scale
    z = jnp.sqrt(-2.0 * jnp.log(u1)) * fastmath.cos(np.float32(2 * np.pi) * u2)
    return z.astype(dtype)
