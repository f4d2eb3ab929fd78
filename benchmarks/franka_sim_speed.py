"""Can this machine step the simulated FR3 in real time? franky-sim's FR3 with the box on the table, idle (no client),
paced at 1 kHz for ``--seconds``: its real-time factor and its step capacity (simulated seconds over the wall seconds
spent stepping: the factor it could reach unpaced), ``--repeats`` times, each in a fresh simulator.

    unshare -rn sh -c 'ip link set lo up; python benchmarks/franka_sim_speed.py'

The robot benchmark (``benchmarks/robot_sim.py``) needs a capacity well above 1 beside the planner on the other core;
below it the robot's clock falls behind the wall's, commands arrive late and the watchdog stops the arm
(docs/robot.md#the-tasks-area-round-the-disc). The last line printed is JSON.
"""

from __future__ import annotations

import argparse
import json
import time

from dexpush.experiments.registry import make_shape
from dexpush.robot.franka_sim import FrankaSim


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=8.0, help="wall seconds per run (default 8)")
    ap.add_argument("--repeats", type=int, default=3, help="runs, each in a fresh simulator (default 3)")
    args = ap.parse_args()
    runs = []
    for _ in range(args.repeats):
        with FrankaSim(make_shape("rect")) as sim:
            time.sleep(args.seconds)
            r = sim.report()
        runs.append({"real_time_factor": round(r.real_time_factor, 3), "step_capacity": round(r.step_capacity, 3)})
        print(f"real-time factor {r.real_time_factor:.2f}, step capacity {r.step_capacity:.2f}", flush=True)
    print(json.dumps({"runs": runs, "min_step_capacity": min(r["step_capacity"] for r in runs)}))


if __name__ == "__main__":
    main()
