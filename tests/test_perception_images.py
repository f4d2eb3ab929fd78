"""Perception on rendered images: markers → poses against the truth, the frames it withholds, calibration,
live sources that fail, and the rendered scene's physics (needs the dexpush[camera] extra)."""

from __future__ import annotations

import math

import numpy as np
import pytest

cv2 = pytest.importorskip("cv2")

from dexpush.model.shape import Shape  # noqa: E402
from dexpush.perception.calibration import (  # noqa: E402
    Board,
    BoardNotFoundError,
    calibrate_extrinsics,
    calibrate_intrinsics,
)
from dexpush.perception.camera_model import CameraModel  # noqa: E402
from dexpush.perception.live import CameraPoses, VideoCaptureSource  # noqa: E402
from dexpush.perception.tracker import MarkerTracker  # noqa: E402
from dexpush.world.physics_plant import PhysicsPlant  # noqa: E402
from dexpush.world.rendered_camera import RenderedCamera, RenderSettings, board_images, setup_cameras  # noqa: E402


def _error(frame, truth) -> tuple[float, float]:
    e = frame.object_pose - truth[:3]
    return float(np.hypot(*e[:2])), abs(math.degrees(math.remainder(float(e[2]), 2 * math.pi)))


@pytest.fixture(scope="module")
def top() -> RenderedCamera:
    return RenderedCamera(PhysicsPlant(Shape.tee()), RenderSettings(setup="top"))


def test_rendered_markers_give_the_true_pose(top: RenderedCamera) -> None:
    rng = np.random.default_rng(1000)
    for _ in range(6):
        pose = np.array([rng.uniform(-0.1, 0.7), rng.uniform(-0.1, 0.4), rng.uniform(-math.pi, math.pi)])
        first = top.reset(pose, pose[:2] + np.array([0.0, 0.3]))
        mm, deg = _error(first, top.state)
        assert mm < 1.5e-3 and deg < 0.6, (pose, mm, deg)
        assert first.time == 0.0
        np.testing.assert_allclose(first.pusher_xy, pose[:2] + np.array([0.0, 0.3]))   # from the robot: exact


def test_frames_arrive_at_the_camera_rate_with_their_capture_times(top: RenderedCamera) -> None:
    top.reset([0.1, 0.1, 0.2], [-0.2, 0.1])
    frames = [f for f in (top.step([0.0, 0.0], 0.04) for _ in range(25)) if f is not None]
    assert 13 <= len(frames) <= 15                         # 15 Hz over 1 s, the first arriving after 60 ms
    times = np.array([f.time for f in frames])
    np.testing.assert_allclose(np.diff(times), 1 / 15, atol=1e-9)
    assert top.captured == 15 and top.withheld == 0


def test_the_arm_hides_markers_and_no_wrong_pose_gets_through() -> None:
    """The pusher to the right of the box: the arm, leaning back to −x, lies over its markers."""
    cam = RenderedCamera(PhysicsPlant(Shape.rectangle()), RenderSettings(setup="top"))
    cam.reset([0.2, 0.15, 0.0], [0.7, 0.15])
    seen = []
    for dx in (0.15, 0.25, 0.35, 0.5):
        cam.plant.reset([0.2, 0.15, 0.0], [0.2 + dx, 0.15])
        frame = cam.tracker.locate(cam.images(), dx, cam.state[3:])
        seen.append(frame is not None)
        if frame is not None:
            assert _error(frame, cam.state)[0] < 3e-3
    assert seen == [False, False, True, True] and cam.tracker.counts["not_seen"] == 2


def test_a_wrong_focal_length_shows_as_a_bad_fit_not_a_wrong_pose() -> None:
    plant = PhysicsPlant(Shape.rectangle())
    true = setup_cameras(RenderSettings(setup="top"))
    c = true[0]
    wrong = [CameraModel(c.width, c.height, c.fx * 1.15, c.fy * 1.15, c.cx, c.cy, c.distortion, c.rotation,
                         c.position, c.name)]
    cam = RenderedCamera(plant, RenderSettings(setup="top"), tracker_cameras=wrong)
    with pytest.raises(ValueError, match="sees nothing it can trust"):
        cam.reset([0.3, 0.15, 0.4], [0.0, 0.15])
    assert cam.tracker.counts["bad_fit"] == 2          # the first look, and the look without the arm


def test_two_cameras_that_disagree_give_no_frame() -> None:
    plant = PhysicsPlant(Shape.rectangle())
    settings = RenderSettings(setup="two")
    true = setup_cameras(settings)
    c = true[1]
    shifted = CameraModel(c.width, c.height, c.fx, c.fy, c.cx, c.cy, c.distortion, c.rotation,
                          c.position + np.array([0.03, 0.0, 0.0]), c.name)
    cam = RenderedCamera(plant, settings, tracker_cameras=[true[0], shifted])
    cam.plant.reset([0.3, 0.15, 0.4], [0.0, 0.15])
    assert cam.tracker.locate(cam.images(), 0.0, [0.0, 0.15]) is None
    assert cam.tracker.counts["disagree"] == 1
    good = RenderedCamera(plant, settings)
    frame = good.reset([0.3, 0.15, 0.4], [0.0, 0.15])
    assert _error(frame, good.state)[0] < 1e-3 and len(good.tracker.last_estimates) == 2


def test_a_pose_that_jumps_is_held_back_until_it_persists(top: RenderedCamera) -> None:
    top.reset([0.1, 0.1, 0.0], [-0.2, 0.1])
    tr = top.tracker
    assert tr.locate(top.images(), 0.0, [0, 0]) is not None
    top.plant.reset([0.6, 0.1, 3.0], [-0.2, 0.1])           # the object "teleports": a swapped or misread marker
    assert tr.locate(top.images(), 0.05, [0, 0]) is None and tr.counts["jump"] == 1
    assert tr.locate(top.images(), 0.3, [0, 0]) is None
    frame = tr.locate(top.images(), 0.6, [0, 0])            # still there after reacquire_s: the new truth
    assert frame is not None and _error(frame, top.state)[0] < 1.5e-3


def test_images_of_the_wrong_kind_are_one_clear_error(top: RenderedCamera) -> None:
    top.reset([0.1, 0.1, 0.0], [-0.2, 0.1])
    img = top.images()[0]
    with pytest.raises(ValueError, match="640×480 pixels; its camera is 1280×720"):
        top.tracker.locate([np.zeros((480, 640), np.uint8)], 0.0, [0, 0])
    with pytest.raises(ValueError, match="uint8"):
        top.tracker.locate([img.astype(np.float32)], 0.0, [0, 0])
    with pytest.raises(ValueError, match="numpy array"):
        top.tracker.locate(["frame.png"], 0.0, [0, 0])
    with pytest.raises(ValueError, match="2 images for 1 cameras"):
        top.tracker.locate([img, img], 0.0, [0, 0])
    n = top.tracker.counts["no_image"]
    assert top.tracker.locate([None], 0.0, [0, 0]) is None and top.tracker.counts["no_image"] == n + 1
    colour = np.repeat(img[..., None], 3, axis=2)
    assert top.tracker.locate([colour], 1.0, [0, 0]) is not None


def test_the_pusher_marker_gives_the_pusher_position() -> None:
    cam = RenderedCamera(PhysicsPlant(Shape.rectangle()), RenderSettings(setup="top", pusher_marker=True))
    frame = cam.reset([0.3, 0.15, 0.2], [0.3, -0.05])
    assert np.hypot(*(frame.pusher_xy - [0.3, -0.05])) < 2e-3
    cam.plant.reset([0.3, 0.15, 0.2], [3.0, 3.0])            # the pusher out of view
    assert cam.tracker.locate(cam.images(), 1.0) is None and cam.tracker.counts["pusher_not_seen"] == 1


def test_the_drawn_scene_has_the_bare_scenes_physics() -> None:
    bare = PhysicsPlant(Shape.tee())
    seen = RenderedCamera(PhysicsPlant(Shape.tee()), RenderSettings(setup="two", pusher_marker=True),
                          obstacles=[(0.3, 0.0, 0.05)])
    for plant in (bare, seen.plant):
        plant.reset([0.0, 0.0, 0.1], [-0.12, 0.0])
        for _ in range(60):
            plant.step([0.08, 0.01], 0.04)
    np.testing.assert_array_equal(bare.state, seen.plant.state)


BOARD = Board(squares=(7, 5), square_m=0.05, marker_m=0.037, pose=(0.15, 0.3, 0.0))


@pytest.mark.parametrize("setup", ["top", "oblique"])
def test_extrinsics_from_a_rendered_board(setup: str) -> None:
    cam = setup_cameras(RenderSettings(setup=setup))[0]
    (image,) = board_images(BOARD, cam)
    est = calibrate_extrinsics(image, cam, BOARD)
    assert np.linalg.norm(est.position - cam.position) < 5e-3
    angle = math.degrees(math.acos(np.clip((np.trace(est.rotation.T @ cam.rotation) - 1) / 2, -1, 1)))
    assert angle < 0.2 and est.reprojection_error_px < 0.3
    # what matters: table points seen through the estimate land where they are
    px = cam.project(np.array([[0.3, 0.15, 0.02], [0.6, 0.3, 0.02]]))
    assert np.max(np.abs(est.on_plane(px, 0.02) - [[0.3, 0.15], [0.6, 0.3]])) < 1.5e-3
    with pytest.raises(BoardNotFoundError, match="not in the image"):
        calibrate_extrinsics(np.full_like(image, 128), cam, BOARD)


def test_intrinsics_from_rendered_views_of_a_tilted_board() -> None:
    cam = setup_cameras(RenderSettings(setup="top"))[0]
    board = Board(squares=(9, 6), square_m=0.06, marker_m=0.045, pose=(0.03, 0.33, 0.0))
    tilts = [(25, 0, 0), (-25, 0, 0), (0, 25, 0), (0, -25, 0), (20, 20, 15), (-20, 15, -15)]
    est = calibrate_intrinsics(board_images(board, cam, tilts, lift_m=0.6)[1:], board)
    assert est.fx == pytest.approx(cam.fx, rel=5e-3) and est.fy == pytest.approx(cam.fy, rel=5e-3)
    assert abs(est.cx - cam.cx) < 2 and abs(est.cy - cam.cy) < 2 and est.reprojection_error_px < 0.3
    with pytest.raises(BoardNotFoundError, match="3 or more"):
        calibrate_intrinsics([np.zeros((720, 1280), np.uint8)] * 3, board)


class _Clock:
    def __init__(self) -> None:
        self.t = 100.0

    def __call__(self) -> float:
        return self.t


class _Capture:
    """A camera that plays back images, then fails in the ways drivers do."""

    def __init__(self, images: list, clock: _Clock) -> None:
        self.images, self.clock = list(images), clock

    def read(self):
        self.clock.t += 1 / 15
        if not self.images:
            return False, None
        img = self.images.pop(0)
        if isinstance(img, Exception):
            raise img
        return True, img


def test_a_live_camera_loop_counts_what_fails_and_goes_stale(top: RenderedCamera) -> None:
    top.reset([0.1, 0.1, 0.0], [-0.2, 0.1])
    img = top.images()[0]
    clock = _Clock()
    source = VideoCaptureSource(capture=_Capture([img, RuntimeError("USB reset"), img], clock), latency_s=0.03,
                                clock=clock)
    poses = CameraPoses([source], MarkerTracker(top.cameras, top.layout), stale_s=0.5, clock=clock)
    first = poses.frame([0.0, 0.0])
    assert first is not None and first.time == pytest.approx(1 / 15 - 0.03)   # on the controller's clock
    assert poses.frame([0.0, 0.0]) is None and source.failures == 1
    assert poses.frame([0.0, 0.0]) is not None and not poses.stale
    for _ in range(8):                                    # the camera stops delivering
        assert poses.frame([0.0, 0.0]) is None
    assert poses.stale and poses.tracker.counts["no_image"] == 9
    with pytest.raises(ValueError, match="2 image sources for 1"):
        CameraPoses([source, source], poses.tracker)
    with pytest.raises(ValueError, match="latency_s"):
        VideoCaptureSource(capture=object(), latency_s=-1)


def test_the_gymnasium_env_sees_through_rendered_images() -> None:
    from dexpush.env import PushEnv

    env = PushEnv(task="II", shape="rect", plant="physics", sensor=RenderSettings(setup="top"))
    obs, _ = env.reset(seed=0)
    assert np.hypot(*(obs[:2] - env.camera.state[:2])) < 2e-3
    for _ in range(5):
        obs, *_ = env.step(np.array([0.05, 0.0], np.float32))
    counts = env.camera.counts()
    assert counts["delivered"] >= 2 and counts["withheld"] == 0


@pytest.mark.parametrize("family", ["4x4_50", "6x6_250", "apriltag_36h11", "apriltag_16h5"])
def test_every_marker_family_is_found_at_its_corners(family: str) -> None:
    from dexpush.perception.detect import MarkerDetector

    det = MarkerDetector(family)
    img = det.marker_image(7, 180)
    img = cv2.copyMakeBorder(img, 60, 60, 80, 80, cv2.BORDER_CONSTANT, value=255)
    found = det.detect(img)
    assert list(found) == [7]
    q = 180 // ({"4x4_50": 6, "6x6_250": 8, "apriltag_36h11": 8, "apriltag_16h5": 6}[family])  # the quiet zone
    x0, y0 = 80 + q, 60 + q
    expected = np.array([[x0, y0], [x0 + 180, y0], [x0 + 180, y0 + 180], [x0, y0 + 180]]) - 0.5
    assert np.max(np.abs(found[7] - expected)) < 1.0
