"""Calibration: where a camera is (extrinsics) and how it images (intrinsics), from a board on the table.

A *board* is a ChArUco board (a chessboard with ArUco markers in its white squares) or a single
ArUco marker, printed and laid flat on the table at a known pose (:class:`Board`). Its corners'
table coordinates ``X_i`` and their pixels ``u_i`` give the camera's pose by a perspective-n-point
solve (planar IPPE, refined by Levenberg–Marquardt):

    min_{R, t}  Σ_i ‖u_i − π(K, d; Rᵀ (X_i − t))‖²

and the RMS of those residuals is the reprojection error reported (pixels). Intrinsics ``K, d``
come from several images of the board held at varied angles (``cv2.calibrateCamera``, Zhang's
method), or from the camera's maker. Board frame of a ChArUco board: OpenCV's (x along the printed
image's rows, y down its columns, origin at its top-left chessboard corner); laid face-up on the
table its y runs against the table's when ``yaw`` is 0.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from dexpush.common.files import read_toml
from dexpush.perception.camera_model import CameraModel
from dexpush.perception.detect import check_image, require_cv2
from dexpush.perception.markers import DICTIONARIES, Marker

__all__ = ["Board", "BoardNotFoundError", "calibrate_extrinsics", "calibrate_intrinsics", "read_board_file"]


class BoardNotFoundError(ValueError):
    """The board (enough of its corners) is not in the image."""


@dataclass(frozen=True)
class Board:
    """A calibration board on the table.

    Args:
        kind: ``charuco`` or ``marker``.
        squares: (columns, rows) of a ChArUco board.
        square_m: a chessboard square's side (m); for a ``marker`` board, the marker's side.
        marker_m: the side of a ChArUco board's markers (m).
        dictionary: the marker family.
        marker_id: a ``marker`` board's id.
        pose: where it lies on the table: (x, y) of its origin (a ChArUco board's top-left chessboard
            corner, a marker's centre) in m, and its yaw in degrees.
    """

    kind: str = "charuco"
    squares: tuple[int, int] = (7, 5)
    square_m: float = 0.04
    marker_m: float = 0.03
    dictionary: str = "4x4_50"
    marker_id: int = 0
    pose: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        if self.kind not in ("charuco", "marker"):
            raise ValueError(f"board kind must be 'charuco' or 'marker', got {self.kind!r}")
        if self.dictionary not in DICTIONARIES:
            raise ValueError(f"unknown marker dictionary {self.dictionary!r}; choose one of {', '.join(DICTIONARIES)}")
        sx, sy = self.squares
        if not all(isinstance(v, int) and not isinstance(v, bool) and 2 <= v <= 64 for v in (sx, sy)):
            raise ValueError(f"board squares must be two whole numbers in [2, 64], got {self.squares!r}")
        for name in ("square_m", "marker_m"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and 0.002 <= v <= 2.0):
                raise ValueError(f"board {name} must be in [0.002, 2] m, got {v!r}")
        if self.kind == "charuco" and self.marker_m >= self.square_m:
            raise ValueError(f"a ChArUco board's markers ({self.marker_m} m) must be smaller than its squares "
                             f"({self.square_m} m)")
        if self.kind == "charuco" and sx * sy // 2 > DICTIONARIES[self.dictionary][1]:
            raise ValueError(f"a {sx}×{sy} ChArUco board needs {sx * sy // 2} markers; {self.dictionary} has "
                             f"{DICTIONARIES[self.dictionary][1]}")

    def _cv_board(self) -> Any:
        cv2 = require_cv2()
        d = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, "DICT_" + self.dictionary.upper()))
        return cv2.aruco.CharucoBoard(tuple(self.squares), self.square_m, self.marker_m, d)

    def board_to_table(self, points: np.ndarray) -> np.ndarray:
        """Board-frame points (n, 3) in the table frame (the board face-up at :attr:`pose`)."""
        c, s = math.cos(math.radians(self.pose[2])), math.sin(math.radians(self.pose[2]))
        R = np.array([[c, s, 0.0], [s, -c, 0.0], [0.0, 0.0, -1.0]])
        return np.asarray(points, np.float64) @ R.T + np.array([self.pose[0], self.pose[1], 0.0])

    def image(self, pixels_per_m: float = 4000.0) -> np.ndarray:
        """The printable board (uint8 grey), with a one-square white margin."""
        cv2 = require_cv2()
        if self.kind == "marker":
            from dexpush.perception.detect import MarkerDetector

            return MarkerDetector(self.dictionary).marker_image(self.marker_id, int(self.square_m * pixels_per_m))
        sx, sy = self.squares
        px = round(self.square_m * pixels_per_m)
        img = self._cv_board().generateImage((sx * px, sy * px), marginSize=0)
        return cv2.copyMakeBorder(img, px, px, px, px, cv2.BORDER_CONSTANT, value=255)

    def find(self, gray: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Board-frame points (n, 3) and their pixels (n, 2) found in ``gray``; :class:`BoardNotFoundError`
        when fewer than 4 are."""
        cv2 = require_cv2()
        if self.kind == "marker":
            from dexpush.perception.detect import MarkerDetector

            found = MarkerDetector(self.dictionary).detect(gray)
            if self.marker_id not in found:
                raise BoardNotFoundError(f"marker {self.marker_id} ({self.dictionary}) is not in the image")
            corners = Marker(self.marker_id, self.square_m).corners()     # marker frame: x right, y up
            board = np.c_[corners[:, 0], -corners[:, 1], np.zeros(4)]     # as a board: y down, z into it
            return board, found[self.marker_id]
        params = cv2.aruco.CharucoParameters()
        detector = cv2.aruco.CharucoDetector(self._cv_board(), params)
        cc, ci, _, _ = detector.detectBoard(gray)
        if ci is None or len(ci) < 6:
            raise BoardNotFoundError(f"the {self.squares[0]}×{self.squares[1]} ChArUco board ({self.dictionary}) is "
                                     f"not "
                                f"in the image ({0 if ci is None else len(ci)} of its corners found, 6 needed)")
        cc = cv2.cornerSubPix(gray, cc.astype(np.float32), (5, 5), (-1, -1),
                              (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 50, 1e-4))
        obj, img = self._cv_board().matchImagePoints(cc, ci)
        return obj.reshape(-1, 3).astype(np.float64), img.reshape(-1, 2).astype(np.float64)


def calibrate_extrinsics(image: np.ndarray, intrinsics: CameraModel, board: Board) -> CameraModel:
    """``intrinsics`` with the pose at which it sees ``board`` lying at its pose on the table, and the
    reprojection error of that pose (see the module docstring)."""
    cv2 = require_cv2()
    gray = check_image(image, intrinsics.width, intrinsics.height, "calibration image")
    obj, px = board.find(gray)
    X = board.board_to_table(obj)
    K, d = intrinsics.K, np.asarray(intrinsics.distortion)
    ok, rvec, tvec = cv2.solvePnP(X, px, K, d, flags=cv2.SOLVEPNP_IPPE if len(X) >= 4 else cv2.SOLVEPNP_ITERATIVE)
    if not ok:
        raise BoardNotFoundError("the board's corners give no camera pose (are they collinear?)")
    rvec, tvec = cv2.solvePnPRefineLM(X, px, K, d, rvec, tvec)
    R_ct = cv2.Rodrigues(rvec)[0]               # table → camera
    position = -R_ct.T @ tvec.ravel()
    cam = CameraModel(intrinsics.width, intrinsics.height, intrinsics.fx, intrinsics.fy, intrinsics.cx, intrinsics.cy,
                      intrinsics.distortion, R_ct.T, position, intrinsics.name)
    err = float(np.sqrt(np.mean(np.sum((cam.project(X) - px) ** 2, axis=1))))
    return CameraModel(cam.width, cam.height, cam.fx, cam.fy, cam.cx, cam.cy, cam.distortion, cam.rotation,
                       cam.position, cam.name, err)


def calibrate_intrinsics(images: list[np.ndarray], board: Board, name: str = "camera") -> CameraModel:
    """Focal lengths, principal point and distortion from ``images`` of a ChArUco board seen at varied
    angles (at least 3 in which it is found); the pose is left at the default (use
    :func:`calibrate_extrinsics` next) and ``reprojection_error_px`` is the solve's RMS error."""
    cv2 = require_cv2()
    if board.kind != "charuco":
        raise ValueError("intrinsics need a ChArUco board (a single marker has too few corners)")
    if not images:
        raise ValueError("no calibration images")
    h, w = np.asarray(images[0]).shape[:2]
    objs, pxs = [], []
    for i, img in enumerate(images):
        gray = check_image(img, w, h, f"calibration image {i}")
        try:
            obj, px = board.find(gray)
        except BoardNotFoundError:
            continue
        objs.append(obj.astype(np.float32))
        pxs.append(px.astype(np.float32))
    if len(objs) < 3:
        raise BoardNotFoundError(f"the board was found in {len(objs)} of {len(images)} images; intrinsics need 3 or "
                                 f"more "
                            "views at varied angles")
    rms, K, dist, _, _ = cv2.calibrateCamera(objs, pxs, (int(w), int(h)), None, None, flags=cv2.CALIB_FIX_K3)
    d = np.zeros(5)
    d[:min(5, dist.size)] = dist.ravel()[:5]
    return CameraModel(int(w), int(h), float(K[0, 0]), float(K[1, 1]), float(K[0, 2]), float(K[1, 2]), tuple(d),
                       name=name, reprojection_error_px=float(rms))


def read_board_file(path: str | os.PathLike) -> Board:
    """The ``[board]`` table of a TOML file: kind, squares, square_m, marker_m, dictionary, marker_id,
    pose = [x, y, yaw_deg]; every key optional (:class:`Board`'s defaults)."""
    path = Path(path)
    table = read_toml(path, "board file").get("board")
    if not isinstance(table, dict):
        raise ValueError(f"board file {path}: no [board] table (see docs/perception.md#calibration)")
    allowed = ("kind", "squares", "square_m", "marker_m", "dictionary", "marker_id", "pose")
    unknown = sorted(set(table) - set(allowed))
    if unknown:
        raise ValueError(f"board file {path}: unknown key {unknown[0]!r}; allowed: {', '.join(allowed)}")
    kw = dict(table)
    for key, n in (("squares", 2), ("pose", 3)):
        if key in kw:
            if not isinstance(kw[key], list) or len(kw[key]) != n:
                raise ValueError(f"board file {path}: {key} must be a list of {n} numbers, got {kw[key]!r}")
            kw[key] = tuple(kw[key])
    if "pose" in kw and not all(isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)
                                for v in kw["pose"]):
        raise ValueError(f"board file {path}: pose must be [x, y, yaw_deg] finite numbers, got {table['pose']!r}")
    try:
        return Board(**kw)
    except (ValueError, TypeError) as exc:
        raise ValueError(f"board file {path}: {exc}") from None
