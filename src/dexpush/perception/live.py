"""Real cameras: image sources and the loop from their images to frames for ``PushingController.act``.

An *image source* is anything with ``read() -> (image or None, capture time)``, the time on
``time.monotonic()``'s clock. :class:`VideoCaptureSource` wraps OpenCV's ``cv2.VideoCapture``
(a USB or built-in camera, a video file, a GStreamer or RTSP pipeline on the loopback); a
RealSense or another SDK needs a ten-line source of its own (docs/perception.md#a-real-camera).
:class:`CameraPoses` reads one image from each source, passes them to a
:class:`dexpush.perception.tracker.MarkerTracker` and returns a frame whose time is the capture time
on the controller's clock (seconds since :meth:`CameraPoses.start`, which is called when the
controller is reset). It counts what went wrong and says when the loop has gone blind
(:attr:`CameraPoses.stale`): no image for ``stale_s`` (the camera or its cable died), or images but
no trusted pose for ``blind_s`` (markers hidden for longer than the controller's prediction can be
trusted); a robot loop must then stop the arm. Shorter gaps (the arm passing over a marker) are the
controller's to bridge: it predicts through frames that are None.

Not testable here: the capture call itself (no camera on this machine). Everything after it is
tested with recorded and rendered images and with sources that fail on purpose.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from typing import Any, Protocol

import numpy as np

from dexpush.common.interfaces import Frame
from dexpush.perception.tracker import MarkerTracker

__all__ = ["CameraPoses", "ImageSource", "VideoCaptureSource"]


class ImageSource(Protocol):
    """One camera: ``read()`` returns the next image (or None when none came) and its capture time (s,
    on ``time.monotonic()``'s clock)."""

    def read(self) -> tuple[np.ndarray | None, float]: ...


class VideoCaptureSource:
    """A camera through ``cv2.VideoCapture``.

    Args:
        device: a camera index (0, 1, ...) or a file or pipeline name, as ``cv2.VideoCapture`` takes.
        latency_s: the time from exposure to ``read()`` returning (the camera's and driver's delay); the
            capture time reported is the return time minus this.
        capture: an object with ``read() -> (ok, image)`` to use instead of opening ``device`` (a
            recorded sequence, a test double).
        clock: the clock (default ``time.monotonic``).
    """

    def __init__(self, device: int | str = 0, latency_s: float = 0.0, capture: Any = None,
                 clock: Callable[[], float] = time.monotonic) -> None:
        if not (isinstance(latency_s, int | float) and math.isfinite(latency_s) and 0 <= latency_s <= 1.0):
            raise ValueError(f"latency_s must be in [0, 1] s, got {latency_s!r}")
        if capture is None:
            from dexpush.perception.detect import require_cv2

            capture = require_cv2().VideoCapture(device)
            if not capture.isOpened():
                raise OSError(f"cannot open camera {device!r} (is it connected, and not in use by another program?)")
        self.capture = capture
        self.latency_s = float(latency_s)
        self.clock = clock
        self.failures = 0

    def read(self) -> tuple[np.ndarray | None, float]:
        try:
            ok, image = self.capture.read()
        except Exception:         # a driver that raises instead of returning False: the same lost frame
            ok, image = False, None
        t = self.clock() - self.latency_s
        if not ok or image is None:
            self.failures += 1
            return None, t
        return image, t

    def close(self) -> None:
        release = getattr(self.capture, "release", None)
        if release is not None:
            release()


class CameraPoses:
    """Frames from real cameras (see the module docstring).

    Args:
        sources: one image source per camera of ``tracker``, in its order.
        tracker: the :class:`MarkerTracker` of the calibrated cameras and the object's markers.
        stale_s: no image from any camera for this long (s) makes :attr:`stale` true.
        blind_s: images, but no frame passed on for this long (s), makes :attr:`stale` true.
        max_skew_s: images whose capture times differ by more are not fused (the object moved between them).
        clock: the clock of the sources (default ``time.monotonic``).
    """

    def __init__(self, sources: Sequence[ImageSource], tracker: MarkerTracker, stale_s: float = 0.5,
                 blind_s: float = 3.0, max_skew_s: float = 0.03, clock: Callable[[], float] = time.monotonic) -> None:
        if len(sources) != len(tracker.cameras):
            raise ValueError(f"{len(sources)} image sources for {len(tracker.cameras)} calibrated cameras")
        for name, v in (("stale_s", stale_s), ("blind_s", blind_s), ("max_skew_s", max_skew_s)):
            if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be a number of seconds > 0, got {v!r}")
        self.sources = tuple(sources)
        self.tracker = tracker
        self.stale_s = float(stale_s)
        self.blind_s = float(blind_s)
        self.max_skew_s = float(max_skew_s)
        self.clock = clock
        self.skewed = 0
        self.start()

    def start(self) -> None:
        """Start the controller's clock now (call it when the controller is reset)."""
        self.t0 = self.clock()
        self._last_passed = self._last_image = self.t0
        self.tracker.reset()
        self.skewed = 0

    @property
    def stale(self) -> bool:
        """True when no image came for ``stale_s`` or no trusted pose for ``blind_s``: stop the robot."""
        now = self.clock()
        return now - self._last_image > self.stale_s or now - self._last_passed > self.blind_s

    def frame(self, pusher_xy: object | None = None) -> Frame | None:
        """Read each camera once; the frame (time on the controller's clock), or None (counted)."""
        reads = [src.read() for src in self.sources]
        images = [img for img, _ in reads]
        times = {i: t for i, (img, t) in enumerate(reads) if img is not None}
        if times:
            self._last_image = self.clock()
        if times and max(times.values()) - min(times.values()) > self.max_skew_s:
            newest = max(times, key=times.get)            # images too far apart in time: the newest alone
            images = [img if i == newest else None for i, img in enumerate(images)]
            times = {newest: times[newest]}
            self.skewed += 1
        capture = (float(np.mean(list(times.values()))) if times else self.clock()) - self.t0
        frame = self.tracker.locate(images, capture, pusher_xy)
        if frame is not None:
            self._last_passed = self.clock()
        return frame
