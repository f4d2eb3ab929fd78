"""What one batched control step costs, piece by piece, on this machine's default JAX device.

    python benchmarks/step_breakdown.py [--lanes 120] [--samples 1024] [--repeats 20]

The batched simulator (dexpush.experiments.simulate) advances ``lanes`` trials per compiled step: the
controller's ``policy_step`` (UKF window update, then one MPPI iteration) and the model
plant (10 Euler substeps). This times, vmapped over the lanes and jitted, each piece alone
and the whole step, with the UKF on and off, plus a 25-step scanned chunk as the benchmark
runs it. Medians of ``--repeats`` calls after warm-up. Use it on a CPU and on a GPU to see
what dominates there. The last line printed is JSON.

Two rows time the estimator's per-lane switch (half the lanes on, as the benchmark's mixed
queue of MPPI and MPPI+UKF trials has it): the way ``estimate_step`` does it (compute the
update, keep it where the flag is set) and the ``lax.cond`` it replaced, rebuilt here from the
same pieces (docs/performance.md#the-estimators-switch).
"""

from __future__ import annotations

import argparse
import json
import time
from functools import partial

import jax
import jax.numpy as jnp
import numpy as np

from dexpush.control.controller import ControllerSettings, estimate_step, plan_step, policy_init, policy_step
from dexpush.control.estimator import estimator_observe, rate_limited
from dexpush.control.mppi import MPPISettings
from dexpush.experiments.registry import make_shape
from dexpush.experiments.scenarios import get_task, initial_conditions
from dexpush.model.cgvmm import LAMBDA_TRUE, Contour, integrate
from dexpush.problem.scene import Scene


def median_ms(fn, repeats: int) -> float:
    jax.block_until_ready(fn())
    jax.block_until_ready(fn())
    ts = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        jax.block_until_ready(fn())
        ts.append(time.perf_counter() - t0)
    return float(np.median(ts) * 1e3)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--lanes", type=int, default=120)
    ap.add_argument("--samples", type=int, default=1024)
    ap.add_argument("--repeats", type=int, default=20)
    ap.add_argument("--task", default="II")
    ap.add_argument("--shape", default="rect")
    args = ap.parse_args()
    task, shape = get_task(args.task), make_shape(args.shape)
    settings = ControllerSettings(mppi=MPPISettings(num_samples=args.samples))
    contour, scene = Contour.of(shape), Scene.make(shape, task.goal, task.obstacles, settings.weights)
    B = args.lanes
    x0 = np.stack([np.concatenate(initial_conditions(task, shape, s)) for s in range(B)]).astype(np.float32)
    X = jnp.asarray(x0)
    states = jax.vmap(lambda s: policy_init((15.0, 0.0, 0.0), settings, s))(jnp.arange(B))
    # fill the UKF windows so the estimate branch does its full work
    fill = jax.jit(jax.vmap(partial(estimate_step, estimate=True, contour=contour, settings=settings)))
    for _ in range(settings.ukf.window + 1):
        states = fill(states, X)
    lam, mu, T = jnp.asarray(LAMBDA_TRUE, jnp.float32), jnp.float32(0.3), jnp.float32(0.04)
    U = jnp.full((B, 2), 0.03, jnp.float32)

    def estimate_by_cond(state, x, on):
        """``estimate_step`` before 2026-11-23, as it was: ``lax.cond`` on the flag (a select under vmap)."""
        dt = jnp.float32(settings.mppi.control_period)

        def observe(s):
            est, _ = estimator_observe(s.estimator, x, jnp.bool_(True), contour, settings.ukf, s.mu, dt,
                                       settings.ukf_substeps)
            return est, rate_limited(s.params, est.filter.mean, dt, settings.ukf), s.mu

        est, lam, mu = jax.lax.cond(on, observe, lambda s: (s.estimator, s.params, s.mu), state)
        return state._replace(estimator=est, params=lam, mu=mu)

    pieces = {
        "estimate (UKF window update)": jax.jit(jax.vmap(
            lambda s, x: estimate_step(s, x, True, contour=contour, settings=settings))),
        "estimate, UKF flag per lane (half on)": jax.jit(jax.vmap(
            lambda s, x, e: estimate_step(s, x, e, contour=contour, settings=settings))),
        "estimate, UKF flag per lane through lax.cond (before)": jax.jit(jax.vmap(estimate_by_cond)),
        "plan (one MPPI iteration)": jax.jit(jax.vmap(
            lambda s, x: plan_step(s, x, contour=contour, scene=scene, settings=settings)[1])),
        "plant (10 Euler substeps)": jax.jit(jax.vmap(lambda s, x: integrate(contour, x, U[0], T, lam, mu, 10))),
        "policy_step, UKF on": jax.jit(jax.vmap(
            lambda s, x: policy_step(s, x, True, contour=contour, scene=scene, settings=settings)[1])),
        "policy_step, UKF off": jax.jit(jax.vmap(
            lambda s, x: policy_step(s, x, False, contour=contour, scene=scene, settings=settings)[1])),
        "policy_step, UKF flag per lane (half on)": jax.jit(jax.vmap(
            lambda s, x, e: policy_step(s, x, e, contour=contour, scene=scene, settings=settings)[1])),
    }
    flags = jnp.arange(B) % 2 == 0
    rows = {}
    for name, fn in pieces.items():
        call = (lambda fn=fn: fn(states, X, flags)) if "flag per lane" in name else (lambda fn=fn: fn(states, X))
        rows[name] = median_ms(call, args.repeats)

    @jax.jit
    def chunk(s, x):
        def body(c, _):
            s, x = c
            s, u, _ = jax.vmap(lambda a, b, e: policy_step(a, b, e, contour=contour, scene=scene,
                                                           settings=settings))(s, x, flags)
            x = jax.vmap(lambda xi, ui: integrate(contour, xi, ui, T, lam, mu, 10))(x, u)
            return (s, x), None
        return jax.lax.scan(body, (s, x), None, length=25)[0]

    rows["25-step scanned chunk (per step)"] = median_ms(lambda: chunk(states, X), max(3, args.repeats // 4)) / 25
    dev = jax.devices()[0]
    print(f"# {dev.platform} ({dev.device_kind}), jax {jax.__version__}, {B} lanes × K = {args.samples}")
    print("| piece | ms per control step (all lanes) |")
    print("|---|---|")
    for name, ms in rows.items():
        print(f"| {name} | {ms:.2f} |")
    print(json.dumps({"device": f"{dev.platform} {dev.device_kind}", "lanes": B, "samples": args.samples,
                      "ms": {k: round(v, 3) for k, v in rows.items()}}))


if __name__ == "__main__":
    main()
