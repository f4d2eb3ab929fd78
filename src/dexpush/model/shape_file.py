"""Shape files: the ``[shape]`` table of a TOML file, read with typed checks (``Shape.from_file``).

    [shape]
    name = "L"                        # optional; default: the file's stem
    polygons = [[[0, 0], [0.2, 0], [0.2, 0.05], [0.05, 0.05], [0.05, 0.15], [0, 0.15]]]
    reference = [0.04, 0.04]          # optional; default: a kernel point near the centroid
    pusher_radius = 0.01              # optional; default 0.01
    # or, instead of polygons:  ellipse = [0.10, 0.06]   (semi-axes, about its centre)

Every length is a number of metres (an integer or a float; not a string, a boolean or a table),
finite, and at most :data:`MAX_SHAPE_M` in magnitude; anything else is a ``ValueError`` that
names the file and the key. See docs/conventions.md#shapes.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any, NamedTuple

from dexpush.common.files import read_toml
from dexpush.model.polygons import MAX_CORNERS, MAX_SHAPE_M

__all__ = ["ShapeSpec", "read_shape_file"]

_KEYS = ("name", "polygons", "ellipse", "reference", "pusher_radius")


class ShapeSpec(NamedTuple):
    """What a ``[shape]`` table asks for: either ``ellipse`` (a, b) or ``polygons``, with the rest."""

    name: str
    polygons: list[list[tuple[float, float]]] | None
    ellipse: tuple[float, float] | None
    reference: tuple[float, float] | None
    pusher_radius: float


def _length(value: Any, where: str, positive: bool = False) -> float:
    """A number of metres, or a ``ValueError`` saying what ``where`` must be."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ValueError(f"{where} must be a number (metres), got {value!r}")
    v = float(value)
    if not math.isfinite(v) or abs(v) > MAX_SHAPE_M or (positive and v <= 0):
        bound = f"in (0, {MAX_SHAPE_M:g}]" if positive else f"within ±{MAX_SHAPE_M:g}"
        raise ValueError(f"{where} must be a finite length {bound} m, got {value!r}")
    return v


def _point(value: Any, where: str) -> tuple[float, float]:
    if not isinstance(value, list) or len(value) != 2:
        raise ValueError(f"{where} must be a point [x, y] (metres), got {value!r}")
    return _length(value[0], f"{where}[0]"), _length(value[1], f"{where}[1]")


def read_shape_file(path: str | os.PathLike) -> ShapeSpec:
    """The ``[shape]`` table of the TOML file at ``path``, checked (other tables are ignored, so one
    file can hold a shape and a run's settings)."""
    path = Path(path)
    doc = read_toml(path, "shape file")
    table = doc.get("shape")
    where = f"shape file {path}"
    if not isinstance(table, dict):
        raise ValueError(f"{where}: no [shape] table (see Shape.from_file for the format)")
    unknown = sorted(set(table) - set(_KEYS))
    if unknown:
        raise ValueError(f"{where}: unknown key {unknown[0]!r} in [shape]; allowed: {', '.join(sorted(_KEYS))}")
    if ("polygons" in table) == ("ellipse" in table):
        raise ValueError(f"{where}: give exactly one of `polygons` or `ellipse` in [shape]")
    name = table.get("name", path.stem)
    if not isinstance(name, str) or not name:
        raise ValueError(f"{where}: name must be a non-empty string, got {name!r}")
    rho = _length(table.get("pusher_radius", 0.01), f"{where}: pusher_radius", positive=True)
    reference = table.get("reference")
    if reference is not None:
        reference = _point(reference, f"{where}: reference")
    if "ellipse" in table:
        ab = table["ellipse"]
        if not (isinstance(ab, list) and len(ab) == 2):
            raise ValueError(f"{where}: ellipse must be [a, b] (semi-axes in metres), got {ab!r}")
        if reference not in (None, (0.0, 0.0)):
            raise ValueError(f"{where}: an ellipse's reference is its centre; drop `reference`")
        return ShapeSpec(name, None, (_length(ab[0], f"{where}: ellipse[0]", True),
                                      _length(ab[1], f"{where}: ellipse[1]", True)), None, rho)
    polys = table["polygons"]
    if not isinstance(polys, list) or not polys:
        raise ValueError(f"{where}: polygons must be a list of polygons [[[x, y], ...], ...]")
    if all(isinstance(c, list) and len(c) == 2 and not isinstance(c[0], list) for c in polys):
        polys = [polys]                      # one polygon given without the outer list
    out = []
    for i, poly in enumerate(polys):
        if not isinstance(poly, list):
            raise ValueError(f"{where}: polygon {i} must be a list of corners [x, y], got {poly!r}")
        out.append([_point(c, f"{where}: polygon {i} corner {j}") for j, c in enumerate(poly)])
    corners = sum(len(p) for p in out)
    if corners > MAX_CORNERS:
        raise ValueError(f"{where}: {corners} corners; a shape may have at most {MAX_CORNERS} (simplify the outline)")
    return ShapeSpec(name, out, None, reference, rho)
