"""From images to a frame: markers → table-plane corners → object pose per camera → fused pose.

:class:`MarkerTracker` turns one image per camera (taken at one capture time) into a
:class:`dexpush.common.interfaces.Frame` for :meth:`dexpush.control.controller.PushingController.act`,
or into ``None`` when it cannot say where the object is. It never passes on a pose it has reason
to doubt; each frame it withholds is counted by its reason (:attr:`MarkerTracker.counts`):

* ``not_seen``: no camera saw one of the object's markers (occluded, blurred, out of view);
* ``bad_fit``: the corners do not fit the markers' geometry within ``max_residual_m`` (a wrong
  marker size or calibration, a misread marker);
* ``uncertain``: the pose's own standard deviation exceeds ``max_std_m`` (when set): e.g. one small
  marker far from the reference point, whose heading error the lever arm turns into millimetres;
* ``disagree``: two cameras' poses disagree beyond their uncertainty (:func:`~dexpush.perception.planar_pose.fuse`);
* ``jump``: the pose moved faster than ``max_speed_mps`` / ``max_turn_deg_s`` since the last frame
  passed on (a flipped or swapped marker);
* ``pusher_not_seen``: the pusher is tracked by its marker and no camera saw it;
* ``no_image``: a camera delivered nothing.

The uncertainty of one camera's pose: corner noise ``σ_c = pixel_std · m_px`` (``m_px``: metres per
pixel there, :meth:`~dexpush.perception.camera_model.CameraModel.metres_per_pixel`, raised to the fit's
residual when that is larger), heading std ``σ_θ = σ_c / √(Σ|p̃_i|²)`` and, for the reference point at
distance ``ℓ`` from the corners' centroid, position std ``√(σ_c²/n + (ℓ σ_θ)²)`` for n corners.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from dexpush.common.interfaces import Frame
from dexpush.perception.camera_model import CameraModel
from dexpush.perception.markers import MarkerLayout
from dexpush.perception.planar_pose import PoseEstimate, fit_planar_pose, fuse

__all__ = ["REASONS", "MarkerTracker", "TrackerSettings"]

#: why a frame was withheld (see the module docstring)
REASONS = ("not_seen", "bad_fit", "uncertain", "disagree", "jump", "pusher_not_seen", "no_image")


@dataclass(frozen=True)
class TrackerSettings:
    """How much the tracker trusts what it sees."""

    pixel_std: float = 0.3             #: corner noise after sub-pixel refinement (pixels), for the weights
    max_residual_m: float = 2.5e-3     #: a fit whose corners miss by more (RMS, m) is not the marker
    gate: float = 4.0                  #: cameras further apart than this many standard deviations disagree
    max_speed_mps: float = 1.0         #: the fastest an object may move between frames passed on (m/s)
    max_turn_deg_s: float = 360.0      #: ... and turn (deg/s)
    jump_slack_m: float = 0.01         #: plus this much (m) whatever the time between frames
    reacquire_s: float = 0.5           #: a pose that keeps "jumping" for this long (s) is taken as the new truth
    max_std_m: float | None = None     #: withhold a pose whose position std (m) is larger; None: no such test

    def __post_init__(self) -> None:
        for name in ("pixel_std", "max_residual_m", "gate", "max_speed_mps", "max_turn_deg_s", "jump_slack_m",
                     "reacquire_s", "max_std_m"):
            v = getattr(self, name)
            if v is None and name == "max_std_m":
                continue
            if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v) or v <= 0:
                raise ValueError(f"TrackerSettings.{name} must be a finite number > 0, got {v!r}")


class MarkerTracker:
    """Poses of one object (and optionally its pusher) from the images of one or more cameras.

    Args:
        cameras: the calibrated cameras, in the order their images are given.
        layout: the markers on the object (and pusher).
        settings: :class:`TrackerSettings`.
    """

    def __init__(self, cameras: Sequence[CameraModel], layout: MarkerLayout,
                 settings: TrackerSettings | None = None) -> None:
        from dexpush.perception.detect import MarkerDetector

        if not cameras or not all(isinstance(c, CameraModel) for c in cameras):
            raise ValueError("MarkerTracker needs one or more CameraModel cameras")
        self.cameras = tuple(cameras)
        self.layout = layout
        self.settings = settings or TrackerSettings()
        self.detector = MarkerDetector(layout.dictionary)
        self._body = {m.id: m.corners() for m in layout.object_markers}
        self.reset()

    def reset(self) -> None:
        """Forget the last pose (the jump check starts afresh) and zero the counts."""
        self._last: tuple[float, np.ndarray] | None = None
        self._jumping_since: float | None = None
        self.counts = dict.fromkeys(("frames", "passed", *REASONS), 0)
        self.last_estimates: list[PoseEstimate] = []

    def _object_estimate(self, cam: CameraModel, found: dict[int, np.ndarray]) -> PoseEstimate | str | None:
        ids = [i for i in found if i in self._body]
        if not ids:
            return None
        body = np.concatenate([self._body[i] for i in ids])
        table = cam.on_plane(np.concatenate([found[i] for i in ids]), self.layout.height)
        if not np.all(np.isfinite(table)):
            return "bad_fit"
        pose, residual = fit_planar_pose(body, table)
        if residual > self.settings.max_residual_m:
            return "bad_fit"
        sc = max(self.settings.pixel_std * float(cam.metres_per_pixel(pose[:2], self.layout.height)), residual)
        centroid = body.mean(0)
        heading_std = sc / math.sqrt(float(np.sum((body - centroid) ** 2)))
        lever = float(np.hypot(*centroid))           # the reference point (the body origin) from the centroid
        return PoseEstimate(pose, math.hypot(sc / math.sqrt(len(body)), lever * heading_std), heading_std, residual,
                            cam.name)

    def _pusher(self, found: list[dict[int, np.ndarray]]) -> np.ndarray | None:
        m = self.layout.pusher
        pts, w = [], []
        for cam, f in zip(self.cameras, found):
            if m is not None and m.id in f:
                xy = cam.on_plane(f[m.id], self.layout.pusher_height).mean(0)
                if np.all(np.isfinite(xy)):
                    pts.append(xy)
                    w.append(1.0 / float(cam.metres_per_pixel(xy, self.layout.pusher_height)) ** 2)
        if not pts:
            return None
        return np.average(np.stack(pts), axis=0, weights=w)

    def locate(self, images: Sequence[np.ndarray | None], time: float,
               pusher_xy: object | None = None) -> Frame | None:
        """The frame seen in ``images`` (one per camera, or None where a camera delivered nothing),
        captured at ``time`` (s); ``pusher_xy``: the pusher's position from the robot, or None to read
        its marker. None when the pose cannot be trusted (counted in :attr:`counts`)."""
        from dexpush.perception.detect import check_image

        if len(images) != len(self.cameras):
            raise ValueError(f"got {len(images)} images for {len(self.cameras)} cameras")
        self.counts["frames"] += 1
        found, estimates, failure = [], [], None
        for cam, img in zip(self.cameras, images):
            if img is None:
                found.append({})
                continue
            f = self.detector.detect(check_image(img, cam.width, cam.height, f"camera {cam.name!r}'s image"))
            found.append(f)
            est = self._object_estimate(cam, f)
            if isinstance(est, PoseEstimate):
                estimates.append(est)
            elif est is not None:
                failure = est
        self.last_estimates = estimates
        if all(img is None for img in images):
            return self._withhold("no_image")
        if not estimates:
            return self._withhold(failure or "not_seen")
        fused, _ = fuse(estimates, self.settings.gate)
        if fused is None:
            return self._withhold("disagree")
        if self.settings.max_std_m is not None and fused.pos_std_m > self.settings.max_std_m:
            return self._withhold("uncertain")
        if pusher_xy is None:
            if self.layout.pusher is None:
                raise ValueError("the layout has no pusher marker: pass pusher_xy (from the robot) to locate()")
            pusher = self._pusher(found)
            if pusher is None:
                return self._withhold("pusher_not_seen")
        else:
            pusher = np.asarray(pusher_xy, dtype=np.float64)
        if self._last is not None:
            dt = max(time - self._last[0], 0.0)
            s = self.settings
            d = np.linalg.norm(fused.pose[:2] - self._last[1][:2])
            turn = abs(math.remainder(float(fused.pose[2] - self._last[1][2]), 2 * math.pi))
            if d > s.max_speed_mps * dt + s.jump_slack_m or turn > math.radians(s.max_turn_deg_s) * dt + math.radians(
                    10.0):
                if self._jumping_since is None:
                    self._jumping_since = float(time)
                if time - self._jumping_since < s.reacquire_s:
                    return self._withhold("jump")
        self._jumping_since = None
        self._last = (float(time), fused.pose)
        self.counts["passed"] += 1
        return Frame(fused.pose, pusher, float(time))

    def _withhold(self, reason: str) -> None:
        self.counts[reason] += 1
        return None
