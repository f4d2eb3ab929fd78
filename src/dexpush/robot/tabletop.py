"""What stands around the simulated Franka besides the pushed object (:class:`Tabletop`): a table with
edges (its top at the robot's table height, the floor below), graspable props (:class:`Prop`: a cup, a
block), a bin to clear them into (:class:`Bin`) and a camera that films the scene; and the pusher the
hand itself is (its closed fingers, :func:`finger_contacts`).

Positions are in the table frame (docs/conventions.md#units-and-frames), heights above the table top
(m); :func:`tabletop_xml` places them in the robot's base frame with the driver's frames. Contact bits
(MuJoCo's contype/conaffinity) keep the physics plant's rules (:func:`dexpush.world.physics_plant.scene_xml`:
bit 1 the table, 2 the object's support spheres, 4 its sides, 8 the pusher) and add: the table and the
floor carry the spheres, the props, the bin and the arm; the props and the bin touch the object's sides too,
so a plate in the bin rests on its floor.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass

import numpy as np

from dexpush.common.checks import check_positive, checked_vector
from dexpush.robot.driver import DriverSettings

__all__ = ["Bin", "Prop", "Tabletop", "finger_contacts", "tabletop_xml"]

_TABLE = {"contype": "1", "conaffinity": "3"}     # carries the spheres (2) and anything with contype 1
_SOLID = {"contype": "1", "conaffinity": "7"}     # props' and bin's walls: the object's sides (4) too
#: the fingers as the pusher: touch what the pusher touches (the sides, bit 4) and what the arm touches
FINGER_CONTYPE, FINGER_CONAFFINITY = 9, 5
_CAMERA_DEFAULT = ((-0.15, -0.75, 0.65), (0.55, 0.15, 0.0))


@dataclass(frozen=True)
class Prop:
    """A graspable object standing on the table: an upright cylinder (``kind="cylinder"``, a cup; ``size`` its
    radius) or a square block (``"box"``; ``size`` its half-width), ``height`` tall, at ``xy`` (table frame)."""

    name: str
    xy: tuple[float, float]
    kind: str = "cylinder"
    size: float = 0.03
    height: float = 0.09
    mass: float = 0.15

    def __post_init__(self) -> None:
        checked_vector(f"prop {self.name} xy", self.xy, 2)
        if self.kind not in ("cylinder", "box"):
            raise ValueError(f"a prop is a cylinder or a box, got {self.kind!r}")
        for name in ("size", "height", "mass"):
            check_positive(f"prop {self.name} {name}", getattr(self, name))
        if 2 * self.size > 0.075:
            raise ValueError(f"prop {self.name} is {2 * self.size * 1e3:.0f} mm across: the Franka hand opens 80 mm")


@dataclass(frozen=True)
class Bin:
    """An open box to clear things into: its inside ``half_size`` (m) about ``xy`` (table frame), its floor at
    ``floor_z`` and its rim at ``rim_z`` (m above the table top; below it beside a table)."""

    xy: tuple[float, float]
    half_size: tuple[float, float] = (0.20, 0.20)
    floor_z: float = -0.25
    rim_z: float = -0.06

    def __post_init__(self) -> None:
        checked_vector("bin xy", self.xy, 2)
        checked_vector("bin half_size", self.half_size, 2)
        if not (self.floor_z < self.rim_z and min(self.half_size) > 0):
            raise ValueError(f"a bin needs a floor below its rim and a positive size, got {self}")

    def holds(self, position: object) -> bool:
        """Whether a body at ``position`` (x, y, z: table frame, z above the table top) lies inside the bin."""
        p = checked_vector("position", position, 3)
        inside = bool(np.all(np.abs(p[:2] - np.asarray(self.xy)) <= np.asarray(self.half_size)))
        return bool(inside and self.floor_z - 0.01 <= p[2] <= self.rim_z)


@dataclass(frozen=True)
class Tabletop:
    """The scene round the pushed object: ``table`` (x_lo, y_lo, x_hi, y_hi), a box whose edges things fall
    from onto the floor ``floor_z`` below (None: the floor is the table, everywhere), ``props``, a ``bin``,
    and the camera filming it (``camera``: its position and the point it looks at, table frame, m)."""

    table: tuple[float, float, float, float] | None = None
    props: tuple[Prop, ...] = ()
    bin: Bin | None = None
    floor_z: float = -0.75
    camera: tuple[tuple[float, float, float], tuple[float, float, float]] = _CAMERA_DEFAULT

    def __post_init__(self) -> None:
        if self.table is not None:
            lo_x, lo_y, hi_x, hi_y = checked_vector("table", self.table, 4)
            if hi_x <= lo_x or hi_y <= lo_y:
                raise ValueError(f"table (x_lo, y_lo, x_hi, y_hi) needs x_hi > x_lo and y_hi > y_lo, got {self.table}")
        names = [p.name for p in self.props]
        if len(set(names)) != len(names):
            raise ValueError(f"props need distinct names, got {names}")


def _yaw_quat(yaw: float) -> str:
    return f"{np.cos(yaw / 2):.6f} 0 0 {np.sin(yaw / 2):.6f}"


def _box(parent: ET.Element, frames: DriverSettings, centre: np.ndarray, half: tuple, z: tuple, look: dict,
         name: str = "") -> None:
    """A box geom: ``centre`` (table frame) with half sizes ``half`` along the table's axes, from z[0] to z[1]
    above the table top."""
    c = frames.to_base(centre)
    attrs = dict(type="box", size=f"{half[0]:.6f} {half[1]:.6f} {(z[1] - z[0]) / 2:.6f}",
                 pos=f"{c[0]:.6f} {c[1]:.6f} {frames.table_z + (z[0] + z[1]) / 2:.6f}",
                 quat=_yaw_quat(frames.table_yaw))
    if name:
        attrs["name"] = name
    ET.SubElement(parent, "geom", attrs | look)


def tabletop_xml(top: Tabletop, frames: DriverSettings, friction: float, worldbody: ET.Element) -> None:
    """Add ``top``'s table (its top's Coulomb ``friction``), props, bin and camera to ``worldbody`` (franky-sim's
    scene, base frame)."""
    grip = {"friction": f"{friction} 0.005 0.0001"}
    if top.table is not None:
        lo_x, lo_y, hi_x, hi_y = top.table
        centre, half = np.array([(lo_x + hi_x) / 2, (lo_y + hi_y) / 2]), ((hi_x - lo_x) / 2, (hi_y - lo_y) / 2)
        _box(worldbody, frames, centre, half, (-0.04, 0.0), _TABLE | grip | {"rgba": "0.85 0.82 0.75 1"},
             name="table_top")
    for p in top.props:
        c = frames.to_base(p.xy)
        body = ET.SubElement(worldbody, "body", name=f"prop_{p.name}",
                             pos=f"{c[0]:.6f} {c[1]:.6f} {frames.table_z + p.height / 2 + 1e-4:.6f}")
        ET.SubElement(body, "freejoint", name=f"prop_{p.name}")
        across = f"{p.size:.6f}" if p.kind == "cylinder" else f"{p.size:.6f} {p.size:.6f}"
        size = f"{across} {p.height / 2:.6f}"
        ET.SubElement(body, "geom", type=p.kind, size=size, mass=f"{p.mass}", contype="1", conaffinity="7",
                      friction="0.8 0.005 0.0001", rgba="0.35 0.55 0.85 1")
    if top.bin is not None:
        b = top.bin
        hx, hy, t = *b.half_size, 0.01
        look = _SOLID | {"rgba": "0.45 0.35 0.25 1"}
        centre = np.asarray(b.xy, dtype=np.float64)
        _box(worldbody, frames, centre, (hx + t, hy + t), (b.floor_z - t, b.floor_z), look, name="bin_floor")
        for sx, sy in ((1, 0), (-1, 0), (0, 1), (0, -1)):
            off = np.array([sx * (hx + t / 2), sy * (hy + t / 2)])
            half = (t / 2, hy + t) if sx else (hx + t, t / 2)
            _box(worldbody, frames, centre + off, half, (b.floor_z, b.rim_z), look)
    eye, target = (np.asarray(v, dtype=np.float64) for v in top.camera)
    e, t = frames.to_base(eye[:2]), frames.to_base(target[:2])
    ET.SubElement(worldbody, "camera", name="scene_camera", mode="fixed",
                  pos=f"{e[0]:.6f} {e[1]:.6f} {frames.table_z + eye[2]:.6f}",
                  xyaxes=_look_at(np.array([*e, eye[2]]), np.array([*t, target[2]])), fovy="50")


def _look_at(eye: np.ndarray, target: np.ndarray) -> str:
    """MJCF ``xyaxes`` of a camera at ``eye`` looking at ``target`` with the world's z up."""
    forward = target - eye
    forward /= np.linalg.norm(forward)
    x = np.cross(forward, [0.0, 0.0, 1.0])
    x /= np.linalg.norm(x)
    y = np.cross(x, forward)
    return " ".join(f"{v:.6f}" for v in (*x, *y))


def finger_contacts(scene: ET.Element, friction: float) -> None:
    """Make the hand's fingers the pusher: their collision geoms touch the object's sides (the physics plant's
    pusher bits) as well as what the arm touches, with the fingertip pads' ``friction``."""
    for body in scene.iter("body"):
        if not body.get("name", "").endswith("finger"):
            continue
        for geom in body.findall("geom"):
            if geom.get("class", "").startswith("fingertip_pad") or (geom.get("class") == "collision"):
                geom.set("contype", str(FINGER_CONTYPE))
                geom.set("conaffinity", str(FINGER_CONAFFINITY))
                geom.set("friction", f"{friction} 0.005 0.0001")
