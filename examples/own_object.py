"""Push your own object: a polygon you define, the MPPI controller, and a plant, in one loop.

    python examples/own_object.py [--out out/examples]

An L-shaped block (two rectangles; the reference point sits in the corner square, from
which every ray crosses the contour once) is pushed 5 cm and turned by 20° on the model
plant (the C-GVMM with the block's true friction parameters). The controller is told a
different λ than the plant's, as on a real robot. Writes a trajectory figure and prints
a one-line summary.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

import dexpush
from dexpush.experiments.scenarios import Task
from dexpush.model.cgvmm import MODE_NAMES
from dexpush.viz import plot_episode
from dexpush.world.model_plant import ModelPlant


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default="out/examples", help="output folder (default out/examples)")
    ap.add_argument("--max-steps", type=int, default=600, help="control steps before giving up (default 600)")
    args = ap.parse_args()

    # metres, in the object's body frame; the reference point (0, 0) is the body origin
    shape = dexpush.Shape.union([[[-0.03, -0.03], [0.10, -0.03], [0.10, 0.03], [-0.03, 0.03]],    # long arm
                                 [[-0.03, -0.03], [0.03, -0.03], [0.03, 0.10], [-0.03, 0.10]]],   # short arm
                                reference=(0.0, 0.0), pusher_radius=0.01)
    plant = ModelPlant(shape, params=(30.0, 0.01, 0.01))          # the world's true λ = [β, x_bf, y_bf]
    task = Task("L", "push the L", goal=(0.05, 0.02, np.radians(20.0)))
    controller = dexpush.PushingController(shape, task.goal, params=(20.0, 0.0, 0.0))   # our guess of λ
    result = dexpush.run_loop(plant, controller, task.problem(shape), object_pose=(0.0, 0.0, 0.0),
                              pusher_xy=(-0.08, 0.0), max_steps=args.max_steps)

    modes = np.asarray(dexpush.contact_solution(shape, result.states[:-1], result.commands, plant.params).mode)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    plot_episode(shape, result.states, modes, np.asarray(task.goal), np.zeros((0, 3)),
                 title=f"own L-shaped object: {'success' if result.success else 'failure'} "
                       f"in {len(result.commands)} steps", path=out / "own_object.png")
    print(json.dumps({"success": bool(result.success), "steps": len(result.commands),
                      "modes_used": sorted({MODE_NAMES[m] for m in modes}),
                      "final_pose": np.round(result.states[-1, :3], 4).tolist(),
                      "figure": str(out / "own_object.png")}))


if __name__ == "__main__":
    main()
