"""The paper's pushing-and-grasping demonstration (Sec. IV-D) on the simulated Franka (:func:`run_clearing`):
clear a table of a cup and a block, picked directly, and of a flat plate that no hand can pick from the
table, pushed with the hand's closed fingers until it overhangs the table's edge (an
:class:`dexpush.problem.goal_region.Overhang` goal, MPPI with the UKF, unknown λ, the 15 Hz noise-model
camera), then grasped by the overhanging rim, lifted 5 cm and dropped into a bin
(docs/goal_regions.md#the-demonstration-on-the-franka). Needs ``pip install 'dexpush[franka]'``.

The table's pushing edge faces the robot: a level hand reaches a rim there (its fingers one above and one
below the plate), while beyond the far edge or beside a side edge the FR3's joints allow no level grasp at
the table's height. The arm's reach bounds the push: the fingers must get behind the plate, at most 0.78 m
from the robot's axis, so the plate starts 7–13 cm from its goal line, anywhere across 24 cm of the edge.

The grasps are scripted (:class:`dexpush.robot.pick.Picker`) from the simulator's true poses, as the paper's
came from a 6D pose tracker (SAM2 with FoundationPose); the push sees only the camera.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from dexpush.common.checks import check_positive
from dexpush.control.controller import ControllerSettings
from dexpush.experiments.robot_trial import RobotSettings, run_robot_episode
from dexpush.experiments.scenarios import Task, initial_conditions
from dexpush.model.shape import Shape
from dexpush.problem.goal_region import Overhang
from dexpush.robot.driver import DriverSettings
from dexpush.robot.pick import Picker, PickSettings
from dexpush.robot.tabletop import Bin, Prop, Tabletop
from dexpush.world.physics_plant import PhysicsSettings

__all__ = ["LIFT_KEPT", "MAX_TILT_DEG", "ClearingScene", "PlateTask", "run_clearing"]

#: the height a lifted plate must keep, of the lift (the rest is the grasp's give), and its most tilt (degrees)
LIFT_KEPT = 0.8
MAX_TILT_DEG = 20.0


@dataclass(frozen=True)
class PlateTask(Task):
    """A task whose start is drawn across the table: x within ±``start_jitter_m``, y within ±``lateral_m``."""

    lateral_m: float = 0.12

    def trial_start(self, shape: Shape, seed: int) -> tuple[np.ndarray, np.ndarray]:
        pose, pusher = initial_conditions(self, shape, seed)
        dy = np.random.default_rng([int(seed), 38]).uniform(-self.lateral_m, self.lateral_m)
        return pose + np.array([0.0, dy, 0.0]), pusher + np.array([0.0, dy])


@dataclass(frozen=True)
class ClearingScene:
    """The demonstration's table (table frame: its +x edge, the pushing edge, faces the robot ``edge_m`` from
    its base; the frame turned half a turn from the base's), the plate, the props and the bin."""

    table: tuple[float, float, float, float] = (-0.20, -0.32, 0.45, 0.32)
    edge_m: float = 0.45                  #: the pushing edge's distance from the robot's base (m)
    plate_radius: float = 0.12            #: a 24 cm dish (m)
    plate_thickness: float = 0.005        #: (m)
    plate_mass: float = 0.4               #: (kg)
    finger_radius: float = 0.013          #: the closed fingers as the planner's pusher disc: their 17 × 19 mm pads (m)
    overhang_m: float = 0.06              #: the goal: the plate past the edge by this much (m)
    start: tuple[float, float] = (0.295, 0.0)   #: the plate's start, table frame (m), jittered per seed
    start_jitter_m: float = 0.025         #: ... by this along x (m)
    lateral_m: float = 0.12               #: ... and this along the edge (m)
    props: tuple[Prop, ...] = (Prop("cup", (0.15, 0.25)),
                               Prop("block", (0.15, -0.25), kind="box", size=0.025, height=0.06, mass=0.1))
    bin: Bin = field(default_factory=lambda: Bin((0.75, 0.55)))
    lift_m: float = 0.05                  #: lift the grasped plate by this much (m)
    pick: PickSettings = field(default_factory=PickSettings)

    def __post_init__(self) -> None:
        for name in ("edge_m", "plate_radius", "plate_thickness", "plate_mass", "finger_radius", "overhang_m",
                     "lift_m"):
            check_positive(name, getattr(self, name))

    def shape(self) -> Shape:
        return Shape.ellipse(self.plate_radius, self.plate_radius, pusher_radius=self.finger_radius, name="plate")

    def frames(self) -> DriverSettings:
        """The driver's frames: the table frame's +x edge ``edge_m`` in front of the base, facing it; the pusher
        the closed fingertips."""
        from dexpush.robot.franka_sim import FINGERTIP_M

        return DriverSettings(table_origin=(self.edge_m + self.table[2], 0.0), table_yaw=float(np.pi),
                              tool_offset=FINGERTIP_M, tip_height=0.0025)

    def task(self) -> PlateTask:
        return PlateTask("plate", "push the plate to the edge", (0.0, 0.0, 0.0), start=(*self.start, 0.0),
                         start_jitter_m=self.start_jitter_m, start_jitter_deg=180.0, workspace=self.table,
                         region=Overhang("+x", self.overhang_m), lateral_m=self.lateral_m)

    def tabletop(self) -> Tabletop:
        return Tabletop(table=self.table, props=self.props, bin=self.bin)

    def physics(self) -> PhysicsSettings:
        return PhysicsSettings(support_spacing=0.02, height=self.plate_thickness, mass=self.plate_mass,
                               table=self.table)


def _wait(world: Any, seconds: float) -> None:
    """Let ``seconds`` of simulated time pass."""
    end = world.time + seconds
    while world.time < end:
        time.sleep(0.01)


def run_clearing(seed: int, scene: ClearingScene | None = None, *, settings: ControllerSettings | None = None,
                 sensor: Any = None, params: str = "unknown", video: str | Path | None = None,
                 video_fps: float = 10.0, progress: bool = False, log: Any = None) -> dict:
    """Clear the table once (trial ``seed``: the plate's start); returns the record. ``settings``: the push's
    planner (default: ``ControllerSettings()``).

    The record: ``props_in_bin`` (by name), ``overhang`` (the push ended in the region), ``dropped`` (the plate
    fell during the push), ``grasped`` and ``lifted`` (it rose with the hand by ``LIFT_KEPT`` of the lift and
    stayed up a second, tilted less than ``MAX_TILT_DEG``), ``plate_in_bin``, ``success`` (everything in the
    bin), the push's record (``push``: the :class:`dexpush.experiments.records.EpisodeRecord` fields) and its
    robot side (``robot``), ``plate_time_s`` (simulated seconds from the push's start to the plate let go over
    the bin), ``total_s``, ``error`` (what stopped the script, if anything) and ``video`` (the file written).
    """
    import dataclasses

    import franky

    from dexpush.robot.franka_sim import FrankaSim, SimSettings
    from dexpush.robot.franky_driver import FrankyDriver

    scene = scene or ClearingScene()
    say = log or (lambda text: None)
    shape, task, frames = scene.shape(), scene.task(), scene.frames()
    start, _ = task.trial_start(shape, seed)
    sim_settings = SimSettings(physics=scene.physics(), driver=frames, tool="fingers", tabletop=scene.tabletop())
    out: dict[str, Any] = {"seed": int(seed), "start": np.round(start, 4).tolist(), "props_in_bin": {},
                           "overhang": False, "dropped": None, "grasped": False, "lifted": False,
                           "plate_in_bin": False, "success": False, "plate_time_s": None, "error": None}
    with FrankaSim(shape, (), sim_settings) as world:
        world.place(start)
        if video is not None:
            world.record(video_fps)
        driver = FrankyDriver(world.address, frames, realtime=False)
        picker = Picker(driver.robot, franky.Gripper(world.address), frames, scene.pick)
        t0 = world.time
        try:
            for prop in scene.props:
                say(f"picking the {prop.name}")
                x, y, _, _ = world.bodies()[prop.name]
                picker.pick_from_above((x, y), prop.height, 2 * prop.size)
                picker.drop_into(scene.bin)
                picker.home()
            say("pushing the plate to the edge")
            picker.close()
            t_push = world.time
            episode, report = run_robot_episode(task, shape, params=params, seed=seed,
                                                settings=settings or ControllerSettings(),
                                                sensor=sensor, robot=RobotSettings(place_task=False, driver=frames),
                                                world=world, driver=driver, progress=progress)
            out["push"] = dataclasses.asdict(episode.record)
            out["robot"] = report
            out["overhang"], out["dropped"] = bool(episode.record.success), bool(episode.record.dropped)
            if out["overhang"]:
                x, y, z0, _ = world.bodies()["object"]
                overhang = x + scene.plate_radius - scene.table[2]
                say(f"grasping the plate by its rim: it overhangs by {overhang * 1e3:.0f} mm")
                n = np.array([1.0, 0.0])                     # the +x edge's outward normal (table frame)
                point = np.array([scene.table[2], y])
                height = sim_settings.physics.support_radius + scene.plate_thickness / 2
                out["grasped"] = picker.pick_rim(point, n, height, scene.plate_thickness, overhang)
                say(f"grasp {'held' if out['grasped'] else 'missed'}: fingers {picker.gripper.width * 1e3:.1f} mm "
                    f"apart, plate at {np.round(world.bodies()['object'], 3).tolist()}")
                picker.lift(scene.lift_m)
                _wait(world, 1.0)
                x, y, z, tilt = world.bodies()["object"]
                out["lifted"] = bool(z - z0 >= LIFT_KEPT * scene.lift_m and tilt < MAX_TILT_DEG)
                out["lift_m"], out["lift_tilt_deg"] = round(float(z - z0), 4), round(float(tilt), 1)
                say(f"lifted by {(z - z0) * 1e3:.0f} mm, tilted {tilt:.1f}°")
                tcp = frames.to_table(picker.tcp()[1][:2])
                picker.drop_into(scene.bin, carried=np.array([x, y]) - tcp)
                out["plate_time_s"] = round(world.time - t_push, 2)
                picker.home()
        except Exception as exc:                             # the script stops; what got done is recorded
            out["error"] = f"{type(exc).__name__}: {exc}"
            say(f"stopped: {out['error']}")
        _wait(world, 1.5)
        bodies = world.bodies()
        out["props_in_bin"] = {p.name: scene.bin.holds(bodies[p.name][:3]) for p in scene.props}
        out["plate_in_bin"] = scene.bin.holds(bodies["object"][:3])
        out["success"] = bool(out["plate_in_bin"] and all(out["props_in_bin"].values()))
        out["total_s"] = round(world.time - t0, 2)
        if video is not None:
            out["video"] = _save_video(world, Path(video), video_fps)
        driver.close()
    return out


def _save_video(world: Any, path: Path, fps: float) -> str:
    """The filmed frames to ``path`` (MP4 with ffmpeg, else a GIF beside it)."""
    from dexpush.viz import write_video

    path.parent.mkdir(parents=True, exist_ok=True)
    frames_file = path.with_suffix(".frames.npy")
    try:
        n = world.save_frames(str(frames_file))
        if n == 0:
            return ""
        return write_video(list(np.load(frames_file)), path, fps)
    finally:
        frames_file.unlink(missing_ok=True)

