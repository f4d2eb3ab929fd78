"""`dexpush robot` without the franka extra, and its bad input: one line, no traceback."""

from __future__ import annotations

import sys

import pytest

from dexpush.cli.main import main


def test_without_the_franka_extra_it_says_what_to_install(monkeypatch: pytest.MonkeyPatch,
                                                         capsys: pytest.CaptureFixture) -> None:
    monkeypatch.setitem(sys.modules, "franky_sim", None)      # as if not installed
    monkeypatch.setitem(sys.modules, "franky", None)
    assert main(["robot", "--sim", "--max-steps", "2", "--quiet", "--no-animation", "--out", "/tmp/dexpush-x"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "pip install 'dexpush[franka]'" in err[0]


@pytest.mark.parametrize("argv, message", [
    (["--robot", "192.0.2.1"], "tracker"),
    (["--camera", "rendered", "--noise-mm", "2"], "rendered images have their own errors"),
    (["--workspace", "0,0,0,1"], "workspace"),
    (["--dynamics-factor", "2"], "dynamics_factor"),
    (["--cutoff-frequency", "2000"], "cutoff_frequency is in (0, 1000] Hz"),
])
def test_bad_robot_input_is_one_line(argv: list[str], message: str, capsys: pytest.CaptureFixture) -> None:
    assert main(["robot", *argv, "--quiet", "--no-animation", "--out", "/tmp/dexpush-x"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err


def test_limit_flags_not_given_leave_the_settings_defaults() -> None:
    """`--v-limit`, `--a-limit` (robot, ros) and `--j-limit` (ros) default to the settings classes' values: a
    flag not given is left out, a given one replaces its field."""
    import argparse

    from dexpush.cli.commands import given_flags, safety_settings
    from dexpush.robot.safety import SafetySettings
    from dexpush.robot.smoothing import SmoothingSettings

    none = argparse.Namespace(v_limit=None, a_limit=None, j_limit=None)
    assert safety_settings(none) == SafetySettings()
    assert SmoothingSettings(**given_flags(none, a_max="a_limit", j_max="j_limit")) == SmoothingSettings()
    given = safety_settings(argparse.Namespace(v_limit=0.1, a_limit=None))
    assert (given.v_max, given.a_max) == (0.1, SafetySettings().a_max)
    assert given_flags(argparse.Namespace(), v_max="v_limit") == {}
