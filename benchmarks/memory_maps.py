"""How many memory mappings a compiled controller program holds (Linux), and what frees them.

    python benchmarks/memory_maps.py

XLA's CPU client maps each compiled kernel's code and data separately, and a program stays mapped while
JAX caches it. A process that compiles many different programs (a test session, a notebook that tries many
settings) reaches Linux's ``vm.max_map_count`` (65,530 by default); LLVM's next allocation then fails
("LLVM compilation error: Cannot allocate memory") and XLA aborts or segfaults. This compiles one control
period (``policy_step``, the estimator and MPPI with K = 128) scanned over 40 frames, without and with the
push plan, and counts ``/proc/self/maps`` before, after, and after ``jax.clear_caches()``.
"""

from __future__ import annotations

import json
import os
from dataclasses import replace

import jax
import jax.numpy as jnp

from dexpush import Shape
from dexpush.control.controller import ControllerSettings
from dexpush.control.mppi import MPPISettings
from dexpush.control.policy import policy_init, policy_step
from dexpush.control.push_plan import PushPlanSettings
from dexpush.model.cgvmm import Contour
from dexpush.problem.scene import Scene

FRAMES = 40


def mappings() -> int:
    with open("/proc/self/maps", "rb") as f:
        return sum(1 for _ in f)


def scanned_policy(settings: ControllerSettings, shape: Shape) -> object:
    """One jitted program: ``policy_step`` over a (FRAMES, 5) array of observations."""
    contour, scene = Contour.of(shape), Scene.make(shape, (0.3, 0.0, 0.0), (), settings.weights)

    @jax.jit
    def run(xs: jnp.ndarray) -> tuple:
        def body(state: object, x: jnp.ndarray) -> tuple:
            state, u, _ = policy_step(state, x, True, contour=contour, scene=scene, settings=settings)
            return state, u
        return jax.lax.scan(body, policy_init((15.0, 0.0, 0.0), settings, 0), xs)
    return run


def main() -> None:
    if not os.path.exists("/proc/self/maps"):
        raise SystemExit("memory_maps: needs Linux's /proc/self/maps")
    shape = Shape.rectangle()
    on = ControllerSettings(estimate_params=True, mppi=MPPISettings(num_samples=128),
                            push_plan=PushPlanSettings(enabled=True))
    xs = jnp.tile(jnp.asarray([[0.0, 0.0, 0.0, -0.12, 0.01]], jnp.float32), (FRAMES, 1))
    out = {}
    for name, settings in (("without the push plan", replace(on, push_plan=PushPlanSettings(enabled=False))),
                           ("with the push plan", on)):
        before = mappings()
        jax.block_until_ready(scanned_policy(settings, shape)(xs))
        compiled = mappings()
        jax.clear_caches()
        out[name] = {"added": compiled - before, "left_after_clear_caches": mappings() - before}
        print(f"{name}: +{compiled - before} mappings compiled, +{mappings() - before} after jax.clear_caches()")
    with open("/proc/sys/vm/max_map_count") as f:
        out["vm.max_map_count"] = int(f.read())
    print(json.dumps(out))


if __name__ == "__main__":
    main()
