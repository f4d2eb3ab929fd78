"""Scene files: a problem's obstacles, walls, workspace and goal region in TOML (:func:`load_scene`,
:class:`Layout`).

A scene file (docs/workspaces.md#scene-files) holds any of::

    workspace = [-0.5, -0.5, 0.5, 0.5]          # x_lo, y_lo, x_hi, y_hi (m), or [[x, y], ...] corners
    goal_region = "overhang:+x,0.06"             # optional: a goal region (docs/goal_regions.md)

    [[disc]]
    centre = [0.2, 0.1]
    radius = 0.03

    [[box]]
    centre = [0.3, -0.1]
    size = [0.10, 0.06]                          # width, height (m)
    yaw_deg = 30                                 # optional, default 0

    [[wall]]
    start = [-0.2, 0.25]
    end = [0.5, 0.25]
    thickness = 0.02

    [[polygon]]
    corners = [[0.0, 0.3], [0.1, 0.3], [0.05, 0.4]]   # convex, either winding

Every mistake is one ``ValueError`` line that names the file, the entry and the key.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from dexpush.problem.goal_region import GoalRegion, parse_region
from dexpush.problem.regions import box, convex_polygon, wall, workspace_halfplanes

__all__ = ["Layout", "load_scene"]

_KINDS = {"disc": ("centre", "radius"), "box": ("centre", "size", "yaw_deg"),
          "wall": ("start", "end", "thickness"), "polygon": ("corners",)}


@dataclass(frozen=True)
class Layout:
    """What a problem must keep clear of: disc ``obstacles`` (c_x, c_y, r), convex ``polygons`` (boxes,
    walls and polygons as corner tuples) and a ``workspace`` (a rectangle (x_lo, y_lo, x_hi, y_hi) or
    convex corners; None: unbounded). All in metres, in the world frame."""

    obstacles: tuple[tuple[float, float, float], ...] = ()
    polygons: tuple[tuple[tuple[float, float], ...], ...] = ()
    workspace: tuple | None = None
    #: a goal region (:mod:`dexpush.problem.goal_region`), or None
    region: GoalRegion | None = None

    def plus(self, other: Layout) -> Layout:
        """Both layouts' obstacles; ``other``'s workspace and goal region where it has them."""
        return Layout(self.obstacles + other.obstacles, self.polygons + other.polygons,
                      other.workspace if other.workspace is not None else self.workspace,
                      other.region if other.region is not None else self.region)

    @classmethod
    def from_flags(cls, boxes: object = (), walls: object = (), workspace: object = None) -> Layout:
        """The layout of the command line's ``--obstacle-box CX,CY,W,H[,YAW]`` (yaw in rad),
        ``--wall X0,Y0,X1,Y1,T`` and ``--workspace X0,Y0,X1,Y1``."""
        polys = []
        for i, b in enumerate(boxes or ()):
            if len(b) not in (4, 5):
                raise ValueError(f"box {i}: expected cx, cy, width, height[, yaw], got {tuple(b)!r}")
            polys.append(_corners(box(*b)))
        for i, w in enumerate(walls or ()):
            if len(w) != 5:
                raise ValueError(f"wall {i}: expected x0, y0, x1, y1, thickness, got {tuple(w)!r}")
            polys.append(_corners(wall(*w)))
        if workspace is not None:
            workspace_halfplanes(tuple(workspace))
        return cls((), tuple(polys), None if workspace is None else tuple(float(v) for v in workspace))


def load_scene(path: str | Path) -> Layout:
    """The :class:`Layout` of a scene file (the module docstring); a one-line ``ValueError`` for a missing
    or unreadable file, an unknown table or key, or an invalid entry (a degenerate or concave polygon,
    a negative radius, ...)."""
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text())
    except OSError as exc:
        raise ValueError(f"scene file {path}: cannot read it ({exc.strerror or exc})") from None
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"scene file {path}: not valid TOML ({exc})") from None
    unknown = sorted(set(data) - {"workspace", "goal_region", *_KINDS})
    if unknown:
        raise ValueError(f"scene file {path}: unknown key {unknown[0]!r}; a scene has workspace, goal_region and "
                         f"[[{']], [['.join(_KINDS)}]] tables")
    discs, polys = [], []
    for kind, keys in _KINDS.items():
        entries = data.get(kind, [])
        if not isinstance(entries, list) or not all(isinstance(e, dict) for e in entries):
            raise ValueError(f"scene file {path}: {kind} must be an array of tables ([[{kind}]])")
        for i, entry in enumerate(entries):
            where = f"scene file {path}: {kind} {i}"
            extra = sorted(set(entry) - set(keys))
            if extra:
                raise ValueError(f"{where}: unknown key {extra[0]!r}; expected {', '.join(keys)}")
            try:
                if kind == "disc":
                    (cx, cy), r = _pair(entry, "centre"), _number(entry, "radius")
                    if not r > 0:
                        raise ValueError(f"radius must be positive, got {r}")
                    discs.append((cx, cy, r))
                elif kind == "box":
                    (cx, cy), (w, h) = _pair(entry, "centre"), _pair(entry, "size")
                    yaw = math.radians(_number(entry, "yaw_deg", 0.0))
                    polys.append(_corners(box(cx, cy, w, h, yaw)))
                elif kind == "wall":
                    polys.append(_corners(wall(*_pair(entry, "start"), *_pair(entry, "end"),
                                               _number(entry, "thickness"))))
                else:
                    if "corners" not in entry:
                        raise ValueError("missing key 'corners'")
                    polys.append(_corners(convex_polygon(entry["corners"], "corners")))
            except (ValueError, TypeError) as exc:
                raise ValueError(f"{where}: {exc}") from None
    workspace = data.get("workspace")
    if workspace is not None:
        try:
            workspace_halfplanes(workspace)
        except (ValueError, TypeError) as exc:
            raise ValueError(f"scene file {path}: workspace: {exc}") from None
        workspace = tuple(tuple(map(float, c)) if isinstance(c, list) else float(c) for c in workspace)
    region = data.get("goal_region")
    if region is not None:
        if not isinstance(region, str):
            raise ValueError(f"scene file {path}: goal_region must be a string such as \"overhang:+x,0.06\"")
        try:
            region = parse_region(region)
        except ValueError as exc:
            raise ValueError(f"scene file {path}: {exc}") from None
    return Layout(tuple(discs), tuple(polys), workspace, region)


def _corners(corners: np.ndarray) -> tuple[tuple[float, float], ...]:
    return tuple((float(x), float(y)) for x, y in np.asarray(corners))


def _number(entry: dict, key: str, default: float | None = None) -> float:
    if key not in entry:
        if default is None:
            raise ValueError(f"missing key {key!r}")
        return default
    v = entry[key]
    if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
        raise ValueError(f"{key} must be a finite number, got {v!r}")
    return float(v)


def _pair(entry: dict, key: str) -> tuple[float, float]:
    if key not in entry:
        raise ValueError(f"missing key {key!r}")
    v = entry[key]
    if not isinstance(v, list) or len(v) != 2:
        raise ValueError(f"{key} must be two numbers [a, b], got {v!r}")
    return _number({key: v[0]}, key), _number({key: v[1]}, key)
