"""How near a disc MPPI's plan comes when its rollouts are integrated finer than the planner integrates them
(``MPPISettings.check_substeps``, docs/controller.md#the-temperature-beside-obstacles).

    python benchmarks/update_check.py [--iterations 100]

The state is the margin test's (``tests/test_cost.py::test_from_inside_the_margin_the_plan_never_comes_nearer``):
the 200 × 120 mm box 4 mm from a 5-cm disc, inside the 1-cm margin, the pusher behind it, the goal beyond the
disc. The planner iterates ``--iterations`` times from that state (λ_true known, no stall watch; the margin test
iterates ten times); the plan it ends with is then rolled out with 1, 2, 4 and 10 Euler steps per slot, and the
table gives the least clearance (mm) of its slot-end states in each. The planner's own rollouts take one step per
slot. Rows: the median over every sample (the default), and the median over the samples that paid no penalty
(``spread_cap`` 1e6) with its update checked in 1 step per slot (in the planner's own model: it catches an
average that crosses what no sample crossed, not the model's error) and in 4.
"""

from __future__ import annotations

import argparse
import functools

import jax
import jax.numpy as jnp

from dexpush import Shape
from dexpush.control.controller import ControllerSettings, plan_step, policy_init
from dexpush.control.mppi import MPPISettings
from dexpush.control.settings import StallSettings
from dexpush.model.cgvmm import LAMBDA_TRUE, Contour, integrate
from dexpush.problem.obstacles import clearance
from dexpush.problem.scene import Scene

SUBSTEPS = (1, 2, 4, 10)


@functools.partial(jax.jit, static_argnums=5)
def least_clearance(contour: Contour, scene: Scene, x: jnp.ndarray, sequence: jnp.ndarray, durations: jnp.ndarray,
                    substeps: int) -> jnp.ndarray:
    """The least clearance (m) of the slot-end states of ``sequence`` from ``x``, ``substeps`` steps per slot."""
    def slot(xs: jnp.ndarray, inp: tuple[jnp.ndarray, jnp.ndarray]) -> tuple[jnp.ndarray, jnp.ndarray]:
        xs = integrate(contour, xs, inp[0], inp[1], jnp.asarray(LAMBDA_TRUE, jnp.float32), jnp.float32(0.3),
                       substeps)
        return xs, clearance(xs, scene)

    return jnp.min(jax.lax.scan(slot, x, (sequence, durations))[1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--iterations", type=int, default=100,
                        help="MPPI iterations from the state (default 100: 4 s of replanning)")
    args = parser.parse_args()
    shape = Shape.rectangle()
    contour = Contour.of(shape)
    x = jnp.asarray([0.30 - 0.10 - 0.05 - 0.004, -0.03, 0.0, 0.30 - 0.155 - 0.11, -0.03], jnp.float32)
    print(f"# the box 4 mm from the disc, {args.iterations} iterations; least clearance (mm) of the plan rolled out "
          "with n Euler steps per slot")
    print("| λ's median over | update checked with | " + " | ".join(f"n = {n}" for n in SUBSTEPS) + " |")
    print("|---|---|" + "---|" * len(SUBSTEPS))
    for cap, check in ((None, None), (1e6, 1), (1e6, 4)):
        mppi = MPPISettings(spread_cap=cap) if check is None else MPPISettings(spread_cap=cap, check_substeps=check)
        settings = ControllerSettings(stall=StallSettings(after_s=None), mppi=mppi)
        scene = Scene.make(shape, (0.6, 0.0, 0.0), ((0.30, 0.0, 0.05),), settings.weights)
        step = jax.jit(functools.partial(plan_step, contour=contour, scene=scene, settings=settings))
        state = policy_init(LAMBDA_TRUE, settings, 3)
        for _ in range(args.iterations):
            state, _, result = step(state, x)
        durations = jnp.asarray(mppi.step_durations(), jnp.float32)
        gaps = [float(least_clearance(contour, scene, x, result.sequence, durations, n)) * 1e3 for n in SUBSTEPS]
        over = "every sample" if cap is None else "the samples that paid no penalty"
        checked = "–" if check is None else f"{check} step(s) per slot"
        print(f"| {over} | {checked} | " + " | ".join(f"{g:.2f}" for g in gaps) + " |")


if __name__ == "__main__":
    jax.config.update("jax_platform_name", "cpu")
    main()
