"""The ROS 2 example system: ``dexpush ros`` pushing an object in the MuJoCo plant through ROS 2 topics.

    python examples/ros_system.py                      # Task I, the rectangle, seed 0
    python examples/ros_system.py --tasks I,III --shapes rect,tee --seeds 0-9 --out out/ros

The node runs in its own process (the command a lab starts beside its robot); this process is the
world: the physics plant, seen through the realistic noise-model camera, behind a bridge node that
publishes the object's and the pusher's poses and executes the node's twists (docs/ros.md). Both
run inside a new network namespace with only the loopback interface up (this script makes it with
``unshare -rn`` and runs itself there), so DDS never reaches another machine. Needs the ros extra:
``pip install -e '.[ros]'``.
"""

from __future__ import annotations

import argparse
import os
import sys

from dexpush.cli.arguments import seed_list


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--tasks", default="I", help="comma-separated tasks (default I)")
    p.add_argument("--shapes", default="rect", help="comma-separated shapes (default rect)")
    p.add_argument("--seeds", type=seed_list, default=[0], help="e.g. 0-9 (default 0)")
    p.add_argument("--trigger", default="timer", choices=("timer", "pose"),
                   help="the node plans every control period (timer, as run_loop), or on each pose (default timer)")
    p.add_argument("--camera-rate", type=float, default=15.0,
                   help="the realistic camera's frame rate (Hz, default 15: the paper's)")
    p.add_argument("--out", default="out/examples/ros", help="output folder (default out/examples/ros)")
    args = p.parse_args()

    from dexpush.common.netns import run_in_loopback_namespace

    try:
        code = run_in_loopback_namespace([sys.executable, *sys.argv])   # DDS never leaves the machine
    except OSError as exc:
        print(f"ros_system: {exc}; not running ROS 2", file=sys.stderr)
        return 2
    if code is not None:
        return code

    from dataclasses import replace

    from dexpush.experiments.ros_trial import run_ros_episodes
    from dexpush.world.sensing import SensorSettings

    camera = replace(SensorSettings.realistic(seed=0), rate_hz=args.camera_rate)
    try:
        rows = run_ros_episodes(args.tasks.split(","), args.shapes.split(","), args.seeds, args.out,
                                sensor=camera, trigger=args.trigger)
    except KeyboardInterrupt:
        print(f"ros_system: interrupted; every finished trial is in {args.out}: the same command resumes there",
              file=sys.stderr)
        return 130
    except (OSError, RuntimeError) as exc:
        print(f"ros_system: {exc}", file=sys.stderr)
        return 1
    for (task, shape) in dict.fromkeys((r["task"], r["shape"]) for r in rows):
        group = [r for r in rows if (r["task"], r["shape"]) == (task, shape)]
        ok = [r for r in group if r["success"]]
        mean = sum(r["time_s"] for r in ok) / len(ok) if ok else float("nan")
        lat = group[-1]["status"].get("latency_ms") or {}
        print(f"task {task} {shape}: {len(ok)}/{len(group)} reached the goal through ROS 2, mean time {mean:.1f} s; "
              f"pose received -> twist published: median {lat.get('median')} ms, p99 {lat.get('p99')} ms")
    print(f"results: {os.path.join(args.out, 'ros_trials.jsonl')}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
