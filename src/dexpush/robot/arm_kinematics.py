"""The Franka FR3's kinematics for scripted grasps (:class:`ArmKinematics`): the hand's TCP pose from the
joints, and joints that put the TCP at a pose (``pip install 'dexpush[franka]'``: pinocchio, and the FR3's
URDF from the installed franky-sim package, under its Apache-2.0 licence).

The TCP is franky's default end-effector frame: the flange turned −45° about its z axis and 0.1034 m along
it (between the fingertips, z pointing out of the hand, the fingers closing along y). Inverse kinematics is
damped least squares on the pose error log(T⁻¹ T*) in the TCP frame, the joints clamped inside their
ranges, from the present joints first (the solution on the arm's present branch) and then from perturbed and
random starts; the solution nearest the present joints wins, so a joint motion to it is short.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = ["ArmKinematics", "IkSettings"]

#: franky's default TCP: 0.1034 m along the flange's z, turned −45° about it
TCP_OFFSET_M = 0.1034
TCP_YAW = -np.pi / 4


@dataclass(frozen=True)
class IkSettings:
    """Inverse kinematics: iterations per start, damping, the pose error accepted (m and rad, as one norm),
    how many starts, how far inside each joint's range a solution stays (rad)."""

    iterations: int = 150
    damping: float = 1e-4
    tolerance: float = 1e-4
    starts: int = 100
    joint_margin: float = 0.05


class ArmKinematics:
    """Forward and inverse kinematics of the FR3 with its hand (poses in the robot's base frame, m)."""

    def __init__(self, settings: IkSettings | None = None, seed: int = 0) -> None:
        try:
            import franky_sim
            import pinocchio as pin
        except ImportError as exc:
            raise ImportError("scripted grasps need pinocchio and franky-sim's FR3 model: "
                              "pip install 'dexpush[franka]'") from exc
        self._pin = pin
        self.settings = settings or IkSettings()
        urdf = Path(franky_sim.__file__).parent / "assets" / "fr3_clean.urdf"
        model = pin.buildModelFromUrdf(str(urdf))
        flange = model.getFrameId("link8")
        frame = model.frames[flange]
        tcp = pin.SE3(pin.rpy.rpyToMatrix(0.0, 0.0, TCP_YAW), np.array([0.0, 0.0, TCP_OFFSET_M]))
        model.addFrame(pin.Frame("dexpush_tcp", frame.parentJoint, flange, frame.placement * tcp,
                                 pin.FrameType.OP_FRAME))
        self._model, self._data = model, model.createData()
        self._tcp = model.getFrameId("dexpush_tcp")
        m = self.settings.joint_margin
        self.lower = np.asarray(model.lowerPositionLimit[:7], dtype=np.float64) + m
        self.upper = np.asarray(model.upperPositionLimit[:7], dtype=np.float64) - m
        self._rng = np.random.default_rng(seed)

    def fk(self, q: object) -> tuple[np.ndarray, np.ndarray]:
        """The TCP's rotation (3, 3) and position (3,) at joints ``q`` (7,)."""
        pin = self._pin
        pin.framesForwardKinematics(self._model, self._data, np.asarray(q, dtype=np.float64))
        T = self._data.oMf[self._tcp]
        return np.array(T.rotation), np.array(T.translation)

    def _solve(self, target: object, q: np.ndarray) -> tuple[np.ndarray, float]:
        pin, s = self._pin, self.settings
        err = np.inf
        for _ in range(s.iterations):
            pin.framesForwardKinematics(self._model, self._data, q)
            e = pin.log6(self._data.oMf[self._tcp].inverse() * target).vector
            err = float(np.linalg.norm(e))
            if err < s.tolerance:
                break
            J = pin.computeFrameJacobian(self._model, self._data, q, self._tcp, pin.ReferenceFrame.LOCAL)
            q = np.clip(q + J.T @ np.linalg.solve(J @ J.T + s.damping * np.eye(6), e), self.lower, self.upper)
        return q, err

    def ik(self, rotation: object, position: object, near: object) -> np.ndarray:
        """Joints that put the TCP at (``rotation``, ``position``), nearest ``near`` (7,) among those found.

        Raises:
            ValueError: when no start converges (the pose is out of the arm's reach or its joint ranges).
        """
        pin, s = self._pin, self.settings
        target = pin.SE3(np.asarray(rotation, dtype=np.float64), np.asarray(position, dtype=np.float64))
        q0 = np.clip(np.asarray(near, dtype=np.float64), self.lower, self.upper)
        best, best_d = None, np.inf
        for k in range(s.starts):
            if k == 0:
                start = q0
            elif k < s.starts // 2:
                start = np.clip(q0 + self._rng.normal(0.0, 0.6, 7), self.lower, self.upper)
            else:
                start = self._rng.uniform(self.lower, self.upper)
            q, err = self._solve(target, start)
            if err < s.tolerance:
                d = float(np.linalg.norm(q - q0))
                if d < best_d:
                    best, best_d = q, d
                if k == 0:
                    break
        if best is None:
            raise ValueError(f"no joints put the hand at {np.round(position, 3).tolist()} m with that "
                             "orientation (out of the arm's reach or its joint ranges)")
        return best
