"""The ROS 2 node (``dexpush ros``): :class:`dexpush.ros.core.NodeCore` on ROS 2 topics (docs/ros.md).

Subscribes to the object's and the pusher's ``geometry_msgs/PoseStamped`` (best-effort, sensor QoS:
a reliable publisher matches too) and to goals (``PoseStamped``) and resets (``std_msgs/Empty``);
publishes ``geometry_msgs/TwistStamped`` (MoveIt Servo's ``delta_twist_cmds`` by default) and the
status as ``std_msgs/String`` holding one JSON object (``ros2 topic echo`` shows it).

Threads: the ROS executor takes messages and runs the stream timer (the watchdog, and with
smoothing the interpolated stream); the planner runs in its own thread, so a planner that hangs
or compiles never holds up the watchdog's zero. Needs ``rclpy``: ``pip install 'dexpush[ros]'``
or a sourced ROS 2 installation.
"""

from __future__ import annotations

import json
import math
import threading
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from dexpush.robot.smoothing import CommandSmoother
from dexpush.ros.core import NodeCore, yaw_of

__all__ = ["Topics", "clock_seconds", "planar_pose", "require_rclpy", "run_node", "seconds", "set_stamp"]


def require_rclpy() -> Any:
    """``rclpy``, or an ``ImportError`` saying how to get it."""
    try:
        import rclpy
    except ImportError as exc:
        raise ImportError("the ROS 2 node needs rclpy: pip install 'dexpush[ros]', or source a ROS 2 installation "
                          f"(setup.bash) before starting it ({exc})") from None
    return rclpy


@dataclass(frozen=True)
class Topics:
    """The node's topic names (relative names resolve in the node's namespace)."""

    object_pose: str = "/dexpush/object_pose"          #: geometry_msgs/PoseStamped in
    pusher_pose: str = "/dexpush/pusher_pose"          #: geometry_msgs/PoseStamped in
    goal: str = "/dexpush/goal"                        #: geometry_msgs/PoseStamped in
    reset: str = "/dexpush/reset"                      #: std_msgs/Empty in
    twist: str = "/servo_node/delta_twist_cmds"        #: geometry_msgs/TwistStamped out (MoveIt Servo's)
    status: str = "/dexpush/status"                    #: std_msgs/String (JSON) out


def seconds(stamp: Any) -> float:
    """A ``builtin_interfaces/Time`` in seconds."""
    return float(stamp.sec) + 1e-9 * float(stamp.nanosec)


def set_stamp(stamp: Any, t: float) -> None:
    """Write ``t`` (s) into a ``builtin_interfaces/Time``."""
    sec = math.floor(t)
    stamp.sec, stamp.nanosec = sec, min(int((t - sec) * 1e9), 999_999_999)


def clock_seconds(node: Any) -> float:
    """An rclpy node's clock now, in seconds."""
    return node.get_clock().now().nanoseconds * 1e-9


def planar_pose(msg: Any, frame_id: str, xyt: object, t: float) -> Any:
    """``msg`` (a ``geometry_msgs/PoseStamped``) holding the planar pose (x, y[, θ]) at time ``t`` in ``frame_id``."""
    v = [float(c) for c in np.ravel(xyt)]
    msg.header.frame_id = frame_id
    set_stamp(msg.header.stamp, t)
    msg.pose.position.x, msg.pose.position.y = v[0], v[1]
    th = v[2] if len(v) > 2 else 0.0
    msg.pose.orientation.z, msg.pose.orientation.w = math.sin(th / 2), math.cos(th / 2)
    return msg


class _Node:
    """The rclpy side: subscriptions, publishers, the stream timer and the planner thread."""

    def __init__(self, core: NodeCore, topics: Topics, name: str) -> None:
        require_rclpy()
        from geometry_msgs.msg import PoseStamped, TwistStamped
        from rclpy.node import Node
        from rclpy.qos import QoSProfile, qos_profile_sensor_data
        from std_msgs.msg import Empty, String

        self.core = core
        self.node = Node(name)
        self._Twist, self._String = TwistStamped, String
        reliable = QoSProfile(depth=10)
        n = self.node
        n.create_subscription(PoseStamped, topics.object_pose, self._on_object, qos_profile_sensor_data)
        n.create_subscription(PoseStamped, topics.pusher_pose, self._on_pusher, qos_profile_sensor_data)
        n.create_subscription(PoseStamped, topics.goal, self._on_goal, reliable)
        n.create_subscription(Empty, topics.reset, lambda _msg: core.reset(), reliable)
        self.twist_pub = n.create_publisher(TwistStamped, topics.twist, reliable)
        self.status_pub = n.create_publisher(String, topics.status, reliable)
        self.twist_frame = core.node.twist_frame or core.node.world_frame
        s = core.node
        self.smoother = None if s.smoothing is None else CommandSmoother(1.0 / s.stream_hz, s.smoothing)
        period = 1.0 / s.stream_hz if self.smoother is not None else core.T / 2
        n.create_timer(period, self._stream)
        n.create_timer(1.0 / s.status_hz, self._status)
        self.watchdog_trips = 0
        self._tripped = False
        self._stop = threading.Event()
        self._planner = threading.Thread(target=self._plan_loop, name="dexpush-planner", daemon=True)
        self.error: BaseException | None = None

    # ------------------------------------------------------------------ messages in
    def now(self) -> float:
        return clock_seconds(self.node)

    def _on_object(self, msg: Any) -> None:
        p, q = msg.pose.position, msg.pose.orientation
        self.core.object_pose(p.x, p.y, yaw_of(q.x, q.y, q.z, q.w), seconds(msg.header.stamp), msg.header.frame_id,
                              self.now())

    def _on_pusher(self, msg: Any) -> None:
        p = msg.pose.position
        self.core.pusher_pose(p.x, p.y, seconds(msg.header.stamp), msg.header.frame_id, self.now())

    def _on_goal(self, msg: Any) -> None:
        p, q = msg.pose.position, msg.pose.orientation
        self.core.set_goal((p.x, p.y, yaw_of(q.x, q.y, q.z, q.w)), msg.header.frame_id)

    # ------------------------------------------------------------------ commands out
    def _publish(self, v: np.ndarray) -> None:
        msg = self._Twist()
        msg.header.stamp = self.node.get_clock().now().to_msg()
        msg.header.frame_id = self.twist_frame
        msg.twist.linear.x, msg.twist.linear.y = float(v[0]), float(v[1])
        self.twist_pub.publish(msg)

    def _stream(self) -> None:
        """The stream timer: with smoothing, one step of the smoothed stream; without, the watchdog's zero."""
        target, tripped = self.core.stream_target(self.now())
        if tripped and not self._tripped:
            self.watchdog_trips += 1
            self.node.get_logger().warning("dexpush: no command for the watchdog's "
                                           f"{self.core.node.watchdog_s:g} s: sending zero")
        self._tripped = tripped
        if self.smoother is not None:
            self._publish(self.smoother.step(target))
        elif tripped:
            self._publish(target)

    def status(self) -> dict[str, Any]:
        """The status message's fields: the core's and the watchdog's trips."""
        return {**self.core.status(), "watchdog_trips": self.watchdog_trips}

    def _status(self) -> None:
        self.status_pub.publish(self._String(data=json.dumps(self.status())))

    # ------------------------------------------------------------------ the planner
    def _plan_loop(self) -> None:
        core, T = self.core, self.core.T
        pose_trigger = core.node.trigger == "pose"
        next_tick = time.monotonic()
        try:
            while not self._stop.is_set():
                if pose_trigger:             # on each pose, or 1.5 periods after the last plan without one
                    core.new_pose.wait(1.5 * T)
                    core.new_pose.clear()
                    began = time.monotonic()
                else:
                    delay = next_tick - time.monotonic()
                    if delay > 0:
                        self._stop.wait(delay)
                    began = next_tick
                    next_tick = max(next_tick + T, time.monotonic() - T)   # late: skip, never burst
                if self._stop.is_set():
                    break
                tick = core.tick()
                if self.smoother is None:
                    self._publish(tick.command)
                now = self.now()
                if tick.received is not None:
                    core.latencies_ms.append((now - tick.received) * 1e3)
                core.late_by(time.monotonic() - began)
        except BaseException as exc:      # the stream's watchdog sends zero from here on; the node reports it
            self.error = exc
            self.node.get_logger().error(f"dexpush: the planner stopped: {type(exc).__name__}: {exc}")

    def start(self) -> None:
        self._planner.start()

    def close(self) -> None:
        self._stop.set()
        self.core.new_pose.set()
        self._planner.join(timeout=5.0)
        for _ in range(3):                   # a stop the robot hears even if one message is lost
            self._publish(np.zeros(2))
        self.node.destroy_node()


def run_node(core: NodeCore, topics: Topics | None = None, name: str = "dexpush", duration_s: float | None = None,
             until_reached: bool = False) -> dict[str, Any]:
    """Run the node until SIGINT (Ctrl-C), ``duration_s`` seconds, or (``until_reached``) the goal is
    reached; then send zero and return the last status. Starts and shuts down ``rclpy`` unless a caller
    already did."""
    rclpy = require_rclpy()
    from rclpy.executors import ExternalShutdownException
    from rclpy.signals import SignalHandlerOptions

    own = not rclpy.ok()
    if own:       # Ctrl-C is a KeyboardInterrupt here, so that the zero twists go out before rclpy shuts down
        rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
    node = _Node(core, topics or Topics(), name)
    node.start()
    t_end = math.inf if duration_s is None else time.monotonic() + duration_s
    try:
        while rclpy.ok() and time.monotonic() < t_end and node.error is None:
            rclpy.spin_once(node.node, timeout_sec=0.05)
            if until_reached and core.mode == "reached":
                break
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        status = node.status()
        node.close()
        if own and rclpy.ok():
            rclpy.shutdown()
    if node.error is not None:
        raise RuntimeError(f"the planner stopped: {type(node.error).__name__}: {node.error}") from node.error
    return status
