"""A robot's control loop at a 15 Hz camera's rate, against a stand-in robot (docs/robot.md).

    python examples/robot_loop.py [--realtime] [--physics] [--out out/examples]

Replace ``StandInRobot`` with your driver and ``Camera`` with your tracker; the loop in
``main`` is what runs on the robot. The stand-in is a plant behind the
:class:`dexpush.Plant` protocol (the model plant with a λ and μ_c the controller does not
know, or ``--physics``: MuJoCo), seen through the realistic camera (15 Hz, 1 mm / 0.5°
noise, 60 ms latency, 5 % dropped frames). The controller estimates λ online (the UKF),
commands the pusher at the camera's rate, and compensates the latency from each frame's
capture time. ``--realtime`` paces the loop by the wall clock as a robot would. Writes the
log in the format ``dexpush fit`` reads (``robot_loop_log.csv``) and prints a one-line summary.
"""

from __future__ import annotations

import argparse
import csv
import json
import time
from pathlib import Path

import numpy as np

import dexpush
from dexpush.problem.problem import is_success
from dexpush.world.model_plant import ModelPlant
from dexpush.world.physics_plant import PhysicsPlant
from dexpush.world.sensing import Camera

RATE_HZ = 15.0                     # the camera's rate: one command per frame period


class StandInRobot:
    """What your robot driver provides (the :class:`dexpush.Plant` protocol): hold a pusher
    velocity for ``dt`` seconds, and report the object pose and pusher position."""

    def __init__(self, shape: dexpush.Shape, physics: bool) -> None:
        self.world = PhysicsPlant(shape) if physics else ModelPlant(shape, params=(40.0, 0.006, -0.004), mu=0.25)

    def reset(self, object_pose: object, pusher_xy: object) -> dexpush.Observation:
        return self.world.reset(object_pose, pusher_xy)

    def step(self, velocity: object, dt: float) -> dexpush.Observation:
        return self.world.step(velocity, dt)          # a real driver: send the velocity, wait dt, read back

    def observe(self) -> dexpush.Observation:
        return self.world.observe()

    @property
    def state(self) -> np.ndarray:
        return self.world.state


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--realtime", action="store_true", help="pace the loop by the wall clock (15 Hz)")
    ap.add_argument("--physics", action="store_true", help="the stand-in robot is the MuJoCo plant")
    ap.add_argument("--max-steps", type=int, default=600, help="commands before giving up (default 600: 40 s)")
    ap.add_argument("--out", default="out/examples", help="output folder (default out/examples)")
    args = ap.parse_args()

    shape = dexpush.Shape.rectangle()                   # metres; the goal refers to the reference point
    goal = (0.30, 0.15, np.radians(30.0))
    settings = dexpush.ControllerSettings(
        estimate_params=True,                           # λ unknown: estimate it online
        mu=0.3,                                         # our guess of μ_c
        mppi=dexpush.MPPISettings(control_period=1.0 / RATE_HZ, v_max=0.1, dt0=1.0 / RATE_HZ))
    controller = dexpush.PushingController(shape, goal, params=(15.0, 0.0, 0.0), settings=settings, seed=0)

    robot = StandInRobot(shape, args.physics)
    camera = Camera(robot, dexpush.SensorSettings.realistic(seed=0))
    frame = camera.reset((0.0, 0.0, 0.0), (-0.16, 0.02))
    controller.reset(frame.object_pose, frame.pusher_xy)     # compiles before the clock starts

    period = 1.0 / RATE_HZ
    rows, latency_ms = [], []
    success = False
    next_tick = time.perf_counter()
    for _ in range(args.max_steps):
        t0 = time.perf_counter()
        command = controller.act(frame, period)        # frame is None when no frame arrived (dropped)
        latency_ms.append((time.perf_counter() - t0) * 1e3)
        if frame is not None:                           # log what the camera saw: the fit's input
            rows.append([frame.time, *frame.object_pose, *frame.pusher_xy])
        frame = camera.step(command, period)            # the robot holds the command for one period
        success = bool(is_success(robot.state[:3], goal))
        if success:
            break
        if args.realtime:
            next_tick += period
            time.sleep(max(0.0, next_tick - time.perf_counter()))

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    with open(out / "robot_loop_log.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["t", "x", "y", "theta", "px", "py"])
        w.writerows(rows)
    commands = len(latency_ms)
    print(json.dumps({"success": success, "commands": commands, "seconds": round(commands * period, 2),
                      "lambda_estimate": np.round(controller.params, 4).tolist(),
                      "act_ms_median": round(float(np.median(latency_ms)), 2),
                      "act_ms_p99": round(float(np.percentile(latency_ms, 99)), 2),
                      "rejected_frames": controller.rejected_frames, "log": str(out / "robot_loop_log.csv")}))


if __name__ == "__main__":
    main()
