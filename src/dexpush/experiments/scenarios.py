"""The paper's benchmark tasks (Sec. IV-B) made concrete by docs/conventions.md#benchmark-tasks.

* Task I, long re-positioning: goal (0.60, 0.30, 0).
* Task II, re-orientation: goal (0, 0, π/2).
* Task III, obstacle avoidance: goal (0.60, 0, 0), obstacle disc at (0.30, 0), r = 0.05 m.

Each trial starts from q₀ = (0, 0, 0) perturbed uniformly by ±0.02 m in x, y and ±10° in
θ, with the pusher 0.05 m outside the inflated contour at a uniformly random azimuth;
the perturbation is drawn from ``numpy.random.default_rng(seed)``. Success: within
N_max = 1500 control steps, position error < 8 mm and heading error < 3°.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dexpush.model.shape import Shape
from dexpush.problem.problem import Problem
from dexpush.problem.weights import CostWeights

__all__ = ["MAX_STEPS", "TASKS", "Task", "get_task", "initial_conditions"]

MAX_STEPS = 1500   #: N_max, the control steps a trial may take


@dataclass(frozen=True)
class Task:
    """A benchmark scenario: a goal pose, optional disc obstacles (c_x, c_y, r), and the start
    distribution. (A *task* in the paper's sense; :meth:`problem` gives what a method solves.)"""

    key: str
    title: str
    goal: tuple[float, float, float]
    obstacles: tuple[tuple[float, float, float], ...] = ()
    start: tuple[float, float, float] = (0.0, 0.0, 0.0)
    start_jitter_m: float = 0.02
    start_jitter_deg: float = 10.0
    pusher_clearance_m: float = 0.05

    def trial_start(self, shape: Shape, seed: int) -> tuple[np.ndarray, np.ndarray]:
        """The start of trial ``seed`` on ``shape``: :func:`initial_conditions`."""
        return initial_conditions(self, shape, seed)

    def problem(self, shape: Shape, weights: CostWeights | None = None) -> Problem:
        """The :class:`dexpush.problem.problem.Problem` of pushing ``shape`` in this scenario."""
        return Problem(shape, self.goal, self.obstacles, weights or CostWeights())


TASKS: dict[str, Task] = {
    "I": Task("I", "long re-positioning", (0.60, 0.30, 0.0)),
    "II": Task("II", "re-orientation", (0.0, 0.0, float(np.pi / 2))),
    "III": Task("III", "obstacle avoidance", (0.60, 0.0, 0.0), obstacles=((0.30, 0.0, 0.05),)),
}
_ALIASES = {"1": "I", "2": "II", "3": "III", "reposition": "I", "reorient": "II", "obstacle": "III"}


def get_task(name: str | Task) -> Task:
    """Look a task up by ``I``/``II``/``III`` (or 1/2/3, reposition/reorient/obstacle)."""
    if isinstance(name, Task):
        return name
    key = str(name).strip()
    key = _ALIASES.get(key.lower(), key.upper())
    if key not in TASKS:
        raise ValueError(f"unknown task {name!r}; choose one of I, II, III "
                         "(or 1, 2, 3, reposition, reorient, obstacle)")
    return TASKS[key]


def initial_conditions(task: Task, shape: Shape, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Start pose and pusher position of trial ``seed`` (docs/conventions.md#benchmark-tasks)."""
    if int(seed) < 0:
        raise ValueError(f"seed must be >= 0, got {seed}")
    rng = np.random.default_rng(int(seed))
    j = task.start_jitter_m
    jitter = np.array([rng.uniform(-j, j), rng.uniform(-j, j),
                       np.radians(rng.uniform(-task.start_jitter_deg, task.start_jitter_deg))])
    pose = np.asarray(task.start, dtype=np.float64) + jitter
    phi = rng.uniform(-np.pi, np.pi)
    r, _ = shape.contour(np.array(phi))
    r = np.asarray(r, dtype=np.float64)
    r = r * (1.0 + task.pusher_clearance_m / np.linalg.norm(r))
    c, s = np.cos(pose[2]), np.sin(pose[2])
    pusher = pose[:2] + np.array([c * r[0] - s * r[1], s * r[0] + c * r[1]])
    return pose, pusher
