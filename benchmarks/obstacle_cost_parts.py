"""The obstacle cost of one clutter scene, whole and in parts, on a batch of random states.

    python benchmarks/obstacle_cost_parts.py [--shape ellipse] [--seed 0] [--states 25600]

For the clutter task's layout of ``--seed`` (Task C: padded to 8 discs and 8 polygons, the table as
the workspace), ``dexpush.problem.cost.obstacle_cost`` is compiled and timed on ``--states`` random
states (an MPPI iteration's 1024 samples × 25 steps) for the whole scene and for the scene with the
polygons, the discs or the workspace left out, and for 2 and 3 of the discs beside the 8 polygons and for
the polygons twice over without discs (the table left out). Prints the median of 10 calls per variant; the last
line is JSON. Run it on an idle machine.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import time

import jax
import jax.numpy as jnp
import numpy as np

import dexpush
from dexpush.experiments.scenarios import TASKS
from dexpush.problem.cost import obstacle_cost


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--shape", default="ellipse", choices=["rect", "tee", "ellipse"])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--states", type=int, default=1024 * 25)
    args = ap.parse_args()
    shape = {"rect": dexpush.Shape.rectangle, "tee": dexpush.Shape.tee, "ellipse": dexpush.Shape.ellipse}[args.shape]()
    problem = TASKS["C"].layout(shape, args.seed)[0]
    scene, weights = problem.scene, problem.weights
    no_polygons = {"polygons": scene.polygons[:0], "polygon_planes": scene.polygon_planes[:0]}
    variants = {"whole scene": scene,
                "discs and workspace": dataclasses.replace(scene, **no_polygons),
                "polygons and workspace": dataclasses.replace(scene, obstacles=scene.obstacles[:0]),
                "discs and polygons": dataclasses.replace(scene, bounds=scene.bounds[:0])}
    twice = {"polygons": jnp.concatenate([scene.polygons] * 2),
             "polygon_planes": jnp.concatenate([scene.polygon_planes] * 2)}
    for discs in (2, 3):                 # where the whole scene's slowdown begins: without the table
        variants[f"{discs} discs, 8 polygons"] = dataclasses.replace(scene, obstacles=scene.obstacles[:discs],
                                                                     bounds=scene.bounds[:0])
    variants["16 polygons"] = dataclasses.replace(scene, obstacles=scene.obstacles[:0], bounds=scene.bounds[:0],
                                                  **twice)
    rng = np.random.default_rng(0)
    n = args.states
    x = jnp.asarray(np.stack([rng.uniform(-0.5, 0.5, n), rng.uniform(-0.5, 0.5, n), rng.uniform(-np.pi, np.pi, n),
                              rng.uniform(-0.5, 0.5, n), rng.uniform(-0.5, 0.5, n)], -1), jnp.float32)
    rows = []
    for name, variant in variants.items():
        cost = jax.jit(lambda x, sc: obstacle_cost(x, sc, weights))
        t0 = time.perf_counter()
        cost(x, variant).block_until_ready()
        compile_s = time.perf_counter() - t0
        ms = []
        for _ in range(10):
            t0 = time.perf_counter()
            cost(x, variant).block_until_ready()
            ms.append((time.perf_counter() - t0) * 1e3)
        rows.append({"variant": name, "compile_s": round(compile_s, 1), "ms_median": round(float(np.median(ms)), 2)})
        print(f"{shape.name} clutter seed {args.seed}, {name:>22}: compile {compile_s:5.1f} s, "
              f"{n} states in {np.median(ms):7.2f} ms", flush=True)
    print(json.dumps(rows))


if __name__ == "__main__":
    main()
