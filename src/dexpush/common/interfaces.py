"""What the parts of a pushing loop exchange: observations, and the ``Plant`` and ``Controller`` protocols.

One control period of any experiment, simulated or on a robot, is

    frame = camera.step(command, control_period)     # the plant moves; a frame may arrive
    command = controller.act(frame, frame_period)    # None when no frame arrived

and :func:`dexpush.experiments.runner.run_loop` runs it for *any* object that satisfies :class:`Plant`
(the model plant, the MuJoCo plant, your own simulator or robot driver) and any object
that satisfies :class:`Controller` (:class:`dexpush.PushingController`, the GCS tracker,
your own). These are structural protocols: nothing has to inherit from them.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

import numpy as np

__all__ = ["CONTROL_PERIOD_S", "Controller", "Frame", "Observation", "Plant", "Sensor", "check_plant"]

#: T, the control period (s) of the paper's loop (25 Hz): how long a command is held unless told otherwise
CONTROL_PERIOD_S = 0.04


@dataclass(frozen=True)
class Observation:
    """What a plant or camera reports: object pose (..., 3) [x, y, θ], pusher centre (..., 2), time (s).

    Units are metres and radians in the world frame; ``time`` is the capture time on the
    clock that started at the plant's ``reset`` (time 0).
    """

    object_pose: np.ndarray
    pusher_xy: np.ndarray
    time: float

    @property
    def state(self) -> np.ndarray:
        """The 5-vector (or batch) [x_b, y_b, θ, x_c, y_c]."""
        return np.concatenate([self.object_pose, self.pusher_xy], -1)


Frame = Observation   #: a camera frame is an observation whose ``time`` is its capture time


@runtime_checkable
class Plant(Protocol):
    """The world a controller pushes in: it owns the true state.

    ``reset`` places the object and the pusher (pusher outside the object) and returns the
    first observation; ``step`` holds the pusher velocity (m/s, world frame) for ``dt``
    seconds and returns the observation at the end; ``observe`` reports without moving;
    ``state`` is the true [x_b, y_b, θ, x_c, y_c], read only to judge success.
    """

    def reset(self, object_pose: object, pusher_xy: object) -> Observation: ...

    def step(self, velocity: object, dt: float) -> Observation: ...

    def observe(self) -> Observation: ...

    @property
    def state(self) -> np.ndarray: ...


@runtime_checkable
class Controller(Protocol):
    """Anything that turns what the sensor delivered into a pusher velocity command.

    ``reset(object_pose, pusher_xy)`` is called once before the clock starts, with the
    first observation: do slow preparation there (compiling, an offline plan). ``act``
    is called once per control period with the newest frame that arrived in it, or
    ``None`` when none did; ``frame_period`` is the camera's period (s). It returns the
    pusher velocity (v_x, v_y) in m/s for the next period.

    Optional attributes the episode runner reads when present: ``params`` (the model
    parameters λ it currently plans with, logged each step), ``gave_up`` (True ends the
    episode early: nothing left to execute) and ``planning_s`` (wall times of offline
    plans and replans).
    """

    def reset(self, object_pose: object | None = None, pusher_xy: object | None = None) -> None: ...

    def act(self, frame: Observation | None, frame_period: float | None = None) -> np.ndarray: ...


@runtime_checkable
class Sensor(Protocol):
    """Settings of what a controller sees of a plant (a frozen dataclass: the runner reseeds it per trial with
    ``dataclasses.replace(sensor, seed=...)``): ``camera(plant, obstacles)`` wraps the plant in a camera
    (``reset``, ``step``, ``state``, ``counts``; ``dexpush.world.sensing.Camera``); ``rate_hz`` is its frame
    rate (None: every control period); ``perfect`` says it delivers the exact state every period;
    ``describe()`` labels records. ``dexpush.world.sensing.SensorSettings`` (the noise model) and
    ``dexpush.world.rendered_camera.RenderSettings`` (rendered images) are sensors.
    """

    rate_hz: float | None
    seed: int

    @property
    def perfect(self) -> bool: ...

    def camera(self, plant: Plant, obstacles: object = ()) -> Any: ...

    def describe(self) -> str: ...


def check_plant(plant: object) -> Plant:
    """``plant`` if its class has what :class:`Plant` asks for, else a ``ValueError`` naming what is missing.

    (Looked up on the class: a plant's ``state`` may raise until it is reset.)
    """
    missing = [name for name in ("reset", "step", "observe", "state") if not hasattr(type(plant), name)]
    if missing:
        raise ValueError(f"{type(plant).__name__} is not a plant: it lacks {', '.join(missing)} "
                         "(see dexpush.common.interfaces.Plant)")
    return plant  # type: ignore[return-value]
