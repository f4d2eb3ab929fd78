"""The rendered camera and calibration from the command line, the loop closed through images, and the base
install without OpenCV."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from dexpush.cli import main


def _error_line(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert err and err[-1].startswith("dexpush: error: "), err
    assert "Traceback" not in "\n".join(err)
    return err[-1]


@pytest.mark.parametrize("argv, message", [
    (["--camera", "rendered"], "sees the MuJoCo plant"),
    (["--plant", "physics", "--camera-setup", "two"], "add --camera rendered"),
    (["--plant", "physics", "--camera", "rendered", "--noise-mm", "1"], "own errors"),
    (["--plant", "physics", "--camera", "rendered", "--camera-file", "missing.toml"], "does not exist"),
])
def test_rendered_camera_mistakes_are_one_line(tmp_path: Path, capsys, argv: list[str], message: str) -> None:
    code = main(["run", "--task", "II", "--max-steps", "3", "--quiet", "--no-animation", "--out", str(tmp_path),
                 *argv])
    assert code == 2
    assert message in _error_line(capsys)


def test_a_config_with_render_settings_for_the_noise_camera_is_refused(tmp_path: Path, capsys) -> None:
    cfg = tmp_path / "run.toml"
    cfg.write_text("[run]\nplant = \"physics\"\n[render]\nsetup = \"two\"\n")
    assert main(["run", "--config", str(cfg), "--quiet", "--out", str(tmp_path)]) == 2
    assert "[render] sets the rendered camera" in _error_line(capsys)
    cfg.write_text("[run]\nplant = \"physics\"\ncamera = \"rendered\"\n[render]\nsetup = \"fisheye\"\n")
    assert main(["run", "--config", str(cfg), "--quiet", "--out", str(tmp_path)]) == 2
    assert "unknown camera set-up 'fisheye'" in _error_line(capsys)


def test_the_base_install_runs_without_opencv_and_says_what_the_camera_needs(tmp_path: Path) -> None:
    code = ("import sys; sys.modules['cv2'] = None\n"
            "import dexpush\nfrom dexpush.cli import main\n"
            "from dexpush.perception.camera_model import CameraModel\n"
            f"sys.exit(main(['run', '--plant', 'physics', '--camera', 'rendered', '--task', 'II', '--max-steps', '3',"
            f" '--quiet', '--no-animation', '--out', {str(tmp_path)!r}]))")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.strip() == ("dexpush: error: images need OpenCV: pip install 'dexpush[camera]' "
                                   "(opencv-python-headless)")


def test_calibrate_then_run_through_rendered_images_with_the_calibrated_camera(tmp_path: Path, capsys) -> None:
    cv2 = pytest.importorskip("cv2")
    from dexpush.perception.calibration import Board
    from dexpush.perception.camera_file import write_camera_file
    from dexpush.world.rendered_camera import RenderSettings, board_images, setup_cameras

    board_file = tmp_path / "board.toml"
    board_file.write_text("[board]\nkind = \"charuco\"\nsquares = [7, 5]\nsquare_m = 0.05\nmarker_m = 0.037\n"
                          "pose = [0.15, 0.3, 0.0]\n")
    true = setup_cameras(RenderSettings(setup="top"))[0]
    (image,) = board_images(Board(squares=(7, 5), square_m=0.05, marker_m=0.037, pose=(0.15, 0.3, 0.0)), true)
    cv2.imwrite(str(tmp_path / "board.png"), image)
    maker = tmp_path / "maker.toml"         # the intrinsics a camera's maker supplies; its pose unknown
    write_camera_file(maker, [true.__class__(true.width, true.height, true.fx, true.fy, true.cx, true.cy,
                                             true.distortion, name="top")])
    cams = tmp_path / "cameras.toml"
    assert main(["calibrate", str(tmp_path / "board.png"), "--board", str(board_file), "--intrinsics", str(maker),
                 "--name", "top", "--out", str(cams), "--board-image", str(tmp_path / "print.png")]) == 0
    summary = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert summary["reprojection_error_px"] < 0.3 and summary["camera"] == "top"
    assert np.linalg.norm(np.subtract(summary["position_m"], true.position)) < 5e-3
    assert cv2.imread(str(tmp_path / "print.png")) is not None

    out = tmp_path / "run"
    code = main(["run", "--plant", "physics", "--camera", "rendered", "--camera-setup", "top", "--camera-file",
                 str(cams), "--task", "II",
                 "--shape", "rect", "--params", "unknown", "--method", "mppi-ukf", "--max-steps", "40", "--quiet",
                 "--no-animation", "--out", str(out)])
    assert code == 1                                        # 40 steps do not turn the box by 90°
    summary = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert summary["sensor"].startswith("rendered top") and summary["steps"] == 40
    assert summary["object_path_m"] > 0.005 or summary["contact_switches"] > 0     # it pushed, seeing through images
    assert summary["diagnostics"]["rejected_frames"] == 0
    frames = summary["frames"]                              # 40 periods of 0.04 s at 15 Hz: 24 captures
    assert frames["captured"] == 24 and frames["delivered"] + frames["withheld"] + 2 >= frames["captured"]

    # the board missing from the image, a wrong image, a board file with a typo
    blank = tmp_path / "blank.png"
    cv2.imwrite(str(blank), np.full((720, 1280), 200, np.uint8))
    assert main(["calibrate", str(blank), "--board", str(board_file), "--intrinsics", str(maker), "--out",
                 str(tmp_path / "x.toml")]) == 2
    assert "ChArUco board (4x4_50) is not in the image" in _error_line(capsys)
    (tmp_path / "notes.png").write_text("not an image")
    assert main(["calibrate", str(tmp_path / "notes.png"), "--board", str(board_file), "--intrinsics", str(maker)]) == 2
    assert "cannot read image" in _error_line(capsys)
    (tmp_path / "typo.toml").write_text("[board]\nsquare = 0.05\n")
    assert main(["calibrate", str(blank), "--board", str(tmp_path / "typo.toml")]) == 2
    assert "unknown key 'square'" in _error_line(capsys)
    assert main(["calibrate", str(blank), "--board", str(board_file)]) == 2
    assert "give --intrinsics" in _error_line(capsys)


def test_a_random_world_keeps_the_rendered_camera_and_the_runner_reseeds_it() -> None:
    from dexpush.experiments.registry import world_sensor
    from dexpush.world.rendered_camera import RenderSettings
    from dexpush.world.sensing import SensorSettings

    render = RenderSettings(setup="two")
    assert world_sensor("physics-random", render, 3) is render
    assert world_sensor("physics-random", None, 3) == SensorSettings.randomized(3)
    assert world_sensor("physics", render, 3) is render
    assert not render.perfect and render.describe().startswith("rendered two (2 cameras, 1280×720, 15 Hz")


def test_a_shape_files_bad_markers_are_one_line_before_anything_runs(tmp_path: Path, capsys) -> None:
    shape = tmp_path / "box.toml"
    shape.write_text("[shape]\npolygons = [[[-0.1, -0.06], [0.1, -0.06], [0.1, 0.06], [-0.1, 0.06]]]\n\n"
                     "[markers]\nheight = 0.024\n\n[[markers.object]]\nid = 99\nsize = 0.04\n")
    assert main(["run", "--plant", "physics", "--camera", "rendered", "--shape", str(shape), "--task", "II",
                 "--quiet", "--no-animation", "--out", str(tmp_path / "run")]) == 2
    assert "marker id 99 is not in dictionary 4x4_50" in _error_line(capsys)
