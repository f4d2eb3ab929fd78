"""From a camera to ``PushingController.act``: calibrate, track the markers, push (docs/perception.md).

    python examples/camera_loop.py [--steps 250] [--out out/examples]

This is the loop a lab runs with a real camera, with only the camera replaced: its images come from
MuJoCo rendering the physics plant (a 1280×720 camera looking at the table from the side away from
the robot), handed over through the same ``VideoCaptureSource`` that wraps ``cv2.VideoCapture(0)`` on
a robot. Steps:

1. calibrate the camera's pose from an image of a ChArUco board lying on the table
   (``dexpush calibrate`` does the same from image files);
2. track the box's ArUco markers in each image (``MarkerTracker``: table-plane poses, with frames it
   cannot trust withheld) and hand the frames, with their capture times, to the controller;
3. stop the pusher whenever the loop goes blind (``CameraPoses.stale``: no image for 0.5 s, or no
   trusted pose for 3 s); shorter gaps, the arm passing over the markers, the controller predicts through.

The controller acts at 25 Hz (the paper's rate); the camera delivers at 15 Hz, so most periods have no
new frame (``act(None)``).

Needs the camera extra: ``pip install 'dexpush[camera]'``. Prints a one-line summary.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

import dexpush
from dexpush.experiments.scenarios import get_task
from dexpush.perception.calibration import Board, calibrate_extrinsics
from dexpush.perception.camera_file import read_camera_file, write_camera_file
from dexpush.perception.camera_model import CameraModel
from dexpush.perception.live import CameraPoses, VideoCaptureSource
from dexpush.perception.tracker import MarkerTracker
from dexpush.world.physics_plant import PhysicsPlant
from dexpush.world.rendered_camera import RenderedCamera, RenderSettings, board_images

FRAME_HZ = 15.0
PERIOD_S = dexpush.MPPISettings().control_period        # 0.04 s


class RenderedCapture:
    """Stands in for ``cv2.VideoCapture``: ``read()`` returns (ok, image) of the simulated table now."""

    def __init__(self, world: RenderedCamera) -> None:
        self.world = world

    def read(self) -> tuple[bool, np.ndarray]:
        return True, self.world.images()[0]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--steps", type=int, default=250, help="control periods to run for (default 250, 10 s)")
    ap.add_argument("--out", default="out/examples", help="where the camera file goes")
    args = ap.parse_args()
    shape = dexpush.Shape.rectangle()
    world = RenderedCamera(PhysicsPlant(shape), RenderSettings())   # the table, the box and one oblique camera
    truth = world.cameras[0]                                                     # (a real camera's is unknown)

    # 1. calibration: the maker's intrinsics, the pose from a board on the table
    maker = CameraModel(truth.width, truth.height, truth.fx, truth.fy, truth.cx, truth.cy, truth.distortion,
                        name=truth.name)
    board = Board(squares=(7, 5), square_m=0.05, marker_m=0.037, pose=(0.15, 0.3, 0.0))
    camera = calibrate_extrinsics(board_images(board, truth)[0], maker, board)
    path = Path(args.out) / "camera.toml"
    write_camera_file(path, [camera], "examples/camera_loop.py")

    # 2. the loop: camera → markers → frame → act → robot
    task = get_task("II")
    problem = task.problem(shape)
    pose, pusher = task.trial_start(shape, 0)
    world.plant.reset(pose, pusher)
    poses = CameraPoses([VideoCaptureSource(capture=RenderedCapture(world), clock=lambda: world.plant.time)],
                        MarkerTracker(read_camera_file(path), world.layout), clock=lambda: world.plant.time)
    controller = dexpush.PushingController(problem, params=(15.0, 0.0, 0.0))
    poses.start()                                    # the controller's clock starts now (time 0)
    frame = poses.frame(pusher_xy=world.plant.state[3:])
    if frame is None:
        raise SystemExit("the camera does not see the box's markers at the start")
    controller.reset(frame.object_pose, frame.pusher_xy)      # compiles (the simulated clock stands still)
    errors, stops, next_frame = [], 0, 1 / FRAME_HZ
    for step in range(args.steps):
        if step:                                     # (the first act takes the reset frame)
            frame = None
            if world.plant.time >= next_frame - 1e-9:                 # the camera's frame of this period
                frame = poses.frame(pusher_xy=world.plant.state[3:])  # the robot knows its own tip
                next_frame += 1 / FRAME_HZ
                if frame is not None:
                    errors.append(np.hypot(*(frame.object_pose[:2] - world.plant.state[:2])) * 1e3)
        if poses.stale:                                              # blind: stop the arm
            stops += 1
            velocity = np.zeros(2)
        else:
            velocity = controller.act(frame, 1 / FRAME_HZ)
        world.plant.step(velocity, PERIOD_S)                         # a real robot: send, wait one period
    x = world.plant.state
    counts = poses.tracker.counts
    print(json.dumps({"periods": args.steps, "frames": counts["frames"], "passed": counts["passed"],
                      "withheld": {k: v for k, v in counts.items() if k not in ("frames", "passed") and v},
                      "calibration_reprojection_px": round(camera.reprojection_error_px, 3),
                      "pose_error_mm_median": round(float(np.median(errors)), 2) if errors else None,
                      "stops": stops, "success": bool(problem.success(x[:3])),
                      "distance_to_goal_m": round(float(np.hypot(*(x[:2] - problem.goal[:2]))), 4),
                      "camera_file": str(path)}))


if __name__ == "__main__":
    main()
