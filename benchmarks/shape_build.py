"""How long building a Shape (its radial table) takes, by number of polygon corners.

    python benchmarks/shape_build.py [--corners 10,100,1000]

The shape is a star-shaped, wavy polygon (radius 8 cm ± 2 cm) with the given number of
corners; the table has 2,048 azimuths. Medians of 3 builds. The last line printed is JSON.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from dexpush import Shape


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--corners", default="10,100,1000")
    args = ap.parse_args()
    out = {}
    for n in (int(c) for c in args.corners.split(",")):
        ang = np.sort(np.random.default_rng(0).uniform(-np.pi, np.pi, n))
        r = 0.08 + 0.02 * np.sin(5 * ang)
        corners = np.stack([r * np.cos(ang), r * np.sin(ang)], -1)
        ts = []
        for _ in range(3):
            t0 = time.perf_counter()
            Shape.polygon(corners)
            ts.append(time.perf_counter() - t0)
        out[n] = round(float(np.median(ts)), 3)
        print(f"{n:6d} corners: {out[n]:.3f} s", flush=True)
    print(json.dumps({"build_s_by_corners": out}))


if __name__ == "__main__":
    main()
