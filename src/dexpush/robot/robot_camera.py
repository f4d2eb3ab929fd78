"""The simulated Franka seen through rendered images (:class:`RobotCamera`): the rendered camera of
:mod:`dexpush.world.rendered_camera` with the simulated robot's own world in front of it.

A copy of :class:`dexpush.robot.franka_sim.FrankaSim`'s world, with the object's ArUco markers on its
top and the cameras of a set-up, is drawn at each capture instant from the simulator's generalised
coordinates: the FR3 itself, its hand and pusher rod hide the markers where they come between a camera
and the object (no stand-in arm). The images go through the same lens (distortion, motion blur, noise)
and the same :class:`dexpush.perception.tracker.MarkerTracker` as on the physics plant; the pusher's
position comes from the robot's joints, as on a real robot.

The cameras stand where :data:`dexpush.world.rendered_camera.SETUPS` puts them relative to the
workspace's centre, turned so that the robot's base lies on their −x side, as it does there: the
task's middle takes the place of the workspace's centre. The tracker is given them in the table frame,
so its poses are the table frame's.

Drawing and reading an image take about 30 ms of a core; the robot keeps moving meanwhile, as it would
under a real camera. So each frame is drawn on a worker thread while the loop goes on; it is due at
its capture time plus ``latency_s`` and waited for then if it is late (counted in :attr:`late_frames`).
"""

from __future__ import annotations

import math
import threading
import weakref
import xml.etree.ElementTree as ET
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from dexpush.common.interfaces import Frame
from dexpush.perception.camera_model import CameraModel
from dexpush.perception.markers import default_layout, read_marker_layout
from dexpush.perception.tracker import REASONS, MarkerTracker, TrackerSettings
from dexpush.robot.driver import DriverSettings
from dexpush.world.physics_plant import headless_gl
from dexpush.world.rendered_camera import LENS_DISTORTION, SETUPS, Lens, RenderSettings, scene_extras
from dexpush.world.sensing import Camera

__all__ = ["RobotCamera", "RobotRenderSettings", "robot_cameras"]

#: the render copy's geom group for the robot (the arm, the hand, the pusher rod): off for a first look
_ROBOT_GROUP = 5
#: how long a frame may be overdue before the camera is taken to have stopped (wall s)
_FRAME_TIMEOUT_S = 10.0


@dataclass(frozen=True)
class RobotRenderSettings(RenderSettings):
    """:class:`RenderSettings` for the simulated robot's world ``world`` (a started
    :class:`dexpush.robot.franka_sim.FrankaSim`), around the task's ``middle`` (table frame, m)."""

    world: Any = field(default=None, compare=False, repr=False)
    middle: tuple[float, float] = (0.3, 0.0)

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.pusher_marker:
            raise ValueError("on the robot the pusher's position comes from its joints: pusher_marker must be False")

    def camera(self, plant: Any, obstacles: object = ()) -> RobotCamera:
        return RobotCamera(plant, self)


def robot_cameras(settings: RenderSettings, driver: DriverSettings, middle: object) -> list[tuple[CameraModel,
                                                                                                 CameraModel]]:
    """The set-up's cameras around ``middle`` (table frame, m), each as (in the table frame, in the robot's
    base frame): :data:`SETUPS`' offsets from its target, turned so that its −x side faces the robot's base."""
    mid = np.asarray(middle, dtype=np.float64)
    base = driver.to_table(np.zeros(2))                 # the robot's base in the table frame
    away = mid - base
    turn = math.atan2(away[1], away[0])
    c, s = math.cos(turn), math.sin(turn)
    dist = LENS_DISTORTION if settings.distortion else (0.0,) * 5
    out = []
    for i, (pos, target) in enumerate(SETUPS[settings.setup]):
        off = np.subtract(pos, target)
        p = np.array([mid[0] + c * off[0] - s * off[1], mid[1] + s * off[0] + c * off[1], off[2]])
        t = np.array([mid[0], mid[1], 0.0])
        name = f"{settings.setup}{i}" if len(SETUPS[settings.setup]) > 1 else settings.setup
        in_base = [np.r_[driver.to_base(v[:2]), v[2] + driver.table_z] for v in (p, t)]
        out.append(tuple(CameraModel.from_fov(settings.width, settings.height, settings.fovy_deg, a, b,
                                              distortion=dist, name=name) for a, b in ((p, t), in_base)))
    return out


class RobotCamera(Camera):
    """The simulated robot's world seen through rendered images (see the module docstring).

    Args:
        plant: the robot plant (:class:`dexpush.robot.driver.RobotPlant`) whose ``poses`` is ``settings.world``.
        settings: :class:`RobotRenderSettings`.
        tracker: :class:`TrackerSettings`.
    """

    def __init__(self, plant: Any, settings: RobotRenderSettings, tracker: TrackerSettings | None = None) -> None:
        world = settings.world
        if world is None or not hasattr(world, "snapshot"):
            raise ValueError("the rendered camera on the robot needs the simulated robot's world (FrankaSim)")
        headless_gl()
        import mujoco

        super().__init__(plant, settings.sensor())
        self.render_settings = settings
        self.world = world
        frames = world.settings.driver
        physics, shape = world.settings.physics, world.shape
        layout = read_marker_layout(settings.marker_file) if settings.marker_file else None
        if settings.marker_file and layout is None:
            raise ValueError(f"shape file {settings.marker_file}: no [markers] table "
                             "(docs/perception.md#marker-placement)")
        self.layout = layout or default_layout(shape.polygons, physics.height + 2 * physics.support_radius + 0.0004)
        pairs = robot_cameras(settings, frames, settings.middle)
        self.cameras = [table for table, _ in pairs]
        self._in_base = [base for _, base in pairs]
        self.tracker = MarkerTracker(self.cameras, self.layout, tracker)
        self._lenses = [Lens(c, settings, np.random.default_rng((settings.seed, 13, i)))
                        for i, c in enumerate(self._in_base)]
        self._mj = mujoco
        self._yaw = frames.table_yaw
        xml, files = self._render_scene(*world.scene())
        self._worker = ThreadPoolExecutor(1, thread_name_prefix="robot-camera")   # GL contexts are per thread
        self._local = threading.local()
        self._finalizer = weakref.finalize(self, _stop, self._worker, self._local)
        self._worker.submit(self._open, xml, files).result()
        self.late_frames = 0
        self.render_s: list[float] = []
        self._starting = False

    # ------------------------------------------------------------------ on the worker thread
    def _render_scene(self, xml: str, nq: int) -> tuple[str, dict[str, bytes]]:
        """The world's MJCF with the markers on the object, the cameras, and the robot in its own geom group."""
        if nq <= 0:
            raise ValueError("the simulated robot's world has too many coordinates to share with a camera")
        extras = scene_extras(self.layout, self._in_base, replace(self.render_settings, arm=False), 0.0,
                              np.zeros((0, 3)))
        root = ET.fromstring(xml)
        for old in root.findall("visual"):
            root.remove(old)
        root.insert(1, ET.fromstring(extras.visual))
        asset = root.find("asset")
        for e in ET.fromstring(f"<a>{extras.asset}</a>"):
            asset.append(e)
        worldbody = root.find("worldbody")
        for e in ET.fromstring(f"<a>{extras.world}</a>"):
            worldbody.append(e)
        slider = next(b for b in worldbody.iter("body") if b.get("name") == "slider")
        for e in ET.fromstring(f"<a>{extras.slider}</a>"):
            slider.append(e)
        for body in worldbody.iter("body"):
            if body.get("name", "").startswith("robot"):
                for g in body.iter("geom"):
                    g.set("group", str(_ROBOT_GROUP))
        return ET.tostring(root, encoding="unicode"), dict(extras.files)

    def _open(self, xml: str, files: dict[str, bytes]) -> None:
        mj = self._mj
        try:
            model = mj.MjModel.from_xml_string(xml, files)
            self._local.view = (model, mj.MjData(model), [mj.Renderer(model, c.height, c.width) for c in self._in_base])
        except Exception as exc:
            raise OSError(f"MuJoCo cannot render the robot's world here ({type(exc).__name__}: {exc}); set "
                          "MUJOCO_GL=egl or MUJOCO_GL=osmesa before dexpush imports MuJoCo") from None
        self._slider_q = int(model.jnt_qposadr[model.joint("slider").id])

    def _draw(self, qpos: np.ndarray, velocity: np.ndarray, without_robot: bool = False) -> list[np.ndarray]:
        mj = self._mj
        model, data, renderers = self._local.view
        data.qpos[:] = qpos
        mj.mj_kinematics(model, data)
        mj.mj_camlight(model, data)          # the cameras follow (mj_kinematics leaves them)
        option = mj.MjvOption()
        option.geomgroup[_ROBOT_GROUP] = 0 if without_robot else 1
        q = qpos[self._slider_q:self._slider_q + 3]
        out = []
        for r, cam, lens in zip(renderers, self._in_base, self._lenses):
            r.update_scene(data, camera=cam.name, scene_option=option)
            r.scene.flags[mj.mjtRndFlag.mjRND_SHADOW] = 0
            r.scene.flags[mj.mjtRndFlag.mjRND_REFLECTION] = 0
            half = velocity * self.render_settings.exposure_s / 2
            z = self.layout.height + self.world.settings.driver.table_z
            ends = cam.project(np.array([[*(q[:2] - half), z], [*(q[:2] + half), z]]))
            out.append(lens.image(r.render(), ends[1] - ends[0]))
        return out

    def _look(self, qpos: np.ndarray, velocity: np.ndarray, time: float, pusher: np.ndarray,
              starting: bool) -> Frame | None:
        import time as clock

        t0 = clock.perf_counter()
        frame = self.tracker.locate(self._draw(qpos, velocity), time, pusher)
        if frame is None and starting:            # the first look is taken before the arm moves in
            frame = self.tracker.locate(self._draw(qpos, velocity, without_robot=True), time, pusher)
        self.render_s.append(clock.perf_counter() - t0)
        return frame

    # ------------------------------------------------------------------ on the loop's thread
    def images(self, without_arm: bool = False) -> list[np.ndarray]:
        """The images the cameras take now (uint8 grey, one per camera); ``without_arm``: as if the robot were
        out of the way."""
        qpos, velocity, _ = self.world.snapshot()
        return self._worker.submit(self._draw, qpos, velocity, without_arm).result(_FRAME_TIMEOUT_S)

    def _job(self) -> Future:
        qpos, velocity, _ = self.world.snapshot()
        obs = self._observe()
        pusher = obs.pusher_xy + self._rng.normal(size=2) * self.render_settings.pusher_std_m
        return self._worker.submit(self._look, qpos, velocity, self.time, pusher, self._starting)

    def _measure(self) -> Frame | None:
        return self._job().result(_FRAME_TIMEOUT_S)

    def _capture(self) -> None:
        self.captured += 1
        if self._rng.random() < self.settings.drop_prob:
            self.dropped += 1
            return
        self._pending.append((self.time + self.settings.latency_s, self._job()))

    def _arrived(self, item: Any) -> Frame | None:
        if not item.done():
            self.late_frames += 1
        frame = item.result(_FRAME_TIMEOUT_S)
        if frame is None:
            self.withheld += 1
        return frame

    def counts(self) -> dict[str, int]:
        """:meth:`Camera.counts`, with the frames withheld by reason and those that arrived late."""
        out = super().counts()
        out.update({f"withheld_{k}": v for k, v in self.tracker.counts.items() if k in REASONS and v})
        out["late"] = self.late_frames
        return out

    def reset(self, object_pose: object, pusher_xy: object) -> Frame:
        """:meth:`Camera.reset`; the first frame, when the arm hides the markers, is taken as if it were
        out of the way (as a lab takes its first image before the arm comes down)."""
        self.tracker.reset()
        self.render_s = []
        self.late_frames = 0
        self._starting = True
        try:
            return super().reset(object_pose, pusher_xy)
        finally:
            self._starting = False

    def close(self) -> None:
        """Free the renderers and stop the worker thread (also when the camera is dropped)."""
        self._finalizer()


def _stop(worker: ThreadPoolExecutor, local: threading.local) -> None:
    """Free the worker thread's renderers on that thread (where their GL context is current) and stop it. The
    camera may be dropped on the worker thread itself (its last job held the last reference): then at once."""
    def free() -> None:
        for r in getattr(local, "view", (None, None, ()))[2]:
            r.close()
        local.view = None

    if getattr(local, "view", None) is not None:         # on the worker thread
        free()
        worker.shutdown(wait=False)
        return
    try:
        worker.submit(free).result(_FRAME_TIMEOUT_S)
    except RuntimeError:               # the interpreter is shutting its workers down
        pass
    worker.shutdown(wait=True)
