"""Where the markers are: the ``[markers]`` table of a shape file, and a default for the standard shapes.

    [markers]
    dictionary = "4x4_50"          # optional: an ArUco or AprilTag family (DICTIONARIES); default 4x4_50
    height = 0.022                 # the object's top (where its markers lie) above the table (m)

    [[markers.object]]             # one or more
    id = 7
    size = 0.05                    # the black square's side (m), without the white quiet zone
    pose = [0.0, 0.0, 0.0]         # the marker's centre x, y (m) and yaw (degrees) in the object's frame

    [markers.pusher]               # optional: a marker on the pusher's mast, centred above the tip
    id = 9
    size = 0.03
    height = 0.10                  # its height above the table (m)

A marker's own axes: x to the right of its printed image, y up it, as the image is printed;
``yaw`` turns them from the object's x axis. Each marker needs a white quiet zone around it of at
least one module (its side / 6 for a 4×4 family). See docs/perception.md#marker-placement.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from dexpush.common.files import read_toml
from dexpush.model.polygons import inside_polygon

__all__ = ["DICTIONARIES", "MAX_MARKERS", "Marker", "MarkerLayout", "default_layout", "read_marker_layout"]

#: marker families by the name a shape file uses, with their size (bits per side) and id count
DICTIONARIES = {
    "4x4_50": (4, 50), "4x4_100": (4, 100), "5x5_50": (5, 50), "5x5_100": (5, 100), "6x6_50": (6, 50),
    "6x6_250": (6, 250), "apriltag_16h5": (4, 30), "apriltag_25h9": (5, 35), "apriltag_36h11": (6, 587),
}
#: the most markers one object may carry
MAX_MARKERS = 32


@dataclass(frozen=True)
class Marker:
    """One square marker: its id, side (m), and where its centre lies (x, y, yaw rad) in its carrier's frame."""

    id: int
    size: float
    pose: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def corners(self) -> np.ndarray:
        """The four corners (4, 2) in the carrier's frame, in ArUco's order: top-left, top-right,
        bottom-right, bottom-left of the printed image."""
        h = self.size / 2
        local = np.array([[-h, h], [h, h], [h, -h], [-h, -h]])
        c, s = math.cos(self.pose[2]), math.sin(self.pose[2])
        return local @ np.array([[c, s], [-s, c]]) + np.asarray(self.pose[:2])


@dataclass(frozen=True)
class MarkerLayout:
    """The markers of one object (and, optionally, of the pusher)."""

    object_markers: tuple[Marker, ...]
    height: float                          #: the object markers' height above the table (m)
    dictionary: str = "4x4_50"
    pusher: Marker | None = None           #: a marker centred above the pusher's tip, or None: the robot says
    pusher_height: float = 0.10            #: the pusher marker's height above the table (m)

    def __post_init__(self) -> None:
        if self.dictionary not in DICTIONARIES:
            raise ValueError(f"unknown marker dictionary {self.dictionary!r}; choose one of "
                             f"{', '.join(DICTIONARIES)}")
        if not self.object_markers:
            raise ValueError("an object needs at least one marker")
        if len(self.object_markers) > MAX_MARKERS:
            raise ValueError(f"{len(self.object_markers)} markers on the object; at most {MAX_MARKERS}")
        ids = [m.id for m in self.all_markers]
        n_ids = DICTIONARIES[self.dictionary][1]
        for m in self.all_markers:
            if isinstance(m.id, bool) or not isinstance(m.id, int) or not 0 <= m.id < n_ids:
                raise ValueError(f"marker id {m.id!r} is not in dictionary {self.dictionary} (ids 0–{n_ids - 1})")
            if not (isinstance(m.size, float | int) and math.isfinite(m.size) and 0.002 <= m.size <= 1.0):
                raise ValueError(f"marker {m.id}: size must be in [0.002, 1] m, got {m.size!r}")
        if len(set(ids)) != len(ids):
            raise ValueError(f"marker id {next(i for i in ids if ids.count(i) > 1)} is used twice")
        for name in ("height", "pusher_height"):
            v = getattr(self, name)
            if not (isinstance(v, float | int) and math.isfinite(v) and 0.0 <= v <= 2.0):
                raise ValueError(f"marker {name} must be in [0, 2] m above the table, got {v!r}")

    @property
    def all_markers(self) -> tuple[Marker, ...]:
        return self.object_markers + ((self.pusher,) if self.pusher is not None else ())

    def object_marker(self, marker_id: int) -> Marker | None:
        return next((m for m in self.object_markers if m.id == marker_id), None)


def _number(value: Any, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise ValueError(f"{where} must be a finite number, got {value!r}")
    return float(value)


def _marker(table: Any, where: str, allowed: tuple[str, ...] = ("id", "size", "pose")) -> Marker:
    if not isinstance(table, dict):
        raise ValueError(f"{where} must be a table with {', '.join(allowed)}, got {table!r}")
    unknown = sorted(set(table) - set(allowed))
    if unknown:
        raise ValueError(f"{where}: unknown key {unknown[0]!r}; allowed: {', '.join(allowed)}")
    for key in ("id", "size"):
        if key not in table:
            raise ValueError(f"{where}: missing key {key!r}")
    mid = table["id"]
    if isinstance(mid, bool) or not isinstance(mid, int):
        raise ValueError(f"{where}: id must be a whole number, got {mid!r}")
    size = _number(table["size"], f"{where}: size")
    if size <= 0:
        raise ValueError(f"{where}: size must be > 0 m, got {table['size']!r}")
    pose = table.get("pose", [0.0, 0.0, 0.0])
    if not isinstance(pose, list) or len(pose) != 3:
        raise ValueError(f"{where}: pose must be [x, y, yaw_deg], got {pose!r}")
    x, y, yaw = (_number(v, f"{where}: pose") for v in pose)
    if abs(x) > 10 or abs(y) > 10:
        raise ValueError(f"{where}: pose must lie within ±10 m of the object's origin, got {pose!r}")
    return Marker(mid, size, (x, y, math.radians(yaw)))


def read_marker_layout(path: str | os.PathLike) -> MarkerLayout | None:
    """The ``[markers]`` table of the shape file at ``path`` (None when it has none), checked."""
    path = Path(path)
    table = read_toml(path, "shape file").get("markers")
    if table is None:
        return None
    where = f"shape file {path}: [markers]"
    if not isinstance(table, dict):
        raise ValueError(f"{where} must be a table (see docs/perception.md#marker-placement)")
    unknown = sorted(set(table) - {"dictionary", "height", "object", "pusher"})
    if unknown:
        raise ValueError(f"{where}: unknown key {unknown[0]!r}; allowed: dictionary, height, object, pusher")
    if "height" not in table:
        raise ValueError(f"{where}: missing key 'height' (the object's top above the table, m)")
    objects = table.get("object")
    if not isinstance(objects, list) or not objects:
        raise ValueError(f"{where}: give the object's markers as [[markers.object]] tables (id, size, pose)")
    markers = tuple(_marker(t, f"{where} object marker {i}") for i, t in enumerate(objects))
    pusher, pusher_height = None, 0.10
    if "pusher" in table:
        pusher = _marker(table["pusher"], f"{where} pusher", ("id", "size", "height"))
        pusher_height = _number(table["pusher"].get("height", 0.10), f"{where} pusher: height")
    try:
        return MarkerLayout(markers, _number(table["height"], f"{where}: height"),
                            str(table.get("dictionary", "4x4_50")), pusher, pusher_height)
    except ValueError as exc:
        raise ValueError(f"{where}: {exc}") from None


def quiet_zone_side(marker_size: float, dictionary: str = "4x4_50") -> float:
    """The side (m) of a marker with its one-module white quiet zone: ``size·(bits + 4)/(bits + 2)``."""
    bits = DICTIONARIES[dictionary][0]
    return marker_size * (bits + 4) / (bits + 2)


def default_layout(polygons: tuple[np.ndarray, ...] | list[np.ndarray], height: float, max_size: float = 0.06,
                   dictionary: str = "4x4_50", count: int = 3) -> MarkerLayout:
    """Up to ``count`` axis-aligned markers (ids 0, 1, ...) that fit, with their quiet zones, inside the
    footprint without overlapping: the first at the object's origin, each next one as far as possible
    from those placed (a wide spread pins the heading). The size is the largest (at most ``max_size``,
    rounded down to the millimetre) that fits at the origin, shrunk by steps down to half of it while
    that lets more markers fit."""
    def fits(centre: np.ndarray, size: float) -> np.ndarray:
        h = quiet_zone_side(size, dictionary) / 2
        t = np.linspace(-h, h, 7)
        edge = np.concatenate([np.stack([t, np.full(7, s * h)], 1) for s in (-1, 1)]
                              + [np.stack([np.full(7, s * h), t], 1) for s in (-1, 1)])
        pts = np.asarray(centre, np.float64).reshape(-1, 1, 2) + edge[None]
        flat = pts.reshape(-1, 2)
        inside = np.zeros(len(flat), bool)
        for poly in polygons:
            inside |= inside_polygon(flat, np.asarray(poly, np.float64))
        return inside.reshape(len(pts), -1).all(1)

    lo, hi = 0.0, max_size
    if fits(np.zeros(2), hi)[0]:
        lo = hi
    for _ in range(30):
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if fits(np.zeros(2), mid)[0] else (lo, mid)
    s0 = math.floor(lo * 1000) / 1000
    if s0 < 0.01:
        raise ValueError("no marker of at least 10 mm fits around the object's origin; give [markers] in the "
                         "shape file (docs/perception.md#marker-placement)")
    allpts = np.concatenate([np.asarray(p, np.float64) for p in polygons])
    lo_xy, hi_xy = allpts.min(0), allpts.max(0)
    gx, gy = (np.arange(lo_xy[k], hi_xy[k] + 1e-9, 0.0025) for k in (0, 1))
    grid = np.stack(np.meshgrid(gx, gy), -1).reshape(-1, 2)
    best: list[np.ndarray] = [np.zeros(2)]
    best_size = s0
    for size in (s0 * f for f in (1.0, 0.85, 0.72, 0.61, 0.5)):
        size = max(math.floor(size * 1000) / 1000, 0.01)
        side = quiet_zone_side(size, dictionary)
        cand = grid[fits(grid, size)]
        chosen = [np.zeros(2)]
        while len(chosen) < count:
            c = np.stack(chosen)
            free = np.all((np.abs(cand[:, None, 0] - c[None, :, 0]) >= side)
                          | (np.abs(cand[:, None, 1] - c[None, :, 1]) >= side), axis=1)
            if not free.any():
                break
            d = np.min(np.linalg.norm(cand[free][:, None] - c[None], axis=-1), axis=1)
            chosen.append(cand[free][int(np.argmax(d))])
        if len(chosen) > len(best):
            best, best_size = chosen, size
        if len(best) == count:
            break
    markers = tuple(Marker(i, best_size, (round(float(c[0]), 4), round(float(c[1]), 4), 0.0))
                    for i, c in enumerate(best))
    return MarkerLayout(markers, height, dictionary)
