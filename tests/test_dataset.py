"""The MIT-dataset loader and validation, on synthetic files in the dataset's own layout."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from dexpush.data.mit import OBJECTS, load_folder, load_push
from dexpush.data.validation import validate
from dexpush.world.model_plant import ModelPlant

TRUE_LAMBDA = (30.0, 0.0, 0.0)


def synthetic_push(folder: Path, angle: float, offset: float, seed: int, speed: float = 0.05,
                   jump: bool = False, fmt: str = "h5") -> Path:
    """A 50 mm straight push of rect1 by the model plant, written like the raw dataset:
    ~250 Hz streams on slightly different clocks, duplicated timestamps, optional Vicon jump."""
    rng = np.random.default_rng(seed)
    shape = OBJECTS["rect1"]()
    plant = ModelPlant(shape, params=TRUE_LAMBDA, mu=0.25)
    pose = np.array([0.35, -0.03, rng.uniform(-np.pi, np.pi)])
    # start in contact on the face x = −0.045 − ρ (body frame), at height `offset`
    c, s = np.cos(pose[2]), np.sin(pose[2])
    Rm = np.array([[c, -s], [s, c]])
    pusher = pose[:2] + Rm @ np.array([-0.045 - 0.00475, offset])
    direction = Rm @ np.array([np.cos(angle), np.sin(angle)])
    plant.reset(pose, pusher)
    dt = 0.004
    still = 25
    n = still + round(0.05 / speed / dt) + still
    t0 = 1.46e9
    obj, tip = [], []
    for k in range(n):
        obs = plant.observe()
        obj.append([t0 + k * dt, *obs.object_pose])
        tip.append([t0 + k * dt + 0.0013, *obs.pusher_xy, 0.0])
        v = direction * speed if still <= k < n - still else np.zeros(2)
        plant.step(v, dt)
    obj, tip = np.array(obj), np.array(tip)
    obj = np.insert(obj, [40, 90], obj[[40, 90]], axis=0)       # duplicated timestamps
    if jump:
        obj[60:75, 3] += np.pi / 2                              # a Vicon symmetry jump
    name = (f"motion_surface=abs_shape=rect1_a=0_v={speed * 1000:.0f}_i=0.000_s={0.5 + offset / 0.09:.3f}"
            f"_t={angle:.3f}.{fmt}")
    path = folder / name
    wrench = np.zeros((len(tip), 4))
    wrench[:, 0] = tip[:, 0]
    if fmt == "h5":
        with h5py.File(path, "w") as fh:
            fh["object_pose"], fh["tip_pose"], fh["ft_wrench"] = obj, tip, wrench
    else:
        path.write_text(json.dumps({"object_pose": obj.tolist(), "tip_pose": tip.tolist(),
                                    "ft_wrench": wrench.tolist()}))
    return path


@pytest.fixture(scope="module")
def folder(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("mit")
    cases = [(0.0, 0.0), (0.3, 0.02), (-0.35, -0.02), (0.6, 0.0), (-0.6, 0.03), (0.15, -0.03), (0.9, 0.01),
             (-0.9, 0.0)]
    for i, (angle, offset) in enumerate(cases):
        synthetic_push(d, angle, offset, seed=i, jump=(i == 1), fmt="json" if i == 2 else "h5")
    return d


def test_loader_dedups_unwraps_and_resamples(folder: Path) -> None:
    path = next(folder.glob("*t=0.300.h5"))
    push = load_push(path)
    assert push.shape == "rect1" and push.meta["t"] == pytest.approx(0.3)
    np.testing.assert_allclose(np.diff(push.time), 0.04, atol=1e-9)   # 25 Hz
    assert np.max(np.abs(np.diff(push.object_pose[:, 2]))) < 0.1       # the π/2 jump is gone
    assert np.max(np.abs(np.diff(push.pusher_xy, axis=0))) < 0.003     # ≤ 50 mm/s × 0.04 s (+ smoothing)


def test_round_trip_validation_recovers_modes_and_beta(folder: Path) -> None:
    result = validate(load_folder(folder), mu=0.25, fit_full=False)
    rect = result.summary["objects"]["rect1"]
    assert result.summary["pushes"] == 8
    assert rect["mode_agreement"] >= 0.9, rect
    assert rect["beta_fit"] == pytest.approx(TRUE_LAMBDA[0], rel=0.05)
    assert rect["one_step_error_mm"] < 0.1
    assert sum(rect["observed_counts"][m] for m in ("slide_ccw", "slide_cw")) > 0  # sliding is exercised


def _write(folder: Path, name: str, data: bytes) -> Path:
    (folder / name).write_bytes(data)
    return folder


_RECT = "motion_surface=abs_shape=rect1_a=0_v=50_i=0_s=0.5_t=0.0"


@pytest.mark.parametrize("make, match", [
    (lambda d: d / "missing", "data folder not found"),
    (lambda d: d, "no push files"),
    (lambda d: _write(d, _RECT + ".h5", b"junk"), "not a readable HDF5 file"),
    (lambda d: _write(d, _RECT.replace("rect1", "rect9") + ".json", b"{}"), "unknown object 'rect9'"),
    (lambda d: _write(d, _RECT + ".json", b"{}"), "no 'object_pose' stream"),
    (lambda d: _write(d, _RECT + ".json", b"[1, 2"), "not a readable JSON"),
])
def test_bad_data_gives_clear_errors(tmp_path: Path, make, match) -> None:
    with pytest.raises(ValueError, match=match):
        load_folder(make(tmp_path))


def test_validate_mit_cli(folder: Path, tmp_path: Path) -> None:
    proc = subprocess.run([sys.executable, "-m", "dexpush.cli", "validate-mit", str(folder), "--out", str(tmp_path),
                           "--online", "--quiet"], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    summary = json.loads(proc.stdout.strip().splitlines()[-1])
    for key in ("pushes", "samples", "mode_agreement", "one_step_error_mm", "whole_push_error_mm"):
        assert key in summary
    assert set(summary["online"]) == {"rect1"} and "nmse_online" in summary["online"]["rect1"]
    for name in ("mode_decisions.png", "confusion.png", "validation.json", "online.json", "lambda.png"):
        assert (tmp_path / name).stat().st_size > 0


def test_validate_mit_names_a_missing_folder(tmp_path: Path, capsys) -> None:
    from dexpush.cli import main

    assert main(["validate-mit", str(tmp_path / "nope"), "--out", str(tmp_path / "o")]) == 2
    assert "data folder not found" in capsys.readouterr().err


def test_a_stationary_pusher_or_an_all_nan_stream_is_one_clear_error(tmp_path: Path, capsys) -> None:
    from dexpush.cli import main

    (tmp_path / "still").mkdir()
    still = synthetic_push(tmp_path / "still", 0.1, 0.01, 5)
    with h5py.File(still, "r+") as fh:
        tip = fh["tip_pose"][()]
        tip[:, 1:3] = tip[0, 1:3]
        del fh["tip_pose"]
        fh["tip_pose"] = tip
    assert main(["validate-mit", str(tmp_path / "still"), "--out", str(tmp_path / "o1"), "--quiet"]) == 2
    assert "stationary" in capsys.readouterr().err
    (tmp_path / "nan").mkdir()
    bad = synthetic_push(tmp_path / "nan", 0.3, 0.0, 7)
    with h5py.File(bad, "r+") as fh:
        obj = fh["object_pose"][()]
        obj[:, 1:] = np.nan
        del fh["object_pose"]
        fh["object_pose"] = obj
    assert main(["validate-mit", str(tmp_path / "nan"), "--out", str(tmp_path / "o2"), "--quiet"]) == 2
    assert "0 finite samples" in capsys.readouterr().err


def test_online_estimation_learns_beta_from_pushes(folder: Path) -> None:
    """validate-mit --online's core: the controller's UKF over the pushes in order moves β from the prior
    toward the β that generated them, and predicts the one-step motion at least as well as the prior."""
    from dexpush.data.online_ukf import nmse, online_session

    pushes = load_folder(folder)
    summary, (t, lam) = online_session(pushes, OBJECTS["rect1"](), prior=(15.0, 0.0, 0.0), mu=0.25)
    assert summary["updates"] > 0 and np.all(np.isfinite(lam)) and len(t) == len(lam)
    beta = summary["lambda_final"][0]
    assert abs(np.log(beta / TRUE_LAMBDA[0])) < 0.5 * abs(np.log(15.0 / TRUE_LAMBDA[0]))
    assert summary["nmse_online"] <= summary["nmse_prior"] + 1e-3
    assert 1 <= summary["settled_after_push"] <= len(pushes)
    obs = np.random.default_rng(0).normal(size=(50, 3))
    assert nmse(obs, obs) == 0.0 and nmse(np.zeros_like(obs), obs) == pytest.approx(1.0, rel=0.1)


def test_online_estimation_of_mu_moves_toward_the_true_friction(folder: Path) -> None:
    """With ``UKFSettings(estimate_mu=True)`` the session also estimates μ_c (the synthetic pushes slide
    at μ_c = 0.25): from a prior of 0.5 the estimate ends nearer the truth, and every push's replay
    and one-step prediction use the μ_c that stood before it."""
    from dexpush.control.estimator import UKFSettings
    from dexpush.data.online_ukf import online_session

    pushes = load_folder(folder)
    summary, (_, lam) = online_session(pushes, OBJECTS["rect1"](), prior=(30.0, 0.0, 0.0), mu=0.5,
                                       settings=UKFSettings(estimate_mu=True))
    assert lam.shape[1] == 4 and np.all(np.isfinite(lam))
    assert len(summary["mu_c_after_each_push"]) == len(pushes) == len(summary["whole_push_error_deg_each"])
    assert abs(summary["mu_c_final"] - 0.25) < 0.5 * abs(0.5 - 0.25)
    fixed, _ = online_session(pushes, OBJECTS["rect1"](), prior=(30.0, 0.0, 0.0), mu=0.5)
    assert "mu_c_final" not in fixed and summary["nmse_online"] <= fixed["nmse_online"] + 1e-3


def test_estimate_mu_needs_online(folder: Path, tmp_path: Path, capsys) -> None:
    from dexpush.cli import main

    assert main(["validate-mit", str(folder), "--out", str(tmp_path), "--estimate-mu", "--quiet"]) == 2
    assert "--estimate-mu is an option of --online" in capsys.readouterr().err
