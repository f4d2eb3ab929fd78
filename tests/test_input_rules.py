"""Input rules of the user-facing surfaces (docs/reliability.md): wrong types, non-finite and huge values,
missing and extra keys give a valid result or one clear ``ValueError``, never another exception."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from dexpush import Shape
from dexpush.model.polygons import MAX_CORNERS

# values a careless or hostile shape file may hold where a length is due
ODD = st.one_of(st.booleans(), st.text(max_size=4), st.just({"x": 0}), st.just([[0.1], 0.06]),
                st.sampled_from([math.nan, math.inf, -math.inf, 1e30, -1e30, 0.0, -0.05]),
                st.floats(0.001, 0.3), st.integers(-3, 3))


def _toml(v: object) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return "nan" if math.isnan(v) else ("inf" if v == math.inf else "-inf" if v == -math.inf else repr(v))
    if isinstance(v, str):
        return '"' + v.replace("\\", "").replace('"', "") + '"'
    if isinstance(v, dict):
        return "{" + ", ".join(f"{k} = {_toml(x)}" for k, x in v.items()) + "}"
    if isinstance(v, list):
        return "[" + ", ".join(_toml(x) for x in v) + "]"
    return str(v)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(key=st.sampled_from(["pusher_radius", "ellipse_a", "ellipse_b", "reference_x", "corner"]), value=ODD)
def test_a_shape_file_with_any_value_gives_a_shape_or_one_clear_error(tmp_path, key, value) -> None:
    table = {"polygons": [[[0, 0], [0.2, 0], [0.2, 0.1], [0, 0.1]]], "reference": [0.1, 0.05], "pusher_radius": 0.01}
    if key == "pusher_radius":
        table["pusher_radius"] = value
    elif key.startswith("ellipse"):
        table = {"ellipse": [value, 0.06] if key == "ellipse_a" else [0.1, value]}
    elif key == "reference_x":
        table["reference"] = [value, 0.05]
    else:
        table["polygons"] = [[[0, 0], [value, 0], [0.2, 0.1], [0, 0.1]]]
    path = tmp_path / "s.toml"
    path.write_text("[shape]\n" + "".join(f"{k} = {_toml(v)}\n" for k, v in table.items()))
    try:
        shape = Shape.from_file(path)
    except ValueError as exc:
        assert "\n" not in str(exc) and str(exc)
        return
    # accepted: then every length in it was a real, bounded number of metres
    assert 0 < shape.pusher_radius <= 10 and shape.bounding_radius < 20
    assert not isinstance(value, bool | str | dict)


@pytest.mark.parametrize("text", [
    'pusher_radius = "0.01"', "pusher_radius = true", "reference = {x = 0, y = 0}",
    "pusher_radius = 1e30",
])
def test_shape_file_values_of_the_wrong_kind_are_refused_by_name(tmp_path, text) -> None:
    path = tmp_path / "s.toml"
    path.write_text(f"[shape]\npolygons = [[[0, 0], [0.2, 0], [0.2, 0.1], [0, 0.1]]]\n{text}\n")
    key = text.split(" =")[0]
    with pytest.raises(ValueError, match=key):
        Shape.from_file(path)


def test_ellipse_values_of_the_wrong_kind_are_refused(tmp_path) -> None:
    for text in ("[[0.1], 0.06]", "[true, 0.06]", "[1e30, 0.06]"):
        path = tmp_path / "e.toml"
        path.write_text(f"[shape]\nellipse = {text}\n")
        with pytest.raises(ValueError, match="ellipse"):
            Shape.from_file(path)
    with pytest.raises(ValueError, match="at most 10"):
        Shape.ellipse(1e30, 0.06)


def test_too_many_corners_are_refused_before_any_work() -> None:
    import time

    star = [[0.1 * math.cos(2 * math.pi * k / 10_000) * (1 + 0.2 * (k % 2)),
             0.1 * math.sin(2 * math.pi * k / 10_000) * (1 + 0.2 * (k % 2))] for k in range(10_000)]
    t0 = time.perf_counter()
    with pytest.raises(ValueError, match=f"at most {MAX_CORNERS}"):
        Shape.polygon(star)
    square = [[-0.05, -0.05], [0.05, -0.05], [0.05, 0.05], [-0.05, 0.05]]
    with pytest.raises(ValueError, match="corners together"):
        Shape.union([square] * 1000)
    assert time.perf_counter() - t0 < 5.0


# ---------------------------------------------------------------------------- configuration files and flags
def _run_args(*extra: str) -> list[str]:
    return ["run", "--max-steps", "1", "--no-animation", "--quiet", *extra]


def _error(capsys, argv: list[str]) -> str:
    from dexpush.cli import main

    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("dexpush: error: "), err
    return err[0]


@pytest.mark.parametrize("text, says", [
    ("[run]\nmax_steps = inf\n", "max_steps must be a whole number"),
    ("[run]\nseed = inf\n", "seed must be a whole number"),
    ("[run]\nmax_steps = 1e30\n", "max_steps must be a whole number"),
    ("[controller.mppi]\nhorizon = 2.5\n", "horizon must be a whole number"),
    ("[controller.mppi]\nhorizon = true\n", "horizon must be a whole number"),
    ("[controller.mppi]\nnum_samples = 64.5\n", "num_samples must be a whole number"),
    ("[controller.mppi]\nexplore_knots = 2.5\n", "explore_knots must be a whole number"),
    ("[controller]\nmu = \"0.3\"\n", "mu must be a finite number"),
    ("run = 3\n", r"\[run\] must be a table"),
    ("[controller]\nmppi = 3\n", r"\[controller.mppi\] must be a table"),
    ("[controller]\nstall = {after_s = 2, bogus = 1}\n", "unknown key 'bogus'"),
    ("[physics]\ntable_friction = 0.5\n", r"\[physics\] sets the physics plant"),
])
def test_a_config_value_of_the_wrong_kind_is_one_clear_line(tmp_path, capsys, text, says) -> None:
    path = tmp_path / "c.toml"
    path.write_text(text)
    import re

    argv = ["run", "--no-animation", "--quiet", "--config", str(path), "--out", str(tmp_path / "o")]
    assert re.search(says, _error(capsys, argv))


def test_a_shape_file_given_as_config_or_a_shape_table_not_pushed_is_refused(tmp_path, capsys) -> None:
    shape = tmp_path / "s.toml"
    shape.write_text("[shape]\nellipse = [0.1, 0.05]\n")
    assert "is a shape file" in _error(capsys, _run_args("--config", str(shape), "--out", str(tmp_path / "o")))
    both = tmp_path / "both.toml"
    both.write_text("[shape]\nellipse = [0.1, 0.05]\n\n[run]\nseed = 2\n")
    assert "has a [shape] table, but the run pushes" in _error(
        capsys, _run_args("--config", str(both), "--out", str(tmp_path / "o")))


def test_the_flat_names_of_0_3_in_a_config_file_are_read_with_a_note(tmp_path, capsys) -> None:
    from dexpush.cli import main
    from dexpush.cli.config import load_config

    path = tmp_path / "old.toml"
    path.write_text("[controller]\nstall_after_s = 3.0\nprediction_margin_gain = 0.25\n\n[controller.ukf]\n"
                    "prior_time_s = 20.0\n")
    with pytest.warns(FutureWarning, match=r"stall_after_s → stall\.after_s"):
        config = load_config(path)
    assert config.controller.stall.after_s == 3.0 and config.controller.prediction_margin.gain == 0.25
    assert config.controller.ukf.prior_pull.time_s == 20.0
    assert main(["bench", "--config", str(path), "--print-config"]) == 0
    out, err = capsys.readouterr()
    assert "[controller.stall]\nafter_s = 3.0" in out and "[run]" not in out
    assert err.count("dexpush: note: ") == 2 and "stall_after_s → stall.after_s" in err   # [controller], [.ukf]


def test_bench_reads_the_same_config_as_run_and_flags_override_it(tmp_path, capsys) -> None:
    from dexpush.cli import main

    path = tmp_path / "c.toml"
    path.write_text("[controller.stall]\nafter_s = 3.0\n\n[controller.mppi]\nnum_samples = 64\n\n[sensor]\n"
                    "latency_s = 0.02\n")
    assert main(["bench", "--config", str(path), "--samples", "32", "--print-config"]) == 0
    out = capsys.readouterr().out
    assert "num_samples = 32" in out and "after_s = 3.0" in out and "latency_s = 0.02" in out
    run_file = tmp_path / "run.toml"
    run_file.write_text("[run]\nseed = 3\n")
    assert "[run] table says what one `dexpush run` pushes" in _error(
        capsys, ["bench", "--config", str(run_file), "--out", str(tmp_path / "b"), "--quiet"])


def test_camera_flags_change_one_key_each(tmp_path, capsys) -> None:
    from dexpush.cli import main

    path = tmp_path / "c.toml"
    path.write_text("[sensor]\nlatency_s = 0.02\ndrop_prob = 0.1\n")
    assert main(["run", "--config", str(path), "--noise-mm", "1", "--print-config"]) == 0
    out = capsys.readouterr().out
    assert "pos_std_m = 0.001" in out and "latency_s = 0.02" in out and "drop_prob = 0.1" in out
    assert main(["run", "--camera", "realistic", "--noise-mm", "2", "--latency-ms", "10", "--print-config"]) == 0
    out = capsys.readouterr().out
    assert "pos_std_m = 0.002" in out and "latency_s = 0.01" in out and "rate_hz = 15.0" in out
    assert "contradicts --noise-mm" in _error(capsys, _run_args("--camera", "exact", "--noise-mm", "5"))
    with pytest.raises(SystemExit):
        main(["run", "--camera-hz", "0"])
    assert "--camera-hz" in capsys.readouterr().err
    assert "rate_hz must be at most" in _error(capsys, _run_args("--camera-hz", "1e6", "--out", str(tmp_path / "o")))


def test_negative_coordinates_and_degrees_on_the_command_line(capsys) -> None:
    from dexpush.cli import main

    assert main(["run", "--goal", "-0.3,0.2,30deg", "--obstacle", "-0.2,0.1,0.03", "--print-config"]) == 0
    out = capsys.readouterr().out
    assert "goal = [-0.3, 0.2, 0.5235987755982988]" in out and "obstacles = [[-0.2, 0.1, 0.03]]" in out
    with pytest.raises(SystemExit):       # `deg` is for the heading only
        main(["run", "--goal", "30deg,0,0", "--print-config"])
    assert "deg" in capsys.readouterr().err


def test_an_empty_output_folder_is_refused(capsys) -> None:
    from dexpush.cli import main

    with pytest.raises(SystemExit):
        main(["run", "--out", ""])
    assert "empty path" in capsys.readouterr().err


def test_a_printed_config_names_its_shape_file_from_anywhere(tmp_path, monkeypatch, capsys) -> None:
    from dexpush.cli.config import load_config

    monkeypatch.chdir(tmp_path)
    (tmp_path / "shapes").mkdir()
    (tmp_path / "shapes" / "e.toml").write_text("[shape]\nellipse = [0.1, 0.05]\n")
    from dexpush.cli import main

    assert main(["run", "--shape", "shapes/e.toml", "--print-config"]) == 0
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "c.toml").write_text(capsys.readouterr().out)
    assert Path(load_config(tmp_path / "sub" / "c.toml").run.shape).exists()
