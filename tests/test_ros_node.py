"""The ROS 2 node end to end (``dexpush ros`` in its own process, talking over DDS): an episode to the goal
through the bridge, zero twists when the poses stop, bad messages rejected without a crash, a clean
exit on Ctrl-C. Needs rclpy (the ros extra) and runs only inside a loopback-only network namespace:
``make test-ros`` makes one; elsewhere these tests are skipped, never run on the host network."""

import json
import math
import subprocess
import sys
import time

import numpy as np
import pytest

pytestmark = pytest.mark.ros


def _skip_reason() -> str | None:
    try:
        import rclpy  # noqa: F401
    except ImportError:
        return "needs rclpy: pip install -e '.[ros]' (make test-ros)"
    from dexpush.common.netns import why_not_loopback

    why = why_not_loopback()
    if why is not None:
        return f"ROS 2 tests run only in a loopback-only network namespace (make test-ros), and {why}"
    return None


if (_why := _skip_reason()) is not None:
    pytest.skip(_why, allow_module_level=True)

import rclpy  # noqa: E402
from geometry_msgs.msg import PoseStamped, TwistStamped  # noqa: E402
from rclpy.node import Node  # noqa: E402
from std_msgs.msg import Empty, String  # noqa: E402

from dexpush.common.netns import ros_environment  # noqa: E402
from dexpush.experiments.registry import make_shape  # noqa: E402
from dexpush.experiments.ros_trial import stop_node  # noqa: E402
from dexpush.experiments.scenarios import TASKS  # noqa: E402
from dexpush.ros.bridge import PlantBridge  # noqa: E402
from dexpush.ros.node import clock_seconds, planar_pose  # noqa: E402
from dexpush.world.model_plant import ModelPlant  # noqa: E402
from dexpush.world.sensing import SensorSettings  # noqa: E402

T = 0.04


def start_node(*flags: str, tmp_path) -> subprocess.Popen:
    env = ros_environment()
    env["ROS_LOG_DIR"] = str(tmp_path / "ros_log")
    log = open(tmp_path / "node.log", "w")
    return subprocess.Popen([sys.executable, "-m", "dexpush.cli", "ros", "--wait-for-goal", *flags], env=env,
                            stdout=log, stderr=subprocess.STDOUT, text=True)


def stopped(node: subprocess.Popen, tmp_path) -> tuple[int, str]:
    """Ctrl-C to the node; its exit code and its log."""
    return stop_node(node), (tmp_path / "node.log").read_text()


class Probe:
    """A test-side node: poses and goals out, twists and status in."""

    def __init__(self) -> None:
        self.node = Node("probe")
        self.twists: list[tuple[float, np.ndarray]] = []
        self.status: dict = {}
        self.object = self.node.create_publisher(PoseStamped, "/dexpush/object_pose", 10)
        self.pusher = self.node.create_publisher(PoseStamped, "/dexpush/pusher_pose", 10)
        self.goal = self.node.create_publisher(PoseStamped, "/dexpush/goal", 10)
        self.reset = self.node.create_publisher(Empty, "/dexpush/reset", 10)
        self.node.create_subscription(TwistStamped, "/servo_node/delta_twist_cmds", self._twist, 10)
        self.node.create_subscription(String, "/dexpush/status", self._status, 10)

    def _twist(self, m) -> None:
        self.twists.append((time.monotonic(), np.array([m.twist.linear.x, m.twist.linear.y])))

    def _status(self, m) -> None:
        self.status = json.loads(m.data)

    def now(self) -> float:
        return clock_seconds(self.node)

    def pose(self, x, y, th=0.0, stamp=None, frame="world") -> PoseStamped:
        return planar_pose(PoseStamped(), frame, (x, y, th), self.now() if stamp is None else stamp)

    def spin(self, seconds: float, until=None) -> bool:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            rclpy.spin_once(self.node, timeout_sec=0.01)
            if until is not None and until(self.status):
                return True
        return until is None


@pytest.fixture
def ros():
    rclpy.init()
    yield
    rclpy.shutdown()


def test_the_node_pushes_to_the_goal_through_ros_and_stops_when_the_poses_stop(ros, tmp_path):
    node = start_node("--task", "I", "--shape", "rect", "--method", "mppi", "--params", "known",
                      "--trigger", "pose", tmp_path=tmp_path)
    try:
        shape = make_shape("rect")
        task = TASKS["I"]
        camera = SensorSettings().camera(ModelPlant(shape))   # exact frames each period
        bridge = PlantBridge(camera, T)
        pose, pusher = task.trial_start(shape, 0)
        problem = task.problem(shape)

        def spin(timeout):
            assert node.poll() is None, (tmp_path / "node.log").read_text()
            rclpy.spin_once(bridge.node, timeout_sec=timeout)

        result = bridge.episode(pose, pusher, task.goal, problem.success, lambda x: False, 900, spin, trace=True)
        assert result.success, result.status
        assert result.status["latency_ms"]["median"] > 0
        assert {topic for _, topic, _ in result.trace} >= {"twist", "status", "object_pose"}
        bridge.close()

        # poses that stop mid-push: zero twists within the stale time and a period
        probe = Probe()
        probe.spin(0.3)
        probe.reset.publish(Empty())
        assert probe.spin(5.0, lambda st: st.get("mode") == "idle" and st.get("goal") is None)
        probe.goal.publish(probe.pose(0.6, 0.3))
        x = 0.0
        assert probe.spin(5.0, lambda st: st.get("goal") is not None)
        end = time.monotonic() + 3.0
        while time.monotonic() < end:                       # a static object with the pusher behind it
            probe.pusher.publish(probe.pose(x - 0.16, 0.0))
            probe.object.publish(probe.pose(x, 0.0))
            probe.spin(T)
        moving = [v for t, v in probe.twists if t > end - 1.0]
        assert moving and max(np.hypot(*v) for v in moving) > 0.005, probe.status
        probe.spin(0.5 + 0.2)                              # the stale time (0.5 s) and some slack
        last = [v for t, v in probe.twists if t > time.monotonic() - 0.1]
        assert last and all(np.all(v == 0) for v in last), probe.status
        assert probe.status["mode"] == "stale"
    finally:
        code, log = stopped(node, tmp_path)
    assert code == 0, log                                  # Ctrl-C: a clean exit
    assert "Traceback" not in log


def test_bad_messages_are_rejected_and_logged_once_and_the_node_lives_on(ros, tmp_path):
    node = start_node("--task", "I", "--shape", "rect", "--workspace", "-0.3,-0.3,0.9,0.6", tmp_path=tmp_path)
    try:
        probe = Probe()
        assert probe.spin(20.0, lambda st: bool(st)), "no status from the node"
        now = probe.now()
        probe.object.publish(probe.pose(math.nan, 0.0))
        probe.object.publish(probe.pose(0.0, 0.0, stamp=now + 5.0))      # from the future
        probe.object.publish(probe.pose(0.0, 0.0, stamp=now - 10.0))     # 10 s old
        probe.object.publish(probe.pose(0.0, 0.0, frame="camera"))
        probe.object.publish(probe.pose(0.0, 0.0, frame="camera"))       # a second: counted, not logged
        probe.goal.publish(probe.pose(2.0, 0.0))                          # outside the workspace
        probe.goal.publish(probe.pose(0.5, 0.0, frame="map"))
        want = {"object_nan": 1, "object_future": 1, "object_old": 1, "object_frame": 2, "goal_refused": 1,
                "goal_frame": 1}
        assert probe.spin(10.0, lambda st: st.get("rejected") == want), probe.status
        assert probe.status["mode"] == "idle" and node.poll() is None
    finally:
        code, log = stopped(node, tmp_path)
    assert code == 0, log
    assert log.count("frame 'camera'") == 1 and "outside the workspace" in log
    assert "Traceback" not in log



def test_a_smoothed_stream_changes_by_no_more_than_its_limits_allow(ros, tmp_path):
    node = start_node("--task", "I", "--shape", "rect", "--method", "mppi", "--params", "known", "--smooth",
                      "--stream-rate", "200", "--a-limit", "2.0", "--j-limit", "200", tmp_path=tmp_path)
    try:
        probe = Probe()
        assert probe.spin(20.0, lambda st: bool(st)), "no status from the node"
        probe.goal.publish(probe.pose(0.6, 0.3))
        assert probe.spin(5.0, lambda st: st.get("goal") is not None)
        start = time.monotonic()
        while time.monotonic() - start < 4.0 and probe.status.get("mode") != "pushing":
            probe.pusher.publish(probe.pose(-0.16, 0.0))
            probe.object.publish(probe.pose(0.0, 0.0))
            probe.spin(T)
        probe.twists.clear()
        for _ in range(50):                                  # 2 s of a static object with the pusher behind it
            probe.pusher.publish(probe.pose(-0.16, 0.0))
            probe.object.publish(probe.pose(0.0, 0.0))
            probe.spin(T)
        v = np.array([v for _, v in probe.twists])
        assert len(v) > 200, len(v)                          # a stream, not one twist a period
        assert np.max(np.hypot(*v.T)) > 0.005                # it pushes
        # each message within a_max / rate of the one before (a message lost in between doubles it at most)
        assert np.max(np.linalg.norm(np.diff(v, axis=0), axis=1)) <= 2 * 2.0 / 200 + 1e-9
    finally:
        code, log = stopped(node, tmp_path)
    assert code == 0, log
