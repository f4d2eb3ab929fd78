"""Real-time factor of the whole loop through rendered images: render + detect + plan + physics.

    python benchmarks/rendered_rtf.py [--seconds 12] [--setups top,two]

Task II on the rectangle (unknown λ, MPPI+UKF) on the physics plant, seen through each camera set-up at
15 Hz, for ``--seconds`` of simulated time after the controller has compiled; the loop is the episode
runner's (``act``, then the plant and camera step). Prints, per set-up, the real-time factor
(simulated seconds per wall second; ≥ 1 is real time) and where the wall time went, as Markdown rows,
then a JSON line. Run it alone: it times the machine.
"""

from __future__ import annotations

import argparse
import json
import platform
import time

import numpy as np

from dexpush.common.interfaces import CONTROL_PERIOD_S
from dexpush.experiments.methods import get_method
from dexpush.experiments.registry import PARAMS, make_shape
from dexpush.experiments.scenarios import get_task
from dexpush.world.physics_plant import PhysicsPlant
from dexpush.world.rendered_camera import RenderSettings


def measure(setup: str, seconds: float) -> dict:
    shape = make_shape("rect")
    task = get_task("II")
    problem = task.problem(shape)
    camera = RenderSettings(setup=setup).camera(PhysicsPlant(shape), problem.obstacles)
    pose, pusher = task.trial_start(shape, 0)
    frame = camera.reset(pose, pusher)
    controller = get_method("mppi-ukf").controller(problem, PARAMS["unknown"], seed=0)
    controller.reset(frame.object_pose, frame.pusher_xy)                  # compiles: not timed
    locate = camera.tracker.locate
    detect_s: list[float] = []

    def timed_locate(*a, **k):
        t = time.perf_counter()
        out = locate(*a, **k)
        detect_s.append(time.perf_counter() - t)
        return out

    camera.tracker.locate = timed_locate
    camera.render_s.clear()
    act_s = []
    steps = round(seconds / CONTROL_PERIOD_S)
    t0 = time.perf_counter()
    for _ in range(steps):
        t = time.perf_counter()
        u = controller.act(frame, 1 / 15)
        act_s.append(time.perf_counter() - t)
        frame = camera.step(u, CONTROL_PERIOD_S)
    wall = time.perf_counter() - t0
    render = float(np.sum(camera.render_s))
    detect = float(np.sum(detect_s))                   # the tracker's own time (the images are rendered before)
    act = float(np.sum(act_s))
    return {"setup": setup, "sim_s": steps * CONTROL_PERIOD_S, "wall_s": wall, "rtf": steps * CONTROL_PERIOD_S / wall,
            "render_s": render, "detect_pose_s": max(detect, 0.0), "act_s": act,
            "physics_other_s": wall - render - max(detect, 0.0) - act, "frames": len(camera.render_s),
            "withheld": camera.withheld}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=12.0, help="simulated seconds per set-up (default 12)")
    ap.add_argument("--setups", default="top,oblique,two", help="comma-separated camera set-ups")
    args = ap.parse_args()
    print(f"# {platform.machine()}, {platform.python_implementation()} {platform.python_version()}, "
          "1280×720 images at 15 Hz, control at 25 Hz")
    print("| set-up | real-time factor | wall s per simulated s: render / detect + pose / plan (act) / physics "
          "and the rest | frames withheld |\n|---|---|---|---|")
    rows = []
    for setup in args.setups.split(","):
        r = measure(setup, args.seconds)
        rows.append(r)
        per = [r[k] / r["sim_s"] for k in ("render_s", "detect_pose_s", "act_s", "physics_other_s")]
        print(f"| {setup} | {r['rtf']:.2f} | {' / '.join(f'{p:.3f}' for p in per)} | {r['withheld']}/{r['frames']} |",
              flush=True)
    print(json.dumps({r["setup"]: round(r["rtf"], 3) for r in rows}))


if __name__ == "__main__":
    main()
