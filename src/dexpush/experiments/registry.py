"""Names the command line, the benchmark and the Gymnasium env accept, and what they build.

* shapes: ``rect``, ``tee``, ``ellipse`` (docs/conventions.md#shapes sizes) and ``plate`` (a 24 cm dish, 5 mm
  thick on the physics plant: the object of Task V, docs/goal_regions.md);
* parameter scenarios: ``known`` (λ_pred = λ_true) and ``unknown`` (λ_pred starts at [15, 0, 0]);
* methods: :mod:`dexpush.experiments.methods` (its own registry, :data:`~dexpush.experiments.methods.METHODS`);
* plants: ``model`` (the C-GVMM with λ_true), ``physics`` (MuJoCo) and ``physics-random``
  (MuJoCo in a seeded random world with a random camera: :func:`make_plant`, :func:`world_sensor`).

This module wires names to objects and is the only place that knows every plant; the
modules it imports know nothing of each other.
"""

from __future__ import annotations

from dataclasses import replace

from dexpush.common.interfaces import Plant, Sensor
from dexpush.experiments.methods import Method, get_method
from dexpush.model.cgvmm import LAMBDA_TRUE
from dexpush.model.shape import Shape
from dexpush.world.model_plant import ModelPlant
from dexpush.world.physics_plant import PhysicsPlant, PhysicsSettings
from dexpush.world.sensing import SensorSettings

__all__ = ["PARAMS", "PLANTS", "SHAPES", "check_condition", "make_plant", "make_shape", "world_sensor"]

#: λ_pred of the two parameter scenarios (paper Sec. IV-B)
PARAMS = {"known": LAMBDA_TRUE, "unknown": (15.0, 0.0, 0.0)}
_SHAPE_MAKERS = {"rect": Shape.rectangle, "tee": Shape.tee, "ellipse": Shape.ellipse,
                 "plate": lambda: Shape.ellipse(0.12, 0.12, name="plate")}
#: the physics plant's object height (m) by shape name, where it is not PhysicsSettings' 2 cm
_HEIGHTS = {"plate": 0.005}
SHAPES = tuple(_SHAPE_MAKERS)
PLANTS = ("model", "physics", "physics-random")


def make_shape(name: str) -> Shape:
    """The standard shapes of docs/conventions.md#shapes by name."""
    if name not in _SHAPE_MAKERS:
        raise ValueError(f"unknown shape {name!r}; choose one of {', '.join(SHAPES)}")
    return _SHAPE_MAKERS[name]()


def make_plant(name: str, shape: Shape, seed: int = 0, table: tuple[float, float, float, float] | None = None) -> Plant:
    """The world of an experiment: ``model`` (C-GVMM with λ_true), ``physics`` (MuJoCo), or
    ``physics-random``: MuJoCo in world ``seed`` of :meth:`dexpush.world.physics_plant.PhysicsSettings.randomized`.
    ``table``: the physics plant's table top (x_lo, y_lo, x_hi, y_hi), whose edges the object can fall from
    (None: a plane); the model plant has no table."""
    extra = {"table": table} | ({"height": _HEIGHTS[shape.name]} if shape.name in _HEIGHTS else {})
    if name == "model":
        return ModelPlant(shape)
    if name == "physics":
        return PhysicsPlant(shape, PhysicsSettings(**extra))
    if name == "physics-random":
        return PhysicsPlant(shape, replace(PhysicsSettings.randomized(seed), **extra))
    raise ValueError(f"unknown plant {name!r}; choose one of {', '.join(PLANTS)}")


def world_sensor(plant: object, sensor: Sensor | None, seed: int) -> Sensor | None:
    """The camera of trial ``seed``: a random world brings its own noise-model camera
    (:meth:`dexpush.world.sensing.SensorSettings.randomized`) unless ``sensor`` renders images; other
    plants take ``sensor`` as given."""
    if plant == "physics-random" and (sensor is None or isinstance(sensor, SensorSettings)):
        return SensorSettings.randomized(seed)
    return sensor


def check_condition(params: str, method: str | Method) -> None:
    """Reject an unknown parameter scenario or method name with the list of valid ones."""
    if params not in PARAMS:
        raise ValueError(f"unknown params {params!r}; choose 'known' or 'unknown'")
    get_method(method)
