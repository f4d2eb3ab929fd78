"""A Gymnasium environment, ``dexpush/Push-v0`` (registered when this module is imported).

    import gymnasium as gym
    import dexpush.env  # noqa: F401  (registers the id)
    env = gym.make("dexpush/Push-v0", task="I", shape="rect", plant="model")
    obs, info = env.reset(seed=0)
    obs, reward, terminated, truncated, info = env.step(env.action_space.sample())

* **observation** (float32, 8): object pose [x_b, y_b, θ], pusher position [x_c, y_c] and
  goal pose [x_g, y_g, θ_g]; headings wrapped to [−π, π], positions within ±10 m. With a
  realistic ``sensor`` it is the newest frame that arrived (the previous one again when
  none did).
* **action** (float32, 2): the pusher velocity [v_x, v_y] in m/s, within ±v_max/√2 per axis
  (eq. 10); actions outside are clipped. Each step holds it for one control period
  (0.04 s, 25 Hz, by default).
* **reward**: −d, the decoupled distance d = √(‖p_b − p_g‖² + c·(1 − cos(θ − θ_g))) of the
  paper's eq. (9) with c = 0.1 m², on the *true* pose: 0 at the goal, about −0.67 at Task I's
  start. Dense, negative, in metres.
* **terminated**: the task's success test (8 mm and 3°) on the true pose;
  ``info["is_success"]`` says the same. **truncated**: after ``max_steps`` (N_max = 1500).
* ``render_mode="rgb_array"``: the scene as an (H, W, 3) uint8 image.
* ``plant``: ``model`` (C-GVMM with λ_true), ``physics`` (MuJoCo), or any object that
  satisfies :class:`dexpush.interfaces.Plant` (your own simulator or robot driver);
  ``shape``: a name or a :class:`dexpush.Shape`.
* ``mppi``: :class:`dexpush.MPPISettings` whose ``v_max`` bounds the actions and whose
  ``control_period`` is how long each action is held.

Each reset draws a start from the task's distribution (SPEC §5) with the environment's
``np_random``, so ``reset(seed=s)`` is reproducible.
"""

from __future__ import annotations

from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from dexpush.cost import CostWeights
from dexpush.geometry import Shape
from dexpush.interfaces import Plant, check_plant
from dexpush.mppi import MPPISettings
from dexpush.registry import PLANTS, make_plant, make_shape
from dexpush.se2 import wrap_angle
from dexpush.sensing import Camera, SensorSettings
from dexpush.tasks import MAX_STEPS, get_task, initial_conditions, is_success

__all__ = ["PushEnv"]


class PushEnv(gym.Env):
    """Goal-oriented planar pushing with a point pusher (see the module docstring)."""

    metadata: ClassVar[dict] = {"render_modes": ["rgb_array"], "render_fps": 25}

    def __init__(self, task: str = "I", shape: str | Shape = "rect", plant: str | Plant = "model",
                 sensor: SensorSettings | None = None, max_steps: int = MAX_STEPS,
                 render_mode: str | None = None, mppi: MPPISettings | None = None) -> None:
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode must be None or 'rgb_array', got {render_mode!r}")
        if isinstance(plant, str) and plant not in PLANTS:
            raise ValueError(f"unknown plant {plant!r}; choose one of {', '.join(PLANTS)} or pass a Plant object")
        if int(max_steps) < 1:
            raise ValueError(f"max_steps must be >= 1, got {max_steps}")
        self.task = get_task(task)
        self.shape = make_shape(shape) if isinstance(shape, str) else shape
        if not isinstance(self.shape, Shape):
            raise ValueError(f"shape must be a name or a dexpush.Shape, got {shape!r}")
        self.render_mode = render_mode
        self.max_steps = int(max_steps)
        world = make_plant(plant, self.shape) if isinstance(plant, str) else check_plant(plant)
        self.camera = Camera(world, sensor or SensorSettings())
        self._c = CostWeights().c
        mppi = mppi or MPPISettings()
        self.control_period = mppi.control_period
        v = mppi.v_clip
        self.action_space = spaces.Box(-v, v, shape=(2,), dtype=np.float32)
        lim = np.array([10.0, 10.0, np.pi, 10.0, 10.0, 10.0, 10.0, np.pi], np.float32)
        self.observation_space = spaces.Box(-lim, lim, dtype=np.float32)
        self._goal = np.asarray(self.task.goal, np.float64)
        self._obs: np.ndarray | None = None
        self._steps = 0

    def _observation(self, frame: Any) -> np.ndarray:
        if frame is not None:
            obs = np.concatenate([frame.object_pose, frame.pusher_xy, self._goal])
            obs[[2, 7]] = wrap_angle(obs[[2, 7]])           # headings in [−π, π]
            lim = self.observation_space.high
            self._obs = np.clip(obs, -lim, lim).astype(np.float32)
        return self._obs.copy()

    def _reward_and_success(self) -> tuple[float, bool]:
        q = self.camera.state[:3]
        d2 = np.sum((q[:2] - self._goal[:2]) ** 2) + self._c * (1.0 - np.cos(q[2] - self._goal[2]))
        return -float(np.sqrt(d2)), bool(is_success(q, self._goal))

    def reset(self, *, seed: int | None = None, options: dict | None = None) -> tuple[np.ndarray, dict]:
        super().reset(seed=seed)
        trial = int(self.np_random.integers(0, 2**31 - 1))
        pose, pusher = initial_conditions(self.task, self.shape, trial)
        self._steps = 0
        obs = self._observation(self.camera.reset(pose, pusher))
        _, ok = self._reward_and_success()
        return obs, {"is_success": ok, "trial_seed": trial}

    def step(self, action: object) -> tuple[np.ndarray, float, bool, bool, dict]:
        if self._obs is None:
            raise RuntimeError("call reset() before step()")
        a = np.asarray(action, dtype=np.float64).reshape(-1)
        if a.shape != (2,) or not np.all(np.isfinite(a)):
            raise ValueError(f"action must be a finite pusher velocity (v_x, v_y), got {action!r}")
        a = np.clip(a, self.action_space.low, self.action_space.high)
        obs = self._observation(self.camera.step(a, self.control_period))
        self._steps += 1
        reward, ok = self._reward_and_success()
        truncated = self._steps >= self.max_steps and not ok
        return obs, reward, ok, truncated, {"is_success": ok}

    def render(self) -> np.ndarray | None:
        if self.render_mode != "rgb_array":
            return None
        import matplotlib.pyplot as plt
        from matplotlib.patches import Circle, Polygon

        x = self.camera.state
        fig, ax = plt.subplots(figsize=(4, 3), dpi=80)
        for poly in self.shape.footprint_world(self._goal):
            ax.add_patch(Polygon(poly, closed=True, fill=False, ec="#d62728", ls="--"))
        for poly in self.shape.footprint_world(x[:3]):
            ax.add_patch(Polygon(poly, closed=True, fc="0.6", ec="k"))
        for cx, cy, r in self.task.obstacles:
            ax.add_patch(Circle((cx, cy), r, color="#d62728", alpha=0.5))
        ax.add_patch(Circle(tuple(x[3:]), self.shape.pusher_radius, color="c", ec="k"))
        pts = np.array([x[:2], x[3:], self._goal[:2]])
        pad = self.shape.bounding_radius + 0.05
        ax.set_xlim(pts[:, 0].min() - pad, pts[:, 0].max() + pad)
        ax.set_ylim(pts[:, 1].min() - pad, pts[:, 1].max() + pad)
        ax.set_aspect("equal")
        ax.set_title(f"step {self._steps}", fontsize=8)
        fig.canvas.draw()
        img = np.asarray(fig.canvas.buffer_rgba())[..., :3].copy()
        plt.close(fig)
        return img


gym.register(id="dexpush/Push-v0", entry_point="dexpush.env:PushEnv", max_episode_steps=None)
