"""Input rules of the user-facing surfaces (docs/reliability.md): wrong types, non-finite and huge values,
missing and extra keys give a valid result or one clear ``ValueError``, never another exception."""

from __future__ import annotations

import math

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
