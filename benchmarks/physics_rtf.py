"""Real-time factor of the MuJoCo physics plant: simulated seconds per wall-clock second.

    python benchmarks/physics_rtf.py [--seconds 4]

A pusher drives each standard shape across the table at 0.1 m/s (the controller's speed limit v_max),
stepped at the 25 Hz control rate as a controller would; prints one Markdown row per
shape and a JSON line last.
"""

from __future__ import annotations

import argparse
import json
import platform
import time

import numpy as np

from dexpush.experiments.benchmark import SHAPES, make_shape
from dexpush.world.physics_plant import PhysicsPlant


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=4.0, help="simulated seconds per shape (default 4)")
    args = ap.parse_args()
    print(f"# {platform.machine()}, physics timestep {PhysicsPlant(make_shape('rect')).model.opt.timestep} s")
    print("| shape | support points | real-time factor | max penetration (mm) |\n|---|---|---|---|")
    out = {}
    for name in SHAPES:
        shape = make_shape(name)
        plant = PhysicsPlant(shape)
        r = np.asarray(shape.contour(np.array(np.pi))[0])
        plant.reset([0.0, 0.0, 0.0], [r[0] - 0.002, 0.0])
        steps = int(args.seconds / 0.04)
        t0 = time.perf_counter()
        for _ in range(steps):
            plant.step([0.1, 0.0], 0.04)
        rtf = steps * 0.04 / (time.perf_counter() - t0)
        n_support = int(sum(plant.model.geom_type == 2))   # mjGEOM_SPHERE
        print(f"| {name} | {n_support} | {rtf:.1f}× | {plant.max_penetration * 1e3:.2f} |")
        out[name] = round(rtf, 2)
    print(json.dumps({"real_time_factor": out}))


if __name__ == "__main__":
    main()
