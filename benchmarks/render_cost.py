"""What a rendered frame costs, and what shadows and multisampling would add (why the rendered camera has neither).

    python benchmarks/render_cost.py [--frames 40]

Renders the rendered camera's scene (the box with its markers, the arm, the table) from the default
oblique camera at 1280 × 720 and at 848 × 480, as the rendered camera does (shadows and multisampling
off), then with 4× multisampling (MuJoCo's default), then with MuJoCo's default shadows too; prints the
median milliseconds per frame of MuJoCo's drawing and pixel read-back (the lens and the detection not
included) and a JSON line.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from dexpush.experiments.registry import make_shape
from dexpush.world.physics_plant import PhysicsPlant, SceneExtras
from dexpush.world.rendered_camera import RenderedCamera, RenderSettings


def frame_ms(width: int, height: int, samples: int, shadows: bool, frames: int) -> float:
    cam = RenderedCamera(PhysicsPlant(make_shape("rect")), RenderSettings(width=width, height=height))
    extras = cam.plant.extras
    visual = extras.visual.replace('offsamples="0"', f'offsamples="{samples}"')
    if shadows:                                    # MuJoCo's default shadow map (the scene's is size 0)
        visual = visual.replace('shadowsize="0" ', "")
    plant = PhysicsPlant(cam.plant.shape, cam.plant.settings, SceneExtras(extras.asset, extras.world, extras.slider,
                                                                          extras.pusher, visual, extras.files))
    plant.reset([0.3, 0.15, 0.2], [0.05, 0.15])
    mj = cam._mj
    out = []
    with mj.Renderer(plant.model, height, width) as r:
        for i in range(frames + 3):
            t = time.perf_counter()
            r.update_scene(plant.data, camera=cam.cameras[0].name)
            r.scene.flags[mj.mjtRndFlag.mjRND_SHADOW] = int(shadows)
            r.scene.flags[mj.mjtRndFlag.mjRND_REFLECTION] = 0
            r.render()
            if i >= 3:
                out.append((time.perf_counter() - t) * 1e3)
    return float(np.median(out))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--frames", type=int, default=40, help="frames per configuration (default 40)")
    args = ap.parse_args()
    rows = {}
    print("| image | as rendered (no shadows, no multisampling) | 4× multisampling | 4× multisampling and shadows |\n"
          "|---|---|---|---|")
    for w, h in ((1280, 720), (848, 480)):
        ms = [frame_ms(w, h, 0, False, args.frames), frame_ms(w, h, 4, False, args.frames),
              frame_ms(w, h, 4, True, args.frames)]
        rows[f"{w}x{h}"] = [round(m, 2) for m in ms]
        print(f"| {w} × {h} | {ms[0]:.1f} ms | {ms[1]:.1f} ms | {ms[2]:.1f} ms |", flush=True)
    print(json.dumps(rows))


if __name__ == "__main__":
    main()
