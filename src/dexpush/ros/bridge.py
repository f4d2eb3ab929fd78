"""A simulated world on ROS 2 topics (:class:`PlantBridge`): what a camera and a robot would publish, from a
plant seen through a camera, and the twists it executes (docs/ros.md#the-example-system).

In real time, every control period T the bridge holds the newest twist (zero when none came for
``hold_s``: a robot's own stop), steps the camera-wrapped plant by T, and publishes each frame the
camera delivers as the object's and the pusher's ``PoseStamped``, stamped with the frame's capture
time. The plant stays at rest, its start pose republished, until :meth:`PlantBridge.episode`
begins stepping it.
"""

from __future__ import annotations

import json
import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from dexpush.ros.node import Topics, clock_seconds, planar_pose, require_rclpy

__all__ = ["BridgeResult", "PlantBridge"]


@dataclass
class BridgeResult:
    """One episode through the bridge: the true states (k, 5), the twists executed (k, 2), whether it
    succeeded (judged on the truth), the node's last status, and the trace of the topics."""

    success: bool
    states: np.ndarray
    commands: np.ndarray
    status: dict
    trace: list[tuple[float, str, str]]
    touched: bool = False


class PlantBridge:
    """Poses out, twists in, for ``camera`` (a camera-wrapped plant: ``reset``, ``step``, ``state``;
    :meth:`dexpush.common.interfaces.Sensor.camera`).

    Args:
        camera: the world.
        control_period: T (s).
        frame_id: the poses' frame (the node's world frame).
        topics: the topic names (the node's).
        hold_s: a twist older than this is not executed (s).
    """

    def __init__(self, camera: Any, control_period: float, frame_id: str = "world", topics: Topics | None = None,
                 hold_s: float = 0.1, name: str = "dexpush_bridge") -> None:
        require_rclpy()
        from geometry_msgs.msg import PoseStamped, TwistStamped
        from rclpy.node import Node
        from rclpy.qos import QoSProfile
        from std_msgs.msg import Empty, String

        self.camera, self.T, self.frame_id, self.hold_s = camera, float(control_period), frame_id, float(hold_s)
        topics = topics or Topics()
        self.node = Node(name)
        q = QoSProfile(depth=10)
        self._Pose, self._Empty = PoseStamped, Empty
        self.object_pub = self.node.create_publisher(PoseStamped, topics.object_pose, q)
        self.pusher_pub = self.node.create_publisher(PoseStamped, topics.pusher_pose, q)
        self.goal_pub = self.node.create_publisher(PoseStamped, topics.goal, q)
        self.reset_pub = self.node.create_publisher(Empty, topics.reset, q)
        self.node.create_subscription(TwistStamped, topics.twist, self._on_twist, q)
        self.node.create_subscription(String, topics.status, self._on_status, q)
        self._lock = threading.Lock()
        self._twist = np.zeros(2)
        self._twist_at = -math.inf
        self.status: dict = {}
        self.trace: list[tuple[float, str, str]] | None = None

    def now(self) -> float:
        return clock_seconds(self.node)

    def _on_twist(self, msg: Any) -> None:
        v = np.array([msg.twist.linear.x, msg.twist.linear.y])
        with self._lock:
            self._twist, self._twist_at = v, time.monotonic()
        if self.trace is not None:
            self.trace.append((self.now(), "twist", f"{v[0]:.4f},{v[1]:.4f}"))

    def _on_status(self, msg: Any) -> None:
        with self._lock:
            self.status = json.loads(msg.data)
        if self.trace is not None:
            self.trace.append((self.now(), "status", msg.data))

    def _pose(self, xyt: np.ndarray, stamp: float) -> Any:
        return planar_pose(self._Pose(), self.frame_id, xyt, stamp)

    def publish_frame(self, object_pose: np.ndarray, pusher_xy: np.ndarray, stamp: float) -> None:
        self.pusher_pub.publish(self._pose(np.asarray(pusher_xy), stamp))   # first: the object's triggers a plan
        self.object_pub.publish(self._pose(np.asarray(object_pose), stamp))
        if self.trace is not None:
            self.trace.append((self.now(), "object_pose", ",".join(f"{v:.4f}" for v in object_pose)))

    def _spin_until(self, t: float, spin: Callable[[float], None]) -> None:
        while True:
            left = t - time.monotonic()
            if left <= 0:
                return
            spin(min(left, 0.005))

    def _wait(self, give_up: float, ready_s: float, spin: Callable[[float], None]) -> None:
        if time.monotonic() > give_up:
            raise RuntimeError(f"the node did not start pushing within {ready_s:g} s (status: {self.status})")
        self._spin_until(time.monotonic() + self.T, spin)

    def episode(self, object_pose: object, pusher_xy: object, goal: object, success: Callable[[np.ndarray], bool],
                touches: Callable[[np.ndarray], bool], max_steps: int, spin: Callable[[float], None],
                ready_s: float = 120.0, trace: bool = False) -> BridgeResult:
        """Reset the world and the node, send ``goal``, and run until the truth succeeds, the object or the
        pusher touches an obstacle, or ``max_steps``. ``spin(timeout)`` runs the caller's executor; the
        plant starts moving once the node reports it is pushing (it compiles first), within ``ready_s``."""
        self.trace = [] if trace else None
        frame = self.camera.reset(object_pose, pusher_xy)
        pose0, pusher0 = np.asarray(frame.object_pose, float), np.asarray(frame.pusher_xy, float)
        with self._lock:
            self.status, self._twist_at = {}, -math.inf
        g = np.asarray(goal, dtype=np.float64)
        g[2] = math.atan2(math.sin(g[2]), math.cos(g[2]))   # as the status reports it, from the quaternion
        give_up = time.monotonic() + ready_s

        def until(done: Callable[[dict], bool], send: Callable[[], None] | None = None) -> None:
            sent = -math.inf
            while not done(self.status):
                if send is not None and time.monotonic() - sent > 0.5:
                    send()
                    sent = time.monotonic()
                self.publish_frame(pose0, pusher0, self.now())   # the object waits at the start
                self._wait(give_up, ready_s, spin)

        until(bool)                                                  # the node is up and its topics matched
        until(lambda st: st.get("mode") == "idle" and st.get("goal") is None,
              lambda: self.reset_pub.publish(self._Empty()))        # it forgot the last episode
        until(lambda st: st.get("goal") is not None and np.allclose(st["goal"], g, atol=1e-3),
              lambda: self.goal_pub.publish(self._pose(g, self.now())))
        until(lambda st: st.get("mode") in ("pushing", "reached"))  # it compiled and planned
        epoch, t_next = self.now(), time.monotonic()
        states, commands = [np.asarray(self.camera.state, float)], []
        ok = touched = False
        stopped = 0                         # periods the node has held still, saying it reached the goal
        while len(commands) < max_steps and stopped < 25:
            with self._lock:
                v = self._twist.copy() if time.monotonic() - self._twist_at <= self.hold_s else np.zeros(2)
            frame = self.camera.step(v, self.T)
            x = np.asarray(self.camera.state, float)
            states.append(x)
            commands.append(v)
            if success(x[:3]):
                ok = True
                break
            if touches(x):
                touched = True
                break
            stopped = stopped + 1 if self.status.get("mode") == "reached" else 0
            if frame is not None:
                self.publish_frame(np.asarray(frame.object_pose), np.asarray(frame.pusher_xy), epoch + frame.time)
            t_next += self.T
            self._spin_until(t_next, spin)
        self._spin_until(time.monotonic() + 0.25, spin)    # the node's newest status comes in
        status = dict(self.status)
        self.reset_pub.publish(self._Empty())              # the node stops
        return BridgeResult(ok, np.asarray(states), np.asarray(commands).reshape(-1, 2), status,
                            self.trace or [], touched)

    def close(self) -> None:
        self.node.destroy_node()

