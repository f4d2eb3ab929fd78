"""A Gymnasium environment, ``dexpush/Push-v0`` (registered when this module is imported).

    import gymnasium as gym
    import dexpush.env  # noqa: F401  (registers the id)
    env = gym.make("dexpush/Push-v0", task="I", shape="rect", plant="model")
    obs, info = env.reset(seed=0)
    obs, reward, terminated, truncated, info = env.step(env.action_space.sample())

* **observation** (float32, 8): object pose [x_b, y_b, θ], pusher position [x_c, y_c] and
  goal pose [x_g, y_g, θ_g]; headings wrapped to [−π, π], positions within ±10 m. With a
  realistic ``sensor`` it is the newest frame that arrived (the previous one again when
  none did); ``sensor=RenderSettings(...)`` (``dexpush.world.rendered_camera``, the physics
  plants) makes the frames from rendered images of ArUco markers.
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
  satisfies :class:`dexpush.common.interfaces.Plant` (your own simulator or robot driver);
  ``shape``: a name or a :class:`dexpush.Shape`.
* ``mppi``: :class:`dexpush.MPPISettings` whose ``v_max`` bounds the actions and whose
  ``control_period`` is how long each action is held.

* ``goal``: ``None`` (the task's), a pose (x, y, θ), or ``"random"``: a new goal at each reset,
  uniform in ``goal_range`` = ((x_lo, x_hi), (y_lo, y_hi)) (m) and θ ∈ [−π, π); or one episode's,
  ``reset(options={"goal": (x, y, θ)})``. Goals lie within the observation's ±10 m.
* ``success_position_m``, ``success_heading_deg``: the success gate (default 8 mm and 3°).
* ``problem``: a :class:`dexpush.problem.problem.Problem` instead of ``shape``, ``goal``, the obstacles
  and the success gate (the task still gives the start distribution).

Each reset draws a start from the task's distribution (docs/conventions.md#benchmark-tasks)
with the environment's ``np_random``, so ``reset(seed=s)`` is reproducible.

:class:`VectorPushEnv` runs ``num_envs`` copies on the model plant as one batch (one
compiled, vectorised plant step per ``step``), with Gymnasium's same-step autoreset.
"""

from __future__ import annotations

from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from dexpush.common.interfaces import Plant, Sensor, check_plant
from dexpush.common.se2 import wrap_angle
from dexpush.control.mppi import MPPISettings
from dexpush.experiments.registry import PLANTS, make_plant, make_shape
from dexpush.experiments.scenarios import MAX_STEPS, Task, get_task, initial_conditions
from dexpush.model.cgvmm import MU_C
from dexpush.model.shape import Shape
from dexpush.problem.problem import SUCCESS_HEADING_DEG, SUCCESS_POSITION_M, Problem, is_success
from dexpush.problem.weights import CostWeights
from dexpush.world.model_plant import ModelPlant
from dexpush.world.sensing import SensorSettings

__all__ = ["PushEnv", "VectorPushEnv"]

_OBS_LIMIT = np.array([10.0, 10.0, np.pi, 10.0, 10.0, 10.0, 10.0, np.pi], np.float32)


def _observation(q: np.ndarray, p: np.ndarray, goal: np.ndarray) -> np.ndarray:
    """[object pose, pusher, goal] (..., 8), headings wrapped, clipped to the observation box."""
    obs = np.concatenate([q, p, goal], -1)
    obs[..., [2, 7]] = wrap_angle(obs[..., [2, 7]])
    return np.clip(obs, -_OBS_LIMIT, _OBS_LIMIT).astype(np.float32)


def _reward(q: np.ndarray, goal: np.ndarray, c: float) -> np.ndarray:
    """−d, the decoupled distance of eq. (9), for poses (..., 3) and goals (..., 3)."""
    d2 = np.sum((q[..., :2] - goal[..., :2]) ** 2, -1) + c * (1.0 - np.cos(q[..., 2] - goal[..., 2]))
    return -np.sqrt(d2)


class _Goals:
    """The goal setting shared by both envs: fixed, the task's, or drawn at each reset; and the gate."""

    def __init__(self, task: Task, goal: object, goal_range: object, position_m: float, heading_deg: float) -> None:
        if task.region is not None:
            raise ValueError(f"the Gym envs take goal poses; task {task.key}'s goal is a region "
                             "(docs/goal_regions.md): run it with dexpush run or dexpush bench")
        if isinstance(goal, str) and goal != "random":
            raise ValueError(f"goal must be None, 'random' or a pose (x, y, θ), got {goal!r}")
        self.random = goal == "random"
        self.fixed = self.checked(task.goal if goal is None or self.random else goal)
        try:
            self.range = np.asarray(goal_range, np.float64)
        except (TypeError, ValueError):
            self.range = np.zeros(0)
        if self.range.shape != (2, 2) or not np.all(np.isfinite(self.range)) \
                or not np.all(self.range[:, 0] <= self.range[:, 1]):
            raise ValueError(f"goal_range must be finite ((x_lo, x_hi), (y_lo, y_hi)), got {goal_range!r}")
        if np.any(np.abs(self.range) > _OBS_LIMIT[5]):
            raise ValueError(f"goal_range must lie within ±{_OBS_LIMIT[5]:g} m, the observation's bounds; got "
                             f"{goal_range!r}")
        if not (position_m > 0 and heading_deg > 0):
            raise ValueError(f"the success gate must be positive, got {position_m!r} m and {heading_deg!r}°")
        self.position_m, self.heading_deg = float(position_m), float(heading_deg)

    @staticmethod
    def checked(goal: object) -> np.ndarray:
        """A goal pose (x, y, θ): finite, and its position within the observation's ±10 m."""
        try:
            g = np.asarray(goal, np.float64)
        except (TypeError, ValueError):
            g = np.zeros(0)
        if g.shape != (3,) or not np.all(np.isfinite(g)):
            raise ValueError(f"goal must be a finite pose (x, y, θ), got {goal!r}")
        if np.any(np.abs(g[:2]) > _OBS_LIMIT[5]):
            raise ValueError(f"goal must lie within ±{_OBS_LIMIT[5]:g} m, the observation's bounds (it would be "
                             f"seen clipped); got {goal!r}")
        return g

    def draw(self, rng: np.random.Generator) -> np.ndarray:
        if not self.random:
            return self.fixed.copy()
        return np.array([rng.uniform(*self.range[0]), rng.uniform(*self.range[1]), rng.uniform(-np.pi, np.pi)])

    def success(self, q: np.ndarray, goal: np.ndarray) -> np.ndarray:
        return is_success(q, goal, np, self.position_m, self.heading_deg)


class PushEnv(gym.Env):
    """Goal-oriented planar pushing with a point pusher (see the module docstring)."""

    metadata: ClassVar[dict] = {"render_modes": ["rgb_array"], "render_fps": 25}

    def __init__(self, task: str = "I", shape: str | Shape = "rect", plant: str | Plant = "model",
                 sensor: Sensor | None = None, max_steps: int = MAX_STEPS,
                 render_mode: str | None = None, mppi: MPPISettings | None = None, goal: object = None,
                 goal_range: object = ((-0.5, 0.5), (-0.5, 0.5)), success_position_m: float = SUCCESS_POSITION_M,
                 success_heading_deg: float = SUCCESS_HEADING_DEG, problem: Problem | None = None) -> None:
        if problem is not None:
            if not isinstance(problem, Problem):
                raise ValueError(f"problem must be a dexpush Problem, got {problem!r}")
            if shape != "rect" or goal is not None or (success_position_m, success_heading_deg) != (
                    SUCCESS_POSITION_M, SUCCESS_HEADING_DEG):
                raise ValueError("a Problem holds the shape, the goal and the success test: give them in it, not "
                                 "beside it")
            if problem.region is not None:
                raise ValueError("the Gym envs take goal poses; this Problem's goal is a region (docs/goal_regions.md)")
            shape, goal = problem.shape, problem.goal
            success_position_m, success_heading_deg = problem.tolerance_m, problem.tolerance_deg
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode must be None or 'rgb_array', got {render_mode!r}")
        if isinstance(plant, str) and plant not in PLANTS:
            raise ValueError(f"unknown plant {plant!r}; choose one of {', '.join(PLANTS)} or pass a Plant object")
        if int(max_steps) < 1:
            raise ValueError(f"max_steps must be >= 1, got {max_steps}")
        self.task = get_task(task)
        if problem is None and self.task.varies_by_seed:
            raise ValueError(f"task {self.task.key} has one layout per seed: "
                             "pass problem=task.problem(shape, seed=...)")
        self.obstacles = problem.obstacles if problem is not None else self.task.obstacles
        #: the boxes, walls and workspace bound every episode's problem keeps
        self._regions = ({"polygons": problem.polygons, "workspace": problem.workspace} if problem is not None
                         else {"polygons": self.task.polygons, "workspace": self.task.workspace})
        self.shape = make_shape(shape) if isinstance(shape, str) else shape
        if not isinstance(self.shape, Shape):
            raise ValueError(f"shape must be a name or a dexpush.Shape, got {shape!r}")
        self.render_mode = render_mode
        self.max_steps = int(max_steps)
        world = make_plant(plant, self.shape) if isinstance(plant, str) else check_plant(plant)
        self.camera = (sensor or SensorSettings()).camera(world, self.obstacles)
        self._c = (problem.weights if problem is not None else CostWeights()).c
        if mppi is not None and not isinstance(mppi, MPPISettings):
            raise ValueError(f"mppi must be a dexpush.MPPISettings, got {mppi!r}")
        mppi = mppi or MPPISettings()
        self.control_period = mppi.control_period
        v = mppi.v_clip
        self.action_space = spaces.Box(-v, v, shape=(2,), dtype=np.float32)
        self.observation_space = spaces.Box(-_OBS_LIMIT, _OBS_LIMIT, dtype=np.float32)
        self.goals = _Goals(self.task, goal, goal_range, success_position_m, success_heading_deg)
        self._goal = self.goals.fixed.copy()
        self._problem: Problem | None = problem
        self._obs: np.ndarray | None = None
        self._steps = 0

    @property
    def problem(self) -> Problem:
        """The :class:`dexpush.problem.problem.Problem` of the current episode (its goal is drawn at reset):
        what a method's controller solves in this env (:meth:`dexpush.experiments.methods.Method.controller`)."""
        if self._problem is None or self._problem.goal != tuple(self._goal):
            weights = self._problem.weights if self._problem is not None else CostWeights()
            self._problem = Problem(self.shape, tuple(self._goal), self.obstacles, weights,
                                    tolerance_m=self.goals.position_m, tolerance_deg=self.goals.heading_deg,
                                    **self._regions)
        return self._problem

    def _observation(self, frame: Any) -> np.ndarray:
        if frame is not None:
            self._obs = _observation(np.asarray(frame.object_pose), np.asarray(frame.pusher_xy), self._goal)
        return self._obs.copy()

    def _reward_and_success(self) -> tuple[float, bool]:
        q = self.camera.state[:3]
        return float(_reward(q, self._goal, self._c)), bool(self.goals.success(q, self._goal))

    def reset(self, *, seed: int | None = None, options: dict | None = None) -> tuple[np.ndarray, dict]:
        super().reset(seed=seed)
        trial = int(self.np_random.integers(0, 2**31 - 1))
        pose, pusher = initial_conditions(self.task, self.shape, trial)
        self._goal = self.goals.draw(self.np_random)
        unknown = sorted(set(options or {}) - {"goal"})
        if unknown:
            raise ValueError(f"unknown reset option {unknown[0]!r}; the env takes options={{'goal': (x, y, θ)}}")
        if (options or {}).get("goal") is not None:
            self._goal = self.goals.checked(options["goal"])
        self._steps = 0
        obs = self._observation(self.camera.reset(pose, pusher))
        _, ok = self._reward_and_success()
        return obs, {"is_success": ok, "trial_seed": trial, "goal": self._goal.copy()}

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

        from dexpush.viz import draw_obstacles

        x = self.camera.state
        fig, ax = plt.subplots(figsize=(4, 3), dpi=80)
        for poly in self.shape.footprint_world(self._goal):
            ax.add_patch(Polygon(poly, closed=True, fill=False, ec="#d62728", ls="--"))
        for poly in self.shape.footprint_world(x[:3]):
            ax.add_patch(Polygon(poly, closed=True, fc="0.6", ec="k"))
        draw_obstacles(ax, self.obstacles, self.problem.polygons, self.problem.workspace)
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


class VectorPushEnv(gym.vector.VectorEnv):
    """``num_envs`` pushing environments on the model plant, stepped as one batch.

    Same observations, actions, reward, goals and success gate as :class:`PushEnv` (exact
    observations; no camera), one (num_envs, ·) array each. An environment that terminates
    or truncates is reset in the same ``step`` (Gymnasium's ``SAME_STEP`` autoreset): the
    returned observation is its new start, ``infos["final_obs"]`` holds the last one.
    ``params`` and ``mu`` are the plant's true λ and μ_c.
    """

    metadata: ClassVar[dict] = {"autoreset_mode": gym.vector.AutoresetMode.SAME_STEP}

    def __init__(self, num_envs: int = 16, task: str = "I", shape: str | Shape = "rect",
                 max_steps: int = MAX_STEPS, mppi: MPPISettings | None = None, goal: object = None,
                 goal_range: object = ((-0.5, 0.5), (-0.5, 0.5)), success_position_m: float = SUCCESS_POSITION_M,
                 success_heading_deg: float = SUCCESS_HEADING_DEG, params: object = None, mu: float = MU_C) -> None:
        if isinstance(num_envs, bool) or int(num_envs) != num_envs or num_envs < 1:
            raise ValueError(f"num_envs must be a whole number >= 1, got {num_envs!r}")
        if int(max_steps) < 1:
            raise ValueError(f"max_steps must be >= 1, got {max_steps}")
        self.num_envs, self.max_steps = int(num_envs), int(max_steps)
        self.task = get_task(task)
        self.shape = make_shape(shape) if isinstance(shape, str) else shape
        if not isinstance(self.shape, Shape):
            raise ValueError(f"shape must be a name or a dexpush.Shape, got {shape!r}")
        self.plant = ModelPlant(self.shape, mu=mu) if params is None else ModelPlant(self.shape, params, mu=mu)
        self.goals = _Goals(self.task, goal, goal_range, success_position_m, success_heading_deg)
        if mppi is not None and not isinstance(mppi, MPPISettings):
            raise ValueError(f"mppi must be a dexpush.MPPISettings, got {mppi!r}")
        mppi = mppi or MPPISettings()
        self.control_period = mppi.control_period
        self._c = CostWeights().c
        v = mppi.v_clip
        self.single_action_space = spaces.Box(-v, v, shape=(2,), dtype=np.float32)
        self.single_observation_space = spaces.Box(-_OBS_LIMIT, _OBS_LIMIT, dtype=np.float32)
        self.action_space = gym.vector.utils.batch_space(self.single_action_space, self.num_envs)
        self.observation_space = gym.vector.utils.batch_space(self.single_observation_space, self.num_envs)
        self._goal = np.tile(self.goals.fixed, (self.num_envs, 1))
        self._steps = np.zeros(self.num_envs, int)
        self._x: np.ndarray | None = None

    def _starts(self, which: np.ndarray) -> None:
        """New starts and goals for the environments in ``which`` (a bool mask)."""
        for i in np.flatnonzero(which):
            pose, pusher = initial_conditions(self.task, self.shape, int(self.np_random.integers(0, 2**31 - 1)))
            self._x[i] = np.concatenate([pose, pusher])
            self._goal[i] = self.goals.draw(self.np_random)
            self._steps[i] = 0
        self.plant.reset(self._x[:, :3], self._x[:, 3:])

    def reset(self, *, seed: int | None = None, options: dict | None = None) -> tuple[np.ndarray, dict]:
        if seed is not None:
            self._np_random, self._np_random_seed = gym.utils.seeding.np_random(seed)
        self._x = np.zeros((self.num_envs, 5))
        self._starts(np.ones(self.num_envs, bool))
        q = self._x[:, :3]
        return _observation(q, self._x[:, 3:], self._goal), {"is_success": self.goals.success(q, self._goal)}

    def step(self, actions: object) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict]:
        if self._x is None:
            raise RuntimeError("call reset() before step()")
        a = np.asarray(actions, dtype=np.float64)
        if a.shape != (self.num_envs, 2) or not np.all(np.isfinite(a)):
            raise ValueError(f"actions must be a finite ({self.num_envs}, 2) array of pusher velocities, "
                             f"got shape {a.shape}")
        a = np.clip(a, self.single_action_space.low, self.single_action_space.high)
        self.plant.step(a, self.control_period)
        self._x = self.plant.state.copy()
        self._steps += 1
        q = self._x[:, :3]
        reward = _reward(q, self._goal, self._c)
        success = self.goals.success(q, self._goal)
        truncated = (self._steps >= self.max_steps) & ~success
        obs = _observation(q, self._x[:, 3:], self._goal)
        infos: dict = {"is_success": success}
        done = success | truncated
        if np.any(done):
            infos["final_obs"], infos["_final_obs"] = obs.copy(), done
            self._starts(done)
            obs = _observation(self._x[:, :3], self._x[:, 3:], self._goal)
        return obs, reward.astype(np.float64), success, truncated, infos


gym.register(id="dexpush/Push-v0", entry_point="dexpush.env:PushEnv", vector_entry_point="dexpush.env:VectorPushEnv",
             max_episode_steps=None)
