"""The room a way across the arm's front leaves the object in the arm's band (:func:`way_room`): how the task
is placed on the arm (:func:`dexpush.experiments.robot_trial.task_centre`) and what a robot record keeps of it
(:func:`room_record`; docs/robot.md#the-band-is-an-annulus).
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from dexpush.common.se2 import rotate, wrap_angle
from dexpush.model.polygons import distance_to_polygons
from dexpush.problem.problem import Problem
from dexpush.problem.scene import JUDGE_PIECE_CORNERS, footprint_pieces
from dexpush.robot.driver import DriverSettings

__all__ = ["BENDS_M", "bent_way_room", "room_record", "way_room"]

#: the bends (m, away from the base at the way's middle) :func:`~dexpush.experiments.robot_trial.task_centre` tries;
#: the first, 0, is the straight way
BENDS_M = np.arange(0.0, 0.201, 0.01)


class Insets(Protocol):
    """What the room is reckoned with: :class:`dexpush.experiments.robot_trial.RobotSettings`."""

    def object_inset(self, pusher_radius: float) -> float:
        """How far inside the arm's reach the object's footprint stays (m)."""
        ...


def way_room(problem: Problem, robot: Insets, driver: DriverSettings, pose: object, poses: int = 21,
             bend: float = 0.0) -> float:
    """The room (m) a way leaves the object in the arm's band: the least clearance of the footprint, carried from
    ``pose`` to the goal while it turns at a steady rate (``poses`` poses, the ends included), to the annulus
    :func:`dexpush.experiments.robot_trial.robot_area` bounds the object by (``robot.object_inset`` inside r_max
    and beyond r_min), with the table frame placed by ``driver``. The way is straight, or with ``bend`` (m) a
    parabola that leaves the straight line by that much at its middle, away from the base. Below zero the way does
    not fit: the object must take another, or leave the band where the pusher then has no room behind it
    (docs/robot.md#the-band-is-an-annulus). Obstacles and the task's own walls are not counted."""
    bx, by, r_min, r_max = driver.reach_in_table()
    return float(_way_rooms(problem, robot, np.array([bx, by]), (r_min, r_max), pose, np.array([bend]), poses)[0])


def bent_way_room(problem: Problem, robot: Insets, driver: DriverSettings, pose: object) -> tuple[float, float]:
    """The most room (m) :func:`way_room` finds over the bends :data:`BENDS_M`, and that bend (m)."""
    rooms = _bent_rooms(problem, robot, driver, pose)
    return float(rooms.max()), float(BENDS_M[rooms.argmax()])


def room_record(problem: Problem, robot: Insets, driver: DriverSettings, pose: object) -> dict[str, float]:
    """What a record keeps of the way's room in the arm's band (m): straight (``way_room_m``, the first of
    :data:`BENDS_M`, 0) and bent round the base as far as helps (``bent_way_room_m``, at ``bend_m``)."""
    rooms = _bent_rooms(problem, robot, driver, pose)
    return {"way_room_m": round(float(rooms[0]), 4), "bent_way_room_m": round(float(rooms.max()), 4),
            "bend_m": round(float(BENDS_M[rooms.argmax()]), 3)}


def _bent_rooms(problem: Problem, robot: Insets, driver: DriverSettings, pose: object) -> np.ndarray:
    """:func:`way_room` for each bend of :data:`BENDS_M`."""
    bx, by, r_min, r_max = driver.reach_in_table()
    return _way_rooms(problem, robot, np.array([bx, by]), (r_min, r_max), pose, BENDS_M)


def _way_rooms(problem: Problem, robot: Insets, base: np.ndarray, reach: tuple[float, float], pose: object,
               bends: np.ndarray, poses: int = 21) -> np.ndarray:
    """:func:`way_room` for each of ``bends`` (B,), the base at ``base`` (table frame) and the reach (r_min, r_max):
    the footprint's farthest corner against the outer circle, its nearest point against the inner (0 with the
    base inside it), both from the base seen in each pose's frame {B} (the footprint as its convex pieces, a long
    outline circumscribed by one of 64 corners: never more room)."""
    pose = np.asarray(pose, dtype=np.float64)
    goal = np.asarray(problem.goal, dtype=np.float64)
    t = np.linspace(0.0, 1.0, poses)
    u = (pose[:2] + goal[:2]) / 2 - base
    u = u / np.linalg.norm(u) if np.linalg.norm(u) > 1e-9 else np.array([1.0, 0.0])
    centres = (pose[:2] + t[:, None] * (goal[:2] - pose[:2]))[None] + (4 * t * (1 - t))[None, :, None] \
        * np.asarray(bends, dtype=np.float64)[:, None, None] * u                          # (B, poses, 2)
    turn = pose[2] + t * wrap_angle(goal[2] - pose[2])
    base_in_b = rotate(base - centres, -turn)                  # (B, poses, 2): the base seen from each pose's {B}
    pieces = footprint_pieces(problem.shape, JUDGE_PIECE_CORNERS)     # the ellipse's 64-gon round it
    inset = robot.object_inset(problem.shape.pusher_radius)
    far = np.linalg.norm(np.concatenate(pieces)[:, None, None] - base_in_b, axis=-1).max(0)
    outward = reach[1] - inset - far
    inward = distance_to_polygons(base_in_b, pieces) - (reach[0] + inset)
    return np.minimum(outward, inward).min(-1)
