"""A Franka (Panda or FR3) as a :class:`dexpush.robot.driver.PusherDriver`, over franky-control
(``pip install 'dexpush[franka]'``; docs/robot.md#a-real-franka).

Each planar velocity goes out as a franky ``CartesianVelocityMotion``: franky's Ruckig generator
takes the tip from its present velocity to the new one within the robot's velocity,
acceleration and jerk limits scaled by ``dynamics_factor``, so no command reaches the robot as
a step; libfranka's low-pass filter on the stream is off by default (``cutoff_frequency``). The
motion holds its velocity for ``command_hold_s`` and then brakes to rest, so a stream that stops
stops the robot by itself; the vertical velocity and the rotation hold the tip height and a
vertical tool (a proportional correction, capped).
"""

from __future__ import annotations

import threading
from collections.abc import Callable

import numpy as np

from dexpush.robot.driver import DriverSettings, RobotError

__all__ = ["FrankyDriver"]

#: the end-effector orientation while pushing: z pointing down (a half turn about x), as (x, y, z, w)
DOWN = np.array([1.0, 0.0, 0.0, 0.0])


def _require_franky():
    try:
        import franky
    except ImportError as exc:
        raise ImportError("the Franka driver needs franky-control: pip install 'dexpush[franka]'") from exc
    return franky


def _rotation(q_xyzw: np.ndarray) -> np.ndarray:
    x, y, z, w = q_xyzw / np.linalg.norm(q_xyzw)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def _rotation_vector(R: np.ndarray) -> np.ndarray:
    """log(R) as an axis times angle (rad)."""
    c = np.clip((np.trace(R) - 1) / 2, -1.0, 1.0)
    angle = np.arccos(c)
    w = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    return w * (0.5 if angle < 1e-6 else angle / (2 * np.sin(angle)))


class FrankyDriver:
    """The pusher on a Franka's flange, driven through franky-control.

    Args:
        address: the robot's FCI address (a real robot: its control box's IP; the simulator: 127.x).
        settings: :class:`dexpush.robot.driver.DriverSettings`.
        realtime: require a real-time kernel (True on a real robot; the simulator runs without).
    """

    def __init__(self, address: str, settings: DriverSettings | None = None, realtime: bool = True) -> None:
        franky = _require_franky()
        self._f = franky
        self.settings = settings or DriverSettings()
        self.address = address
        self._lock = threading.RLock()
        config = franky.RealtimeConfig.Enforce if realtime else franky.RealtimeConfig.Ignore
        try:
            self.robot = franky.Robot(address, realtime_config=config)
        except Exception as exc:
            raise RobotError(f"cannot connect to the Franka at {address}: {exc}") from exc
        self.robot.relative_dynamics_factor = self.settings.dynamics_factor
        self.sent = 0
        self.retries = 0
        self.retry_times: list[float] = []    #: the robot's clock (s) at each retry
        self.stops = 0
        self.errors: list[str] = []

    # ------------------------------------------------------------------ state
    def _ee(self) -> tuple[np.ndarray, np.ndarray]:
        try:
            pose = self.robot.current_cartesian_state.pose.end_effector_pose
        except Exception as exc:
            raise RobotError(f"cannot read the Franka's state (the connection to the robot is lost?): {exc}") from exc
        return np.asarray(pose.translation, dtype=np.float64), _rotation(np.asarray(pose.quaternion, dtype=np.float64))

    def tip(self) -> np.ndarray:
        """The tip's (x, y) in the table frame and its height above the table (m)."""
        t, R = self._ee()
        p = t + R @ np.array([0.0, 0.0, self.settings.tool_offset])
        return np.array([*self.settings.to_table(p[:2]), p[2] - self.settings.table_z])

    def tilt(self) -> float:
        """The tool's angle from vertical (rad)."""
        _, R = self._ee()
        return float(np.arccos(np.clip(-R[2, 2], -1.0, 1.0)))

    def time(self) -> float:
        try:
            return float(self.robot.state.time.to_sec())
        except Exception as exc:
            raise RobotError(f"cannot read the Franka's clock (the connection to the robot is lost?): {exc}") from exc

    # ------------------------------------------------------------------ motion
    def _move(self, make: Callable[[], object], asynchronous: bool, **options: float) -> None:
        """``robot.move`` of the motion ``make()`` builds, retried once with a new one (franky starts a motion
        object once): franky's motion generator sometimes fails to plan from the present state (Ruckig's codes
        -110/-111); a robot error is cleared first when the robot reports one."""
        try:
            self.robot.move(make(), asynchronous=asynchronous, **options)
        except Exception as exc:
            self.errors.append(f"{type(exc).__name__}: {exc}")
            self.retries += 1
            try:
                self.retry_times.append(self.time())
            except RobotError:
                self.retry_times.append(float("nan"))
            if self.robot.has_errors:
                self.robot.recover_from_errors()
            self.robot.move(make(), asynchronous=asynchronous, **options)

    def _pose_motion(self, xyz: np.ndarray) -> None:
        f = self._f
        ee = xyz - _rotation(DOWN) @ np.array([0.0, 0.0, self.settings.tool_offset])
        self._move(lambda: f.CartesianMotion(f.Affine(ee.tolist(), DOWN.tolist())), asynchronous=False)

    def move_to(self, xy: object) -> None:
        """Lift to the approach height, travel above ``xy``, and lower the tip to the working height."""
        s = self.settings
        goal = self.settings.to_base(np.asarray(xy, dtype=np.float64).reshape(2))
        with self._lock:
            try:
                self.robot.join_motion()
                here = self.tip()
                up = s.table_z + s.approach_height
                base_here = s.to_base(here[:2])
                if here[2] < s.approach_height - 1e-3:
                    self._pose_motion(np.array([*base_here, up]))
                self._pose_motion(np.array([*goal, up]))
                self._pose_motion(np.array([*goal, s.table_z + s.tip_height]))
            except Exception as exc:
                raise RobotError(f"moving the pusher to {np.round(xy, 4).tolist()} m failed: {exc}") from exc

    def _twist(self, v_table: np.ndarray) -> tuple[list[float], list[float]]:
        s = self.settings
        t, R = self._ee()
        tip_z = (t + R @ np.array([0.0, 0.0, s.tool_offset]))[2]
        vz = np.clip(s.height_gain * (s.table_z + s.tip_height - tip_z), -s.max_correction, s.max_correction)
        w = s.tilt_gain * _rotation_vector(_rotation(DOWN) @ R.T)
        w = w * min(1.0, s.max_correction / max(float(np.linalg.norm(w)), 1e-12))
        vxy = s.vector_to_base(v_table)
        return [float(vxy[0]), float(vxy[1]), float(vz)], [float(w[0]), float(w[1]), float(w[2])]

    def send(self, velocity: object) -> None:
        """Stream a planar velocity (m/s, table frame), held for ``command_hold_s`` unless renewed."""
        f = self._f
        v = np.asarray(velocity, dtype=np.float64).reshape(2)
        if not np.all(np.isfinite(v)):
            raise ValueError(f"velocity must be finite, got {v.tolist()}")
        with self._lock:
            lin, ang = self._twist(v)
            hold = round(self.settings.command_hold_s * 1e3)
            try:
                self._move(lambda: f.CartesianVelocityMotion(f.RobotVelocity(f.Twist(lin, ang)),
                                                             duration=f.Duration(hold)), asynchronous=True,
                           cutoff_frequency=self.settings.cutoff_frequency)
            except Exception as exc:
                self.errors.append(f"{type(exc).__name__}: {exc}")
                raise RobotError(f"the Franka refused a velocity command twice: {exc}") from exc
            self.sent += 1

    def stop(self) -> None:
        """Brake to rest within the robot's limits and wait for it (thread-safe); never raises.

        A zero-velocity motion replaces the running one (franky's generator brakes from the present
        velocity, as it turns to any new command), held for no time, so the robot is at rest when it ends."""
        f = self._f
        with self._lock:
            self.stops += 1
            try:
                self._move(lambda: f.CartesianVelocityMotion(
                    f.RobotVelocity(f.Twist([0.0, 0.0, 0.0], [0.0, 0.0, 0.0])), duration=f.Duration(0)),
                    asynchronous=True, cutoff_frequency=self.settings.cutoff_frequency)
                self.robot.join_motion(timeout=2.0)
            except Exception as exc:      # the robot already stopped with an error: say so, do not raise
                self.errors.append(f"{type(exc).__name__}: {exc}")

    def recover(self) -> bool:
        """Clear a robot error (a reflex) when the robot reports one; True when it is ready again."""
        with self._lock:
            try:
                if self.robot.has_errors:
                    return bool(self.robot.recover_from_errors())
                return True
            except Exception as exc:
                self.errors.append(f"{type(exc).__name__}: {exc}")
                return False

    def close(self) -> None:
        self.stop()
