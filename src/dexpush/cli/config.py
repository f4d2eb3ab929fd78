"""A run's settings as one TOML file: ``dexpush run --config run.toml`` and ``--print-config``.

The file has a table per settings class; every key is optional and takes the class's
documented default when absent. ``dexpush run --print-config`` prints the full effective
file, defaults included, so the easiest start is to save that and edit it::

    [run]                       # what to push where (RunSettings)
    task = "I"                  # I, II, III, IV, V, C: the start distribution, and goal/obstacles unless given
    shape = "examples/shapes/l_block.toml"   # rect, tee, ellipse, or a shape file (Shape.from_file)
    goal = [0.4, 0.2, 0.5]      # x (m), y (m), θ (rad) of the shape's reference point
    obstacles = [[0.2, 0.1, 0.03]]            # discs c_x, c_y, r (m)
    scene = "examples/scenes/tray.toml"      # boxes, walls, workspace (docs/workspaces.md#scene-files)
    method = "mppi-ukf"
    lambda_pred = [20.0, 0.0, 0.0]            # the controller's first λ = [β, x_bf, y_bf]
    true_params = [30.0, 0.005, 0.0]          # the model plant's λ_true
    mu = 0.35                                 # the model plant's μ_c

    [controller]                # ControllerSettings (mu: the μ_c the controller assumes)
    [controller.mppi]           # MPPISettings (K = num_samples, N_p = horizon, v_max, ...)
    [controller.weights]        # CostWeights (eq. 9)
    [controller.ukf]            # UKFSettings
    [sensor]                    # SensorSettings (what the controller sees: the noise-model camera)
    [render]                    # RenderSettings (the rendered camera: [run] camera = "rendered")
    [physics]                   # PhysicsSettings (the MuJoCo plant)

Command-line flags override the file. Unknown keys are errors (with the allowed ones).
A relative ``shape`` or ``scene`` path is read relative to the config file.
"""

from __future__ import annotations

import dataclasses
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from dexpush.cli.settings_file import from_dict, merge, to_dict
from dexpush.cli.settings_file import to_toml as to_toml_text
from dexpush.common.checks import check_params, check_positive, checked_vector
from dexpush.common.files import read_toml
from dexpush.common.interfaces import Plant
from dexpush.control.controller import ControllerSettings
from dexpush.experiments.registry import PARAMS, PLANTS, SHAPES, check_condition, make_shape
from dexpush.experiments.scenarios import MAX_STEPS, Task, get_task
from dexpush.model.cgvmm import LAMBDA_TRUE, MU_C
from dexpush.model.shape import Shape
from dexpush.perception.markers import read_marker_layout
from dexpush.problem.goal_region import parse_region
from dexpush.problem.scene_file import Layout, load_scene
from dexpush.world.model_plant import ModelPlant
from dexpush.world.physics_plant import PhysicsPlant, PhysicsSettings
from dexpush.world.rendered_camera import RenderSettings
from dexpush.world.sensing import SensorSettings

#: the cameras a run can see through: the noise model of the true pose, or rendered images
CAMERAS = ("noise", "rendered")

__all__ = [
    "CAMERAS",
    "RunConfig",
    "RunSettings",
    "build_plant",
    "build_sensor",
    "build_task",
    "check_bench_config",
    "check_run_config",
    "default_config",
    "lambda_pred",
    "load_config",
    "load_shape",
    "to_dict",
    "to_toml",
]


@dataclass(frozen=True)
class RunSettings:
    """What to push where, with which method, in which world (the ``[run]`` table)."""

    task: str = "I"                #: I, II, III, IV, V or C: start distribution, and goal/obstacles unless given
    shape: str = "rect"            #: rect, tee, ellipse, or a TOML shape file
    goal: tuple[float, float, float] | None = None          #: (x, y, θ) in m, m, rad; None: the task's
    obstacles: tuple[tuple[float, float, float], ...] | None = None   #: discs (c_x, c_y, r); None: the task's
    #: a scene file (docs/workspaces.md#scene-files): its discs, boxes, walls and workspace replace the task's
    scene: str | None = None
    boxes: tuple[tuple[float, ...], ...] | None = None      #: boxes (c_x, c_y, width, height[, yaw rad])
    walls: tuple[tuple[float, ...], ...] | None = None      #: walls (x0, y0, x1, y1, thickness)
    workspace: tuple[float, float, float, float] | None = None   #: a rectangle (x_lo, y_lo, x_hi, y_hi)
    #: a goal region in place of the goal pose (docs/goal_regions.md), e.g. "overhang:+x,0.06"
    goal_region: str | None = None
    params: str = "known"          #: known (λ_pred = λ_true) or unknown (λ_pred starts at [15, 0, 0])
    lambda_pred: tuple[float, float, float] | None = None   #: the controller's first λ; overrides ``params``
    method: str = "mppi"           #: mppi, mppi-ukf or gcs
    seed: int = 0                  #: start perturbation and MPPI sampling
    plant: str = "model"           #: model (C-GVMM) or physics (MuJoCo)
    true_params: tuple[float, float, float] | None = None   #: model plant's λ_true; None: [25, −0.01, 0.02]
    mu: float | None = None        #: model plant's μ_c; None: 0.3
    max_steps: int = MAX_STEPS     #: N_max
    camera: str = "noise"          #: noise: [sensor]'s noise-model camera; rendered: images ([render], physics plants)

    def layout(self) -> Layout | None:
        """What the run keeps clear of when it replaces the task's (the scene file, then ``obstacles``,
        ``boxes``, ``walls`` and ``workspace``), or None when none of them is given."""
        given = (self.scene, self.obstacles, self.boxes, self.walls, self.workspace)
        if all(v is None for v in given):
            return None
        layout = load_scene(self.scene) if self.scene is not None else Layout()
        discs = Layout(tuple(tuple(float(v) for v in ob) for ob in self.obstacles or ()))
        return layout.plus(discs).plus(Layout.from_flags(self.boxes or (), self.walls or (), self.workspace))

    def __post_init__(self) -> None:
        get_task(self.task)
        check_condition(self.params, self.method)
        if self.plant not in PLANTS:
            raise ValueError(f"unknown plant {self.plant!r}; choose one of {', '.join(PLANTS)}")
        if self.shape not in SHAPES and not str(self.shape).endswith(".toml"):
            raise ValueError(f"shape must be one of {', '.join(SHAPES)} or a .toml shape file, got {self.shape!r}")
        if self.goal is not None:
            checked_vector("goal", self.goal, 3)
        if self.goal_region is not None:
            parse_region(self.goal_region)
            if self.goal is not None:
                raise ValueError("give a goal pose or a goal region, not both")
        for i, ob in enumerate(self.obstacles or ()):
            c = checked_vector(f"obstacle {i}", ob, 3)
            check_positive(f"obstacle {i} radius", c[2], "metres")
        self.layout()
        for name in ("lambda_pred", "true_params"):
            if getattr(self, name) is not None:
                check_params(checked_vector(name, getattr(self, name), 3))
        if self.mu is not None:
            check_positive("mu", self.mu, "the model plant's pusher–object friction")
        if self.true_params is not None or self.mu is not None:
            if self.plant != "model":
                raise ValueError("true_params and mu set the model plant's world; the physics plant's friction is "
                                 "[physics] pusher_friction / table_friction")
        if isinstance(self.seed, bool) or int(self.seed) != self.seed or not 0 <= self.seed < 2**32:
            raise ValueError(f"seed must be a whole number in [0, 2³²), got {self.seed!r}")
        if self.camera not in CAMERAS:
            raise ValueError(f"unknown camera {self.camera!r}; choose one of {', '.join(CAMERAS)}")
        if isinstance(self.max_steps, bool) or int(self.max_steps) != self.max_steps or self.max_steps < 1:
            raise ValueError(f"max_steps must be a whole number >= 1, got {self.max_steps!r}")


@dataclass(frozen=True)
class RunConfig:
    """Every setting of one ``dexpush run``: the file's tables, one field each."""

    run: RunSettings = field(default_factory=RunSettings)
    controller: ControllerSettings = field(default_factory=ControllerSettings)
    sensor: SensorSettings = field(default_factory=SensorSettings)
    render: RenderSettings = field(default_factory=RenderSettings)
    physics: PhysicsSettings = field(default_factory=PhysicsSettings)

    def replace(self, **sections: dict[str, Any]) -> RunConfig:
        """A copy with keys of some tables replaced, e.g. ``replace(run={"seed": 3})``; nested
        tables as nested dicts (``controller={"mppi": {"num_samples": 256}}``)."""
        return from_dict(RunConfig, merge(to_dict(self, _NOT_IN_FILE), sections), "config", _NOT_IN_FILE)


#: keys a file cannot set: the method sets whether the UKF runs
_NOT_IN_FILE = frozenset({("controller", "estimate_params")})


def load_config(path: str | os.PathLike, overrides: dict[str, dict] | None = None) -> RunConfig:
    """The :class:`RunConfig` of a TOML file (see the module docstring), with ``overrides``
    (tables of keys, as :meth:`RunConfig.replace`) applied on top."""
    path = Path(path)
    doc = read_toml(path, "config file")
    shape = doc.get("run", {}).get("shape") if isinstance(doc.get("run"), dict) else None
    if isinstance(shape, str) and shape.endswith(".toml") and not Path(shape).is_absolute():
        doc["run"]["shape"] = str(path.parent / shape)
    scene = doc.get("run", {}).get("scene") if isinstance(doc.get("run"), dict) else None
    if isinstance(scene, str) and not Path(scene).is_absolute():
        doc["run"]["scene"] = str(path.parent / scene)
    if "shape" in doc:                          # a shape table may live in the same file (Shape.from_file)
        doc.pop("shape")
        named = (overrides or {}).get("run", {}).get("shape", doc.get("run", {}).get("shape"))
        if not doc:
            raise ValueError(f"{path} is a shape file (only a [shape] table): pass it with --shape {path}")
        if not (isinstance(named, str) and Path(named).resolve() == path.resolve()):
            raise ValueError(f"{path} has a [shape] table, but the run pushes {named or 'rect'!r}: set "
                             f"[run] shape = \"{path.name}\" to push it, or remove the table")
    return from_dict(RunConfig, merge(doc, overrides or {}), "config", _NOT_IN_FILE)


def default_config(overrides: dict[str, dict] | None = None) -> RunConfig:
    """The defaults, with ``overrides`` applied."""
    return RunConfig().replace(**(overrides or {}))


def to_toml(config: RunConfig, tables: tuple[str, ...] | None = None) -> str:
    """The config as TOML text that :func:`load_config` reads back to the same settings (only
    ``tables`` when given)."""
    return to_toml_text(config, "dexpush configuration (dexpush run --config FILE, dexpush bench --config FILE); "
                                "every key is optional", _NOT_IN_FILE, tables)


# ---------------------------------------------------------------------------- objects of a run
def load_shape(name_or_file: str) -> Shape:
    """A standard shape by name, or a shape file (:meth:`dexpush.Shape.from_file`)."""
    if name_or_file in SHAPES:
        return make_shape(name_or_file)
    if str(name_or_file).endswith(".toml"):
        return Shape.from_file(name_or_file)
    raise ValueError(f"shape must be one of {', '.join(SHAPES)} or a .toml shape file, got {name_or_file!r}")


def build_task(run: RunSettings) -> Task:
    """The task of a run: the named task, with the goal and obstacles replaced where given
    (then keyed ``custom``: its records are not the benchmark's)."""
    base = get_task(run.task)
    layout = run.layout()
    region = parse_region(run.goal_region) if run.goal_region is not None else getattr(layout, "region", None)
    if run.goal is None and layout is None and region is None:
        return base
    if base.varies_by_seed:
        raise ValueError(f"task {base.key} draws its own goal and layout per seed: give --goal, --obstacle, "
                         "--scene and the like with another task")
    goal = tuple(float(v) for v in run.goal) if run.goal is not None else base.goal
    if layout is None:
        layout = Layout(base.obstacles, base.polygons, base.workspace)
    if region is None and run.goal is None:
        region = base.region
    return dataclasses.replace(base, key="custom", title=f"custom goal (start as task {base.key})", goal=goal,
                               obstacles=layout.obstacles, polygons=layout.polygons, workspace=layout.workspace,
                               region=region)


def build_plant(config: RunConfig, shape: Shape,
                table: tuple[float, float, float, float] | None = None) -> str | Plant:
    """The world of a run: a registry name when the defaults apply, else the plant object (with ``table``, the
    problem's table top: :attr:`dexpush.problem.problem.Problem.table`). Settings of another plant than the run's
    are refused, not dropped."""
    run = config.run
    check_run_config(config)
    if run.plant == "model" and (run.true_params is not None or run.mu is not None):
        return ModelPlant(shape, run.true_params if run.true_params is not None else LAMBDA_TRUE,
                          mu=run.mu if run.mu is not None else MU_C)
    if run.plant == "physics" and config.physics != PhysicsSettings():
        physics = config.physics if table is None else dataclasses.replace(config.physics, table=table)
        return PhysicsPlant(shape, physics)
    return run.plant


def build_sensor(config: RunConfig) -> SensorSettings | RenderSettings | None:
    """What the run's controller sees: None (the exact state), the noise-model camera ([sensor]) or the
    rendered camera ([render]; its markers from the shape file's [markers] table when it has one)."""
    if config.run.camera == "rendered":
        render = config.render
        shape = config.run.shape
        if not render.marker_file and shape.endswith(".toml") and read_marker_layout(shape) is not None:
            render = dataclasses.replace(render, marker_file=shape)     # (checked here, before anything compiles)
        return render
    return config.sensor if config.sensor != SensorSettings() else None


def check_run_config(config: RunConfig, plant: str | None = None) -> None:
    """Settings of another plant or camera than the run's are refused, not dropped. ``plant``: the plant that
    runs, where not [run] plant (``dexpush robot``: the robot)."""
    plant = plant or config.run.plant
    if config.run.camera == "rendered" and plant == "model":
        raise ValueError("the rendered camera sees the MuJoCo plant: use it with plant = \"physics\" "
                         "(--plant physics) or \"physics-random\"")
    if config.run.camera != "rendered" and config.render != RenderSettings():
        raise ValueError("[render] sets the rendered camera, but the run's camera is the noise model: set [run] "
                         "camera = \"rendered\" (or --camera rendered), or remove the [render] table")
    if config.run.camera == "rendered" and config.sensor != SensorSettings():
        raise ValueError("[sensor] sets the noise-model camera, but the run's camera is rendered: its rate, "
                         "latency and drops are [render] rate_hz, latency_s, drop_prob; remove [sensor]")
    if plant != "physics" and config.physics != PhysicsSettings():
        raise ValueError(f"[physics] sets the physics plant, but the run's plant is {plant!r}: set "
                         "[run] plant = \"physics\" (or --plant physics), or remove the [physics] table")


def check_bench_config(config: RunConfig, args: object) -> None:
    """``dexpush bench`` takes its conditions from its flags and runs the named plants with their own
    worlds: a configuration's non-default [run] or [physics] table is refused, not dropped."""
    check_run_config(dataclasses.replace(config, run=dataclasses.replace(config.run, plant="physics")))
    if dataclasses.replace(config.run, camera="noise") != RunSettings():
        raise ValueError("the [run] table says what one `dexpush run` pushes; `dexpush bench` takes that from "
                         "--tasks, --shapes, --params, --methods and --seeds: remove [run] from the file")
    if config.physics != PhysicsSettings():
        raise ValueError("`dexpush bench` runs the physics plant's world (--plant physics) or its randomised "
                         "family (--randomize); a [physics] table is for `dexpush run`: remove it from the file")


def lambda_pred(run: RunSettings) -> tuple[float, float, float]:
    """The λ the controller starts from."""
    return tuple(float(v) for v in run.lambda_pred) if run.lambda_pred is not None else PARAMS[run.params]

