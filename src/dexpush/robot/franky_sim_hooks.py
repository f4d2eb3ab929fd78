"""What dexpush changes in franky-sim's process (:mod:`dexpush.robot.franka_sim` runs it in a child of its own):
its servers bind loopback addresses only (:func:`loopback_only`), the client's stream of Cartesian velocity
commands is checked against a real Franka's limits (:class:`Checks`, :func:`watch_commands`), and a grasp
presses with its force (:func:`force_grasps`).
"""

from __future__ import annotations

import numpy as np

__all__ = ["FRANKA_LIMITS", "Checks", "force_grasps", "loopback_only", "watch_commands"]

#: the Franka's Cartesian limits on the commanded tip motion (translation): m/s, m/s², m/s³
FRANKA_LIMITS = {"velocity": 1.7, "acceleration": 13.0, "jerk": 6500.0}


#: a gap in the command stream longer than this (s) starts a new motion: no derivative spans it
_GAP_S = 0.005


class Checks:
    """The commanded tip motion against :data:`FRANKA_LIMITS`, from each command of the client's 1 kHz
    stream (a millisecond without one is counted in ``missed``; the next difference spans the gap); ``a`` is the
    last commanded acceleration (m/s², base frame; None at a motion's start); ``max_j_at`` the command clock (s)
    of the largest jerk."""

    def __init__(self) -> None:
        self.v = self.a = self.mode = None
        self.t = 0.0
        self.max_a = self.max_j = self.max_j_at = 0.0
        self.over = self.missed = 0

    def command(self, mode: str, v: np.ndarray, t: float) -> None:
        """One command: ``v`` the commanded tip velocity (m/s, base frame) at ``t`` (s, the command's clock)."""
        if mode != self.mode or not (0 < t - self.t <= _GAP_S):   # a new motion (or a new connection)
            self.mode, self.v, self.a = mode, None, None
        if self.v is not None:
            dt = t - self.t
            self.missed += round(dt / 1e-3) - 1
            a = (v - self.v) / dt
            if self.a is not None:
                j = float(np.linalg.norm(a - self.a)) / dt
                if j > self.max_j:
                    self.max_j, self.max_j_at = j, t
                self.over += j > FRANKA_LIMITS["jerk"]
            na = float(np.linalg.norm(a))
            self.max_a = max(self.max_a, na)
            self.over += na > FRANKA_LIMITS["acceleration"]
            self.a = a
        self.v, self.t = v, t


def watch_commands(robot_server: object, checks: Checks) -> None:
    """Feed ``checks`` the commanded tip velocity of every Cartesian velocity command the client sends
    (the pushing stream), on the command's own clock: its message id counts the robot's 1 ms states.

    Pose motions (the moves to the start) are not checked: in the simulator the client's pose
    commands carry its scheduling jitter (a late millisecond shows as a velocity spike of the
    commanded pose), which a real robot's hard 1 kHz cycle does not have; franky's Ruckig shapes them."""
    from franky_sim.franka_robot_protocol import UDPCommand

    handle = robot_server._handle_udp_command

    def handle_and_check(command_data: bytes) -> None:
        handle(command_data)
        cmd = UDPCommand.from_bytes(command_data)
        mode = getattr(getattr(robot_server, "_FrankaRobotServer__control_mode", None), "value", "")
        if cmd.message_id > 0 and not cmd.motion_generation_finished and mode == "cartesian_velocity":
            checks.command(mode, np.asarray(cmd.O_dP_EE_c[:3], dtype=np.float64), cmd.message_id * 1e-3)

    robot_server._handle_udp_command = handle_and_check


def loopback_only() -> None:
    """Make franky-sim's servers bind loopback addresses only: it binds its UDP state socket to every
    interface (0.0.0.0); here such a bind takes the loopback address its TCP server bound, and a bind to
    any address outside 127.x raises."""
    import socket
    import types

    import franky_sim.franka_server as franka_server

    bound = ["127.0.0.1"]

    class LoopbackSocket(socket.socket):
        def bind(self, address: object) -> None:
            if isinstance(address, tuple):
                host = str(address[0])
                if host in ("", "0.0.0.0"):
                    address = (bound[0], *address[1:])
                elif not host.startswith("127."):
                    raise OSError(f"dexpush binds the simulated robot to loopback addresses only, not {host}")
                else:
                    bound[0] = host
            super().bind(address)

    shim = types.SimpleNamespace(**{k: getattr(socket, k) for k in dir(socket) if not k.startswith("__")})
    shim.socket = LoopbackSocket
    franka_server.socket = shim


def force_grasps() -> None:
    """Make franky-sim's grasps press with their force, as a Franka hand does once its fingers stall on the
    object: franky-sim's hand is a position servo (about 1000 N/m per finger) aimed at the grasp's width, which
    squeezes an object of that width with almost nothing. Here a grasp aims the servo ``2 force / k`` inside
    the width (the servo's force is capped at the grasp's force); its success test is unchanged. (Patches
    franky-sim's gripper server in the simulator's own process.)"""
    from franky_sim.franka_gripper_server import FrankaGripperServer

    start = FrankaGripperServer.start_grasp
    if getattr(start, "presses", False):
        return

    def start_grasp(self: object, width: float, speed: float, force: float, *rest: object) -> None:
        start(self, width, speed, force, *rest)
        k = float(np.min(getattr(self._robot, "_kp_hand", [1000.0])))
        self._robot.set_hand_goal(width - 2 * force / k, speed, force)

    start_grasp.presses = True
    FrankaGripperServer.start_grasp = start_grasp
