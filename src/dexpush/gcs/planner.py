"""The entry point :func:`plan_push`: build the graph, solve its relaxation, round a path, time the plan."""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from dexpush.common.checks import check_params, checked_vector
from dexpush.common.interfaces import CONTROL_PERIOD_S
from dexpush.gcs.graph import build_graph, solve_relaxation, two_mode_paths
from dexpush.gcs.problem import Plan, make_problem
from dexpush.gcs.rounding import round_path, timed_reference
from dexpush.gcs.settings import GCSSettings, PlanningError
from dexpush.model.cgvmm import MU_C
from dexpush.model.shape import Shape

__all__ = ["plan_push"]


def _quiet_drake() -> None:
    """Drake logs every GCS solve at INFO; keep warnings only."""
    import logging

    logging.getLogger("drake").setLevel(logging.WARNING)


def plan_push(shape: Shape, start: object, pusher: object, goal: object, params: object,
              mu: float = MU_C, settings: GCSSettings | None = None, dt: float = CONTROL_PERIOD_S) -> Plan:
    """Plan a push of ``shape`` from ``start`` (x, y, θ) with the pusher at ``pusher`` to ``goal``.

    The plan uses ``params`` (λ = [β, x_bf, y_bf]) in the limit surface and the
    pusher–object friction ``mu``; it is sampled every ``dt`` seconds. Raises
    :class:`PlanningError` when the relaxation is infeasible or the rounding fails, and
    ``ValueError`` for bad input.
    """
    settings = settings or GCSSettings()
    if not isinstance(shape, Shape):
        raise ValueError(f"shape must be a dexpush Shape, got {type(shape).__name__}")
    start = checked_vector("start", start, 3)
    pusher = checked_vector("pusher", pusher, 2)
    goal = checked_vector("goal", goal, 3)
    p = checked_vector("params", params, 3)
    check_params(p)
    if not (np.isfinite(mu) and mu > 0):
        raise ValueError(f"mu must be positive, got {mu}")
    if not dt > 0:
        raise ValueError(f"dt must be positive, got {dt}")
    _quiet_drake()
    t0 = time.perf_counter()
    ladder = [settings] + [replace(settings, knots=int(k), retry_knots=()) for k in settings.retry_knots]
    for i, attempt in enumerate(ladder):
        try:
            plan = _plan_once(shape, start, pusher, goal, p, float(mu), attempt, dt)
            break
        except PlanningError:
            if i == len(ladder) - 1:
                raise
    plan.planning_s = time.perf_counter() - t0       # all attempts
    return plan


def _plan_once(shape: Shape, start: np.ndarray, pusher: np.ndarray, goal: np.ndarray, p: np.ndarray, mu: float,
               settings: GCSSettings, dt: float) -> Plan:
    """One build–relax–round pass of :func:`plan_push` with fixed settings."""
    t0 = time.perf_counter()
    P = make_problem(shape, start, pusher, goal, p, mu, settings)
    G = build_graph(P)
    t1 = time.perf_counter()
    candidates, values, relax_cost, vertex_flow = solve_relaxation(G, P)
    t2 = time.perf_counter()
    # the relaxation's own paths first; if none rounds (a loose relaxation likes a single
    # contact mode that cannot end exactly at the goal), the two-mode paths through the
    # faces that carry the most relaxed flow, warm-started by interpolation
    fallback = two_mode_paths(G, vertex_flow)[: settings.max_enumerated_paths]
    best, errors = None, []
    for path in candidates + fallback:
        try:
            sol, cost = round_path(path, values if path in candidates else {}, P)
        except PlanningError as exc:
            errors.append(str(exc))
            continue
        best = (path, sol, cost)
        break
    if best is None:
        raise PlanningError(f"no path of the GCS relaxation could be rounded with {settings.knots} knots "
                            f"({len(errors)} tried); "
                            f"first failure: {errors[0]}")
    relax_s, round_s = t2 - t1, time.perf_counter() - t2
    path, sol, rounded_cost = best
    knots, times, poses, pusher_ref, face = timed_reference(path, sol, P, dt)
    return Plan([V.name for V in path], knots, times, poses, pusher_ref, face, relax_cost, rounded_cost,
                relaxation_s=relax_s, rounding_s=round_s, planning_s=time.perf_counter() - t0, params=p)
