"""What a finished trial leaves behind: its record (docs/conventions.md#benchmark-tasks), its trajectory,
and per-condition summaries.

An :class:`EpisodeRecord` is JSON-friendly and is what the benchmark's condition files
hold; an :class:`Episode` adds the sampled trajectory. :func:`summarize` gives the
per-condition numbers of docs/conventions.md#benchmark-tasks (success rate, path lengths, time to goal, planning time).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any, NamedTuple

import numpy as np

from dexpush.common.interfaces import CONTROL_PERIOD_S, Sensor
from dexpush.experiments.methods import Method, get_method
from dexpush.experiments.simulate import TrialResult
from dexpush.model.cgvmm import LAMBDA_TRUE, MODE_NAMES, contact_solution
from dexpush.problem.problem import Problem

__all__ = ["CONDITION_KEYS", "Condition", "Episode", "EpisodeRecord", "condition_name", "make_episode", "sensor_label",
           "summarize"]

CONDITION_KEYS = ("task", "shape", "params", "method")

#: a trajectory is labelled (contact modes, obstacle touches) padded to a multiple of this many
#: steps, so the jitted labelling compiles once per block count, not once per trajectory length
#: (a compile costs more than a trial's own simulation: docs/performance.md#the-720-trial-table)
LABEL_BLOCK = 256

def _in_blocks(a: np.ndarray) -> np.ndarray:
    """``a`` with its last row repeated up to a multiple of :data:`LABEL_BLOCK` rows."""
    n = -(-len(a) // LABEL_BLOCK) * LABEL_BLOCK
    return np.concatenate([a, np.repeat(a[-1:], n - len(a), axis=0)])


def condition_name(task: str, shape: str, params: str, method: str) -> str:
    """The file stem of a condition, e.g. ``I_rect_known_mppi``."""
    return f"{task}_{shape}_{params}_{method}"


@dataclass
class EpisodeRecord:
    """The per-trial record of docs/conventions.md#benchmark-tasks (JSON-friendly)."""

    task: str
    shape: str
    params: str
    method: str
    seed: int
    success: bool
    steps: int                    #: control steps taken (to success, or N_max)
    time_s: float                 #: simulated time (steps × control period)
    object_path_m: float
    pusher_path_m: float
    final_error_m: float
    final_error_deg: float
    collisions: int               #: control steps that ended in collision with an obstacle
    contact_switches: int         #: contact on/off transitions
    planning_ms_median: float     #: batched runs: a lane's share of a control step's wall time (UKF + MPPI +
    planning_ms_max: float        #: plant; chunk time / (lanes × steps)); other runs: the controller's time per act
    lanes: int = 1                #: lanes of the batch it ran in (needed to reproduce it exactly)
    plant: str = "model"          #: the world: model (C-GVMM, λ_true), physics (MuJoCo), or a user's plant
    sensor: str = "exact"         #: what the controller saw (see dexpush.world.sensing)
    #: with obstacles: the smallest gap (m) between an obstacle and the object or the pusher over the trial
    #: (≤ 0 on a touch; :func:`dexpush.problem.obstacles.clearance`)
    clearance_m: float | None = None
    #: what the method reports of the trial (:meth:`dexpush.experiments.methods.Method.diagnostics`), e.g.
    #: MPPI's ``stall_resets``, the UKF's ``rejected_frames``, ``estimator_updates`` and ``params_estimate``,
    #: GCS's ``offline_plan_s`` and ``replans``
    diagnostics: dict[str, Any] = field(default_factory=dict)
    #: what the camera did, when there was one (:meth:`dexpush.world.sensing.Camera.counts`): frames captured,
    #: dropped, withheld by the perception (by reason, for a rendered camera) and delivered
    frames: dict[str, int] | None = None
    #: with an overhang goal (:class:`dexpush.problem.goal_region.Overhang`): whether the object's centre of mass
    #: crossed the table's edge (it fell; the trial failed there); None for other goals
    dropped: bool | None = None


@dataclass
class Episode:
    """A finished episode: its record plus the sampled trajectory."""

    record: EpisodeRecord
    states: np.ndarray            #: (T+1, 5) true states
    modes: np.ndarray             #: (T,) contact mode at the start of each control step
    commands: np.ndarray          #: (T, 2)
    planning_ms: np.ndarray       #: (T,) wall time per control step (amortized, see EpisodeRecord)
    params: np.ndarray            #: (T, 3) λ_pred the controller planned with at each step
    goal: np.ndarray
    obstacles: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    polygons: tuple = ()                     #: the problem's convex obstacles (corner arrays)
    workspace: np.ndarray | None = None      #: the workspace's corners, or None
    #: a goal region's rows (:class:`dexpush.problem.goal_region.RegionRows`), or None for a goal pose
    region: object = None
    #: (T, 2) the planner's stall restarts and push plans so far after each step, or None
    #: (:attr:`dexpush.experiments.simulate.TrialResult.events`)
    events: np.ndarray | None = None

    def summary(self) -> dict:
        return asdict(self.record)

    def arrays(self) -> dict[str, np.ndarray]:
        """What ``trajectory.npz`` holds: the states, contact modes, commands, planning times, λ_pred, goal, disc
        obstacles and, when kept, the planner's ``events``."""
        arrays = {"states": self.states, "modes": self.modes, "commands": self.commands,
                  "planning_ms": self.planning_ms, "params": self.params, "goal": self.goal,
                  "obstacles": self.obstacles}
        return arrays if self.events is None else {**arrays, "events": self.events}


def _path_length(xy: np.ndarray) -> float:
    return float(np.sum(np.linalg.norm(np.diff(xy, axis=0), axis=-1)))


def sensor_label(sensor: Sensor | None) -> str:
    """A short human-readable description of what the controller saw (the sensor's ``describe()``)."""
    return "exact" if sensor is None else sensor.describe()


class Condition(NamedTuple):
    """What a trial's record is filed under: the scenario's key, the shape's name, the λ_pred scenario
    (``known``, ``unknown``, ``custom``) and the method's name (:data:`CONDITION_KEYS`)."""

    task: str
    shape: str
    params: str
    method: str


def make_episode(problem: Problem, condition: Condition, result: TrialResult, lanes: int, plant: str = "model",
                 sensor: Sensor | None = None, control_period: float = CONTROL_PERIOD_S,
                 method: Method | None = None) -> Episode:
    """The record (docs/conventions.md#benchmark-tasks) and trajectory of a finished trial of ``problem``.

    Contact modes are labelled with the C-GVMM at λ_true (for the trajectory figure); obstacle
    touches and clearance with the problem's obstacles; the method's own fields come from
    :meth:`dexpush.experiments.methods.Method.diagnostics` (``method``, or the registered one of
    ``condition.method``); ``control_period`` converts steps to ``time_s``.
    """
    X, U = result.states, result.commands
    if len(U):
        n = len(U)
        modes = np.asarray(contact_solution(problem.contour, _in_blocks(X[:-1]), _in_blocks(U), LAMBDA_TRUE).mode)[:n]
        xs = _in_blocks(X[1:])
        hits = problem.collides(xs)[:n]
        gaps = problem.clearance(xs)[:n] if problem.has_obstacles else None
    else:
        modes, hits, gaps = np.zeros(0, int), np.zeros(0, bool), None
    in_contact = modes != MODE_NAMES.index("free")
    pos_err, head_err = problem.goal_error(X[-1, :3])
    ms = result.step_ms if len(result.step_ms) else np.zeros(1)
    record = EpisodeRecord(
        task=condition.task, shape=condition.shape, params=condition.params, method=condition.method,
        seed=result.spec.seed, success=bool(result.success), steps=len(U), time_s=round(len(U) * control_period, 3),
        object_path_m=round(_path_length(X[:, :2]), 4), pusher_path_m=round(_path_length(X[:, 3:]), 4),
        final_error_m=round(float(pos_err), 5), final_error_deg=round(float(head_err), 3),
        collisions=int(np.sum(hits)), contact_switches=int(np.sum(in_contact[1:] != in_contact[:-1])),
        planning_ms_median=round(float(np.median(ms)), 3), planning_ms_max=round(float(np.max(ms)), 3),
        lanes=int(lanes), plant=plant, sensor=sensor_label(sensor),
        clearance_m=round(float(gaps.min()), 5) if gaps is not None else None,
        diagnostics=(method or get_method(condition.method)).diagnostics(result), frames=result.frames,
        dropped=bool(np.any(problem.dropped(X))) if problem.region_rows is not None and problem.region_rows.edge
        else None)
    return Episode(record, X, modes, U, result.step_ms, result.params, np.asarray(problem.goal),
                   np.asarray(problem.obstacles).reshape(-1, 3), tuple(np.asarray(p) for p in problem.polygons),
                   None if problem.workspace is None else np.asarray(problem.workspace), problem.region_rows,
                   result.events)


def summarize(trials: list[dict]) -> dict:
    """Per-condition numbers of docs/conventions.md#benchmark-tasks from its trial records."""
    ok = [t for t in trials if t["success"]]

    def mean_std(key: str) -> list[float] | None:
        v = np.array([t[key] for t in ok], float)
        return [round(float(v.mean()), 4), round(float(v.std()), 4)] if len(v) else None

    plan = np.array([t["planning_ms_median"] for t in trials], float)
    def reported(key: str) -> np.ndarray:
        """A diagnostic over the trials that report it."""
        values = [t.get("diagnostics", {}).get(key) for t in trials]
        return np.array([v for v in values if v is not None], float)

    offline, replans, stalls = reported("offline_plan_s"), reported("replans"), reported("stall_resets")
    gaps = np.array([t["clearance_m"] for t in trials if t.get("clearance_m") is not None], float)
    seen = [t["frames"] for t in trials if t.get("frames")]
    judged = [t["dropped"] for t in trials if t.get("dropped") is not None]
    captured = sum(f.get("captured", 0) for f in seen)
    return {"trials": len(trials), "successes": len(ok),
            "success_rate": round(len(ok) / len(trials), 4) if trials else None,
            "object_path_m": mean_std("object_path_m"), "pusher_path_m": mean_std("pusher_path_m"),
            "time_to_goal_s": mean_std("time_s"),
            "planning_ms_median": round(float(np.median(plan)), 3) if len(plan) else None,
            "planning_ms_max": round(float(max(t["planning_ms_max"] for t in trials)), 3) if trials else None,
            "offline_plan_s": [round(float(np.median(offline)), 3), round(float(offline.max()), 3)]
            if len(offline) else None,
            "replans_mean": round(float(replans.mean()), 2) if len(replans) else None,
            "stall_resets_mean": round(float(stalls.mean()), 2) if len(stalls) else None,
            # every trial's smallest obstacle clearance: the least of them, and their median (m)
            "clearance_m": [round(float(gaps.min()), 5), round(float(np.median(gaps)), 5)] if len(gaps) else None,
            # of the frames the cameras captured, the share the perception withheld (rendered cameras)
            "frames_withheld": round(sum(f.get("withheld", 0) for f in seen) / captured, 4) if captured else None,
            # with an overhang goal: trials whose object fell off the table's edge
            "drops": sum(judged) if judged else None}
