"""``PushingController.act`` against the footprint's edge count and the number of obstacles.

    python benchmarks/act_edges.py [--edges 4,64,256,1024] [--obstacles 0,1,8] [--calls 200] [--clutter SEED]

For regular polygons of each edge count (radius 8 cm), the library's 10 × 6 cm ellipse (256
footprint edges), the T (8 edges, not convex: the cost sees them all) and each obstacle count (discs
of 3 cm along the way to the goal, off the straight line), a controller is reset on the first
observation (that compiles: the time is printed) and then acts ``--calls`` times on exact frames
from the model plant. Prints the edges the cost's obstacle terms see (at most
``dexpush.problem.problem.COST_OUTLINE_EDGES`` for a convex footprint), the compile time and the
median and 99th percentile of ``act``. The last line printed is JSON. ``--clutter SEED`` adds the
clutter task's layout of that seed (Task C: discs, boxes, walls and the table, padded to 8 discs and
8 polygons) for the rectangle and the ellipse. Configurations whose cost sees the same arrays (the
same outline edge count and obstacle count) share one compiled program: their reset then costs
nothing. Run it on an idle machine.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

import dexpush
from dexpush.common.interfaces import Observation
from dexpush.problem import Problem
from dexpush.world.model_plant import ModelPlant


def _shape(kind: str) -> dexpush.Shape:
    if kind == "ellipse":
        return dexpush.Shape.ellipse()
    if kind == "tee":
        return dexpush.Shape.tee()
    n = int(kind)
    ang = 2 * np.pi * (np.arange(n) + 0.5) / n
    return dexpush.Shape.polygon(0.08 * np.stack([np.cos(ang), np.sin(ang)], -1), name=f"{n}-gon")


def _obstacles(m: int) -> tuple[tuple[float, float, float], ...]:
    """``m`` discs beside the way to the goal (0.6, 0, 0), alternately above and below it, clear of the goal."""
    return tuple((0.25 + 0.12 * (k // 2), (0.2 if k % 2 else -0.2) * (1 + 0.25 * (k // 2)), 0.03) for k in range(m))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--edges", default="4,64,256,1024")
    ap.add_argument("--obstacles", default="0,1,8")
    ap.add_argument("--calls", type=int, default=200)
    ap.add_argument("--clutter", type=int, default=None, metavar="SEED")
    args = ap.parse_args()
    cases = []
    for kind in [*args.edges.split(","), "ellipse", "tee"]:
        shape = _shape(kind)
        for m in (int(v) for v in args.obstacles.split(",")):
            r = float(shape.contour(np.array(np.pi))[0][0]) - 0.03
            problem = Problem(shape, (0.6, 0.0, 0.0), _obstacles(m))
            cases.append((shape, problem, (0.0, 0.0, 0.0), (r, 0.0), f"{m} obstacles"))
    if args.clutter is not None:
        from dexpush.experiments.scenarios import TASKS

        for shape in (dexpush.Shape.rectangle(), dexpush.Shape.ellipse()):
            problem, start, pusher = TASKS["C"].layout(shape, args.clutter)
            cases.append((shape, problem, tuple(start), tuple(pusher), f"clutter seed {args.clutter}"))
    rows = []
    for shape, problem, start, pusher, label in cases:
        ctrl = dexpush.PushingController(problem, params=(25.0, 0.0, 0.0))
        plant = ModelPlant(shape, params=(25.0, 0.0, 0.0))
        obs = plant.reset(start, pusher)
        t0 = time.perf_counter()
        ctrl.reset(obs.object_pose, obs.pusher_xy)
        compile_s = time.perf_counter() - t0
        ms = []
        for k in range(args.calls):
            t0 = time.perf_counter()
            u = ctrl.act(Observation(obs.object_pose, obs.pusher_xy, k * 0.04))
            ms.append((time.perf_counter() - t0) * 1e3)
            obs = plant.step(u, 0.04)
        row = {"shape": shape.name, "footprint_edges": len(shape.edges[0]),
               "cost_edges": int(problem.scene.edge_a.shape[0]), "case": label,
               "compile_s": round(compile_s, 1), "act_ms_median": round(float(np.median(ms)), 2),
               "act_ms_p99": round(float(np.percentile(ms, 99)), 2)}
        rows.append(row)
        print(f"{row['shape']:>9} ({row['footprint_edges']:4d} edges, cost {row['cost_edges']:3d}), "
              f"{label}: compile {row['compile_s']:6.1f} s, act median {row['act_ms_median']:6.2f} ms, "
              f"p99 {row['act_ms_p99']:6.2f} ms", flush=True)
    print(json.dumps(rows))


if __name__ == "__main__":
    main()
