"""Realistic sensing on any plant: pose noise, a camera rate, latency and dropped frames (docs/conventions.md#plants).

:class:`Camera` wraps any :class:`dexpush.common.interfaces.Plant` (the model plant, the MuJoCo
plant, your own). The control loop still calls ``step(velocity, dt)``
every control period, but gets back a :class:`Frame` only when a camera frame *arrives*
in that period (a :class:`dexpush.common.interfaces.Frame`), otherwise ``None``:

* frames are captured every 1/``rate_hz`` seconds (``None``: at the end of every control
  period), by splitting the plant's step at the capture instants;
* each capture is lost with probability ``drop_prob``; a subclass's perception may also
  withhold one it cannot trust (:meth:`Camera._measure`; counted in ``withheld``);
* a frame arrives ``latency_s`` after its capture; ``Frame.time`` is the capture time, so
  the controller can predict forward over the delay;
* the object pose gets Gaussian noise (``pos_std_m`` on x and y, ``heading_std_rad`` on θ),
  the pusher position ``pusher_std_m`` (a robot knows its own tip well: default 0).

If several frames arrive within one control period only the newest is returned: a
controller acts on the latest information. Everything is seeded: equal seeds give equal
noise and drops.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np

from dexpush.common.checks import check_nonnegative, check_positive, check_whole, checked_vector
from dexpush.common.interfaces import CONTROL_PERIOD_S, Frame, Observation, Plant, check_plant

__all__ = ["MAX_CAMERA_HZ", "Camera", "SensorSettings"]

#: the fastest camera rate (Hz) accepted: each frame is a capture instant the plant's step is split at
MAX_CAMERA_HZ = 1000.0

@dataclass(frozen=True)
class SensorSettings:
    """How the world is observed. The defaults are a perfect sensor at the control rate."""

    pos_std_m: float = 0.0            #: object position noise (m), e.g. 1e-3
    heading_std_rad: float = 0.0      #: object heading noise (rad), e.g. 0.5° = 0.0087
    pusher_std_m: float = 0.0         #: pusher position noise (m)
    rate_hz: float | None = None      #: camera rate; None: one frame per control period
    latency_s: float = 0.0            #: capture-to-arrival delay (s), e.g. 0.06
    drop_prob: float = 0.0            #: probability that a frame is lost
    seed: int = 0

    def __post_init__(self) -> None:
        for name in ("pos_std_m", "heading_std_rad", "pusher_std_m", "latency_s", "drop_prob"):
            check_nonnegative(name, getattr(self, name))
        if self.rate_hz is not None:
            check_positive("rate_hz", self.rate_hz, "Hz, or None for one frame per control period")
            if self.rate_hz > MAX_CAMERA_HZ:
                raise ValueError(f"rate_hz must be at most {MAX_CAMERA_HZ:g} Hz, got {self.rate_hz!r}")
        if not 0.0 <= self.drop_prob < 1.0:
            raise ValueError(f"drop_prob must be in [0, 1), got {self.drop_prob!r}")
        check_whole("seed", self.seed, 0)

    @staticmethod
    def realistic(seed: int = 0) -> SensorSettings:
        """A camera as in docs/conventions.md#plants: 15 Hz, 1 mm and 0.5° noise, 60 ms latency, 5 % drops."""
        return SensorSettings(1e-3, float(np.radians(0.5)), 0.0, 15.0, 0.06, 0.05, seed)

    @staticmethod
    def randomized(seed: int) -> SensorSettings:
        """Camera ``seed`` of the randomised worlds (``--randomize``): object noise 0.5–2 mm and
        0.25–1°, pusher noise 0–0.5 mm, 10, 15 or 30 Hz, latency 30–100 ms, 0–10 % drops, each
        uniform, from ``numpy.random.default_rng((seed, 11))``."""
        rng = np.random.default_rng((int(seed), 11))
        return SensorSettings(float(rng.uniform(0.5e-3, 2e-3)), float(np.radians(rng.uniform(0.25, 1.0))),
                              float(rng.uniform(0.0, 0.5e-3)), float(rng.choice([10.0, 15.0, 30.0])),
                              float(rng.uniform(0.03, 0.10)), float(rng.uniform(0.0, 0.10)), int(seed))

    def camera(self, plant: Plant, obstacles: object = ()) -> Camera:
        """``plant`` seen through this sensor (``obstacles`` are for sensors that draw the scene)."""
        return Camera(plant, self)

    def describe(self) -> str:
        """A one-line label for records and titles."""
        if self.perfect:
            return "exact"
        rate = f"{self.rate_hz:g} Hz" if self.rate_hz else "every step"
        return (f"{rate}, noise {self.pos_std_m * 1e3:g} mm / {np.degrees(self.heading_std_rad):.2g}°, "
                f"latency {self.latency_s * 1e3:g} ms, drops {self.drop_prob:.0%}")

    @property
    def perfect(self) -> bool:
        return (self.pos_std_m == self.heading_std_rad == self.pusher_std_m == self.latency_s == self.drop_prob == 0
                and self.rate_hz is None)


class Camera:
    """A plant seen through a sensor (see the module docstring).

    Args:
        plant: any :class:`dexpush.common.interfaces.Plant` (``reset``, ``step``, ``observe``, ``state``).
        settings: :class:`SensorSettings`.
    """

    def __init__(self, plant: Plant, settings: SensorSettings | None = None) -> None:
        self.plant = check_plant(plant)
        if settings is not None and not isinstance(settings, SensorSettings):
            raise ValueError(f"settings must be a SensorSettings, got {settings!r}")
        self.settings = settings or SensorSettings()
        self._rng = np.random.default_rng(self.settings.seed)
        self._pending: deque[tuple[float, Frame]] = deque()
        self._next_capture = 0.0
        self.time = 0.0
        self.captured = self.dropped = self.delivered = self.withheld = 0

    def _observe(self) -> Observation:
        """The plant's observation, checked: a finite (3,) pose and a finite (2,) pusher position."""
        obs = self.plant.observe()
        name = type(self.plant).__name__
        if not all(hasattr(obs, k) for k in ("object_pose", "pusher_xy")):
            raise ValueError(f"{name}.observe() must return an Observation (object_pose, pusher_xy, time), got "
                             f"{type(obs).__name__}")
        return Observation(checked_vector(f"{name}.observe().object_pose", obs.object_pose, 3),
                           checked_vector(f"{name}.observe().pusher_xy", obs.pusher_xy, 2), getattr(obs, "time", 0.0))

    def _measure(self) -> Frame | None:
        """What the sensor makes of the plant now (time :attr:`time`): the noisy pose, or None when it
        cannot tell (a subclass's perception may withhold a frame)."""
        s = self.settings
        obs = self._observe()
        noise = self._rng.normal(size=5) * [s.pos_std_m, s.pos_std_m, s.heading_std_rad, s.pusher_std_m,
                                            s.pusher_std_m]
        return Frame(obs.object_pose + noise[:3], obs.pusher_xy + noise[3:], self.time)

    def _capture(self) -> None:
        self.captured += 1
        if self._rng.random() < self.settings.drop_prob:
            self.dropped += 1
            return
        frame = self._measure()
        if frame is None:
            self.withheld += 1
            return
        self._pending.append((self.time + self.settings.latency_s, frame))

    def _arrived(self, item: Frame) -> Frame | None:
        """The frame a pending ``item`` holds when it arrives (here the frame itself; a subclass that measures
        while the loop goes on holds a future), or None if it holds none."""
        return item

    def reset(self, object_pose: object, pusher_xy: object) -> Frame:
        """Reset the plant; the first frame (time 0) is returned at once, so a run can start."""
        self.plant.reset(object_pose, pusher_xy)
        self._rng = np.random.default_rng(self.settings.seed)
        self._pending.clear()
        self.time = 0.0
        self.captured = self.dropped = self.delivered = self.withheld = 0
        s = self.settings
        self._next_capture = 1.0 / s.rate_hz if s.rate_hz else np.inf
        first = self._measure()
        if first is None:
            raise ValueError(f"{type(self).__name__} sees nothing it can trust at the start pose; "
                             "check the camera set-up and the markers")
        return first

    def step(self, velocity: object, dt: float = CONTROL_PERIOD_S) -> Frame | None:
        """Advance the plant by ``dt`` under ``velocity``; the newest frame that arrived, or None."""
        v = checked_vector("velocity", velocity, 2)
        dt = check_positive("dt", dt, "s")
        end = self.time + dt
        while self._next_capture <= end + 1e-9:                # captures inside this period
            if self._next_capture > self.time + 1e-9:
                self.plant.step(v, self._next_capture - self.time)
                self.time = self._next_capture
            self._capture()
            self._next_capture += 1.0 / self.settings.rate_hz
        if end > self.time + 1e-9:
            self.plant.step(v, end - self.time)
        self.time = end
        if self.settings.rate_hz is None:
            self._capture()
        newest = None
        while self._pending and self._pending[0][0] <= self.time + 1e-9:
            frame = self._arrived(self._pending.popleft()[1])
            newest = newest if frame is None else frame
        if newest is not None:
            self.delivered += 1
        return newest

    def counts(self) -> dict[str, int]:
        """Frames since the reset: ``captured``, ``dropped`` (lost in transport), ``withheld`` (the
        perception could not trust them) and ``delivered`` (handed to the controller)."""
        return {"captured": self.captured, "dropped": self.dropped, "withheld": self.withheld,
                "delivered": self.delivered}

    @property
    def state(self) -> np.ndarray:
        """The plant's true state (for evaluation only; a controller must not read it), checked: a finite
        [x_b, y_b, θ, x_c, y_c]."""
        return checked_vector(f"{type(self.plant).__name__}.state", self.plant.state, 5)
