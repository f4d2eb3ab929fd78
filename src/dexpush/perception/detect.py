"""Marker detection in one image with OpenCV's ArUco module (the ``dexpush[camera]`` extra).

Corners are refined to sub-pixel accuracy (``CORNER_REFINE_SUBPIX``): without it the corners sit
up to half a pixel off, which biases a pose by millimetres. AprilTag families are read with
AprilTag's own refinement. See docs/perception.md#detection.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from dexpush.perception.markers import DICTIONARIES

__all__ = ["MarkerDetector", "check_image", "require_cv2"]


def require_cv2() -> Any:
    """The ``cv2`` module, or an ``ImportError`` that says how to install it."""
    try:
        import cv2
    except ImportError:
        raise ImportError("images need OpenCV: pip install 'dexpush[camera]' (opencv-python-headless)") from None
    if not hasattr(cv2, "aruco"):
        raise ImportError("this OpenCV has no aruco module: pip install 'dexpush[camera]' (opencv-python-headless "
                          ">= 4.7)")
    return cv2


def check_image(image: object, width: int, height: int, where: str = "image") -> np.ndarray:
    """``image`` as a (height, width) uint8 grey image: a grey (H, W) or colour (H, W, 3) uint8 array is
    accepted, anything else is a one-line ``ValueError``."""
    if not isinstance(image, np.ndarray):
        raise ValueError(f"{where} must be a numpy array of pixels, got {type(image).__name__}")
    if image.dtype != np.uint8:
        raise ValueError(f"{where} must be 8-bit (uint8) pixels, got {image.dtype}")
    if image.ndim == 3 and image.shape[2] == 3:
        image = image.mean(axis=2, dtype=np.float32).astype(np.uint8)
    elif image.ndim != 2:
        raise ValueError(f"{where} must be (H, W) grey or (H, W, 3) colour, got shape {image.shape}")
    if image.shape != (height, width):
        raise ValueError(f"{where} is {image.shape[1]}×{image.shape[0]} pixels; its camera is {width}×{height}")
    return np.ascontiguousarray(image)


class MarkerDetector:
    """Finds the markers of one family in grey images: ``detect(gray) -> {id: corners (4, 2)}``."""

    def __init__(self, dictionary: str = "4x4_50") -> None:
        if dictionary not in DICTIONARIES:
            raise ValueError(f"unknown marker dictionary {dictionary!r}; choose one of {', '.join(DICTIONARIES)}")
        cv2 = require_cv2()
        self.dictionary = dictionary
        self._dict = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, "DICT_" + dictionary.upper()))
        params = cv2.aruco.DetectorParameters()
        params.cornerRefinementMethod = (cv2.aruco.CORNER_REFINE_APRILTAG if dictionary.startswith("apriltag")
                                         else cv2.aruco.CORNER_REFINE_SUBPIX)
        params.cornerRefinementWinSize = 4
        self._detector = cv2.aruco.ArucoDetector(self._dict, params)

    def detect(self, gray: np.ndarray) -> dict[int, np.ndarray]:
        """The markers found in ``gray`` (a checked uint8 image): id → its 4 corners (pixels), in
        ArUco's order. A marker found twice is dropped (no way to tell which is right)."""
        corners, ids, _ = self._detector.detectMarkers(gray)
        out: dict[int, np.ndarray] = {}
        twice: set[int] = set()
        if ids is not None:
            for c, i in zip(corners, ids.ravel()):
                i = int(i)
                if i in out:
                    twice.add(i)
                out[i] = np.asarray(c, np.float64).reshape(4, 2)
        for i in twice:
            del out[i]
        return out

    def marker_image(self, marker_id: int, pixels: int, quiet_zone: bool = True) -> np.ndarray:
        """The printable image (uint8, grey) of marker ``marker_id``: ``pixels`` across the black square,
        with a one-module white quiet zone when ``quiet_zone``."""
        cv2 = require_cv2()
        img = cv2.aruco.generateImageMarker(self._dict, int(marker_id), int(pixels), borderBits=1)
        if quiet_zone:
            m = round(pixels / (DICTIONARIES[self.dictionary][0] + 2))
            img = cv2.copyMakeBorder(img, m, m, m, m, cv2.BORDER_CONSTANT, value=255)
        return img
