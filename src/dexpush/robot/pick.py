"""Scripted grasps with the Franka hand (:class:`Picker`): pick an upright object from above, pick a thin
object by the part that overhangs the table's edge (the fingers closing vertically on its rim), lift, and
drop into a bin (docs/goal_regions.md#the-demonstration-on-the-franka).

Every move is a joint motion (franky's ``JointMotion``, shaped by its Ruckig generator within the robot's
limits scaled by ``dynamics_factor``; the robot's own factor, the pushing driver's, is restored after) to
joints from :class:`dexpush.robot.arm_kinematics.ArmKinematics`, nearest the present ones, then corrected
once or twice by the pose error the joint controller left. Positions are in the table frame (x, y) with
heights above the table top, as everywhere in dexpush.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dexpush.common.checks import check_positive
from dexpush.robot.arm_kinematics import ArmKinematics
from dexpush.robot.driver import DriverSettings, RobotError
from dexpush.robot.tabletop import Bin

__all__ = ["PickSettings", "Picker", "hand_down", "hand_level"]


@dataclass(frozen=True)
class PickSettings:
    """How the scripted grasps move (m, N, m/s)."""

    grasp_force: float = 60.0        #: the hand's grasping force (N; the Franka hand holds 70 continuously)
    grasp_speed: float = 0.05        #: the fingers' closing speed (m/s)
    open_margin: float = 0.02        #: the fingers open this much wider than the part they close on (m)
    clearance: float = 0.10          #: come down onto a thing from this far above it (m)
    rim_approach: float = 0.08       #: move in on a plate's rim from this far out (m): the fingertips clear it
    travel_height: float = 0.15      #: carry things this high above the table top (m)
    drop_height: float = 0.08        #: let go this far above the bin's rim (m)
    rim_inset: float = 0.012         #: the TCP at least this far outside the table edge: the fingertips stop short (m)
    palm_m: float = 0.045            #: from the TCP back to the hand's face, between the fingers (m)
    rim_clearance: float = 0.015     #: the hand's face stops this far short of a plate's rim (m)
    corrections: int = 2             #: re-aim a move this often by the pose error it left
    tolerance: float = 0.002         #: ... while that error exceeds this (m)
    dynamics_factor: float = 0.4     #: fraction of the Franka's joint velocity, acceleration and jerk limits
    carry_factor: float = 0.1        #: ... while carrying (a plate held by its rim slips when swung faster)
    #: where the arm waits between grasps (joints, rad): the FR3 upright, the hand over the table
    home_joints: tuple[float, ...] = (0.0, 0.0, 0.0, -1.57, 0.0, 1.57, 0.785)

    def __post_init__(self) -> None:
        for name in ("grasp_force", "grasp_speed", "open_margin", "clearance", "travel_height", "drop_height",
                     "tolerance", "dynamics_factor", "carry_factor"):
            check_positive(name, getattr(self, name))
        for name in ("dynamics_factor", "carry_factor"):
            if getattr(self, name) > 1:
                raise ValueError(f"{name} is a fraction of the robot's limits (0, 1], got {getattr(self, name)}")


def hand_down(yaw: float) -> np.ndarray:
    """The TCP rotation pointing down (z along −z of the base), its x axis at ``yaw`` (base frame, rad)."""
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([[c, s, 0.0], [s, -c, 0.0], [0.0, 0.0, -1.0]])


def hand_level(direction: object) -> np.ndarray:
    """The TCP rotation pointing level along ``direction`` (base frame, (x, y)), the fingers one above the other
    (its y axis up): the grasp of a thin plate by its rim."""
    d = np.asarray(direction, dtype=np.float64)
    z = np.array([d[0], d[1], 0.0]) / np.linalg.norm(d)
    y = np.array([0.0, 0.0, 1.0])
    return np.column_stack([np.cross(y, z), y, z])


class Picker:
    """Scripted grasps by a Franka (``robot``: a ``franky.Robot``; ``gripper``: a ``franky.Gripper``), with the
    table frame of ``frames``.

    Each method raises :class:`dexpush.robot.driver.RobotError` when the robot refuses a motion, and returns
    whether the hand holds something where that is the question.
    """

    def __init__(self, robot: object, gripper: object, frames: DriverSettings, settings: PickSettings | None = None,
                 kinematics: ArmKinematics | None = None) -> None:
        import franky

        self._f = franky
        self.robot, self.gripper, self.frames = robot, gripper, frames
        self.settings = settings or PickSettings()
        self.kinematics = kinematics or ArmKinematics()

    # ------------------------------------------------------------------ poses
    def _base(self, xy: object, z: float) -> np.ndarray:
        p = self.frames.to_base(np.asarray(xy, dtype=np.float64))
        return np.array([p[0], p[1], self.frames.table_z + z])

    def joints(self) -> np.ndarray:
        return np.asarray(self.robot.current_joint_state.position, dtype=np.float64)

    def tcp(self) -> tuple[np.ndarray, np.ndarray]:
        """The TCP's rotation and position (base frame) from the joints."""
        return self.kinematics.fk(self.joints())

    def move(self, rotation: np.ndarray, position: np.ndarray, factor: float | None = None) -> None:
        """Move the TCP to (``rotation``, ``position``) (base frame) by a joint motion at ``factor`` of the robot's
        limits (default ``dynamics_factor``); re-aimed by the error left."""
        s = self.settings
        aim = np.asarray(position, dtype=np.float64)
        for attempt in range(1 + s.corrections):
            try:
                q = self.kinematics.ik(rotation, aim, self.joints())
            except ValueError as exc:
                if attempt:                  # the re-aimed pose is past the reach: keep the move already made
                    break
                raise RobotError(str(exc)) from None
            try:
                self._joint_motion(q, factor)
            except RobotError as exc:
                raise RobotError(f"the Franka refused a move to {np.round(position, 3).tolist()} m: {exc}") from None
            error = np.asarray(position) - self.tcp()[1]
            if np.linalg.norm(error) < s.tolerance or attempt == s.corrections:
                break
            aim = aim + error

    def rise(self) -> None:
        """Straight up to the travel height, the hand turned as it is (from a push or a grasp: a joint motion from
        the table's height would sweep the hand across whatever is there), or as high as the arm allows there."""
        R, p = self.tcp()
        top = self.frames.table_z + self.settings.travel_height
        for z in np.linspace(top, p[2], 4, endpoint=False):
            if z <= p[2] + self.settings.tolerance:
                return
            q = self.solve(R, np.array([p[0], p[1], z]))
            if q is not None:
                self._joint_motion(q)
                return

    def home(self) -> None:
        """Up from the table, then to ``home_joints``."""
        self.rise()
        self._joint_motion(np.asarray(self.settings.home_joints, dtype=np.float64))

    def _joint_motion(self, q: np.ndarray, factor: float | None = None) -> None:
        """A joint motion to ``q`` at ``factor`` (default ``dynamics_factor``); a robot error is cleared and raised as a
        RobotError."""
        own = self.robot.relative_dynamics_factor
        self.robot.relative_dynamics_factor = self.settings.dynamics_factor if factor is None else factor
        try:
            self.robot.move(self._f.JointMotion(q.tolist()))
        except Exception as exc:
            if self.robot.has_errors:
                self.robot.recover_from_errors()
            raise RobotError(f"{type(exc).__name__}: {exc}") from exc
        finally:
            self.robot.relative_dynamics_factor = own

    def close(self) -> None:
        """Close the fingers on nothing: the closed hand is the pusher."""
        self.gripper.move(0.0, self.settings.grasp_speed)

    def solve(self, rotation: np.ndarray, position: np.ndarray) -> np.ndarray | None:
        """Joints that put the TCP at (``rotation``, ``position``) (base frame), nearest the present ones; None if
        none do."""
        try:
            return self.kinematics.ik(rotation, position, self.joints())
        except ValueError:
            return None

    def open(self, width: float) -> None:
        self.gripper.move(float(np.clip(width, 0.0, 0.08)), self.settings.grasp_speed)

    def grasp(self, width: float) -> bool:
        """Close on a part ``width`` wide (m) with ``grasp_force``; whether the fingers stopped on it (within 1 cm
        either way, and at least half its width apart: a miss closes them further and is False)."""
        s = self.settings
        try:
            held = self.gripper.grasp(float(width), s.grasp_speed, s.grasp_force, 0.01, 0.01)
            return bool(held and self.gripper.width >= 0.5 * width)     # (a thin part's window includes a miss)
        except self._f.CommandException:             # the hand closed outside the tolerance: nothing held
            return False
        except Exception as exc:
            raise RobotError(f"the hand failed to grasp: {exc}") from exc

    # ------------------------------------------------------------------ grasps
    def pick_from_above(self, xy: object, height: float, width: float) -> bool:
        """Grasp an upright object of ``height`` and ``width`` at ``xy`` halfway up, from above; lift it to the
        travel height. Returns whether the hand holds it."""
        s = self.settings
        R = hand_down(self.frames.table_yaw)
        self.rise()
        self.open(width + s.open_margin)
        self.move(R, self._base(xy, height + s.clearance))
        self.move(R, self._base(xy, height / 2))
        held = self.grasp(width)
        self.move(R, self._base(xy, height + s.travel_height))
        return held

    def pick_rim(self, point: object, outward: object, height: float, thickness: float, overhang: float) -> bool:
        """Grasp a plate that overhangs the table's edge by ``overhang`` at ``point`` on the edge (table frame, m),
        ``outward`` the edge's outward normal, the plate's mid-plane ``height`` above the table top and
        ``thickness`` thick. The hand comes level from outside the edge, its fingers one above and one below the
        plate, and closes with its face ``rim_clearance`` short of the rim (and the TCP at least ``rim_inset``
        outside the edge). Returns whether the hand holds it (it is not lifted yet)."""
        s = self.settings
        n = np.asarray(outward, dtype=np.float64) / np.linalg.norm(outward)
        n_base = self.frames.vector_to_base(n)
        R = hand_level(-n_base)
        grip = np.asarray(point, dtype=np.float64) + max(s.rim_inset, overhang - s.palm_m + s.rim_clearance) * n
        self.home()
        self.open(thickness + 2 * s.open_margin)
        # turned level high above the table (the hand swings low as it turns), as high as the arm allows there
        for lift in (2.0, 1.5, 1.0):
            q = self.solve(R, self._base(grip + s.rim_approach * n, height + lift * s.travel_height))
            if q is not None:
                self._joint_motion(q)
                break
        self.move(R, self._base(grip + s.rim_approach * n, height))
        self.move(R, self._base(grip, height))
        return self.grasp(thickness)

    def lift(self, dz: float) -> None:
        """Raise the TCP by ``dz`` (m), its orientation held."""
        R, p = self.tcp()
        self.move(R, p + np.array([0.0, 0.0, dz]))

    def drop_into(self, bin: Bin, carried: object = (0.0, 0.0)) -> None:
        """Carry what the hand holds over ``bin`` at the travel height and let go ``drop_height`` above its rim.
        ``carried``: where the held thing's middle lies from the TCP (table frame, m; a plate held by its rim
        lies mostly beyond the fingertips); the hand turns about the vertical to bring it over the bin."""
        s = self.settings
        R, p = self.tcp()
        here = self.frames.to_table(p[:2])
        middle = here + np.asarray(carried, dtype=np.float64)
        base_mid, base_bin = self.frames.to_base(middle), self.frames.to_base(bin.xy)
        turn = np.arctan2(base_bin[1], base_bin[0]) - np.arctan2(base_mid[1], base_mid[0])
        c, sn = np.cos(turn), np.sin(turn)
        Rz = np.array([[c, -sn, 0.0], [sn, c, 0.0], [0.0, 0.0, 1.0]])
        offset = Rz[:2, :2] @ (base_mid - p[:2])            # the held thing's middle from the TCP, turned
        tcp_xy = base_bin - offset
        high = max(p[2], self.frames.table_z + s.travel_height)
        slow = s.carry_factor
        self.move(R, np.array([p[0], p[1], high]), slow)
        self.move(Rz @ R, np.array([tcp_xy[0], tcp_xy[1], high]), slow)
        self.move(Rz @ R, np.array([tcp_xy[0], tcp_xy[1], self.frames.table_z + bin.rim_z + s.drop_height]), slow)
        self.open(0.08)
