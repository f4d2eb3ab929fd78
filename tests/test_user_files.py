"""Your own object, run settings and recordings: shape files, the run config, logs and ``dexpush fit``."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from dexpush import Shape
from dexpush.cli import main
from dexpush.cli.config import RunConfig, build_plant, build_task, default_config, load_config, to_toml
from dexpush.data.push_logs import read_log
from dexpush.model.kernel import kernel_point
from dexpush.model.radial_table import radial_table_polygons
from dexpush.world.model_plant import ModelPlant

EXAMPLES = Path(__file__).resolve().parents[1] / "examples" / "shapes"
L_BLOCK = [[0.0, 0.0], [0.20, 0.0], [0.20, 0.05], [0.05, 0.05], [0.05, 0.15], [0.0, 0.15]]


def write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


# ---------------------------------------------------------------------------- shape files
def test_a_shape_file_builds_the_same_contour_as_the_api(tmp_path: Path) -> None:
    f = write(tmp_path / "box.toml", "[shape]\npolygons = [[[-0.1, -0.06], [0.1, -0.06], [0.1, 0.06], [-0.1, 0.06]]]\n"
                                     "reference = [0.0, 0.0]\npusher_radius = 0.01\n")
    s, ref = Shape.from_file(f), Shape.rectangle()
    assert s.name == "box" and np.array_equal(s.radius_table, ref.radius_table)
    e = Shape.from_file(write(tmp_path / "e.toml", '[shape]\nname = "egg"\nellipse = [0.1, 0.06]\n'))
    assert e.name == "egg" and np.array_equal(e.radius_table, Shape.ellipse().radius_table)
    one = Shape.from_file(write(tmp_path / "one.toml", "[shape]\npolygons = [[-0.1, -0.06], [0.1, -0.06], "
                                                       "[0.1, 0.06], [-0.1, 0.06]]\n"))   # one polygon, no outer list
    assert np.allclose(one.radius_table, ref.radius_table)


def test_the_reference_is_chosen_in_the_kernel_and_reported() -> None:
    s = Shape.from_file(EXAMPLES / "l_block.toml")
    ox, oy = s.origin
    assert 0.0 < ox < 0.2 and 0.0 < oy < 0.15 and (ox < 0.05 or oy < 0.05)   # inside the L
    # the footprint in the file's frame is the stored one shifted back by the origin
    assert np.allclose(s.polygons[0] + np.array(s.origin), np.array(L_BLOCK)[[0, 1, 2, 3, 4, 5]])
    # and near the centroid (0.075, 0.05): within a grid cell or two
    assert np.hypot(ox - 0.075, oy - 0.05) < 0.03


@settings(max_examples=25, deadline=None)
@given(st.integers(5, 12), st.floats(0.2, 0.9), st.integers(0, 10_000))
def test_kernel_point_of_random_star_polygons(n: int, dent: float, seed: int) -> None:
    """Star polygons about a random centre: the point found sees the whole inflated contour."""
    rng = np.random.default_rng(seed)
    ang = (np.arange(n) + rng.uniform(-0.35, 0.35, n)) * 2 * np.pi / n     # in order, gaps well below π
    r = np.where(np.arange(n) % 2 == 0, 0.1, 0.1 * dent)
    centre = rng.uniform(-0.5, 0.5, 2)
    poly = centre + np.stack([r * np.cos(ang), r * np.sin(ang)], -1)
    p = kernel_point([poly], 0.005, table_size=512)
    R, dR = radial_table_polygons((poly - p,), 0.005, 512)     # raises if p is not in the kernel
    assert np.all(np.isfinite(R) & np.isfinite(dR)) and np.all(R > 0)


@pytest.mark.parametrize("text, message", [
    ("[object]\nellipse = [0.1, 0.1]\n", "no [shape] table"),
    ("[shape]\nellipse = [0.1, 0.1]\ncolour = 'red'\n", "unknown key 'colour'"),
    ("[shape]\nellipse = [0.1, 0.1]\npolygons = [[[0, 0], [1, 0], [0, 1]]]\n", "exactly one of"),
    ("[shape]\nellipse = [0.1]\n", "ellipse must be [a, b]"),
    ("[shape]\npolygons = [[[0, 0], [1, 0]]]\n", "at least 3 distinct corners"),
    ("[shape\n", "not valid TOML"),
    # a U: no point sees both arms' inner faces
    ("[shape]\npolygons = [[[0, 0], [0.3, 0], [0.3, 0.2], [0.25, 0.2], [0.25, 0.05], [0.05, 0.05], [0.05, 0.2], "
     "[0, 0.2]]]\n", "not star-shaped"),
])
def test_bad_shape_files_say_what_is_wrong(tmp_path: Path, text: str, message: str) -> None:
    with pytest.raises(ValueError, match=message.replace("[", r"\[").replace("]", r"\]")):
        Shape.from_file(write(tmp_path / "bad.toml", text))


# ---------------------------------------------------------------------------- run configuration
def test_the_printed_config_reads_back_to_the_same_settings(tmp_path: Path) -> None:
    cfg = default_config({"run": {"goal": [0.4, 0.2, 0.5], "obstacles": [[0.2, 0.1, 0.03]], "method": "mppi-ukf",
                                  "true_params": [30.0, 0.0, 0.0]},
                          "controller": {"mu": 0.25, "mppi": {"num_samples": 256}}, "sensor": {"rate_hz": 15.0}})
    again = load_config(write(tmp_path / "run.toml", to_toml(cfg)))
    assert again == cfg
    assert again.controller.mppi.num_samples == 256 and again.run.obstacles == ((0.2, 0.1, 0.03),)


def test_config_overrides_and_the_objects_it_builds(tmp_path: Path) -> None:
    write(tmp_path / "l.toml", (EXAMPLES / "l_block.toml").read_text())
    f = write(tmp_path / "run.toml", '[run]\nshape = "l.toml"\ntask = "III"\ngoal = [0.5, 0.0, 0.0]\nmu = 0.4\n')
    cfg = load_config(f, {"run": {"seed": 4}})
    assert Path(cfg.run.shape) == tmp_path / "l.toml"          # relative to the config file
    assert cfg.run.seed == 4 and cfg.run.task == "III"
    task = build_task(cfg.run)
    assert task.key == "custom" and task.goal == (0.5, 0.0, 0.0) and task.obstacles == ((0.30, 0.0, 0.05),)
    plant = build_plant(cfg, Shape.from_file(cfg.run.shape))
    assert isinstance(plant, ModelPlant) and plant.mu == 0.4
    assert build_plant(RunConfig(), Shape.rectangle()) == "model"


@pytest.mark.parametrize("text, message", [
    ("[run]\nspeed = 3\n", "unknown key 'speed' in \\[run\\]"),
    ("[controller.mppi]\nnum_samples = 0\n", "num_samples"),
    ("[controller]\nestimate_params = true\n", "unknown key 'estimate_params'"),
    ("[run]\nlambda_pred = [-1.0, 0.0, 0.0]\n", "β"),
    ("[run]\nobstacles = [[0.1, 0.1]]\n", "obstacles\\[0\\] must be a list of 3"),
    ("[run]\ngoal = [0.1, 0.1, nan]\n", "goal"),
])
def test_bad_configs_say_what_is_wrong(tmp_path: Path, text: str, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        load_config(write(tmp_path / "bad.toml", text))


def test_print_config_shows_flags_over_the_file(tmp_path: Path, capsys) -> None:
    f = write(tmp_path / "run.toml", '[run]\nseed = 5\nmethod = "mppi-ukf"\n[controller.mppi]\nhorizon = 20\n')
    assert main(["run", "--config", str(f), "--seed", "7", "--goal", "0.3,0.1,90deg", "--print-config"]) == 0
    printed = capsys.readouterr().out
    cfg = load_config(write(tmp_path / "printed.toml", printed))
    assert cfg.run.seed == 7 and cfg.run.method == "mppi-ukf" and cfg.controller.mppi.horizon == 20
    assert cfg.run.goal == pytest.approx((0.3, 0.1, np.pi / 2))


def test_run_a_shape_file_with_goal_obstacle_and_world_end_to_end(tmp_path: Path, capsys) -> None:
    out = tmp_path / "run"
    code = main(["run", "--shape", str(EXAMPLES / "l_block.toml"), "--goal", "0.5,0,0", "--obstacle", "0.25,0,0.04",
                 "--true-params", "30,0.005,0", "--mu", "0.35", "--lambda-pred", "20,0,0", "--method", "mppi-ukf",
                 "--samples", "64", "--max-steps", "12", "--quiet", "--out", str(out)])
    assert code == 1                                          # 12 steps do not reach the goal
    summary = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert summary["task"] == "custom" and summary["shape"] == "l_block" and summary["params"] == "custom"
    assert summary["plant"] == "ModelPlant" and summary["steps"] == 12
    data = np.load(out / "trajectory.npz")
    assert np.allclose(data["goal"], [0.5, 0, 0]) and np.allclose(data["obstacles"], [[0.25, 0, 0.04]])
    assert np.allclose(data["params"][0], [20, 0, 0])         # the controller started from --lambda-pred
    for key in ("trajectory", "params", "animation"):
        assert Path(summary["files"][key]).stat().st_size > 0


# ---------------------------------------------------------------------------- logs and fitting
TRUE_LAMBDA = (30.0, 0.005, -0.003)


def synthetic_pushes(lam: tuple[float, float, float] = TRUE_LAMBDA, rate: float = 50.0) -> np.ndarray:
    """Rows [push, t, x, y, θ, p_x, p_y] of six 2-s straight pushes of the rect on the model plant at ``rate``."""
    plant = ModelPlant(Shape.rectangle(), lam, mu=0.3)
    rows = []
    for k, (y0, ang) in enumerate([(-0.04, 0.0), (0.0, 0.3), (0.04, -0.3), (0.03, 0.5), (-0.03, -0.5), (0.0, 0.0)]):
        plant.reset(np.zeros(3), np.array([-0.111, y0]))
        v = 0.05 * np.array([np.cos(ang), np.sin(ang)])
        for i in range(int(2.0 * rate)):
            rows.append([k, i / rate, *np.asarray(plant.state)])
            plant.step(v, 1.0 / rate)
    return np.array(rows)


@pytest.fixture(scope="module")
def pushes() -> np.ndarray:
    return synthetic_pushes()


def test_fit_recovers_lambda_from_a_csv_log(tmp_path: Path, pushes: np.ndarray, capsys) -> None:
    log = tmp_path / "log.csv"
    np.savetxt(log, pushes, delimiter=",", header="# six pushes\npush,t,x,y,theta,px,py", comments="")
    assert main(["fit", str(log), "--shape", "rect", "--mu", "0.3", "--quiet", "--out", str(tmp_path / "fit")]) == 0
    summary = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    lam, std = np.array(summary["lambda"]), np.array(summary["lambda_std"])
    assert summary["pushes"] == 6
    assert abs(lam[0] - TRUE_LAMBDA[0]) < 0.1 * TRUE_LAMBDA[0]
    assert np.all(np.abs(lam[1:] - TRUE_LAMBDA[1:]) < 0.0015)
    assert np.all(std > 0) and std[0] < 5.0
    assert summary["whole_push_error_mm"] < 3.0 and summary["use"].startswith("dexpush run --lambda-pred")
    assert (tmp_path / "fit" / "fit.png").stat().st_size > 0


def test_the_npz_log_reads_the_same_pushes_as_the_csv(tmp_path: Path, pushes: np.ndarray) -> None:
    np.savetxt(tmp_path / "a.csv", pushes[:, 1:], delimiter=",", header="t,x,y,theta,px,py", comments="")
    np.savez(tmp_path / "a.npz", t=pushes[:, 1], object_pose=pushes[:, 2:5], pusher_xy=pushes[:, 5:7],
             push=pushes[:, 0].astype(int))
    (csv_push,), npz = read_log(tmp_path / "a.csv")[:1], read_log(tmp_path / "a.npz")
    assert len(npz) == 6 and len(read_log(tmp_path)) == 1 + 6          # a folder reads both files
    assert np.allclose(npz[0].object_pose[:10], csv_push.object_pose[:10])


def test_fit_estimates_mu_when_asked(tmp_path: Path, pushes: np.ndarray, capsys) -> None:
    np.savetxt(tmp_path / "log.csv", pushes, delimiter=",", header="push,t,x,y,theta,px,py", comments="")
    assert main(["fit", str(tmp_path / "log.csv"), "--shape", "rect", "--fit-mu", "--mu", "0.5", "--quiet",
                 "--out", str(tmp_path / "fit")]) == 0
    summary = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert summary["mu_c_std"] is not None and abs(summary["mu_c"] - 0.3) < 0.05    # started at 0.5


@pytest.mark.parametrize("text, message", [
    ("t,x,y,theta\n0,0,0,0\n", "missing px, py"),
    ("t,x,y,theta,px,py\n0,0,0,0,abc,0\n", "not a number"),
    ("t,x,y,theta,px,py\n" + "".join(f"{i * 0.01},0,0,0,0,0\n" for i in range(20)), "over 0.5 s"),
])
def test_bad_logs_say_what_is_wrong(tmp_path: Path, text: str, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        read_log(write(tmp_path / "log.csv", text))


def test_fit_needs_contact(tmp_path: Path) -> None:
    t = np.arange(0, 2, 0.02)
    rows = np.stack([t, 0 * t, 0 * t, 0 * t, 0.3 + 0.05 * t, 0 * t], -1)   # the pusher never comes near
    np.savetxt(tmp_path / "log.csv", rows, delimiter=",", header="t,x,y,theta,px,py", comments="")
    assert main(["fit", str(tmp_path / "log.csv"), "--shape", "rect", "--quiet", "--out", str(tmp_path)]) == 2


def test_the_robot_loop_example_runs_and_logs_what_fit_reads(tmp_path: Path) -> None:
    import subprocess
    import sys

    script = Path(__file__).resolve().parents[1] / "examples" / "robot_loop.py"
    proc = subprocess.run([sys.executable, str(script), "--max-steps", "30", "--out", str(tmp_path)],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    summary = json.loads(proc.stdout.strip().splitlines()[-1])
    assert summary["commands"] == 30 and np.all(np.isfinite(summary["lambda_estimate"]))
    (push,) = read_log(tmp_path / "robot_loop_log.csv")          # the log is in the format `dexpush fit` reads
    assert push.object_pose.shape[1] == 3 and len(push.time) >= 25 * 1.5
