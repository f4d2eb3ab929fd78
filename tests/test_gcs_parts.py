"""The pieces of the GCS planner (dexpush.gcs.*) one at a time: regions, routes, the SE(2) step,
McCormick envelopes, the problem's heading range, the graph, and the tracker's controller interface."""

from __future__ import annotations

from dataclasses import replace
from itertools import pairwise
from types import SimpleNamespace

import numpy as np
import pytest

pytest.importorskip("pydrake")

from dexpush.gcs import GCSSettings, GCSTracker, Plan, contact_faces, free_regions
from dexpush.gcs.geometry import region_graph, region_route
from dexpush.gcs.graph import build_graph
from dexpush.gcs.problem import make_problem
from dexpush.gcs.rounding import _exact_step
from dexpush.gcs.vertices import _Lifted, contact_vertex
from dexpush.model.shape import Shape, distance_to_polygons

LAMBDA = np.array([25.0, -0.01, 0.02])          # PARAMS["known"] of the benchmark
START, PUSHER, GOAL = np.array([0.0, 0.0, 0.0]), np.array([-0.13, 0.0]), np.array([0.15, 0.05, 0.2])

SHAPES = {"rect": Shape.rectangle, "tee": Shape.tee}


@pytest.fixture(scope="module")
def rect_problem():
    return make_problem(Shape.rectangle(), START, PUSHER, GOAL, LAMBDA, 0.3, GCSSettings())


# ------------------------------------------------------------------------------- geometry
@pytest.mark.parametrize("name", ["rect", "tee"])
def test_free_regions_hold_their_face_and_clear_the_object(name):
    shape = SHAPES[name]()
    rho = shape.pusher_radius
    faces = contact_faces(shape)
    rng = np.random.default_rng(0)
    r = shape.bounding_radius + 0.1
    cloud = rng.uniform(-r, r, (20000, 2))
    for offset in (rho, rho + GCSSettings().free_margin_m):
        regions = free_regions(shape, faces, offset)
        assert len(regions) == len(faces)
        for f, region in zip(faces, regions):
            # where a contact starts and ends is in the face's own region (offset ρ) ...
            q = f.pusher_point(np.linspace(f.sigma_lo, f.sigma_hi, 41), rho)
            if offset == rho:
                assert all(region.contains(p) for p in q), f.index
            # ... and every point of a region keeps `offset` from every piece of the object
            inside = cloud[np.all(cloud @ region.A.T <= region.b, axis=1)]
            assert len(inside) > 50
            assert np.all(distance_to_polygons(inside, shape.polygons) >= offset - 1e-9)
            for j, poly in enumerate(shape.polygons):
                assert not region.contains(poly.mean(axis=0)), (f.index, j)      # no piece's centre


def test_region_graph_of_the_rect_is_a_ring_of_its_faces():
    shape = Shape.rectangle()
    faces = contact_faces(shape)
    adj = region_graph(free_regions(shape, faces, shape.pusher_radius + GCSSettings().free_margin_m))
    assert len(adj) == 4
    for i, nbrs in enumerate(adj):
        # neighbours round a corner (perpendicular faces); the opposite face's region is disjoint
        assert len(nbrs) == 2 and i not in nbrs
        assert all(abs(faces[i].n_out @ faces[j].n_out) < 1e-9 for j in nbrs)
    for i in range(4):
        for j in range(4):
            route = region_route(adj, i, j)
            assert route is not None and route[0] == i and route[-1] == j
            assert all(b in adj[a] for a, b in pairwise(route))
            assert len(route) == 1 + (0 if i == j else 1 if j in adj[i] else 2)     # fewest hops


def test_region_graph_of_the_tee_connects_every_face():
    shape = Shape.tee()
    faces = contact_faces(shape)
    adj = region_graph(free_regions(shape, faces, shape.pusher_radius + GCSSettings().free_margin_m))
    assert all(region_route(adj, 0, j) is not None for j in range(len(faces)))
    assert region_route([[1], [0], []], 0, 2) is None                              # unreachable: None


# ------------------------------------------------------------------------------- problem
def test_problem_from_the_world(rect_problem):
    P = rect_problem
    assert len(P.faces) == 4 and P.mu == pytest.approx(0.8 * 0.3)
    np.testing.assert_allclose(P.pusher_body, PUSHER)              # start heading 0: {B} = world shifted
    assert np.all(P.lo <= np.minimum(START[:2], GOAL[:2])) and np.all(P.hi >= np.maximum(START[:2], GOAL[:2]))
    turned = make_problem(Shape.rectangle(), np.array([0.1, 0.2, np.pi / 2]), np.array([0.1, 0.07]), GOAL,
                          LAMBDA, 0.3, GCSSettings())
    np.testing.assert_allclose(turned.pusher_body, [-0.13, 0.0], atol=1e-12)       # the pusher, seen from {B}


def test_heading_range_covers_start_and_goal_the_short_way(rect_problem):
    rng = np.random.default_rng(1)
    pad = rect_problem.settings.heading_pad_rad
    for th0, thg in [(3.0, -3.0), (-3.0, 3.0), (0.0, 0.0), *rng.uniform(-np.pi, np.pi, (50, 2))]:
        P = replace(rect_problem, start=np.array([0.0, 0.0, th0]), goal=np.array([0.1, 0.0, thg]))
        lo, hi = P.heading_range
        assert lo <= th0 - pad + 1e-12 and th0 + pad <= hi + 1e-12
        goals = thg + 2 * np.pi * np.array([-1, 0, 1])
        assert np.any((lo + pad - 1e-12 <= goals) & (goals <= hi - pad + 1e-12)), (th0, thg, lo, hi)
        assert hi - lo <= np.pi + 2 * pad + 1e-12                                  # never the long way round


# ------------------------------------------------------------------------------- dynamics
def _moment_free_impulse(P, f, sigma, cn):
    """c_f such that the impulse (c_n, c_f) at σ on f turns the object by exactly 0 (ω linear in c_f)."""
    w0 = P.twist(P.step_wrench(f, sigma, cn, 0.0))[2]
    w1 = P.twist(P.step_wrench(f, sigma, cn, 1.0))[2]
    return -w0 / (w1 - w0)


def test_exact_step_without_rotation_is_a_translation(rect_problem):
    P = rect_problem
    f = P.faces[0]
    sigma = 0.5 * (f.sigma_lo + f.sigma_hi)
    cf = _moment_free_impulse(P, f, sigma, 0.02)
    vx, vy, w = P.twist(P.step_wrench(f, sigma, 0.02, cf))
    assert abs(w) < 1e-15 and np.hypot(vx, vy) > 1e-4
    th, x, y = 0.7, 0.1, -0.2
    th1, x1, y1 = _exact_step(P, f, (th, x, y), sigma, 0.02, cf)
    assert th1 == pytest.approx(th, abs=1e-15)
    np.testing.assert_allclose([x1, y1], [x + np.cos(th) * vx - np.sin(th) * vy, y + np.sin(th) * vx + np.cos(th) * vy],
                               atol=1e-15)


@pytest.mark.parametrize(("face", "ratio", "turn"), [(0, 0.2, 0.05), (1, -0.2, 0.3), (3, 0.0, 0.5), (2, 0.1, 0.01)])
def test_exact_step_matches_fine_euler_integration_of_the_twist(rect_problem, face, ratio, turn):
    P = rect_problem
    f = P.faces[face]
    sigma = f.sigma_lo + 0.3 * (f.sigma_hi - f.sigma_lo)
    # the impulse c_f = ratio·c_n at σ that turns the object by `turn` rad (≤ max_step_rad = 0.5)
    cn = turn / abs(P.twist(P.step_wrench(f, sigma, 1.0, ratio))[2])
    cf = ratio * cn
    vx, vy, w = P.twist(P.step_wrench(f, sigma, cn, cf))
    assert abs(w) == pytest.approx(turn) and np.hypot(vx, vy) > 1e-4
    pose = (-0.4, 0.3, 0.1)
    n = 200_000
    th = pose[0] + w * np.arange(n) / n                          # constant body twist over unit time
    x = pose[1] + np.sum(np.cos(th) * vx - np.sin(th) * vy) / n
    y = pose[2] + np.sum(np.sin(th) * vx + np.cos(th) * vy) / n
    np.testing.assert_allclose(_exact_step(P, f, pose, sigma, cn, cf), (pose[0] + w, x, y), atol=1e-6)


# ------------------------------------------------------------------------------- relaxation
def _envelope(L, w, u, v, zu, zv):
    """The interval of w that L's inequalities leave for z[u] = zu, z[v] = zv."""
    lower, upper = -np.inf, np.inf
    for terms, bound in L.ineq:
        if w not in terms:
            continue
        rest = bound - terms.get(u, 0.0) * zu - terms.get(v, 0.0) * zv
        if terms[w] > 0:
            upper = min(upper, rest / terms[w])
        else:
            lower = max(lower, rest / terms[w])
    return lower, upper


def test_mccormick_envelope_holds_the_true_product():
    rng = np.random.default_rng(2)
    for _ in range(30):
        lu, lv = rng.uniform(-1, 1, 2)
        hu, hv = lu + rng.uniform(0.01, 2), lv + rng.uniform(0.01, 2)
        L = _Lifted()
        u, v = int(L.new(1, lu, hu)[0]), int(L.new(1, lv, hv)[0])
        w = L.product(u, v)
        for zu, zv in zip(rng.uniform(lu, hu, 200), rng.uniform(lv, hv, 200)):
            lower, upper = _envelope(L, w, u, v, zu, zv)
            assert lower - 1e-12 <= zu * zv <= upper + 1e-12
        for zu in (lu, hu):                                       # tight at the box's corners
            for zv in (lv, hv):
                np.testing.assert_allclose(_envelope(L, w, u, v, zu, zv), (zu * zv, zu * zv), atol=1e-12)
        # the polyhedron (with the box rows) holds the lifted point of every (u, v) in the box
        poly = L.polyhedron()
        zu, zv = rng.uniform(lu, hu), rng.uniform(lv, hv)
        assert poly.PointInSet(np.array([zu, zv, zu * zv]), 1e-9)
        assert not poly.PointInSet(np.array([hu + 0.1, zv, (hu + 0.1) * zv]), 1e-9)


def test_rotation_coefficients_match_the_twist(rect_problem):
    """δθ = M₂·[f; q(σ) × f] is linear in (c_n, c_f) plus a σ·c_n term: the relaxation's coefficients."""
    from dexpush.gcs.vertices import _rotation_coefficients

    P = rect_problem
    rng = np.random.default_rng(3)
    for f in P.faces:
        g_n, g_t, g_sn = _rotation_coefficients(P, f)
        for sigma, cn, cf in rng.uniform(0, 0.05, (10, 3)):
            w = P.twist(P.step_wrench(f, sigma, cn, cf))[2]
            assert w == pytest.approx(g_n * cn + g_t * cf + g_sn * sigma * cn, abs=1e-12)


@pytest.mark.parametrize("relaxation", ["mccormick", "sdp"])
def test_contact_vertex_names_its_variables(rect_problem, relaxation):
    from pydrake.geometry.optimization import GraphOfConvexSets

    P = replace(rect_problem, settings=GCSSettings(relaxation=relaxation))
    V = contact_vertex(GraphOfConvexSets(), P, P.faces[2])
    N = P.settings.knots
    assert V.kind == "contact" and V.name == "face 2" and V.face == 2 and V.knots == N
    sizes = {k: np.size(V.var(k)) for k in ("c", "s", "x", "y", "sigma", "cn", "cf", "omega")}
    assert sizes == dict(c=N, s=N, x=N, y=N, sigma=1, cn=N - 1, cf=N - 1, omega=N - 1)


def test_graph_of_the_rect(rect_problem):
    G = build_graph(rect_problem)
    names = set(G.vertices)
    faces = {f"face {i}" for i in range(4)}
    starts = {f"start -> face {i}" for i in range(4)}
    pairs = {f"face {i} -> face {j}" for i in range(4) for j in range(4) if i != j}
    assert names == faces | starts | pairs
    assert G.source.name == "start" and G.target.name == "goal"
    # every contact ends at the goal or moves on through a free motion; every free motion ends in contact
    n_edges = len(starts) * 2 + len(faces) + len(pairs) * 2
    assert len(G.gcs.Edges()) == n_edges


# ------------------------------------------------------------------------------- tracker
def _fake_plan(pose, pusher, steps=20, dt=0.04):
    times = np.arange(steps) * dt
    path = pusher + np.outer(np.arange(steps), [0.002, 0.001])
    return Plan(["start", "goal"], [], times, np.tile(pose, (steps, 1)), path, np.full(steps, -1), 0.0, 0.0, 0.0, 0.0,
                0.0)


@pytest.fixture
def fake_planner(monkeypatch):
    calls = []

    def plan_push(shape, start, pusher, goal, params, mu, settings, dt):
        calls.append((start.copy(), pusher.copy()))
        return _fake_plan(start, pusher, dt=dt)

    monkeypatch.setattr("dexpush.gcs.tracker.plan_push", plan_push)
    return calls


def _frame(pose, pusher):
    return SimpleNamespace(object_pose=np.array(pose, dtype=np.float64), pusher_xy=np.array(pusher, dtype=np.float64),
                           time=0.0)


def test_tracker_act_needs_a_first_frame(fake_planner):
    tracker = GCSTracker(Shape.rectangle(), GOAL, LAMBDA)
    with pytest.raises(ValueError, match="frame"):
        tracker.act(None)
    assert not fake_planner and not tracker.planning_s
    tracker.act(_frame(START, PUSHER))
    tracker.act(None)
    tracker.reset()                                               # a new episode forgets the last frame
    with pytest.raises(ValueError, match="frame"):
        tracker.act(None, 0.04)


def test_tracker_reset_with_poses_plans_once_before_acting(fake_planner):
    tracker = GCSTracker(Shape.rectangle(), GOAL, LAMBDA)
    tracker.reset(START, PUSHER)
    assert len(fake_planner) == 1 and len(tracker.plans) == 1 and len(tracker.planning_s) == 1
    np.testing.assert_array_equal(fake_planner[0][0], START)
    tracker.act(_frame(START, PUSHER))
    assert len(fake_planner) == 1                                 # on track: no replan
    tracker.reset()
    assert tracker.plans == [] and tracker.planning_s == [] and tracker.failures == [] and not tracker.gave_up
    assert len(fake_planner) == 1                                 # reset without poses does not plan
    with pytest.raises(ValueError, match="both"):
        tracker.reset(START)
    with pytest.raises(ValueError, match="pusher_xy"):
        tracker.reset(START, [0.0, np.nan])
    assert len(fake_planner) == 1


def test_tracker_act_is_command(fake_planner):
    shape = Shape.rectangle()
    a, b = GCSTracker(shape, GOAL, LAMBDA), GCSTracker(shape, GOAL, LAMBDA)
    a.reset(START, PUSHER)
    b.reset(START, PUSHER)
    rng = np.random.default_rng(4)
    pusher, last = PUSHER.copy(), None
    for step in range(8):
        pose = START + rng.normal(0, 1e-3, 3)
        frame = None if step in (3, 6) else _frame(pose, pusher)
        if frame is None:
            expected = b.command(last.object_pose, last.pusher_xy)   # no new frame: the last one again
        else:
            expected, last = b.command(frame.object_pose, frame.pusher_xy), frame
        u = a.act(frame, frame_period=0.1 * step + 0.01)        # frame_period is ignored
        np.testing.assert_array_equal(u, expected)
        pusher = pusher + 0.04 * u
    # the tracker keeps its own copy of the frame
    frame = _frame(START, PUSHER)
    a.act(frame)
    b.command(START, PUSHER)
    frame.object_pose[:] = 1.0
    np.testing.assert_array_equal(a.act(None), b.command(START, PUSHER))


def test_tracker_params_is_read_only():
    tracker = GCSTracker(Shape.rectangle(), GOAL, [25, -0.01, 0.02])
    p = tracker.params
    assert p.dtype == np.float64 and p.shape == (3,)
    np.testing.assert_array_equal(p, LAMBDA)
    p[0] = 1.0
    np.testing.assert_array_equal(tracker.params, LAMBDA)
    with pytest.raises(AttributeError):
        tracker.params = np.zeros(3)


def test_tracker_reset_makes_the_real_offline_plan():
    tracker = GCSTracker(Shape.rectangle(), GOAL, LAMBDA)
    tracker.reset(START, PUSHER)
    assert len(tracker.plans) == 1 and not tracker.failures
    plan = tracker.plans[0]
    np.testing.assert_array_equal(plan.params, LAMBDA)
    np.testing.assert_allclose(plan.poses[0], START, atol=1e-9)
    u = tracker.act(_frame(plan.poses[0], plan.pusher[0]))
    u_max = 0.1 / np.sqrt(2)
    np.testing.assert_allclose(u, np.clip((plan.pusher[1] - plan.pusher[0]) / 0.04, -u_max, u_max))
    assert len(tracker.plans) == 1                                # on the plan: no replan
