"""Names the command line, the benchmark and the Gymnasium env accept, and what they build.

* shapes: ``rect``, ``tee``, ``ellipse`` (docs/conventions.md#shapes sizes);
* parameter scenarios: ``known`` (λ_pred = λ_true) and ``unknown`` (λ_pred starts at [15, 0, 0]);
* methods: ``mppi`` (fixed λ_pred), ``mppi-ukf`` (online estimation), ``gcs`` (plan and track);
* plants: ``model`` (the C-GVMM with λ_true), ``physics`` (MuJoCo) and ``physics-random``
  (MuJoCo in a seeded random world with a random camera: :func:`make_plant`, :func:`world_sensor`).

This module wires names to objects and is the only place that knows every plant and
every controller; the modules it imports know nothing of each other.
"""

from __future__ import annotations

from dataclasses import replace

from dexpush.common.interfaces import Controller, Plant
from dexpush.control.controller import ControllerSettings, PushingController
from dexpush.experiments.scenarios import Task
from dexpush.model.cgvmm import LAMBDA_TRUE
from dexpush.model.shape import Shape
from dexpush.world.plants import ModelPlant, PhysicsPlant, PhysicsSettings
from dexpush.world.sensing import SensorSettings

__all__ = ["ALL_METHODS", "METHODS", "PARAMS", "PLANTS", "SHAPES", "check_condition", "make_controller",
           "make_plant", "make_shape", "world_sensor"]

#: λ_pred of the two parameter scenarios (paper Sec. IV-B)
PARAMS = {"known": LAMBDA_TRUE, "unknown": (15.0, 0.0, 0.0)}
_SHAPE_MAKERS = {"rect": Shape.rectangle, "tee": Shape.tee, "ellipse": Shape.ellipse}
SHAPES = tuple(_SHAPE_MAKERS)
METHODS = ("mppi", "mppi-ukf")        #: the closed-loop MPPI methods the benchmark runs by default
ALL_METHODS = (*METHODS, "gcs")        #: plus the GCS plan-and-track baseline (Tasks I, II; dexpush.gcs)
PLANTS = ("model", "physics", "physics-random")


def make_shape(name: str) -> Shape:
    """The standard shapes of docs/conventions.md#shapes by name."""
    if name not in _SHAPE_MAKERS:
        raise ValueError(f"unknown shape {name!r}; choose one of {', '.join(SHAPES)}")
    return _SHAPE_MAKERS[name]()


def make_plant(name: str, shape: Shape, seed: int = 0) -> Plant:
    """The world of an experiment: ``model`` (C-GVMM with λ_true), ``physics`` (MuJoCo), or
    ``physics-random``: MuJoCo in world ``seed`` of :meth:`dexpush.world.plants.PhysicsSettings.randomized`."""
    if name == "model":
        return ModelPlant(shape)
    if name == "physics":
        return PhysicsPlant(shape)
    if name == "physics-random":
        return PhysicsPlant(shape, PhysicsSettings.randomized(seed))
    raise ValueError(f"unknown plant {name!r}; choose one of {', '.join(PLANTS)}")


def world_sensor(plant: object, sensor: SensorSettings | None, seed: int) -> SensorSettings | None:
    """The camera of trial ``seed``: a random world brings its own
    (:meth:`dexpush.world.sensing.SensorSettings.randomized`), other plants take ``sensor`` as given."""
    return SensorSettings.randomized(seed) if plant == "physics-random" else sensor


def check_condition(params: str, method: str) -> None:
    """Reject an unknown parameter scenario or method name with the list of valid ones."""
    if params not in PARAMS:
        raise ValueError(f"unknown params {params!r}; choose 'known' or 'unknown'")
    if method not in ALL_METHODS:
        raise ValueError(f"unknown method {method!r}; choose one of {', '.join(ALL_METHODS)}")


def make_controller(method: str, shape: Shape, task: Task, params: object, seed: int = 0,
                    settings: ControllerSettings | None = None) -> Controller:
    """The controller of ``method`` for ``task`` on ``shape``, starting from λ_pred = ``params``.

    ``mppi`` and ``mppi-ukf`` give a :class:`PushingController` (the UKF on for
    ``mppi-ukf``, whatever ``settings.estimate_params`` says); ``gcs`` gives a
    :class:`dexpush.gcs.GCSTracker` (needs the ``drake`` package; no obstacles).
    """
    settings = settings or ControllerSettings()
    if method in METHODS:
        settings = replace(settings, estimate_params=method == "mppi-ukf")
        return PushingController(shape, task.goal, params=params, obstacles=task.obstacles, settings=settings,
                                 seed=seed)
    if method == "gcs":
        from dexpush.gcs import GCSTracker  # Drake loads only for this method

        if task.obstacles:
            raise ValueError(f"the GCS baseline has no obstacle support (task {task.key}); use tasks I or II")
        return GCSTracker(shape, task.goal, params, mu=settings.mu, control_period=settings.mppi.control_period,
                          v_max=settings.mppi.v_max)
    raise ValueError(f"unknown method {method!r}; choose one of {', '.join(ALL_METHODS)}")
