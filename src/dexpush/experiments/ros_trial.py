"""Episodes through ROS 2 (:func:`run_ros_episodes`): ``dexpush ros`` in its own process, a simulated world
behind :class:`dexpush.ros.bridge.PlantBridge` in this one, inside a loopback-only network namespace
(docs/ros.md#the-example-system).

Each trial is judged as :func:`dexpush.experiments.runner.run_loop` judges one: on the true state,
success within the goal's tolerance, failure on a touch or after ``max_steps`` control periods (or
when the node has stopped, saying it reached the goal, while the truth has not). Results go to
``ros_trials.jsonl`` in ``out``, one line per trial, written as each ends; a rerun skips the trials
already there.
"""

from __future__ import annotations

import csv
import json
import signal
import subprocess
import sys
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from dexpush.common.files import atomic_path
from dexpush.common.netns import ros_environment, why_not_loopback
from dexpush.experiments.registry import make_plant
from dexpush.experiments.scenarios import MAX_STEPS, TASKS
from dexpush.model.shape import Shape
from dexpush.world.sensing import SensorSettings

__all__ = ["run_ros_episodes", "stop_node"]


def _node_command(task: str, shape: str, method: str, params: str, seed: int, trigger: str,
                  extra: tuple[str, ...]) -> list[str]:
    return [sys.executable, "-m", "dexpush.cli", "ros", "--task", task, "--shape", shape, "--method", method,
            "--params", params, "--seed", str(seed), "--trigger", trigger, "--wait-for-goal", *extra]


def _done(path: Path) -> dict[tuple[str, str, int], dict]:
    rows: dict[tuple[str, str, int], dict] = {}
    if path.exists():
        for line in path.read_text().splitlines():
            if line.strip():
                r = json.loads(line)
                rows[(r["task"], r["shape"], r["seed"])] = r
    return rows


def _append(path: Path, row: dict) -> None:
    text = (path.read_text() if path.exists() else "") + json.dumps(row) + "\n"
    with atomic_path(path) as tmp:
        Path(tmp).write_text(text)


def run_ros_episodes(tasks: list[str], shapes: list[str], seeds: list[int], out: str | Path, *,
                     plant: str = "physics", sensor: SensorSettings | None = None, method: str = "mppi-ukf",
                     params: str = "unknown", trigger: str = "timer", max_steps: int = MAX_STEPS,
                     node_args: tuple[str, ...] = (), trace_first: bool = True, progress: bool = True) -> list[dict]:
    """Run every (task, shape, seed) through the node; the rows of ``ros_trials.jsonl`` (module docstring).

    ``sensor`` is the camera the bridge sees the plant through (default: the realistic noise model,
    reseeded per trial as ``dexpush bench`` does); ``trigger`` the node's (``timer``: every control
    period, as ``run_loop``; ``pose``: on each frame); ``node_args`` more flags for ``dexpush ros``. Must
    run in a loopback-only namespace.
    """
    why = why_not_loopback()
    if why is not None:
        raise OSError(f"ROS 2 runs here only in a loopback-only network namespace, and {why} "
                      "(examples/ros_system.py makes one)")
    from dexpush.ros.node import require_rclpy

    rclpy = require_rclpy()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    results = out / "ros_trials.jsonl"
    done = _done(results)
    sensor = sensor or SensorSettings.realistic(seed=0)
    env = ros_environment()
    env.setdefault("ROS_LOG_DIR", str(out / "ros_log"))
    rows = []
    for task_key in tasks:
        for shape_name in shapes:
            todo = [s for s in seeds if (task_key, shape_name, s) not in done]
            rows += [done[(task_key, shape_name, s)] for s in seeds if (task_key, shape_name, s) in done]
            if not todo:
                continue
            log_path = out / f"node_{task_key}_{shape_name}.log"
            with open(log_path, "a") as log:
                node = subprocess.Popen(_node_command(task_key, shape_name, method, params, 0, trigger, node_args),
                                        env=env, stdout=log, stderr=subprocess.STDOUT)
                from rclpy.signals import SignalHandlerOptions

                rclpy.init(signal_handler_options=SignalHandlerOptions.NO)    # Ctrl-C: a KeyboardInterrupt
                try:
                    for row in _group(rclpy, node, log_path, task_key, shape_name, todo, plant, sensor, max_steps,
                                      trace_first, out):
                        _append(results, row)
                        rows.append(row)
                        if progress:
                            lat = row["status"].get("latency_ms") or {}
                            print(f"ros: task {task_key} {shape_name} seed {row['seed']}: "
                                  f"{'success' if row['success'] else 'fail'} in {row['time_s']} s, node latency "
                                  f"median {lat.get('median')} ms, p99 {lat.get('p99')} ms", file=sys.stderr)
                finally:
                    rclpy.shutdown()
                    stop_node(node)
    return rows


def stop_node(node: subprocess.Popen, timeout_s: float = 20.0) -> int:
    """Ctrl-C to a ``dexpush ros`` process, as a user would, and its exit code (killed after ``timeout_s``)."""
    if node.poll() is None:
        node.send_signal(signal.SIGINT)
        try:
            node.wait(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            node.kill()
            node.wait()
    return node.returncode


def _group(rclpy: Any, node: subprocess.Popen, log_path: Path, task_key: str, shape_name: str, seeds: list[int],
           plant: str, sensor: SensorSettings, max_steps: int, trace_first: bool, out: Path) -> Any:
    """The trials of one (task, shape) through one node: yields their rows."""
    from dexpush.control.controller import ControllerSettings
    from dexpush.experiments.registry import make_shape
    from dexpush.ros.bridge import PlantBridge

    task = TASKS[task_key]
    shape: Shape = make_shape(shape_name)
    problem = task.problem(shape)
    T = ControllerSettings().mppi.control_period
    bridge = None

    def spin(timeout: float) -> None:
        if node.poll() is not None:
            raise RuntimeError(f"dexpush ros exited with code {node.returncode} (its log: {log_path})")
        rclpy.spin_once(bridge.node, timeout_sec=timeout)

    def touches(x: np.ndarray) -> bool:
        return problem.has_obstacles and bool(problem.collides(x))

    try:
        for seed in seeds:
            world = make_plant(plant, shape, seed)
            camera = replace(sensor, seed=sensor.seed * 1_000_003 + seed).camera(world, problem.obstacles)
            if bridge is None:
                bridge = PlantBridge(camera, T)
            bridge.camera = camera
            pose, pusher = task.trial_start(shape, seed)
            t0 = time.perf_counter()
            r = bridge.episode(pose, pusher, task.goal, problem.success, touches, max_steps, spin,
                               trace=trace_first and seed == seeds[0])
            final = r.states[-1]
            if r.trace:
                with atomic_path(out / f"trace_{task_key}_{shape_name}_{seed}.csv") as tmp, open(tmp, "w",
                                                                                                 newline="") as fh:
                    w = csv.writer(fh)
                    w.writerow(["t", "topic", "value"])
                    w.writerows((f"{t - r.trace[0][0]:.4f}", topic, v) for t, topic, v in r.trace)
            yield {"task": task_key, "shape": shape_name, "seed": seed, "success": r.success, "touched": r.touched,
                   "steps": len(r.commands), "time_s": round(len(r.commands) * T, 2),
                   "final_distance_m": round(float(np.hypot(*(final[:2] - np.asarray(task.goal[:2])))), 4),
                   "wall_s": round(time.perf_counter() - t0, 1), "status": r.status}
    finally:
        if bridge is not None:
            bridge.close()
