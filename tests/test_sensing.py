"""Realistic sensing: the rate, delay, noise and drop pattern asked for, and a controller that copes."""

from __future__ import annotations

import numpy as np
import pytest

from dexpush import Shape
from dexpush.world.model_plant import ModelPlant
from dexpush.world.sensing import Camera, SensorSettings


def run_camera(settings: SensorSettings, steps: int = 75) -> tuple[Camera, list]:
    cam = Camera(ModelPlant(Shape.rectangle()), settings)
    cam.reset([0.0, 0.0, 0.0], [-0.3, 0.0])
    return cam, [cam.step([0.05, 0.0]) for _ in range(steps)]


def test_exact_sensor_delivers_every_step_without_noise() -> None:
    _, frames = run_camera(SensorSettings(), 10)
    assert all(f is not None for f in frames)
    np.testing.assert_allclose(frames[-1].pusher_xy, [-0.3 + 0.05 * 0.4, 0.0], atol=1e-6)
    assert frames[-1].time == pytest.approx(0.4)


def test_camera_rate_latency_and_noise() -> None:
    s = SensorSettings(pos_std_m=1e-3, heading_std_rad=np.radians(0.5), rate_hz=15.0, latency_s=0.06)
    cam, frames = run_camera(s, 75)                     # 3 s at 25 Hz
    got = [f for f in frames if f is not None]
    assert cam.captured == 45 and len(got) == 44        # 15 Hz; the last capture is still in flight
    times = np.array([f.time for f in got])
    np.testing.assert_allclose(np.diff(times), 1 / 15, atol=1e-9)
    arrival = np.array([0.04 * (k + 1) for k, f in enumerate(frames) if f is not None])
    delay = arrival - times
    assert np.all(delay >= 0.06 - 1e-9) and np.all(delay < 0.06 + 0.04)
    # the object stands still (pusher far away): the pose noise is all there is
    poses = np.array([f.object_pose for f in got])
    assert 0.5e-3 < poses[:, :2].std() < 2e-3 and 0.2 < np.degrees(poses[:, 2].std()) < 1.0
    # the pusher is exact and its frame is from capture time, not arrival time
    np.testing.assert_allclose([f.pusher_xy[0] for f in got], -0.3 + 0.05 * times, atol=1e-5)  # float32 plant


def test_dropped_frames_follow_the_probability_and_the_seed() -> None:
    s = SensorSettings(rate_hz=25.0, drop_prob=0.3, seed=7)
    cam, frames = run_camera(s, 400)
    assert 0.2 < cam.dropped / cam.captured < 0.4
    pattern = [f is None for f in frames]
    _, again = run_camera(s, 400)
    assert pattern == [f is None for f in again]


@pytest.mark.parametrize("bad", [dict(rate_hz=0.0), dict(drop_prob=1.0), dict(latency_s=-0.1),
                                 dict(pos_std_m=np.nan)])
def test_bad_settings_are_named(bad: dict) -> None:
    with pytest.raises(ValueError, match=next(iter(bad))):
        SensorSettings(**bad)


def test_controller_copes_with_a_slow_late_lossy_camera() -> None:
    """Task II on the model plant through a realistic camera: the controller holds, predicts,
    and skips UKF updates on missing frames; the run makes clear progress toward the goal."""
    from dexpush.experiments.runner import run_episode

    ep = run_episode("II", "rect", params="unknown", method="mppi-ukf", seed=1, max_steps=150,
                     sensor=SensorSettings.realistic())
    rec = ep.record
    assert rec.sensor.startswith("15 Hz") and (rec.success or rec.steps == 150)
    start_err = abs(np.angle(np.exp(1j * (ep.states[0, 2] - np.pi / 2))))
    end_err = abs(np.angle(np.exp(1j * (ep.states[-1, 2] - np.pi / 2))))
    assert end_err < 0.5 * start_err
    assert np.all(np.isfinite(ep.commands))


def test_planning_state_is_the_frame_predicted_to_the_present() -> None:
    """``planning_state`` (world frame) is the observation for ``command``; for ``act`` the newest
    frame moved on by the commands issued since its capture, and the frame itself when it is fresh."""
    from dexpush import PushingController, Shape
    from dexpush.common.interfaces import Observation
    from dexpush.common.se2 import footprint_shift
    from dexpush.model.cgvmm import LAMBDA_TRUE

    shape = Shape.rectangle()
    ctrl = PushingController(shape, goal=(1.6, 2.3, 0.0), params=LAMBDA_TRUE)
    assert ctrl.planning_state is None
    pose, pusher = np.array([1.0, 2.0, 0.1]), np.array([1.0 - 0.111 * np.cos(0.1), 2.0 - 0.111 * np.sin(0.1)])
    ctrl.command(pose, pusher)
    np.testing.assert_allclose(ctrl.planning_state, np.r_[pose, pusher], atol=1e-6)
    ctrl.reset()
    u0 = ctrl.act(Observation(pose, pusher, 0.0))                      # fresh: the frame itself
    np.testing.assert_allclose(ctrl.planning_state, np.r_[pose, pusher], atol=1e-6)
    assert ctrl.prediction_shift_m == 0.0
    with pytest.warns(RuntimeWarning, match="set aside"):              # the same frame again: not newer, so
        ctrl.act(Observation(pose, pusher, 0.0))                       # set aside, and the state moved on by u0
    assert ctrl.rejected_frame_times == 1
    np.testing.assert_allclose(ctrl.planning_state[3:], pusher + 0.04 * u0, atol=1e-6)
    assert np.linalg.norm(u0) > 0.01
    # the prediction's shift, which the obstacle margin grows with, is the footprint's from the frame
    corners = shape.edges[0]
    moved = footprint_shift(corners, pose, ctrl.planning_state[:3])
    assert ctrl.prediction_shift_m == pytest.approx(moved, abs=1e-6) and moved > 1e-4
    ctrl.act(None)                                                     # no frame: on from the same frame
    further = footprint_shift(corners, pose, ctrl.planning_state[:3])
    assert ctrl.prediction_shift_m == pytest.approx(further, abs=1e-6) and further > moved
    ctrl.command(pose, pusher)                                         # an exact observation: nothing predicted
    assert ctrl.prediction_shift_m == 0.0
