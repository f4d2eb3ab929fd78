"""Camera files: one ``[[camera]]`` table per camera, as ``dexpush calibrate`` writes them and runs read them.

    [[camera]]
    name = "top"
    width = 640
    height = 480
    fx = 615.0
    fy = 615.0
    cx = 319.5
    cy = 239.5
    distortion = [0.0, 0.0, 0.0, 0.0, 0.0]            # k1, k2, p1, p2, k3 (OpenCV)
    position = [0.3, 0.15, 1.3]                       # optical centre in the table frame (m)
    rotation = [[1, 0, 0], [0, -1, 0], [0, 0, -1]]    # columns: the camera's x, y, z axes (OpenCV frame)
    reprojection_error_px = 0.21                      # optional: the calibration's RMS error

See docs/perception.md#camera-files. A missing key, a wrong type or an impossible value is a
``ValueError`` that names the file, the camera and the key.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any

import numpy as np

from dexpush.common.files import atomic_path, read_toml
from dexpush.perception.camera_model import CameraModel

__all__ = ["MAX_CAMERAS", "read_camera_file", "write_camera_file"]

#: the most cameras a camera file may hold
MAX_CAMERAS = 16

_REQUIRED = ("width", "height", "fx", "fy", "cx", "cy", "position", "rotation")
_OPTIONAL = ("name", "distortion", "reprojection_error_px")


def _numbers(value: Any, shape: tuple[int, ...], where: str) -> np.ndarray:
    def ok(v: Any) -> bool:
        return not isinstance(v, bool) and isinstance(v, int | float) and math.isfinite(v)

    try:
        arr = np.asarray(value, dtype=object)
    except ValueError:
        arr = None
    if arr is None or arr.shape != shape or not all(ok(v) for v in arr.ravel()):
        raise ValueError(f"{where} must be {'×'.join(map(str, shape))} finite numbers, got {value!r}")
    return arr.astype(np.float64)


def read_camera_file(path: str | os.PathLike) -> list[CameraModel]:
    """The cameras of the file at ``path``, checked (see the module docstring for the format)."""
    path = Path(path)
    doc = read_toml(path, "camera file")
    tables = doc.get("camera")
    if not isinstance(tables, list) or not tables or not all(isinstance(t, dict) for t in tables):
        raise ValueError(f"camera file {path}: no [[camera]] table (see docs/perception.md#camera-files)")
    if len(tables) > MAX_CAMERAS:
        raise ValueError(f"camera file {path}: {len(tables)} cameras, at most {MAX_CAMERAS}")
    cameras = []
    for i, t in enumerate(tables):
        name = t.get("name", f"camera{i}")
        where = f"camera file {path}, camera {name!r}"
        if not isinstance(name, str) or not name:
            raise ValueError(f"camera file {path}: camera {i}: name must be a non-empty string, got {name!r}")
        unknown = sorted(set(t) - set(_REQUIRED) - set(_OPTIONAL))
        if unknown:
            raise ValueError(f"{where}: unknown key {unknown[0]!r}; allowed: {', '.join(_REQUIRED + _OPTIONAL)}")
        missing = [k for k in _REQUIRED if k not in t]
        if missing:
            raise ValueError(f"{where}: missing key {missing[0]!r}")
        for key in ("width", "height"):
            if isinstance(t[key], bool) or not isinstance(t[key], int):
                raise ValueError(f"{where}: {key} must be a whole number of pixels, got {t[key]!r}")
        intr = {k: float(_numbers(t[k], (), f"{where}: {k}")) for k in ("fx", "fy", "cx", "cy")}
        err = t.get("reprojection_error_px")
        if err is not None:
            err = float(_numbers(err, (), f"{where}: reprojection_error_px"))
        try:
            cameras.append(CameraModel(
                t["width"], t["height"], **intr,
                distortion=tuple(_numbers(t.get("distortion", [0.0] * 5), (5,), f"{where}: distortion")),
                rotation=_numbers(t["rotation"], (3, 3), f"{where}: rotation"),
                position=_numbers(t["position"], (3,), f"{where}: position"), name=name,
                reprojection_error_px=err))
        except ValueError as exc:
            raise ValueError(f"camera file {path}: {exc}") from None
    names = [c.name for c in cameras]
    if len(set(names)) != len(names):
        raise ValueError(f"camera file {path}: two cameras are named {next(n for n in names if names.count(n) > 1)!r}")
    return cameras


def _fmt(v: object) -> str:
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return repr(float(v))
    if isinstance(v, np.ndarray):
        v = v.tolist()
    return "[" + ", ".join(_fmt(float(x) if isinstance(x, int | float) else x) for x in v) + "]"


def write_camera_file(path: str | os.PathLike, cameras: list[CameraModel], comment: str = "") -> None:
    """Write ``cameras`` to ``path`` (atomically), in the format :func:`read_camera_file` reads."""
    lines = [f"# {line}" for line in comment.splitlines()] + ([""] if comment else [])
    for c in cameras:
        lines += ["[[camera]]", f"name = {_fmt(c.name)}", f"width = {int(c.width)}", f"height = {int(c.height)}"]
        lines += [f"{k} = {_fmt(float(getattr(c, k)))}" for k in ("fx", "fy", "cx", "cy")]
        lines += [f"distortion = {_fmt(list(c.distortion))}", f"position = {_fmt(c.position)}",
                  f"rotation = {_fmt([_fmt(row) for row in c.rotation]).replace(chr(34), '')}"]
        if c.reprojection_error_px is not None:
            lines.append(f"reprojection_error_px = {_fmt(float(c.reprojection_error_px))}")
        lines.append("")
    with atomic_path(path) as tmp:
        tmp.write_text("\n".join(lines))
