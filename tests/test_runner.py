"""One episode loop for any plant and any controller: a user's own plant, a user's own controller."""

from __future__ import annotations

import numpy as np
import pytest

import dexpush
from dexpush import Observation, PushingController, Shape, run_episode, run_loop
from dexpush.common.interfaces import Controller, Plant, check_plant
from dexpush.experiments.scenarios import Task
from dexpush.world.model_plant import ModelPlant
from dexpush.world.sensing import SensorSettings


class EulerPlant:
    """A user's own simulator, written against the public API only: the C-GVMM (``dexpush.cgvmm``)
    integrated with explicit Euler in float64 numpy, true λ = [20, 0, 0], μ_c = 0.3."""

    def __init__(self, shape: Shape, substeps: int = 10) -> None:
        self.shape, self.substeps = shape, substeps
        self.x: np.ndarray | None = None
        self.t = 0.0
        self.steps = 0

    @property
    def state(self) -> np.ndarray:
        if self.x is None:
            raise RuntimeError("reset first")
        return self.x.copy()

    def observe(self) -> Observation:
        return Observation(self.x[:3].copy(), self.x[3:].copy(), self.t)

    def reset(self, object_pose, pusher_xy) -> Observation:
        self.x = np.concatenate([np.asarray(object_pose, float), np.asarray(pusher_xy, float)])
        self.t = 0.0
        return self.observe()

    def step(self, velocity, dt: float) -> Observation:
        h = dt / self.substeps
        for _ in range(self.substeps):
            xdot, _ = dexpush.cgvmm(self.shape, self.x, np.asarray(velocity, float), [20.0, 0.0, 0.0])
            self.x = self.x + h * np.asarray(xdot, float)
        self.t += dt
        self.steps += 1
        return self.observe()


class PushRight:
    """A user's own controller: push along +x at 5 cm/s; gives up after ``limit`` commands."""

    def __init__(self, limit: int) -> None:
        self.limit, self.calls, self.resets = limit, 0, 0

    def reset(self, object_pose=None, pusher_xy=None) -> None:
        self.calls, self.resets = 0, self.resets + 1

    def act(self, frame, frame_period=None) -> np.ndarray:
        self.calls += 1
        return np.array([0.05, 0.0])

    @property
    def gave_up(self) -> bool:
        return self.calls >= self.limit


def test_the_test_plant_and_controller_satisfy_the_protocols() -> None:
    plant = EulerPlant(Shape.rectangle())
    assert check_plant(plant) is plant
    plant.reset((0.0, 0.0, 0.0), (-0.2, 0.0))
    assert isinstance(plant, Plant)       # (Python < 3.12 reads ``state`` here: reset first)
    assert isinstance(PushRight(3), Controller)
    assert isinstance(PushingController(Shape.rectangle(), (0.1, 0.0, 0.0), params=(25.0, 0.0, 0.0)), Controller)


def test_mppi_pushes_on_a_users_own_plant() -> None:
    shape = Shape.rectangle()
    plant = EulerPlant(shape)
    task = Task("near", "short push", goal=(0.04, 0.0, 0.0))
    ctrl = PushingController(shape, task.goal, params=(20.0, 0.0, 0.0))
    res = run_loop(plant, ctrl, task.problem(shape), (0.0, 0.0, 0.0), (-0.14, 0.0), max_steps=200)
    assert res.success, res.states[-1]
    assert len(res.states) == len(res.commands) + 1 == plant.steps + 1
    np.testing.assert_allclose(res.params, np.tile([20.0, 0.0, 0.0], (len(res.commands), 1)), rtol=1e-6)
    assert np.all(np.abs(res.commands) <= 0.1 / np.sqrt(2) + 1e-9)


def test_any_controller_on_any_plant_with_a_camera_and_giving_up() -> None:
    shape = Shape.rectangle()
    ctrl = PushRight(limit=7)
    task = Task("far", "never reached", goal=(1.0, 0.0, 0.0))
    res = run_loop(ModelPlant(shape), ctrl, task.problem(shape), (0.0, 0.0, 0.0), (-0.2, 0.0),
                   sensor=SensorSettings(rate_hz=10.0, latency_s=0.05), max_steps=100)
    assert ctrl.resets == 1 and len(res.commands) == 7 and not res.success     # gave_up ended it
    assert np.all(np.isnan(res.params))                                          # it has no λ
    np.testing.assert_allclose(res.states[-1, 3:], [-0.2 + 7 * 0.04 * 0.05, 0.0], atol=1e-6)


def test_obstacle_contact_ends_the_loop_as_a_failure() -> None:
    shape = Shape.rectangle()
    task = Task("wall", "obstacle ahead", goal=(1.0, 0.0, 0.0), obstacles=((0.2, 0.0, 0.05),))
    res = run_loop(ModelPlant(shape), PushRight(limit=10_000), task.problem(shape), (0.0, 0.0, 0.0), (-0.2, 0.0),
                   max_steps=400)
    assert not res.success and len(res.commands) < 400
    assert res.states[-1, 0] > 0.02          # the object was pushed into the obstacle


def test_run_episode_takes_a_plant_object() -> None:
    ep = run_episode("II", Shape.rectangle(), params="known", method="mppi", plant=EulerPlant(Shape.rectangle()),
                     max_steps=3)
    assert ep.record.plant == "EulerPlant" and ep.record.steps == 3 and ep.states.shape == (4, 5)


def test_a_non_plant_is_refused() -> None:
    with pytest.raises(ValueError, match="not a plant"):
        run_episode("I", "rect", plant=object(), max_steps=1)   # type: ignore[arg-type]


def test_run_loop_reads_the_older_task_and_shape_form_with_a_deprecation_warning() -> None:
    shape = Shape.rectangle()
    task = Task("far", "never reached", goal=(1.0, 0.0, 0.0))
    with pytest.warns(DeprecationWarning, match="pass a Problem"):
        old = run_loop(ModelPlant(shape), PushRight(limit=5), task, shape, (0.0, 0.0, 0.0), (-0.2, 0.0))
    new = run_loop(ModelPlant(shape), PushRight(limit=5), task.problem(shape), (0.0, 0.0, 0.0), (-0.2, 0.0))
    np.testing.assert_array_equal(old.states, new.states)
    with pytest.raises(TypeError, match="problem is a dexpush Problem"):
        run_loop(ModelPlant(shape), PushRight(limit=5), shape, (0.0, 0.0, 0.0), (-0.2, 0.0))
