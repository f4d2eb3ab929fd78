"""The command line, end to end, in a subprocess (as a user runs it)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from dexpush.cli import main


def dexpush(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "dexpush.cli", *args], capture_output=True, text=True,
                          timeout=600)


def test_run_writes_files_and_prints_json_last(tmp_path: Path, capsys) -> None:
    out = tmp_path / "run"    # in-process (the subprocess path is covered below); shares test_tasks' compile
    code = main(["run", "--task", "III", "--shape", "rect", "--seed", "2", "--max-steps", "25", "--quiet",
                 "--out", str(out)])
    assert code == 1          # 25 steps cannot reach the goal: exit code 1
    summary = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    for key in ("success", "steps", "time_s", "object_path_m", "pusher_path_m", "final_error_m",
                "final_error_deg", "collisions", "contact_switches", "planning_ms_median"):
        assert key in summary
    assert summary["steps"] == 25 and summary["success"] is False and summary["task"] == "III"
    for name in ("trajectory.png", Path(summary["files"]["animation"]).name, "summary.json", "trajectory.npz"):
        assert (out / name).stat().st_size > 0, name
    assert json.loads((out / "summary.json").read_text())["seed"] == 2
    assert not list(out.glob(".*")), "temporary files left behind"


def test_run_saves_where_the_planner_stalled_and_planned_a_push(tmp_path: Path, capsys) -> None:
    """With a camera (the host loop) ``trajectory.npz`` holds, per step, the stall restarts and push plans so far:
    non-decreasing, one row per command, ending at the summary's counts; the trajectory figure marks them."""
    out = tmp_path / "run"
    code = main(["run", "--task", "I", "--shape", "rect", "--seed", "0", "--max-steps", "40", "--stall-after", "0.2",
                 "--camera", "realistic", "--no-animation", "--quiet", "--out", str(out)])
    assert code == 1
    summary = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    events = np.load(out / "trajectory.npz")["events"]
    assert events.shape == (summary["steps"], 2) and np.all(np.diff(events, axis=0) >= 0)
    assert events[-1, 0] == summary["diagnostics"]["stall_resets"] >= 1
    assert events[-1, 1] == summary["diagnostics"]["push_plans"]


def test_push_candidates_reads_a_run_folder_and_says_what_both_searches_see(tmp_path: Path, capsys,
                                                                              monkeypatch) -> None:
    """``benchmarks/push_candidates.py`` on a run folder: both searches' counts and best pushes; a folder that is not
    a run's is refused in one line."""
    import importlib.util

    import numpy as np

    out = tmp_path / "run"      # a run folder's two files: the box 3 cm short of Task III's goal, the pusher behind
    out.mkdir()
    (out / "summary.json").write_text(json.dumps({"task": "III", "shape": "rect", "seed": 2}))
    states = np.array([[0.57, 0.0, 0.0, 0.44, 0.0]] * 12)
    np.savez(out / "trajectory.npz", states=states, params=np.array([[15.0, 0.0, 0.0]] * 11))
    spec = importlib.util.spec_from_file_location("push_candidates", Path(__file__).resolve().parents[1]
                                                  / "benchmarks" / "push_candidates.py")
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    monkeypatch.setattr(sys, "argv", ["push_candidates.py", str(out), "--step", "10"])
    script.main()
    text = capsys.readouterr().out
    assert "task III rect seed 2, step 10: 30.0 mm and 0.00 deg from the goal" in text
    assert "far search (measure d, m):" in text and "32 walks open" in text and "/48 pushes clear" in text
    assert "endgame search (measure E):" in text and "96 walks open" in text and "/864 pushes clear" in text
    monkeypatch.setattr(sys, "argv", ["push_candidates.py", str(tmp_path)])
    with pytest.raises(SystemExit, match="not a dexpush run folder"):
        script.main()


@pytest.mark.slow   # `make demo` runs it; the run path is covered in-process above, the entry point below
def test_demo_succeeds(tmp_path: Path) -> None:
    proc = dexpush("demo", "--quiet", "--no-animation", "--out", str(tmp_path))
    assert proc.returncode == 0, proc.stderr
    summary = json.loads(proc.stdout.strip().splitlines()[-1])
    assert summary["success"] is True and summary["final_error_m"] < 0.008
    assert (tmp_path / "trajectory.png").exists()


def test_physics_plant_with_a_realistic_camera_end_to_end(tmp_path: Path) -> None:
    code = main(["bench", "--plant", "physics", "--camera", "realistic", "--tasks", "I", "--shapes", "tee",
                 "--params", "unknown", "--methods", "mppi-ukf", "--trials", "1", "--max-steps", "30",
                 "--quiet", "--out", str(tmp_path)])
    assert code == 0
    rec = json.loads((tmp_path / "benchmark.json").read_text())["trials"][0]
    assert rec["plant"] == "physics" and rec["sensor"].startswith("15 Hz") and rec["steps"] == 30
    assert rec["pusher_path_m"] > 0.01 and rec["planning_ms_max"] < 1000   # compile is not in the timing
    assert (tmp_path / "figures" / "I_tee_unknown_mppi-ukf.png").exists()


@pytest.mark.parametrize("args, message", [
    (["run", "--task", "VI"], "unknown task 'VI'"),
    (["run", "--shape", "star"], "shape must be one of rect, tee, ellipse, plate or a .toml shape file"),
    (["run", "--goal-region", "overhang:+x,0.06"], "an overhang goal needs a workspace"),
    (["run", "--goal-region", "ledge:+x,0.06"], "goal region 'ledge:+x,0.06': expected"),
    (["run", "--goal", "0.1,0.2,0", "--goal-region", "box:0,0,0,0.1,0.1"], "a goal pose or a goal region, not both"),
    (["run", "--shape", "missing.toml"], "shape file 'missing.toml' does not exist"),
    (["run", "--goal", "0.1,0.2"], "--goal: expected 3 comma-separated numbers"),
    (["run", "--plant", "physics", "--mu", "0.4"], "true_params and mu set the model plant"),
    (["run", "--seed", "-3"], "seed must be >= 0"),
    (["run", "--max-steps", "0"], "must be a positive integer"),
    (["run", "--plant", "bullet"], "invalid choice: 'bullet'"),
    (["run", "--drop", "1.5"], "drop_prob must be in [0, 1)"),
    (["run", "--wall", "0,0,1,1"], "--wall: expected 5 comma-separated numbers"),
    (["run", "--scene", "missing.toml"], "scene file missing.toml: cannot read it"),
    (["run", "--obstacle-box", "0,0,0.1,0.1"], "the start of seed 0"),
    (["bench", "--seeds", "5-2"], "bad seed range"),
    (["bench", "--randomize"], "--randomize randomises the physics plant's world: use it with --plant physics"),
])
def test_bad_arguments_give_one_clear_line(args, message, tmp_path: Path, capsys) -> None:
    try:                                   # in-process; the installed entry point is run below
        code = main([*args, "--out", str(tmp_path)])
    except SystemExit as exc:              # argparse's own errors
        code = exc.code
    err = capsys.readouterr().err
    assert code == 2
    lines = err.strip().splitlines()
    assert message in lines[-1] and sum("error:" in line for line in lines) == 1   # (usage, then) one line
    assert "Traceback" not in err


def test_a_bad_argument_is_one_line_from_the_entry_point(tmp_path: Path) -> None:
    proc = dexpush("run", "--plant", "physics", "--mu", "0.4", "--out", str(tmp_path))
    assert proc.returncode == 2
    assert "true_params and mu set the model plant" in proc.stderr.strip().splitlines()[-1]
    assert "Traceback" not in proc.stderr


def test_version_is_printed(capsys) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0 and capsys.readouterr().out.startswith("dexpush 0.")


def test_a_run_in_a_scene_file_draws_its_walls_and_boxes_and_the_next_run_compiles_nothing(tmp_path: Path) -> None:
    import os

    cache = tmp_path / "cache"
    env = {k: v for k, v in os.environ.items() if k != "DEXPUSH_NO_CACHE"} | {"DEXPUSH_CACHE_DIR": str(cache)}
    args = [sys.executable, "-m", "dexpush.cli", "run", "--scene", "examples/scenes/tray.toml", "--goal",
            "0.45,0.1,90deg", "--max-steps", "5", "--no-animation", "--quiet"]
    first = subprocess.run([*args, "--out", str(tmp_path / "a")], capture_output=True, text=True, env=env, timeout=600)
    assert first.returncode == 1, first.stderr            # 5 steps cannot reach the goal
    summary = json.loads((tmp_path / "a" / "summary.json").read_text())
    assert summary["task"] == "custom" and summary["collisions"] == 0 and summary["clearance_m"] > 0
    assert (tmp_path / "a" / "trajectory.png").stat().st_size > 10_000
    entries = sorted(p.name for p in cache.iterdir())
    assert entries                                         # the compiled programs were written
    second = subprocess.run([*args, "--out", str(tmp_path / "b")], capture_output=True, text=True, env=env,
                            timeout=600)
    assert second.returncode == 1, second.stderr
    assert sorted(p.name for p in cache.iterdir()) == entries   # and found again: nothing new compiled
