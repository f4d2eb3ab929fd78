"""The MuJoCo plant (:class:`PhysicsPlant`): the object a rigid body on a free joint, held on the table
by support spheres with friction pairs, pushed by a velocity-servoed pusher disc; its world
(:class:`PhysicsSettings`: frictions, support pressure, mass, pusher radius, or a seeded random
family) and the scene's XML (:func:`scene_xml`). A :class:`dexpush.common.interfaces.Plant`.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import jax.numpy as jnp
import numpy as np

from dexpush.common.checks import check_positive, checked_vector
from dexpush.common.interfaces import CONTROL_PERIOD_S, Observation
from dexpush.model.cgvmm import Contour, contact_gap
from dexpush.model.convex_pieces import convex_pieces
from dexpush.model.polygons import convex_hull, distance_to_polygons
from dexpush.model.shape import Shape
from dexpush.world.model_plant import check_no_tunnelling

__all__ = ["MAX_PRISMS", "PRESSURES", "PUSHER_MASS", "PhysicsPlant", "PhysicsSettings", "SceneExtras", "convex_prisms",
           "scene_xml"]


# ---------------------------------------------------------------------------- physics plant
#: support-pressure patterns of the physics slider (:class:`PhysicsSettings`)
PRESSURES = ("uniform", "ring", "corners")


@dataclass(frozen=True)
class PhysicsSettings:
    """The MuJoCo scene of :class:`PhysicsPlant` (docs/conventions.md#plants), with the reason for each value."""

    mass: float = 0.5                 #: slider mass (kg)
    height: float = 0.02              #: slider height (m); the pusher touches its side at half height
    table_friction: float = 0.4       #: slider–table Coulomb friction
    pusher_friction: float = 0.25     #: pusher–slider Coulomb friction (μ_c of the world)
    timestep: float = 0.002           #: physics step (s): 0.2 mm of pusher travel at 0.1 m/s
    support_spacing: float = 0.01     #: grid of support points under the footprint (m): a uniform
                                      #: pressure distribution, whatever the shape (see PhysicsPlant)
    support_radius: float = 0.002     #: radius of each support sphere (m)
    solref: tuple[float, float] = (0.004, 1.0)   #: contact time constant 2·timestep, critically damped
    impratio: float = 10.0            #: stiffer frictional constraints: less creep at rest
    #: where the weight rests (:data:`PRESSURES`): ``uniform`` (the support grid under the whole
    #: footprint), ``ring`` (only within ``pressure_band`` of the outline) or ``corners`` (only
    #: within ``pressure_band`` of the footprint's convex-hull vertices)
    pressure: str = "uniform"
    pressure_band: float = 0.02       #: width (m) of the ring, radius (m) of each corner patch
    pusher_radius_scale: float = 1.0  #: the world's pusher radius over the shape's (the controller assumes 1)
    #: the table's top (x_lo, y_lo, x_hi, y_hi) (m), a box with edges the object can overhang and fall from
    #: (its support spheres past an edge carry nothing); None: a plane without edges
    table: tuple[float, float, float, float] | None = None

    def __post_init__(self) -> None:
        if self.table is not None:
            lo_x, lo_y, hi_x, hi_y = checked_vector("table (x_lo, y_lo, x_hi, y_hi)", self.table, 4)
            if hi_x - lo_x < 1e-3 or hi_y - lo_y < 1e-3:
                raise ValueError(f"table (x_lo, y_lo, x_hi, y_hi) needs x_hi > x_lo and y_hi > y_lo, got {self.table}")
        for name in ("mass", "height", "table_friction", "pusher_friction", "timestep", "support_spacing",
                     "support_radius", "impratio", "pressure_band", "pusher_radius_scale"):
            check_positive(name, getattr(self, name))
        if self.pressure not in PRESSURES:
            raise ValueError(f"unknown pressure {self.pressure!r}; choose one of {', '.join(PRESSURES)}")

    @staticmethod
    def randomized(seed: int) -> PhysicsSettings:
        """World ``seed`` of the randomised family (``dexpush bench --plant physics --randomize``).

        Table and pusher friction uniform in [0.15, 0.5], pressure uniform / ring / corners with
        equal odds, mass uniform in [0.2, 2] kg, pusher radius × [0.8, 1.2]. Drawn from
        ``numpy.random.default_rng((seed, 7))``, so a world never shares its draws with the trial's start.
        """
        rng = np.random.default_rng((int(seed), 7))
        return PhysicsSettings(mass=float(rng.uniform(0.2, 2.0)), table_friction=float(rng.uniform(0.15, 0.5)),
                               pusher_friction=float(rng.uniform(0.15, 0.5)),
                               pressure=PRESSURES[int(rng.integers(len(PRESSURES)))],
                               pusher_radius_scale=float(rng.uniform(0.8, 1.2)))


def _support_points(shape: Shape, spacing: float, pressure: str = "uniform", band: float = 0.02) -> np.ndarray:
    """Grid points inside the footprint (body frame), at least one per polygon; for a ``ring`` or
    ``corners`` pressure only those within ``band`` of the outline or of a convex-hull vertex."""
    from matplotlib.path import Path as MplPath

    pts = []
    for poly in shape.polygons:
        lo, hi = poly.min(0), poly.max(0)
        nx, ny = (np.maximum(np.round((hi - lo) / spacing), 1)).astype(int)
        gx = lo[0] + (np.arange(nx) + 0.5) * (hi[0] - lo[0]) / nx
        gy = lo[1] + (np.arange(ny) + 0.5) * (hi[1] - lo[1]) / ny
        grid = np.stack(np.meshgrid(gx, gy), -1).reshape(-1, 2)
        inside = grid[MplPath(poly).contains_points(grid)]
        pts.append(inside if len(inside) else poly.mean(0)[None])
    pts = np.concatenate(pts)
    # pieces of a union may overlap: keep one point per grid cell
    pts = np.unique(np.round(pts / (spacing / 4)) * (spacing / 4), axis=0)
    if pressure == "uniform":
        return pts
    if pressure == "ring":   # some point within ``band`` lies outside the footprint
        ang = np.linspace(0.0, 2 * np.pi, 16, endpoint=False)
        probes = pts[:, None] + band * np.stack([np.cos(ang), np.sin(ang)], -1)[None]
        keep = np.any(distance_to_polygons(probes, shape.polygons) > 0, axis=1)
    else:
        hull = convex_hull(np.concatenate(shape.polygons))
        keep = np.min(np.linalg.norm(pts[:, None] - hull[None], axis=-1), 1) <= band
    return pts[keep] if keep.sum() >= 3 else pts


def _inertia(points: np.ndarray, mass: float, height: float) -> tuple[np.ndarray, np.ndarray]:
    """Centre of mass and diagonal inertia of a uniform prism sampled by its support points."""
    com = points.mean(0)
    d = points - com
    izz = mass * np.mean(np.sum(d * d, 1))
    ixx = mass * (np.mean(d[:, 1] ** 2) + height**2 / 12)
    iyy = mass * (np.mean(d[:, 0] ** 2) + height**2 / 12)
    return com, np.array([ixx, iyy, izz])


#: the pusher body's mass (kg): heavy, so a contact impulse changes its velocity by < 0.1 mm/s a step
PUSHER_MASS = 100.0

#: the most convex prisms a slider may be built from (each is a MuJoCo mesh the pusher is tested against)
MAX_PRISMS = 64


def convex_prisms(shape: Shape) -> list[np.ndarray]:
    """The footprint as convex pieces for MuJoCo, which collides meshes by their convex hulls.

    Convex polygons are kept whole; a non-convex one is split (:func:`dexpush.model.convex_pieces.convex_pieces`),
    never replaced by its hull. A footprint needing more than :data:`MAX_PRISMS` pieces is refused.
    """
    pieces = [piece for poly in shape.polygons for piece in convex_pieces(poly)]
    if len(pieces) > MAX_PRISMS:
        raise ValueError(f"the physics plant would build {shape.name!r} from {len(pieces)} convex prisms (at most "
                         f"{MAX_PRISMS}): its outline is too ragged to simulate faithfully; simplify the polygon(s)")
    return pieces


@dataclass(frozen=True)
class SceneExtras:
    """Things added to the scene that do not touch its physics: cameras, textures, marker plates, a
    visual arm (:mod:`dexpush.world.rendered_camera`). Each string is MJCF inserted into the
    ``<asset>``, the ``<worldbody>``, the slider's body or the pusher's body; ``files`` are the assets'
    file contents by name. Geoms added must not collide (``contype="0" conaffinity="0"``) and bodies
    must carry no mass or joints: the dynamics stay those of the bare scene."""

    asset: str = ""
    world: str = ""
    slider: str = ""
    pusher: str = ""
    visual: str = ""
    files: tuple[tuple[str, bytes], ...] = ()


def scene_xml(shape: Shape, settings: PhysicsSettings, extras: SceneExtras | None = None) -> str:
    """MJCF of table, slider and pusher, built from the shape (convex prisms, :func:`convex_prisms`).

    Contact groups (contype/conaffinity bits) keep the three kinds of contact apart: the
    table touches only the slider's support spheres (friction ``table_friction``), the
    pusher touches only the slider's side prisms (``pusher_friction``), and nothing else
    collides. The support spheres spread the slider's weight evenly over its footprint, so
    the friction load follows the footprint (a box on a plane would carry it on 4 corners).
    The slider has a free joint: locking roll and pitch would let the table's normal forces
    absorb the tipping moment unevenly and distort that pressure distribution.
    """
    s = settings
    x = extras or SceneExtras()
    h = s.height
    points = _support_points(shape, s.support_spacing, s.pressure, s.pressure_band)
    com, inertia = _inertia(points, s.mass, h)
    meshes, sides = [], []
    for i, poly in enumerate(convex_prisms(shape)):
        verts = " ".join(f"{x:.6f} {y:.6f} {z:.6f}" for z in (-h / 2, h / 2) for x, y in poly)
        meshes.append(f'<mesh name="piece{i}" vertex="{verts}"/>')
        sides.append(f'<geom type="mesh" mesh="piece{i}" pos="0 0 {h / 2 + s.support_radius:.6f}" contype="4" '
                     f'conaffinity="8" friction="{s.pusher_friction} 0.005 0.0001" rgba="0.6 0.6 0.65 1" '
                     f'mass="0"/>')
    supports = [f'<geom type="sphere" size="{s.support_radius}" pos="{x:.6f} {y:.6f} {s.support_radius:.6f}" '
                f'contype="2" conaffinity="1" friction="{s.table_friction} 0.005 0.0001" mass="0" '
                f'rgba="0.3 0.3 0.3 1"/>' for x, y in points]
    rho = shape.pusher_radius * s.pusher_radius_scale
    solref = f"{s.solref[0]} {s.solref[1]}"
    return f"""<mujoco model="dexpush">
  <option timestep="{s.timestep}" integrator="implicitfast" cone="elliptic" impratio="{s.impratio}"/>
  <default><geom solref="{solref}" solimp="0.95 0.99 0.001"/></default>
  {x.visual}
  <asset>{''.join(meshes)}{x.asset}</asset>
  <worldbody>
    {_table_geom(s)}
    <body name="slider" pos="0 0 0">
      <freejoint name="slider"/>
      <inertial pos="{com[0]:.6f} {com[1]:.6f} {h / 2 + s.support_radius:.6f}" mass="{s.mass}"
                diaginertia="{inertia[0]:.8f} {inertia[1]:.8f} {inertia[2]:.8f}"/>
      {''.join(sides)}
      {''.join(supports)}
      {x.slider}
    </body>
    <body name="pusher" pos="0 0 {h / 2 + s.support_radius:.6f}">
      <joint name="pusher_x" type="slide" axis="1 0 0"/>
      <joint name="pusher_y" type="slide" axis="0 1 0"/>
      <geom type="cylinder" size="{rho} {h}" contype="8" conaffinity="4" mass="{PUSHER_MASS}"
            friction="{s.pusher_friction} 0.005 0.0001" rgba="0.1 0.7 0.8 1"/>
      {x.pusher}
    </body>
    {x.world}
  </worldbody>
</mujoco>"""


def _table_geom(s: PhysicsSettings) -> str:
    """The table: a plane, or a 4 cm thick box whose top is ``s.table`` at z = 0."""
    look = f'contype="1" conaffinity="2" friction="{s.table_friction} 0.005 0.0001" rgba="0.9 0.9 0.9 1"'
    if s.table is None:
        return f'<geom name="table" type="plane" size="2 2 0.1" {look}/>'
    lo_x, lo_y, hi_x, hi_y = s.table
    return (f'<geom name="table" type="box" size="{(hi_x - lo_x) / 2:.6f} {(hi_y - lo_y) / 2:.6f} 0.02" '
            f'pos="{(hi_x + lo_x) / 2:.6f} {(hi_y + lo_y) / 2:.6f} -0.02" {look}/>')


def headless_gl() -> None:
    """Before MuJoCo's first import: on Linux without a display, choose EGL for its off-screen rendering
    (``MUJOCO_GL=egl``; MuJoCo reads it once, at import) unless the user chose. The rendered camera
    (:mod:`dexpush.world.rendered_camera`) needs it; the physics alone never renders."""
    import sys

    if "mujoco" not in sys.modules and sys.platform.startswith("linux") and not os.environ.get("DISPLAY"):
        os.environ.setdefault("MUJOCO_GL", "egl")


class PhysicsPlant:
    """A MuJoCo world standing in for the real robot (docs/conventions.md#plants "physics plant").

    The slider is a rigid body on a table with Coulomb friction, pushed by a kinematic
    cylinder that follows the commanded velocity exactly, as a stiff position-controlled
    robot arm would (a heavy body on two slide joints whose position and velocity are set
    every physics step, so its contact friction acts on its sliding). Nothing here uses the C-GVMM: the motion comes
    from MuJoCo's contact dynamics, so the controller meets a world that is not its model.
    Same interface as :class:`ModelPlant` (one scene, not a batch).

    Args:
        shape: the slider's footprint (split into convex prisms, :func:`convex_prisms`).
        settings: :class:`PhysicsSettings`.
        extras: :class:`SceneExtras` (cameras and other things to see; no physics).
    """

    def __init__(self, shape: Shape, settings: PhysicsSettings | None = None,
                 extras: SceneExtras | None = None) -> None:
        headless_gl()
        import mujoco

        self._mj = mujoco
        self.shape = shape
        self._contour = Contour.of(shape)
        self.settings = settings or PhysicsSettings()
        self.extras = extras or SceneExtras()
        self.model = mujoco.MjModel.from_xml_string(scene_xml(shape, self.settings, self.extras),
                                                    dict(self.extras.files) or None)
        self.data = mujoco.MjData(self.model)
        self._qadr = self.model.jnt_qposadr[self.model.joint("slider").id]
        self._pq = [self.model.jnt_qposadr[self.model.joint(n).id] for n in ("pusher_x", "pusher_y")]
        self._pv = [self.model.jnt_dofadr[self.model.joint(n).id] for n in ("pusher_x", "pusher_y")]
        self._z = self.settings.height / 2 + self.settings.support_radius
        self.time = 0.0
        self._ready = False
        self.max_penetration = 0.0

    @property
    def state(self) -> np.ndarray:
        """The true [x_b, y_b, θ, x_c, y_c] (the controller should not read this)."""
        if not self._ready:
            raise RuntimeError("call reset() before using the plant")
        q = self.data.qpos[self._qadr:self._qadr + 7]
        w, x, y, z = q[3:7]
        theta = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
        return np.array([q[0], q[1], theta, *self.data.qpos[self._pq]])

    @property
    def tilt_deg(self) -> float:
        """How far (degrees) the object's plane is tilted from the table's: a few hundredths at rest, tens once
        it falls off an edge."""
        x, y = self.data.qpos[self._qadr + 4:self._qadr + 6]
        return float(np.degrees(np.arccos(np.clip(1 - 2 * (x * x + y * y), -1.0, 1.0))))

    def observe(self) -> Observation:
        x = self.state
        return Observation(x[:3], x[3:], self.time)

    def reset(self, object_pose: object, pusher_xy: object) -> Observation:
        """Place the slider (at rest) and the pusher; the pusher must not start inside it."""
        q = checked_vector("object_pose", object_pose, 3)
        p = checked_vector("pusher_xy", pusher_xy, 2)
        if float(contact_gap(self._contour, jnp.asarray(np.concatenate([q, p])))) < -1e-3:
            raise ValueError("pusher starts inside the object; place it on or outside the pusher-inflated contour")
        mj = self._mj
        mj.mj_resetData(self.model, self.data)
        self.data.qpos[self._qadr:self._qadr + 7] = [q[0], q[1], 0.0, np.cos(q[2] / 2), 0, 0, np.sin(q[2] / 2)]
        self.data.qpos[self._pq] = p
        mj.mj_forward(self.model, self.data)
        self.time = self._target = 0.0
        self._steps = 0
        self.max_penetration = 0.0
        self._ready = True
        return self.observe()

    def step(self, velocity: object, dt: float = CONTROL_PERIOD_S) -> Observation:
        """Move the pusher at ``velocity`` (m/s, world frame) for ``dt`` seconds of physics."""
        if not self._ready:
            raise RuntimeError("call reset() before step()")
        v = checked_vector("velocity", velocity, 2)
        dt = check_positive("dt", dt, "s")
        h = self.model.opt.timestep
        check_no_tunnelling(v, h, self.shape.pusher_radius, "settings.timestep")
        self._target += dt          # whole physics steps, rounded on the running total: no drift
        n = round(self._target / h) - self._steps
        for _ in range(n):
            # the pusher is kinematic: it starts each physics step where the command put it, with the
            # commanded velocity, which the contact solver sees (a teleported mocap body has none, so its
            # friction could not act on its own sliding); the step's end is then set exactly
            target = self.data.qpos[self._pq] + v * h
            self.data.qvel[self._pv] = v
            self._mj.mj_step(self.model, self.data)
            self.data.qpos[self._pq] = target
            if self.data.ncon:
                self.max_penetration = max(self.max_penetration, float(-self.data.contact.dist.min()))
        self._steps += n
        self.time = self._steps * h
        return self.observe()
