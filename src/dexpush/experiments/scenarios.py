"""The paper's benchmark tasks (Sec. IV-B) made concrete by docs/conventions.md#benchmark-tasks.

* Task I, long re-positioning: goal (0.60, 0.30, 0).
* Task II, re-orientation: goal (0, 0, π/2).
* Task III, obstacle avoidance: goal (0.60, 0, 0), obstacle disc at (0.30, 0), r = 0.05 m.
* Task IV, confined re-arrangement (the paper's Fig. 9): a 0.70 × 0.50 m area walled on every side
  (x ∈ [−0.15, 0.55], y ∈ [−0.25, 0.25], walls 2 cm thick), three discs, the object moved to the far
  side and turned by −90°: goal (0.40, 0, −π/2).
* Task V, push to the edge (the paper's Sec. IV-D, before the grasp): a 0.75 × 0.70 m table
  (x ∈ [−0.30, 0.45], y ∈ [−0.35, 0.35]), no obstacles, the goal a region: the footprint overhanging the
  +x edge by at least 6 cm with its centre of mass still on the table, at any heading
  (:class:`dexpush.problem.goal_region.Overhang`); the centre of mass past the edge is a drop, a failure.
* Clutter (``C``): a family, one layout per seed (:class:`ClutterTask`): a 1 × 1 m table (the
  workspace), 3–8 obstacles (discs, boxes, walls), a random start and goal at least 0.35 m apart with
  any heading change, and a free path of at least 3 cm round the footprint from start to goal.

Each trial starts from q₀ = (0, 0, 0) perturbed uniformly by ±0.02 m in x, y and ±10° in
θ, with the pusher 0.05 m outside the inflated contour at a uniformly random azimuth;
the perturbation is drawn from ``numpy.random.default_rng(seed)``. Success: within
N_max = 1500 control steps, position error < 8 mm and heading error < 3°.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from dexpush.model.shape import Shape
from dexpush.problem.goal_region import GoalRegion, Overhang
from dexpush.problem.problem import Problem
from dexpush.problem.regions import wall
from dexpush.problem.weights import CostWeights

__all__ = ["MAX_STEPS", "TASKS", "ClutterTask", "Task", "get_task", "initial_conditions"]

MAX_STEPS = 1500   #: N_max, the control steps a trial may take


@dataclass(frozen=True)
class Task:
    """A benchmark scenario: a goal pose, optional obstacles (discs (c_x, c_y, r), convex polygons), an
    optional workspace, and the start distribution. (A *task* in the paper's sense; :meth:`problem`
    gives what a method solves.)"""

    key: str
    title: str
    goal: tuple[float, float, float]
    obstacles: tuple[tuple[float, float, float], ...] = ()
    start: tuple[float, float, float] = (0.0, 0.0, 0.0)
    start_jitter_m: float = 0.02
    start_jitter_deg: float = 10.0
    pusher_clearance_m: float = 0.05
    polygons: tuple[tuple[tuple[float, float], ...], ...] = ()
    workspace: tuple[float, ...] | None = None
    #: a goal region (:mod:`dexpush.problem.goal_region`) in place of ``goal``; None: the goal pose
    region: GoalRegion | None = None

    #: whether each seed has its own layout (:class:`ClutterTask`): then :meth:`problem` needs the seed
    varies_by_seed = False

    @property
    def has_obstacles(self) -> bool:
        return bool(self.obstacles or self.polygons or self.workspace is not None or self.varies_by_seed)

    def trial_start(self, shape: Shape, seed: int) -> tuple[np.ndarray, np.ndarray]:
        """The start of trial ``seed`` on ``shape``: :func:`initial_conditions`."""
        return initial_conditions(self, shape, seed)

    def problem(self, shape: Shape, weights: CostWeights | None = None, seed: int | None = None) -> Problem:
        """The :class:`dexpush.problem.problem.Problem` of pushing ``shape`` in this scenario (``seed``:
        which layout, for a task that has one per seed)."""
        return Problem(shape, self.goal if self.region is None else self.region, self.obstacles,
                       weights or CostWeights(), polygons=self.polygons, workspace=self.workspace)


TASKS: dict[str, Task] = {
    "I": Task("I", "long re-positioning", (0.60, 0.30, 0.0)),
    "II": Task("II", "re-orientation", (0.0, 0.0, float(np.pi / 2))),
    "III": Task("III", "obstacle avoidance", (0.60, 0.0, 0.0), obstacles=((0.30, 0.0, 0.05),)),
}
_ALIASES = {"1": "I", "2": "II", "3": "III", "4": "IV", "5": "V", "reposition": "I", "reorient": "II",
            "obstacle": "III", "confined": "IV", "edge": "V", "clutter": "C"}


def get_task(name: str | Task) -> Task:
    """Look a task up by ``I``/``II``/``III`` (or 1/2/3, reposition/reorient/obstacle)."""
    if isinstance(name, Task):
        return name
    key = str(name).strip()
    key = _ALIASES.get(key.lower(), key.upper())
    if key not in TASKS:
        raise ValueError(f"unknown task {name!r}; choose one of I, II, III, IV, V, C "
                         "(or 1, 2, 3, 4, 5, reposition, reorient, obstacle, confined, edge, clutter)")
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
    # the azimuth is redrawn (from the same stream) while the pusher would start within PUSHER_START_GAP_M
    # of an obstacle or a wall; Tasks I–III never redraw
    for _ in range(100):
        pusher = _pusher_start(shape, pose, rng, task.pusher_clearance_m)
        gap = _pusher_gap(pusher, task.obstacles, task.polygons, task.workspace)
        if gap >= PUSHER_START_GAP_M + shape.pusher_radius:
            return pose, pusher
    raise ValueError(f"task {task.key}: no pusher start clear of the obstacles around the start pose")


#: the least gap (m) between a trial's starting pusher disc and any obstacle or wall
PUSHER_START_GAP_M = 0.02


def _pusher_gap(pusher: np.ndarray, discs: object, polygons: object, workspace: object) -> float:
    """The distance (m) from the pusher's centre to the nearest of the ``discs`` (c_x, c_y, r) and convex
    ``polygons``, or to the ``workspace`` boundary (None: unbounded)."""
    from dexpush.problem.regions import point_gap, workspace_halfplanes

    d = np.asarray(discs, np.float64).reshape(-1, 3)
    gaps = [np.hypot(*(pusher - d[:, :2]).T) - d[:, 2]] + [np.atleast_1d(point_gap(pusher, p)) for p in polygons]
    if workspace is not None:
        h = workspace_halfplanes(workspace)
        gaps.append(h[:, 2] - h[:, :2] @ pusher)
    return float(np.min(np.concatenate(gaps), initial=np.inf))


def _walled(lo_x: float, lo_y: float, hi_x: float, hi_y: float,
            t: float) -> tuple[tuple[tuple[float, float], ...], ...]:
    """Four walls ``t`` thick just outside the rectangle (lo_x, lo_y)–(hi_x, hi_y), overlapping at the corners."""
    walls = (wall(lo_x - t, lo_y - t / 2, hi_x + t, lo_y - t / 2, t),
             wall(lo_x - t, hi_y + t / 2, hi_x + t, hi_y + t / 2, t),
             wall(lo_x - t / 2, lo_y, lo_x - t / 2, hi_y, t), wall(hi_x + t / 2, lo_y, hi_x + t / 2, hi_y, t))
    return tuple(tuple(map(tuple, w)) for w in walls)


@dataclass(frozen=True)
class ClutterTask(Task):
    """The random clutter family: seed s has its own layout (:meth:`layout`), drawn from
    ``numpy.random.default_rng(s)`` by rejection: a table ``table_m`` square about the origin (the
    workspace), ``count`` obstacles (discs of radius 2–5 cm, boxes of 4–16 cm sides at any yaw, walls
    of 15–35 cm, 2 cm thick), a start and a goal anywhere at least ``min_travel_m`` apart with any
    headings, both clear of everything by ``free_m``, and a path between them along which the
    footprint, in some heading, keeps ``free_m`` from everything (:class:`dexpush.problem.guidance.CostToGo`
    with that margin). Its scenes are padded to :data:`SLOTS` so that every seed shares compiled code.
    """

    table_m: float = 1.0
    count: tuple[int, int] = (3, 8)
    min_travel_m: float = 0.35
    free_m: float = 0.03

    varies_by_seed = True
    #: the padding of every layout's scene (discs, polygons)
    SLOTS = (8, 8)

    @functools.lru_cache(maxsize=32)   # noqa: B019 (a frozen task; the layouts of a benchmark group)
    def layout(self, shape: Shape, seed: int) -> tuple[Problem, np.ndarray, np.ndarray]:
        """(problem, start pose, pusher start) of seed ``seed`` on ``shape``."""
        from dexpush.problem.guidance import cost_to_go
        from dexpush.problem.regions import box, point_gap
        rng = np.random.default_rng(int(seed))
        half = self.table_m / 2
        corners = np.array([[-half, -half], [half, -half], [half, half], [-half, half]])
        for _ in range(500):
            discs, polys = [], []
            for _ in range(int(rng.integers(self.count[0], self.count[1] + 1))):
                kind = rng.integers(3)
                c = rng.uniform(-half, half, 2)
                if kind == 0:
                    discs.append((c[0], c[1], rng.uniform(0.02, 0.05)))
                elif kind == 1:
                    side = rng.uniform(0.04, 0.16, 2)
                    polys.append(box(c[0], c[1], side[0], side[1], rng.uniform(-np.pi, np.pi)))
                else:
                    a = rng.uniform(-np.pi, np.pi)
                    d = rng.uniform(0.075, 0.175) * np.array([np.cos(a), np.sin(a)])
                    polys.append(wall(*(c - d), *(c + d), 0.02))
            polys = [p for p in polys if np.all(np.abs(p) < half)]      # walls and boxes on the table
            if not discs and not polys:
                continue
            start = np.array([*rng.uniform(-half, half, 2), rng.uniform(-np.pi, np.pi)])
            goal = np.array([*rng.uniform(-half, half, 2), rng.uniform(-np.pi, np.pi)])
            if np.hypot(*(goal[:2] - start[:2])) < self.min_travel_m:
                continue
            d = np.asarray(discs, np.float64).reshape(-1, 3)
            if not all(_clear(shape, q, d, polys, corners, self.free_m, point_gap) for q in (start, goal)):
                continue
            field = cost_to_go(shape.polygons, shape.bounding_radius, goal, d, tuple(polys), corners, self.free_m)
            if not field.connects(start):
                continue
            pusher = _pusher_start(shape, start, rng, self.pusher_clearance_m)
            if _pusher_gap(pusher, d, polys, (-half, -half, half, half)) < PUSHER_START_GAP_M:
                continue
            problem = Problem(shape, tuple(goal), tuple(map(tuple, d)),
                              polygons=tuple(tuple(map(tuple, p)) for p in polys),
                              workspace=(-half, -half, half, half), pad_to=self.SLOTS)
            return problem, start, pusher
        raise RuntimeError(f"no clutter layout found for seed {seed} in 500 draws")

    def trial_start(self, shape: Shape, seed: int) -> tuple[np.ndarray, np.ndarray]:
        _, start, pusher = self.layout(shape, seed)
        return start, pusher

    def problem(self, shape: Shape, weights: CostWeights | None = None, seed: int | None = None) -> Problem:
        if seed is None:
            raise ValueError("the clutter task has one layout per seed: pass seed=")
        problem = self.layout(shape, seed)[0]
        return problem if weights is None else problem.with_weights(weights)


def _clear(shape: Shape, pose: np.ndarray, discs: np.ndarray, polys: list, corners: np.ndarray, free: float,
           point_gap) -> bool:
    """Whether the footprint at ``pose`` keeps ``free`` (m) from the discs and polygons and inside the table
    (checked at its outline, sampled every 5 mm)."""
    pts = []
    for p in shape.footprint_world(pose):
        for a, b in zip(p, np.roll(p, -1, axis=0), strict=True):
            k = max(int(np.hypot(*(b - a)) / 0.005), 1)
            pts.append(a + (b - a) * (np.arange(k) / k)[:, None])
    pts = np.concatenate(pts)
    if np.min(-point_gap(pts, corners)) < free:
        return False
    if len(discs) and np.min(np.hypot(*(pts[:, None] - discs[:, :2]).transpose(2, 0, 1)) - discs[:, 2]) < free:
        return False
    if any(np.hypot(*(pose[:2] - d[:2])) < d[2] for d in discs):
        return False
    return all(np.min(point_gap(pts, p)) >= free and point_gap(pose[:2], p) > 0 for p in polys)


def _pusher_start(shape: Shape, pose: np.ndarray, rng: np.random.Generator, clearance: float) -> np.ndarray:
    """The pusher ``clearance`` (m) outside the inflated contour at a random azimuth (as :func:`initial_conditions`)."""
    phi = rng.uniform(-np.pi, np.pi)
    r = np.asarray(shape.contour(np.array(phi))[0], dtype=np.float64)
    r = r * (1.0 + clearance / np.linalg.norm(r))
    c, s = np.cos(pose[2]), np.sin(pose[2])
    return pose[:2] + np.array([c * r[0] - s * r[1], s * r[0] + c * r[1]])


TASKS["IV"] = Task("IV", "confined re-arrangement", (0.38, 0.0, float(-np.pi / 2)),
                   obstacles=((0.16, 0.13, 0.03), (0.22, -0.20, 0.025), (0.42, 0.16, 0.025)),
                   polygons=_walled(-0.20, -0.30, 0.50, 0.20, 0.02))
TASKS["V"] = Task("V", "push to the edge", (0.0, 0.0, 0.0), workspace=(-0.30, -0.35, 0.45, 0.35),
                  region=Overhang("+x", 0.06))
TASKS["C"] = ClutterTask("C", "random clutter", (0.0, 0.0, 0.0))
