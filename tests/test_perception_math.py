"""The perception package's geometry, files and fusion: numpy only, no OpenCV, no images."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from dexpush.model.polygons import inside_polygon
from dexpush.model.shape import Shape
from dexpush.perception.camera_file import read_camera_file, write_camera_file
from dexpush.perception.camera_model import CameraModel, look_at
from dexpush.perception.markers import Marker, MarkerLayout, default_layout, quiet_zone_side, read_marker_layout
from dexpush.perception.planar_pose import PoseEstimate, fit_planar_pose, fuse

DIST = (0.08, -0.15, 0.0005, -0.0003, 0.05)


def _camera(position=(0.3, -0.75, 1.0), target=(0.3, 0.15, 0.0), distortion=DIST) -> CameraModel:
    return CameraModel.from_fov(1280, 720, 42.0, position, target, distortion=distortion, name="cam")


@given(st.floats(-0.3, 0.9), st.floats(-0.3, 0.6), st.floats(0.0, 0.2))
@settings(max_examples=60, deadline=None)
def test_a_projected_table_point_comes_back_through_the_plane(x: float, y: float, z: float) -> None:
    cam = _camera()
    px = cam.project(np.array([x, y, z]))
    assert np.all(np.isfinite(px))
    np.testing.assert_allclose(cam.on_plane(px, z), [x, y], atol=1e-7)


@given(st.floats(-0.5, 0.5), st.floats(-0.3, 0.3))
@settings(max_examples=60, deadline=None)
def test_undistortion_inverts_distortion(a: float, b: float) -> None:
    cam = _camera()
    d = cam._distort(np.array([a, b]))
    px = d * [cam.fx, cam.fy] + [cam.cx, cam.cy]
    np.testing.assert_allclose(cam.undistort_normalised(px), [a, b], atol=1e-9)


def test_look_at_is_a_rotation_whose_axis_points_at_the_target() -> None:
    for pos in [(0.3, 0.15, 1.4), (0.3, -0.75, 1.0), (1.0, 1.0, 0.5)]:
        R = look_at(pos, (0.3, 0.15, 0.0))
        np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-12)
        assert np.linalg.det(R) == pytest.approx(1.0)
        axis = np.subtract((0.3, 0.15, 0.0), pos)
        np.testing.assert_allclose(R[:, 2], axis / np.linalg.norm(axis), atol=1e-12)
        assert R[2, 1] <= 1e-12        # image "down" never points up


def test_a_pixel_spans_more_table_further_away_and_at_a_slant() -> None:
    top = _camera((0.3, 0.15, 1.4), (0.3, 0.15, 0.0), (0.0,) * 5)
    assert float(top.metres_per_pixel([0.3, 0.15], 0.0)) == pytest.approx(1.4 / top.fx, rel=1e-6)
    oblique = _camera()
    near, far = oblique.metres_per_pixel(np.array([[0.3, -0.2], [0.3, 0.5]]), 0.0)
    assert far > near > 1.4 / top.fx * 0.5


def test_a_point_behind_the_camera_projects_to_nan_and_a_ray_away_from_the_plane_meets_nothing() -> None:
    cam = _camera((0.0, 0.0, 1.0), (0.0, 0.0, 0.0), (0.0,) * 5)
    assert np.all(np.isnan(cam.project([0.0, 0.0, 2.0])))
    assert np.all(np.isnan(cam.on_plane([cam.cx, cam.cy], 2.0)))


@pytest.mark.parametrize("kw, message", [
    ({"width": 0}, "width"), ({"fx": -1.0}, "focal"), ({"fx": float("nan")}, "fx"),
    ({"distortion": (0.1, 0.2)}, "distortion"), ({"rotation": np.eye(3) * 2}, "rotation"),
    ({"rotation": np.diag([1.0, 1.0, -1.0])}, "rotation"), ({"position": [0, 0, float("inf")]}, "position"),
])
def test_an_impossible_camera_is_refused(kw: dict, message: str) -> None:
    base = dict(width=640, height=480, fx=500.0, fy=500.0, cx=319.5, cy=239.5)
    with pytest.raises(ValueError, match=message):
        CameraModel(**{**base, **kw})


def test_camera_file_round_trip(tmp_path) -> None:
    a, b = _camera(), _camera((0.3, 1.05, 1.0))
    b = CameraModel(b.width, b.height, b.fx, b.fy, b.cx, b.cy, b.distortion, b.rotation, b.position, "other", 0.12)
    path = tmp_path / "cams.toml"
    write_camera_file(path, [a, b], "two cameras")
    back = read_camera_file(path)
    assert [c.name for c in back] == ["cam", "other"] and back[1].reprojection_error_px == pytest.approx(0.12)
    for c, d in zip([a, b], back):
        np.testing.assert_allclose(d.project([0.2, 0.1, 0.0]), c.project([0.2, 0.1, 0.0]), atol=1e-9)


@pytest.mark.parametrize("text, message", [
    ("", "no \\[\\[camera\\]\\]"),
    ("[[camera]]\nwidth = 640\n", "missing key"),
    ("[[camera]]\nwidth = 640\nheight = 480\nfx = 1\nfy = 1\ncx = 1\ncy = 1\nposition = [0, 0, 1]\n"
     "rotation = [[1, 0, 0], [0, -1, 0], [0, 0, -1]]\nlens = 3\n", "unknown key 'lens'"),
    ("[[camera]]\nwidth = '640'\nheight = 480\nfx = 1\nfy = 1\ncx = 1\ncy = 1\nposition = [0, 0, 1]\n"
     "rotation = [[1, 0, 0], [0, -1, 0], [0, 0, -1]]\n", "width must be a whole number"),
    ("[[camera]]\nwidth = 640\nheight = 480\nfx = 1\nfy = 1\ncx = 1\ncy = 1\nposition = [0, 0]\n"
     "rotation = [[1, 0, 0], [0, -1, 0], [0, 0, -1]]\n", "position must be 3"),
    ("[[camera]\n", "not valid TOML"),
])
def test_a_bad_camera_file_is_one_clear_error(tmp_path, text: str, message: str) -> None:
    path = tmp_path / "cam.toml"
    path.write_text(text)
    with pytest.raises(ValueError, match=message):
        read_camera_file(path)
    with pytest.raises(ValueError, match="does not exist"):
        read_camera_file(tmp_path / "missing.toml")


MARKERS = """
[shape]
polygons = [[[-0.1, -0.06], [0.1, -0.06], [0.1, 0.06], [-0.1, 0.06]]]

[markers]
height = 0.03
{extra}
[[markers.object]]
id = {id}
size = {size}
pose = [0.05, 0.0, 90]
{more}
"""


def _layout_file(tmp_path, id=3, size=0.04, extra="", more=""):
    path = tmp_path / "box.toml"
    path.write_text(MARKERS.format(id=id, size=size, extra=extra, more=more))
    return path


def test_a_shape_files_markers_are_read(tmp_path) -> None:
    lay = read_marker_layout(_layout_file(tmp_path, more="[markers.pusher]\nid = 9\nsize = 0.03\nheight = 0.12\n"))
    assert lay.height == 0.03 and lay.pusher == Marker(9, 0.03) and lay.pusher_height == 0.12
    (m,) = lay.object_markers
    assert m.id == 3 and m.pose[2] == pytest.approx(math.pi / 2)
    # corners in ArUco's order, turned by the yaw: the printed image's top-left first
    np.testing.assert_allclose(m.corners()[0], [0.05 - 0.02, -0.02], atol=1e-12)
    assert read_marker_layout(tmp_path / "box.toml") is not None
    (tmp_path / "plain.toml").write_text("[shape]\nellipse = [0.1, 0.05]\n")
    assert read_marker_layout(tmp_path / "plain.toml") is None


@pytest.mark.parametrize("kw, message", [
    ({"id": 50}, "not in dictionary 4x4_50"), ({"size": 0}, "size must be > 0"),
    ({"size": '"4 cm"'}, "size must be a finite number"),
    ({"extra": "dictionary = 'qr'"}, "unknown marker dictionary"),
    ({"more": "[[markers.object]]\nid = 3\nsize = 0.02\n"}, "used twice"),
    ({"more": "[[markers.object]]\nid = 4\nsize = 0.02\nheight = 1\n"}, "unknown key 'height'"),
])
def test_bad_markers_are_one_clear_error(tmp_path, kw: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        read_marker_layout(_layout_file(tmp_path, **kw))


@pytest.mark.parametrize("shape, count", [(Shape.rectangle(), 3), (Shape.tee(), 3), (Shape.ellipse(), 3),
                                          (Shape.rectangle(0.05, 0.05), 1)])
def test_the_default_markers_fit_on_the_footprint_without_overlapping(shape: Shape, count: int) -> None:
    lay = default_layout(shape.polygons, 0.02)
    assert lay.object_markers[0].pose[:2] == (0.0, 0.0)
    for m in lay.object_markers:
        h = quiet_zone_side(m.size, lay.dictionary) / 2
        corners = np.array(m.pose[:2]) + h * np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]])
        assert all(any(inside_polygon(c[None], p)[0] for p in shape.polygons) for c in corners)
    for i, a in enumerate(lay.object_markers):
        for b in lay.object_markers[i + 1:]:
            side = quiet_zone_side(a.size, lay.dictionary)
            assert max(abs(a.pose[0] - b.pose[0]), abs(a.pose[1] - b.pose[1])) >= side - 1e-9
    assert len(lay.object_markers) == count


def test_no_default_marker_on_a_sliver() -> None:
    with pytest.raises(ValueError, match="no marker"):
        default_layout([np.array([[-0.1, -0.003], [0.1, -0.003], [0.1, 0.003], [-0.1, 0.003]])], 0.02)


@given(st.floats(-1, 1), st.floats(-1, 1), st.floats(-math.pi, math.pi), st.floats(0.0, 1e-3))
@settings(max_examples=60, deadline=None)
def test_the_planar_fit_recovers_a_rigid_motion(x: float, y: float, theta: float, noise: float) -> None:
    body = np.concatenate([Marker(0, 0.05).corners(), Marker(1, 0.03, (0.08, 0.02, 0.3)).corners()])
    c, s = math.cos(theta), math.sin(theta)
    table = body @ np.array([[c, s], [-s, c]]) + [x, y]
    table += np.random.default_rng(0).normal(0, noise, table.shape)
    pose, residual = fit_planar_pose(body, table)
    assert np.hypot(*(pose[:2] - [x, y])) <= 4 * noise + 1e-9
    assert abs(math.remainder(pose[2] - theta, 2 * math.pi)) <= 100 * noise + 1e-9
    assert residual <= 3 * noise + 1e-12


def _est(x: float, theta: float = 0.0, std: float = 1e-3) -> PoseEstimate:
    return PoseEstimate(np.array([x, 0.0, theta]), std, math.radians(0.3), 0.0, f"c{x}")


def test_fusion_weighs_by_uncertainty_and_averages_headings_across_the_cut() -> None:
    fused, dropped = fuse([_est(0.0, std=1e-3), _est(0.002, std=2e-3)])
    assert dropped == 0 and fused.pose[0] == pytest.approx(0.002 * 0.2)    # weights 1 : 1/4
    assert fused.pos_std_m < 1e-3
    fused, _ = fuse([_est(0.0, math.pi - 0.002), _est(0.0, -math.pi + 0.002)])
    assert abs(abs(fused.pose[2]) - math.pi) < 1e-9


def test_fusion_drops_the_camera_that_disagrees_and_refuses_when_two_do() -> None:
    fused, dropped = fuse([_est(0.0), _est(0.0005), _est(0.05)])
    assert dropped == 1 and abs(fused.pose[0]) < 1e-3
    fused, dropped = fuse([_est(0.0), _est(0.05)])
    assert fused is None and dropped == 2
    fused, dropped = fuse([_est(0.0, 0.0), _est(0.0, math.radians(20))])
    assert fused is None
    assert fuse([]) == (None, 0)


def test_a_layout_checks_itself() -> None:
    with pytest.raises(ValueError, match="at least one marker"):
        MarkerLayout((), 0.02)
    with pytest.raises(ValueError, match="height"):
        MarkerLayout((Marker(0, 0.04),), -0.1)
