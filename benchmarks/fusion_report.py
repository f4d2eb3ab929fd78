"""How XLA compiles one C-GVMM step on this machine: fused loops and copied operations.

    python benchmarks/fusion_report.py [--shape rect|tee] [--samples 1024]

Compiles ``dexpush.model.cgvmm.step`` on a batch of states as the MPPI rollout calls it (state as a
tuple of arrays, traced Δt), with and without the seams of ``dexpush.common.fastmath.materialize``
(without: ``traced_one`` is made to return a Python 1, so no value is stored on purpose), and
prints for each: the number of fused loops XLA runs per step, the multiplications in the
program as written and in the compiled loops (their ratio is how much XLA recomputes), and
the time of a 25-step rollout over the batch (best of 5 blocks of 50 calls). The last line
printed is JSON. See docs/performance.md.
"""

from __future__ import annotations

import argparse
import json
import re
import time

import jax
import jax.numpy as jnp
import numpy as np

import dexpush  # noqa: F401  (XLA settings first)
from dexpush.common import fastmath
from dexpush.experiments.registry import make_shape
from dexpush.model import cgvmm as model
from dexpush.model.cgvmm import LAMBDA_TRUE, Contour


def count(hlo: str, op: str) -> int:
    return len(re.findall(rf"= \S+ {op}\(", hlo))


def report(contour: Contour, K: int) -> dict:
    p = jnp.asarray(LAMBDA_TRUE, jnp.float32)
    rng = np.random.default_rng(0)
    xs = tuple(jnp.asarray(v, jnp.float32) for v in (rng.normal(0, .01, K), rng.normal(0, .01, K),
                                                     rng.normal(0, .1, K), rng.normal(-.1, .01, K),
                                                     rng.normal(0, .01, K)))
    u = jnp.asarray(rng.normal(0, .05, (K, 2)), jnp.float32)
    lowered = jax.jit(lambda xs, u, dt: model.step(contour, xs, u, dt, p, 0.3)).lower(xs, u, jnp.float32(0.04))
    written, compiled = lowered.as_text(dialect="hlo"), lowered.compile().as_text()

    V = jnp.asarray(rng.normal(0, .05, (25, K, 2)), jnp.float32)
    dts = jnp.full(25, 0.04, jnp.float32)

    @jax.jit
    def rollout(x, V, dts):
        return jax.lax.scan(lambda x, inp: (model.step(contour, x, inp[0], inp[1], p, 0.3), None), x, (V, dts))[0]

    jax.block_until_ready(rollout(xs, V, dts))
    best = float("inf")
    for _ in range(5):
        t0 = time.perf_counter()
        for _ in range(50):
            jax.block_until_ready(rollout(xs, V, dts))
        best = min(best, (time.perf_counter() - t0) / 50)
    return {"loops_per_step": count(compiled, "fusion"), "multiplies_written": count(written, "multiply"),
            "multiplies_compiled": count(compiled, "multiply"), "rollout_ms": round(best * 1e3, 3)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--shape", default="rect")
    ap.add_argument("--samples", type=int, default=1024)
    args = ap.parse_args()
    contour = Contour.of(make_shape(args.shape))
    rows = {"with seams": report(contour, args.samples)}
    original = fastmath.traced_one
    fastmath.traced_one = lambda x: 1.0
    try:
        rows["without seams"] = report(contour, args.samples)
    finally:
        fastmath.traced_one = original
    print(f"# {args.shape}, K = {args.samples}, jax {jax.__version__} ({jax.default_backend()})")
    print("| step compiled | fused loops | multiplications (written → compiled) | 25-step rollout (ms) |")
    print("|---|---|---|---|")
    for name, r in rows.items():
        ratio = r["multiplies_compiled"] / r["multiplies_written"]
        print(f"| {name} | {r['loops_per_step']} | {r['multiplies_written']} → {r['multiplies_compiled']} "
              f"({ratio:.1f}×) | {r['rollout_ms']:.2f} |")
    print(json.dumps({"shape": args.shape, "samples": args.samples, **rows}))


if __name__ == "__main__":
    main()
