"""The GCS plan-and-track baseline (dexpush.gcs): faces, plans, replay through the C-GVMM, errors."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest

pytest.importorskip("pydrake")

from dexpush.common.se2 import pose_error
from dexpush.experiments.benchmark import run_benchmark
from dexpush.experiments.registry import PARAMS, make_shape
from dexpush.experiments.scenarios import get_task, initial_conditions
from dexpush.experiments.tables import write_tables
from dexpush.gcs import GCSSettings, GCSTracker, PlanningError, contact_faces, plan_push
from dexpush.model.cgvmm import Contour, replay
from dexpush.model.shape import Shape, distance_to_polygons

_PLANS: dict = {}


def _plan(shape: str, task: str, seed: int, params: str = "known"):
    key = (shape, task, seed, params)
    if key not in _PLANS:
        s, t = make_shape(shape), get_task(task)
        pose, pusher = initial_conditions(t, s, seed)
        _PLANS[key] = (s, t, pose, pusher, plan_push(s, pose, pusher, t.goal, PARAMS[params]))
    return _PLANS[key]


def test_faces_of_rect_and_tee():
    rect = contact_faces(make_shape("rect"))
    assert len(rect) == 4
    assert np.allclose(sorted(tuple(f.n_out.round(6)) for f in rect), sorted([(0, -1), (1, 0), (0, 1), (-1, 0)]))
    tee = make_shape("tee")
    faces = contact_faces(tee, sigma_margin=0.0)
    assert len(faces) == 8
    # the pusher on a face never overlaps the other piece: concave corners shorten the faces by ρ
    for f in faces:
        q = f.pusher_point(np.linspace(f.sigma_lo, f.sigma_hi, 50), tee.pusher_radius)
        for j, poly in enumerate(tee.polygons):
            if j != f.polygon:
                assert np.all(distance_to_polygons(q, [poly]) >= tee.pusher_radius - 1e-9)
    bar_under = [f for f in faces if np.allclose(f.n_out, (0, -1)) and f.polygon == 0]
    assert len(bar_under) == 2 and all(abs(f.d[0] * (f.sigma_hi - f.sigma_lo)) < 0.075 - 0.009 for f in bar_under)


def test_non_convex_piece_is_rejected():
    ell = Shape.polygon([[0, 0], [0.1, 0], [0.1, 0.1], [0.05, 0.02], [0, 0.1]], reference=(0.05, 0.01))
    with pytest.raises(PlanningError, match="convex"):
        contact_faces(ell)


def test_plan_replays_through_the_cgvmm():
    """Every step of the plan obeys the C-GVMM with the same λ (quasi-static dynamics,
    sticking inside the friction cone): each control step, replayed from the plan's own
    state, lands on the plan's next state; the whole plan replayed open loop ends near
    its end (pushing from behind is open-loop unstable, so errors grow along a long push;
    see docs/gcs.md)."""
    shape, task, pose, _pusher, plan = _plan("rect", "I", 1)
    assert plan.modes[0] == "start" and plan.modes[-1] == "goal"
    assert any(m.startswith("face") for m in plan.modes)
    np.testing.assert_allclose(plan.poses[0], pose, atol=1e-9)
    end_err = np.linalg.norm(plan.poses[-1, :2] - np.asarray(task.goal[:2]))
    assert end_err < 1e-3 and abs(plan.poses[-1, 2] - task.goal[2]) < np.radians(0.5)
    u = plan.commands()
    assert np.all(np.abs(u) <= 0.1 / np.sqrt(2) + 1e-9)
    contour, lam = Contour.of(shape), jnp.asarray(PARAMS["known"], jnp.float32)
    states = np.concatenate([plan.poses, plan.pusher], -1)
    one = jax.vmap(lambda x, v: replay(contour, x, v[None], jnp.float32(0.04), lam, jnp.float32(0.3))[0])
    nxt = np.asarray(one(jnp.asarray(states[:-1], jnp.float32), jnp.asarray(u, jnp.float32)))
    step_err = np.linalg.norm(nxt[:, :2] - plan.poses[1:, :2], axis=1)
    step_deg = np.degrees(np.abs(nxt[:, 2] - plan.poses[1:, 2]))
    # inside a mode a step lands within float32 round-off; the steps that straddle a mode
    # change (the reference is sampled every 0.04 s across the switch) within 0.5 mm / 0.3°
    assert np.median(step_err) < 1e-5 and np.median(step_deg) < 1e-3
    assert step_err.max() < 5e-4 and step_deg.max() < 0.3, (step_err.max(), step_deg.max())
    assert np.any(plan.face >= 0) and np.any(step_deg > 1e-3)      # it did push and turn the object
    X = np.asarray(replay(contour, jnp.asarray(states[0], jnp.float32), jnp.asarray(u, jnp.float32),
                          jnp.float32(0.04), lam, jnp.float32(0.3)))
    err = np.linalg.norm(X[-1, :2] - plan.poses[-1, :2])
    dth = np.degrees(abs(np.angle(np.exp(1j * (X[-1, 2] - plan.poses[-1, 2])))))
    assert err < 0.01 and dth < 5.0, (err, dth)


# tee II seed 4 rounds only on the retry with 7 knots (GCSSettings.retry_knots)
@pytest.mark.parametrize(("shape", "task", "seed"), [("rect", "II", 1), ("tee", "I", 0), ("rect", "I", 2),
                                                     ("tee", "II", 4)])
def test_plan_exists(shape, task, seed):
    _s, t, _pose, _, plan = _plan(shape, task, seed)
    assert plan.rounded_cost >= plan.relaxation_cost - 1e-6     # the relaxation is a lower bound
    assert np.linalg.norm(plan.poses[-1, :2] - np.asarray(t.goal[:2])) < 1e-3
    assert pose_error(plan.poses[-1], t.goal)[1] < 0.5
    assert plan.planning_s > 0 and len(plan.knots) >= 1


def test_solver_failure_is_an_error_not_an_empty_plan():
    shape, task = make_shape("rect"), get_task("I")
    pose, pusher = initial_conditions(task, shape, 1)
    tiny = GCSSettings(max_step_m=0.002, workspace_margin_m=0.05)     # 0.67 m cannot be covered
    with pytest.raises(PlanningError):
        plan_push(shape, pose, pusher, task.goal, PARAMS["known"], settings=tiny)


def test_tracker_gives_up_when_planning_fails():
    shape, task = make_shape("rect"), get_task("I")
    pose, pusher = initial_conditions(task, shape, 1)
    tracker = GCSTracker(shape, task.goal, PARAMS["known"], settings=GCSSettings(max_step_m=0.002,
                                                                               workspace_margin_m=0.05))
    assert not tracker.gave_up
    assert np.all(tracker.command(pose, pusher) == 0.0)
    assert tracker.gave_up and len(tracker.failures) == 1 and not tracker.plans


def test_bench_fills_the_gcs_column_and_skips_task_iii(tmp_path):
    records = run_benchmark(tmp_path, ["I", "III"], ["rect"], ["known"], ["gcs"], [1], max_steps=30,
                            progress=False, figures=False)
    assert [(r["task"], r["method"]) for r in records] == [("I", "gcs")]
    gcs = records[0]
    assert gcs["steps"] == 30 and not gcs["success"] and gcs["lanes"] == 1
    assert gcs["diagnostics"]["offline_plan_s"] > 0.01 and gcs["diagnostics"]["replans"] >= 0
    assert not (tmp_path / "conditions" / "III_rect_known_gcs.json").exists()
    table = Path(write_tables(tmp_path, records, {})["markdown"]).read_text()
    row = next(line for line in table.splitlines() if "| gcs |" in line)
    assert row.startswith("| I | rect | known | gcs | 0/1") and "not implemented" not in table
    again = run_benchmark(tmp_path, ["I"], ["rect"], ["known"], ["gcs"], [1], max_steps=30, progress=False,
                          figures=False)
    assert again == [gcs]                   # resumed from the condition file, not re-run


def test_bad_input():
    shape = make_shape("rect")
    with pytest.raises(ValueError, match="start"):
        plan_push(shape, [0, np.nan, 0], [0.2, 0], [0.6, 0.3, 0], PARAMS["known"])
    with pytest.raises(ValueError, match="relaxation"):
        GCSSettings(relaxation="magic")
    with pytest.raises(PlanningError, match="pusher"):
        plan_push(shape, [0, 0, 0], [0.0, 0.0], [0.6, 0.3, 0], PARAMS["known"])    # pusher inside the object


def test_cli_runs_gcs_and_refuses_task_iii(tmp_path):
    out = tmp_path / "run"
    proc = subprocess.run([sys.executable, "-m", "dexpush.cli", "run", "--task", "I", "--shape", "rect",
                           "--method", "gcs", "--seed", "1", "--max-steps", "40", "--out", str(out)],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 1, proc.stderr[-2000:]      # 40 steps cannot reach the goal: exit 1
    rec = json.loads(proc.stdout.strip().splitlines()[-1])
    assert rec["method"] == "gcs" and rec["steps"] == 40 and rec["diagnostics"]["offline_plan_s"] > 0.01 \
        and rec["diagnostics"]["replans"] >= 0
    bad = subprocess.run([sys.executable, "-m", "dexpush.cli", "run", "--task", "III", "--method", "gcs",
                          "--out", str(tmp_path / "bad")], capture_output=True, text=True, timeout=300)
    assert bad.returncode != 0 and "obstacle" in bad.stderr
