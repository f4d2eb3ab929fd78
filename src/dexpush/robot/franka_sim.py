"""A simulated Franka FR3 that pushes (:class:`FrankaSim`): franky-sim's MuJoCo FR3, served over the
libfranka protocol on a loopback address, with a pusher rod on its hand, the object of the
physics plant (:func:`dexpush.world.physics_plant.scene_xml`: a free body on support spheres with
explicit friction pairs) on the table, and the obstacles drawn (``pip install 'dexpush[franka]'``).

The simulator runs in a child process (it steps at 1 kHz in Python; apart from the planner, it
gets a core of its own). The parent reads the object's true pose and the simulator's checks
through shared memory and sends it commands (place the object, knock it, stop) through a pipe.
The checks are those a real Franka makes and franky-sim does not: the commanded tip
acceleration and jerk of the pushing stream against the robot's limits (a real robot aborts
with a reflex beyond them) and the joints against their ranges (:class:`SimReport`).
"""

from __future__ import annotations

import multiprocessing as mp
import time
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field

import numpy as np

from dexpush.common.checks import check_positive
from dexpush.common.se2 import wrap_angle
from dexpush.model.shape import Shape
from dexpush.robot.driver import DriverSettings
from dexpush.robot.franky_sim_hooks import FRANKA_LIMITS, Checks, force_grasps, loopback_only, watch_commands
from dexpush.robot.tabletop import Tabletop, finger_contacts, tabletop_xml
from dexpush.world.physics_plant import PhysicsSettings, SceneExtras, scene_xml

__all__ = ["FINGERTIP_M", "FRANKA_LIMITS", "FrankaSim", "SimReport", "SimSettings"]


#: the end-effector frame's offset from the hand along its z axis in franky-sim (the fingertip centre), m
_EE_FROM_HAND = 0.1034
_ROD_LENGTH = 0.06
#: how far the fingertip pads reach beyond the end-effector frame (m): the tool offset of the "fingers" tool
FINGERTIP_M = 0.0080

# shared-memory layout (float64)
_TIME, _POSE, _TIP, _ACC, _JERK, _OVER, _JOINTS, _STEPS, _BUSY, _WALL, _MISSED = 0, 1, 4, 7, 8, 9, 10, 11, 12, 13, 14
_VEL = 15         # the object's velocity (x, y, base frame)
_JERK_AT = 17     # the command clock (s) of the largest commanded jerk
_SIZE = 18
#: the most generalised coordinates the scene may have (the whole qpos is shared, for a camera that renders it)
_QPOS_MAX = 256


@dataclass(frozen=True)
class SimSettings:
    """The simulated robot's world.

    The object is the physics plant's slider (``physics``; its support grid is coarser than the
    plant's default, 2 cm: the robot's own collisions already fill the 1 ms step); the robot's
    base is at the origin, the table frame where ``driver.table_origin`` says. The pusher (``tool``) is a
    rod on the hand (``"rod"``: ``driver.tool_offset`` beyond the end-effector frame) or the hand's closed
    fingers (``"fingers"``: the hand is free to grasp; ``driver.tool_offset`` is then the fingertips' reach
    beyond that frame, :data:`FINGERTIP_M`). ``tabletop``: a table with edges, props, a bin, a camera
    (:class:`dexpush.robot.tabletop.Tabletop`); None: the floor is the table.
    """

    physics: PhysicsSettings = field(default_factory=lambda: PhysicsSettings(support_spacing=0.02))
    driver: DriverSettings = field(default_factory=DriverSettings)
    realtime: float = 1.0            #: pace the 1 kHz loop by the wall clock (1: real time; 0: as fast as it can)
    hosts: tuple[str, ...] = tuple(f"127.0.0.{i}" for i in range(1, 255))   #: loopback addresses to bind
    start_timeout_s: float = 60.0    #: how long the child may take to come up (s)
    tool: str = "rod"                #: the pusher: a rod on the hand, or the hand's closed "fingers"
    tabletop: Tabletop | None = None

    def __post_init__(self) -> None:
        if self.tool not in ("rod", "fingers"):
            raise ValueError(f"tool is 'rod' or 'fingers', got {self.tool!r}")
        if not (np.isfinite(self.realtime) and self.realtime >= 0):
            raise ValueError(f"realtime is a pacing factor >= 0, got {self.realtime!r}")
        bad = [h for h in self.hosts if not h.startswith("127.")]
        if bad or not self.hosts:
            raise ValueError(f"the simulated robot binds loopback addresses (127.x) only, got {bad or 'none'}")
        check_positive("start_timeout_s", self.start_timeout_s, "s")


@dataclass(frozen=True)
class SimReport:
    """What the simulator checked since it started: ``over_limits`` counts the 1 ms steps in which the
    commanded tip acceleration or jerk exceeded :data:`FRANKA_LIMITS` (a real Franka would abort with a
    reflex), ``joint_limit_steps`` those with a joint outside its range, ``missed_commands`` the steps
    in a motion that brought no new command from the client (a real Franka tolerates a few: libfranka's
    ``communication_constraints_violation`` ends a motion after too many); the maxima; the simulated
    seconds, the real-time factor (simulated over wall seconds) and the stepping capacity (simulated
    seconds over the wall seconds spent stepping: the factor it could reach unpaced); ``max_jerk_at_s``: when the
    largest jerk was commanded, on the robot's clock (the client's ``time()``, 1 ms a state since it connected)."""

    sim_s: float
    max_acceleration: float
    max_jerk: float
    over_limits: int
    joint_limit_steps: int
    missed_commands: int
    real_time_factor: float
    step_capacity: float
    max_jerk_at_s: float = 0.0


def _world_xml(shape: Shape, physics: PhysicsSettings, obstacles: np.ndarray,
               polygons: tuple[np.ndarray, ...] = ()) -> str:
    """The physics plant's scene with the obstacles drawn: discs as cylinders, polygons (boxes, walls) as
    prisms 6 cm high (no collisions: a touch is judged from the true state)."""
    look = 'contype="0" conaffinity="0" rgba="0.8 0.3 0.3 0.6"'
    discs = "".join(f'<geom type="cylinder" size="{r:.6f} 0.03" pos="{x:.6f} {y:.6f} 0.03" {look}/>'
                    for x, y, r in obstacles)
    meshes = "".join(f'<mesh name="keep_out_{i}" vertex="'
                     + " ".join(f"{x:.6f} {y:.6f} {z}" for z in (0, 0.06) for x, y in p) + '"/>'
                     for i, p in enumerate(polygons))
    prisms = "".join(f'<geom type="mesh" mesh="keep_out_{i}" {look}/>' for i in range(len(polygons)))
    return scene_xml(shape, physics, SceneExtras(asset=meshes, world=discs + prisms))


class FrankaSim:
    """franky-sim's FR3 pushing the object, in a child process on a loopback address.

    Use as a context manager (it shuts the child down); ``address`` is where a franky client
    connects; it is also a :class:`dexpush.robot.driver.PoseSource` (the object's true pose).

    Args:
        shape: the object.
        obstacles: discs (c_x, c_y, r) in the table frame (m), drawn in the scene.
        settings: :class:`SimSettings`.
        polygons: convex polygons (boxes, walls; each its corners) in the table frame (m), drawn likewise.
    """

    def __init__(self, shape: Shape, obstacles: object = (), settings: SimSettings | None = None,
                 polygons: object = ()) -> None:
        try:
            import franky_sim  # noqa: F401
        except ImportError as exc:
            raise ImportError("the simulated Franka needs franky-sim: pip install 'dexpush[franka]'") from exc
        self.shape = shape
        self.settings = settings or SimSettings()
        obs = np.asarray(obstacles, dtype=np.float64).reshape(-1, 3)
        base_obs = np.concatenate([self.settings.driver.to_base(obs[:, :2]), obs[:, 2:]], 1) if len(obs) else obs
        base_polys = tuple(self.settings.driver.to_base(np.asarray(p, dtype=np.float64)) for p in polygons)
        self._xml = _world_xml(shape, self.settings.physics, base_obs, base_polys)
        ctx = mp.get_context("spawn")
        self._shared = ctx.Array("d", _SIZE, lock=False)
        self._qpos = ctx.Array("d", _QPOS_MAX, lock=False)
        self._conn, child = ctx.Pipe()
        d = self.settings.driver
        rho = float(shape.pusher_radius * self.settings.physics.pusher_radius_scale)
        self._proc = ctx.Process(target=_serve, name="franky-sim", daemon=True,
                                 args=(self._xml, rho, d, self.settings.hosts, float(self.settings.realtime),
                                       self._shared, child, self.settings.tool, self.settings.tabletop, self._qpos))
        self.address: str | None = None
        self._nq = 0

    def start(self) -> FrankaSim:
        self._proc.start()
        if not self._conn.poll(self.settings.start_timeout_s):
            self.close()
            raise RuntimeError(f"the simulated Franka did not come up within {self.settings.start_timeout_s:g} s")
        try:
            kind, value = self._conn.recv()
        except EOFError:
            kind, value = "error", f"its process ended (exit code {self._proc.exitcode})"
        if kind != "ready":
            self.close()
            raise RuntimeError(f"the simulated Franka failed to start: {value}")
        self.address, self._nq = value
        return self

    def __enter__(self) -> FrankaSim:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _ask(self, *message: object, timeout_s: float = 10.0) -> object:
        if not self._proc.is_alive():
            raise RuntimeError("the simulated Franka has stopped")
        self._conn.send(message)
        if not self._conn.poll(timeout_s):
            raise RuntimeError(f"the simulated Franka did not answer {message[0]!r}")
        kind, value = self._conn.recv()
        if kind == "error":
            raise RuntimeError(f"the simulated Franka: {value}")
        return value

    # PoseSource
    def object_pose(self) -> np.ndarray:
        return np.array(self._shared[_POSE:_POSE + 3])

    def place(self, pose: object) -> None:
        """Put the object at rest at ``pose`` (x, y, θ in the table frame)."""
        self._ask("place", tuple(float(v) for v in np.asarray(pose, dtype=np.float64).reshape(3)))

    def knock(self, dxy: object) -> None:
        """Move the object by ``dxy`` (m, table frame) at once, as a hand knocking it would."""
        self._ask("knock", tuple(float(v) for v in np.asarray(dxy, dtype=np.float64).reshape(2)))

    def bodies(self) -> dict[str, np.ndarray]:
        """The true positions of the object (``"object"``) and the props (by name): (x, y) in the table frame,
        the height of the body's origin above the table top and its tilt from upright (degrees)."""
        return {k: np.asarray(v) for k, v in self._ask("bodies").items()}

    def record(self, fps: float = 10.0, size: tuple[int, int] = (320, 240)) -> None:
        """Start filming the tabletop's camera at ``fps`` (simulated time), ``size`` (width, height) pixels."""
        self._ask("record", float(fps), (int(size[0]), int(size[1])))

    def save_frames(self, path: str) -> int:
        """Stop filming and write the frames to ``path`` (``.npy``, (N, H, W, 3) uint8); returns N."""
        return int(self._ask("save_frames", str(path), timeout_s=3600.0))

    def scene(self) -> tuple[str, int]:
        """The simulated world as MJCF (the robot, the object, the drawn obstacles, in the robot's base frame;
        its meshes by absolute path) and its number of generalised coordinates: a camera's copy of the world
        (:class:`dexpush.robot.robot_camera.RobotCamera`)."""
        return str(self._ask("scene")), self._nq

    def snapshot(self) -> tuple[np.ndarray, np.ndarray, float]:
        """The world's generalised coordinates now, the object's velocity (x, y in the base frame, m/s) and the
        simulated time: what a camera's copy needs to draw it. Read while the simulator steps: at worst one
        coordinate is a millisecond newer than the rest."""
        t = float(self._shared[_TIME])
        return np.array(self._qpos[:self._nq]), np.array(self._shared[_VEL:_VEL + 2]), t

    @property
    def time(self) -> float:
        return float(self._shared[_TIME])

    def tip(self) -> np.ndarray:
        """The pusher tip's true position (table frame, z above the table), from the simulation."""
        return np.array(self._shared[_TIP:_TIP + 3])

    def report(self) -> SimReport:
        s = self._shared
        sim_s = s[_STEPS] * 1e-3
        return SimReport(float(s[_TIME]), float(s[_ACC]), float(s[_JERK]), int(s[_OVER]), int(s[_JOINTS]),
                         int(s[_MISSED]),
                         float(sim_s / s[_WALL]) if s[_WALL] > 0 else 0.0,
                         float(sim_s / s[_BUSY]) if s[_BUSY] > 0 else 0.0, float(s[_JERK_AT]))

    def close(self) -> None:
        if self._proc.is_alive():
            try:
                self._conn.send(("close",))
            except (BrokenPipeError, OSError):
                pass
            self._proc.join(5.0)
        if self._proc.is_alive():
            self._proc.terminate()
            self._proc.join(2.0)


# ---------------------------------------------------------------------------- the child process
def _graft(sim: object, xml: str, rho: float, frames: DriverSettings, tool: str = "rod",
           tabletop: Tabletop | None = None) -> None:
    """Move our scene's slider, meshes and drawn obstacles into franky-sim's scene and put the pusher on the
    hand: a rod (its bottom ``frames.tool_offset`` beyond the end-effector frame) or the fingers; add the
    tabletop's table (the floor then drops below it), props, bin and camera."""
    tool_offset = frames.tool_offset
    ours = ET.fromstring(xml)
    solref = ours.find("default/geom").get("solref")
    solimp = ours.find("default/geom").get("solimp")
    opt, our_opt = sim.scene.find("option"), ours.find("option")
    for key in ("cone", "impratio"):
        opt.set(key, our_opt.get(key))
    for geom in sim.worldbody.findall("geom"):
        if geom.get("name") == "ground":     # the table: touches the slider's support spheres only
            table = ours.find("worldbody/geom")
            for key in ("conaffinity", "friction"):
                geom.set(key, table.get(key))
            geom.set("contype", "0")         # not the arm (its base rests on it): a low tip is checked instead
            if tabletop is not None and tabletop.table is not None:     # the floor, below the table's edges
                geom.set("pos", f"0 0 {frames.table_z + tabletop.floor_z:.6f}")
                geom.set("contype", "1")
                geom.set("conaffinity", "3")
    asset = sim.scene.find("asset")
    for mesh in ours.find("asset"):
        asset.append(mesh)
    for child in ours.find("worldbody"):
        if child.tag == "body" and child.get("name") == "pusher":
            pusher = child.find("geom")
            continue
        if child.tag == "geom" and child.get("name") == "table":
            continue
        for g in child.iter("geom"):
            g.set("solref", g.get("solref", solref))
            g.set("solimp", g.get("solimp", solimp))
        sim.worldbody.append(child)
    if tabletop is not None:
        table_friction = float(ours.find("worldbody/geom").get("friction").split()[0])   # the scene's table's
        tabletop_xml(tabletop, frames, table_friction, sim.worldbody)
    hand = next(b for b in sim.worldbody.iter("body") if b.get("name", "").endswith("hand"))
    bottom = _EE_FROM_HAND + tool_offset
    ET.SubElement(hand, "site", name="pusher_tip", pos=f"0 0 {bottom:.6f}", size="0.002")
    if tool == "fingers":
        finger_contacts(sim.worldbody, 1.0)
        # flat pads on a flat plate: several contact points (one, by default, lets a pinched plate pivot)
        flag = opt.find("flag") if opt.find("flag") is not None else ET.SubElement(opt, "flag")
        flag.set("multiccd", "enable")
        return
    ET.SubElement(hand, "geom", name="pusher_rod", type="cylinder", size=f"{rho:.6f} {_ROD_LENGTH / 2}",
                  pos=f"0 0 {bottom - _ROD_LENGTH / 2:.6f}", contype=pusher.get("contype"),
                  conaffinity=pusher.get("conaffinity"), friction=pusher.get("friction"), mass="0.05",
                  rgba="0.1 0.7 0.8 1", solref=solref, solimp=solimp)


def _serve(xml: str, rho: float, frames: DriverSettings, hosts: tuple[str, ...], realtime: float, shared: object,
           conn: object, tool: str = "rod", tabletop: Tabletop | None = None, qshared: object = None) -> None:
    """The child: build the scene, serve the robot, step at 1 kHz, answer the parent."""
    try:
        from dexpush.world.physics_plant import headless_gl

        headless_gl()
        import mujoco
        from franky_sim import SimulationServer
        from franky_sim.mujoco_simulator import MujocoSimulator
    except Exception as exc:
        conn.send(("error", f"{type(exc).__name__}: {exc}"))
        return
    yaw = frames.table_yaw
    try:
        loopback_only()
        force_grasps()
        sim = MujocoSimulator()
        sim.init()
        robot = sim.add_robot()
        _graft(sim, xml, rho, frames, tool, tabletop)
        scene = ET.tostring(sim.scene, encoding="unicode")
        server = SimulationServer(sim, hostname_candidates=iter(hosts))
        server.init()
    except Exception as exc:
        conn.send(("error", f"{type(exc).__name__}: {exc}"))
        return
    model, data = sim.model, sim.data
    nq = model.nq if qshared is not None and model.nq <= _QPOS_MAX else 0
    qadr = model.jnt_qposadr[model.joint("slider").id]
    dadr = model.jnt_dofadr[model.joint("slider").id]
    tip_site = model.site("pusher_tip").id
    joints = [model.joint(f"robot0_fr3_joint{i}").id for i in range(1, 8)]
    jq = model.jnt_qposadr[joints]
    lo, hi = model.jnt_range[joints, 0], model.jnt_range[joints, 1]
    checks = Checks()
    watch_commands(server.robot_servers[0], checks)

    def publish() -> None:
        q = data.qpos[qadr:qadr + 7]
        w, x, y, z = q[3:7]
        th = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z)) - yaw
        xy = frames.to_table(q[:2])
        tip = data.site_xpos[tip_site]
        shared[_POSE:_POSE + 3] = [xy[0], xy[1], wrap_angle(th)]
        shared[_TIP:_TIP + 3] = [*frames.to_table(tip[:2]), tip[2]]
        shared[_TIME] = data.time
        shared[_ACC], shared[_JERK], shared[_JERK_AT] = checks.max_a, checks.max_j, checks.max_j_at
        shared[_OVER], shared[_MISSED] = checks.over, checks.missed
        shared[_VEL:_VEL + 2] = data.qvel[dadr:dadr + 2]
        if nq:
            qshared[:nq] = data.qpos

    def place(pose: tuple[float, float, float]) -> None:
        xy = frames.to_base(pose[:2])
        th = pose[2] + yaw
        data.qpos[qadr:qadr + 7] = [xy[0], xy[1], 0.0, np.cos(th / 2), 0.0, 0.0, np.sin(th / 2)]
        data.qvel[dadr:dadr + 6] = 0.0
        mujoco.mj_forward(model, data)
        publish()

    free = {"object": model.body("slider").id} | {
        model.body(b).name.removeprefix("prop_"): model.body(b).id
        for b in range(model.nbody) if model.body(b).name.startswith("prop_")}

    def bodies() -> dict[str, tuple[float, float, float, float]]:
        out = {}
        for name, b in free.items():
            p, (_, x, y, _) = data.xpos[b], data.xquat[b]
            xy = frames.to_table(p[:2])
            tilt = np.degrees(np.arccos(np.clip(1 - 2 * (x * x + y * y), -1.0, 1.0)))
            out[name] = (float(xy[0]), float(xy[1]), float(p[2] - frames.table_z), float(tilt))
        return out

    film: dict = {"states": [], "next": 0.0, "period": 0.0, "size": (320, 240)}

    def record(fps: float, size: tuple[int, int]) -> None:
        film.update(states=[], next=data.time, period=1.0 / fps, size=size)

    def save_frames(path: str) -> int:
        """Render the recorded states (after the fact: rendering in the 1 kHz loop would slow it)."""
        states, film["states"], film["period"] = film["states"], [], 0.0
        if not states:
            np.save(path, np.zeros((0, 1, 1, 3), np.uint8))
            return 0
        view = mujoco.MjData(model)
        w, h = film["size"]
        with mujoco.Renderer(model, h, w) as renderer:
            images = []
            for q in states:
                view.qpos[:] = q
                mujoco.mj_forward(model, view)
                renderer.update_scene(view, camera="scene_camera")
                images.append(renderer.render().copy())
        np.save(path, np.stack(images))
        return len(images)

    publish()
    conn.send(("ready", (robot.hostname, nq)))
    steps, busy = 0, 0.0
    start = time.perf_counter()
    try:
        while True:
            if steps % 10 == 0 and conn.poll():
                message = conn.recv()
                if message[0] == "close":
                    break
                try:
                    answer = None
                    if message[0] == "place":
                        place(message[1])
                    elif message[0] == "knock":
                        pose = np.array(shared[_POSE:_POSE + 3])
                        place((pose[0] + message[1][0], pose[1] + message[1][1], pose[2]))
                    elif message[0] == "bodies":
                        answer = bodies()
                    elif message[0] == "record":
                        record(*message[1:])
                    elif message[0] == "save_frames":
                        answer = save_frames(message[1])
                    elif message[0] == "scene":
                        answer = scene
                    conn.send(("ok", answer))
                except Exception as exc:
                    conn.send(("error", f"{type(exc).__name__}: {exc}"))
            t0 = time.perf_counter()
            server.run_once(realtime=False)
            busy += time.perf_counter() - t0
            steps += 1
            q = data.qpos[jq]
            shared[_JOINTS] += bool(np.any(q < lo) or np.any(q > hi))
            publish()
            if film["period"] > 0 and data.time >= film["next"]:
                film["states"].append(data.qpos.copy())
                film["next"] += film["period"]
            now = time.perf_counter()
            shared[_STEPS], shared[_BUSY], shared[_WALL] = steps, busy, now - start
            if realtime > 0:              # paced: never ahead of the wall clock (scaled); behind, it runs flat out
                ahead = start + steps * 1e-3 / realtime - now
                if ahead > 0:
                    time.sleep(ahead)
    finally:
        server.cleanup()
        sim.cleanup()
