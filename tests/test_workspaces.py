"""Boxes, walls and workspaces: their validation, their gaps, the cost-to-go, Task IV and the clutter family,
and the scene file."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from dexpush import Shape
from dexpush.common.se2 import wrap_angle
from dexpush.experiments.scenarios import TASKS, initial_conditions
from dexpush.problem.guidance import GRID_STRETCH, cost_to_go
from dexpush.problem.obstacles import _polygon_gaps_vectorised, clearance, obstacle_distances, polygon_gaps
from dexpush.problem.problem import Problem
from dexpush.problem.regions import box, clip_convex, convex_polygon, halfplanes, point_gap, wall, workspace_halfplanes
from dexpush.problem.scene import Scene
from dexpush.problem.scene_file import Layout, load_scene
from dexpush.problem.weights import CostWeights

RECT = Shape.rectangle()


# ---------------------------------------------------------------- regions
@pytest.mark.parametrize("corners, message", [
    ([[0, 0], [1, 0]], "3"),
    ([[0, 0], [1, 0], [2, 0]], "area"),
    ([[0, 0], [2, 0], [1, 0.2], [2, 2], [0, 2]], "convex"),
])
def test_degenerate_polygons_are_refused(corners: list, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        convex_polygon(corners, "box 0")


def test_regions_have_the_size_they_are_given() -> None:
    b = box(0.3, -0.1, 0.2, 0.1, np.pi / 6)
    e = np.roll(b, -1, 0) - b
    assert sorted(np.round(np.hypot(*e.T), 9)) == [0.1, 0.1, 0.2, 0.2]
    w = wall(0.0, 0.0, 0.5, 0.0, 0.02)
    assert np.allclose(np.sort(w[:, 1]), [-0.01, -0.01, 0.01, 0.01]) and np.ptp(w[:, 0]) == pytest.approx(0.5)
    with pytest.raises(ValueError, match="x_hi > x_lo"):
        workspace_halfplanes((0.0, 0.0, -1.0, 1.0))
    assert point_gap(np.array([0.0, 0.5]), w) == pytest.approx(0.49)
    assert point_gap(np.array([0.25, 0.0]), w) == pytest.approx(-0.01)


# ---------------------------------------------------------------- gaps
def _segments_cross(p: np.ndarray, q: np.ndarray) -> bool:
    def side(a, b, c):
        return np.sign((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))
    for a, b in zip(p, np.roll(p, -1, 0)):
        for c, d in zip(q, np.roll(q, -1, 0)):
            if side(a, b, c) != side(a, b, d) and side(c, d, a) != side(c, d, b):
                return True
    return False


def _true_gap(p: np.ndarray, q: np.ndarray) -> float:
    """The distance between two convex polygons (0 when they overlap), from their corners and edges."""
    if _segments_cross(p, q) or np.any(point_gap(p, q) < 0) or np.any(point_gap(q, p) < 0):
        return 0.0
    return float(min(np.min(np.abs(point_gap(p, q))), np.min(np.abs(point_gap(q, p)))))


@settings(max_examples=60, deadline=None)
@given(st.floats(-0.3, 0.3), st.floats(-0.3, 0.3), st.floats(-np.pi, np.pi),
       st.floats(0.02, 0.2), st.floats(0.02, 0.2), st.floats(-np.pi, np.pi))
def test_separating_axis_gap_is_negative_exactly_on_overlap_and_never_more_than_the_gap(
        x: float, y: float, th: float, w: float, h: float, yaw: float) -> None:
    obstacle = box(0.1, 0.05, w, h, yaw)
    problem = Problem(RECT, (0.0, 0.6, 0.0), polygons=(obstacle,), weights=CostWeights(guidance=False))
    state = np.array([x, y, th, 2.0, 2.0])           # the pusher far away: only the footprint counts
    body, _ = next(polygon_gaps(state, problem.judge_scene))
    footprint = RECT.footprint_world(np.array([x, y, th]))[0]
    true = _true_gap(footprint, obstacle)
    assert (float(body) < 0) == (true == 0.0) or abs(float(body)) < 1e-5
    assert float(body) <= true + 1e-5


@pytest.mark.parametrize("name", ["ellipse", "tee"])
def test_the_array_reductions_give_the_unrolled_gaps(name: str) -> None:
    shape = Shape.ellipse() if name == "ellipse" else Shape.tee()
    problem = Problem(shape, (0.0, 0.6, 0.0), ((0.25, 0.1, 0.03),), polygons=(box(-0.2, 0.1, 0.1, 0.05, 0.4),),
                      weights=CostWeights(guidance=False))
    rng = np.random.default_rng(0)
    x = np.c_[rng.uniform(-0.3, 0.3, (64, 2)), rng.uniform(-3, 3, 64), rng.uniform(-0.3, 0.3, (64, 2))]
    scene = problem.scene                      # at most 32 corners per piece: the unrolled path
    unrolled = [np.asarray(b) for b, _ in polygon_gaps(x, scene)]
    arrays = [np.asarray(b) for b, _ in _polygon_gaps_vectorised(x, scene)]
    np.testing.assert_allclose(arrays, unrolled, atol=1e-6)
    # the judge's 256-edge ellipse takes the array path for the discs; its gaps agree with the cost's
    # 12-edge outline (circumscribed) to the outline's 4.9 mm sag
    judge = [np.asarray(d2) for _, _, d2, _, _ in obstacle_distances(x, problem.judge_scene)]
    cost = [np.asarray(d2) for _, _, d2, _, _ in obstacle_distances(x, scene)]
    np.testing.assert_allclose(np.sqrt(judge), np.sqrt(cost), atol=5e-3)


def test_workspace_gap_is_exact_for_a_box_in_a_rectangle() -> None:
    problem = Problem(RECT, (0.0, 0.0, 0.0), workspace=(-0.5, -0.3, 0.5, 0.3), weights=CostWeights(guidance=False))
    x = np.array([[0.2, 0.0, 0.0, 0.0, 0.0], [0.2, 0.0, np.pi / 2, 0.0, 0.0], [0.45, 0.0, 0.0, 0.0, 0.0]])
    np.testing.assert_allclose(np.asarray(clearance(x, problem.judge_scene)), [0.2, 0.2, -0.05], atol=1e-6)


def test_a_problem_without_obstacles_has_no_guide_and_the_same_scene() -> None:
    plain = Problem(RECT, (0.6, 0.3, 0.0))
    assert plain.guide is None and not plain.has_obstacles
    assert plain.scene.guide.size == 0 and plain.scene.polygons.shape[0] == 0 and plain.scene.bounds.shape[0] == 0
    assert Scene.make(RECT, np.array([0.6, 0.3, 0.0]), np.zeros((0, 3)), CostWeights()).polygons.shape[0] == 0


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 10_000), st.integers(1, 6))
def test_clipping_keeps_exactly_the_points_inside_both(seed: int, cuts: int) -> None:
    rng = np.random.default_rng(seed)
    square = np.array([[-0.3, -0.3], [0.3, -0.3], [0.3, 0.3], [-0.3, 0.3]])
    ang = rng.uniform(0, 2 * np.pi, cuts)
    rows = np.c_[np.cos(ang), np.sin(ang), rng.uniform(-0.1, 0.4, cuts)]
    clipped = clip_convex(square, rows)
    pts = rng.uniform(-0.35, 0.35, (400, 2))
    both = np.maximum(np.max(pts @ rows[:, :2].T - rows[:, 2], 1), point_gap(pts, square))   # < 0: inside both
    if len(clipped) == 0:
        assert not np.any(both < -1e-6)
        return
    assert np.all(clipped @ rows[:, :2].T - rows[:, 2] <= 1e-9)           # every corner keeps every cut
    assert np.all(point_gap(clipped, square) <= 1e-9)
    h = halfplanes(convex_polygon(clipped))                                 # convex and counter-clockwise
    clip = np.max(pts @ h[:, :2].T - h[:, 2], 1)
    assert not np.any((both < -1e-6) & (clip > 1e-6)) and not np.any((clip < -1e-6) & (both > 1e-6))


def test_the_object_and_pusher_workspaces_bound_each_alone() -> None:
    """An object-only bound charges the footprint's leaving it, not the pusher's, a pusher-only bound (a robot's
    reach) the reverse; the judge leaves both out; without them the scene is what it was."""
    from dexpush.problem.cost import obstacle_cost
    w = CostWeights(guidance=False)
    inner = (-0.3, -0.3, 0.3, 0.3)
    free = Problem(RECT, (0.0, 0.0, 0.0), workspace=(-1.0, -1.0, 1.0, 1.0), weights=w)
    obj = Problem(RECT, (0.0, 0.0, 0.0), workspace=(-1.0, -1.0, 1.0, 1.0), weights=w, object_workspace=inner)
    push = Problem(RECT, (0.0, 0.0, 0.0), workspace=(-1.0, -1.0, 1.0, 1.0), weights=w, pusher_workspace=inner)
    assert free.scene.object_bounds.shape[0] == free.scene.pusher_bounds.shape[0] == 0
    assert obj.scene.object_bounds.shape[0] == push.scene.pusher_bounds.shape[0] == 4
    object_out = np.array([[0.35, 0.0, 0.0, 0.0, 0.2]])      # the footprint past x = 0.3, the pusher inside
    pusher_out = np.array([[0.0, 0.0, 0.0, 0.35, 0.0]])      # the pusher past x = 0.3, the footprint inside
    cost = lambda p, x: float(np.asarray(obstacle_cost(x, p.scene, w))[0])   # noqa: E731
    assert cost(free, object_out) == cost(free, pusher_out) == 0.0
    assert cost(obj, object_out) >= w.C_pen and cost(obj, pusher_out) == 0.0
    assert cost(push, pusher_out) >= w.C_pen and cost(push, object_out) == 0.0
    assert not obj.collides(object_out)[0] and not push.collides(pusher_out)[0]     # no touch
    assert set(obj.with_weights(w).object_workspace) == set(obj.object_workspace)
    assert set(push.with_weights(w).pusher_workspace) == set(push.pusher_workspace)


@settings(max_examples=25, deadline=None)
@given(st.floats(-0.02, 0.02), st.floats(0.0005, 0.02))
def test_the_pusher_keeps_its_own_margin_from_its_own_bounds(gap: float, margin: float) -> None:
    """The pusher's gap g to a bound of its own (a robot's reach) costs C_margin·(1 − g/m_p) within
    ``pusher_bound_margin_m`` = m_p and C_pen past it, the workspace's edge (a table's) C_margin·(1 − g/m) within
    ``obstacle_margin_m`` = m as before; a plan from inside either margin keeps the state's own gap as that margin."""
    from dexpush.problem.cost import obstacle_cost, plan_margin
    w = CostWeights(guidance=False, pusher_bound_margin_m=margin)
    edge = 0.3 + RECT.pusher_radius
    own = Problem(RECT, (0.0, 0.0, 0.0), weights=w, pusher_workspace=(-edge, -edge, edge, edge))
    table = Problem(RECT, (0.0, 0.0, 0.0), weights=w, workspace=(-edge, -edge, edge, edge))
    assume(abs(gap) > 1e-5)                                              # a touch or not, in float32 too
    x = np.array([[0.0, 0.0, 0.0, 0.3 - gap, 0.0]], np.float32)        # the pusher's disc `gap` inside x = edge
    for problem, field, m in ((own, "pusher_margin", margin), (table, "margin", w.obstacle_margin_m)):
        got = float(np.asarray(obstacle_cost(x, problem.scene, w))[0])
        expected = w.C_pen + w.C_margin if gap < 0 else w.C_margin * min(max(1.0 - gap / m, 0.0), 1.0)
        assert got == pytest.approx(expected, rel=1e-4, abs=w.C_margin * 1e-4), (field, got, expected)
        planned = plan_margin(x[0], problem.scene, w)
        assert float(getattr(planned, field)) == pytest.approx(min(max(gap, 1e-4), m), abs=1e-6)
    assert float(plan_margin(x[0], own.scene, w).margin) == pytest.approx(w.obstacle_margin_m)   # the other margin kept


@settings(max_examples=25, deadline=None)
@given(st.floats(-0.4, 0.4), st.floats(-0.4, 0.4), st.floats(-np.pi, np.pi), st.floats(0.0, 2 * np.pi))
def test_a_keep_out_disc_charges_what_a_disc_obstacle_would_and_is_no_touch(x: float, y: float, th: float,
                                                                           phi: float) -> None:
    """A keep-out disc (c, r_o, r_p) gives the footprint the gap a disc obstacle of radius r_o at c gives it, and
    the pusher the gap of a disc of radius r_p (exact, inside the footprint too), in the world's and the
    controller's frames; the judge leaves it out (no touch), and the guidance goes round it."""
    w = CostWeights()
    centre, r_o, r_p = (0.05, -0.02), 0.12, 0.05
    pusher = (x + 0.15 * np.cos(phi), y + 0.15 * np.sin(phi))
    state = np.array([[x, y, th, *pusher]], np.float32)
    keep = Problem(RECT, (0.6, 0.0, 0.0), weights=w, keep_out=((*centre, r_o, r_p),))
    body = Problem(RECT, (0.6, 0.0, 0.0), obstacles=((*centre, r_o),), weights=CostWeights(guidance=False))
    tip = Problem(RECT, (0.6, 0.0, 0.0), obstacles=((*centre, r_p),), weights=CostWeights(guidance=False))
    from dexpush.problem.obstacles import bound_gaps, pusher_bound_gaps
    (gap_body, _), = list(bound_gaps(state, keep.scene))
    gap_pusher, = list(pusher_bound_gaps(state, keep.scene))
    assert abs(float(gap_body[0]) - float(body.clearance(np.c_[state[:, :3], [[9.0, 9.0]]])[0])) < 1e-5
    assert abs(float(gap_pusher[0]) - float(tip.clearance(np.c_[[[9.0, 9.0, 0.0]], state[:, 3:]])[0])) < 1e-5
    local = state - np.array([[0.6, 0.0, 0.0, 0.6, 0.0]], np.float32)
    (local_body, _), = list(bound_gaps(local, keep.local_scene))
    assert abs(float(local_body[0]) - float(gap_body[0])) < 1e-5
    assert not keep.collides(state)[0] and keep.clearance(state)[0] == np.inf
    assert keep.guide is not None and not keep.guide.connects(centre) and keep.guide.connects((0.0, 0.35))
    assert keep.with_weights(w).keep_out == keep.keep_out


@pytest.mark.parametrize("bad", [((0.0, 0.0, 0.1),), ((0.0, 0.0, -0.1, 0.1),), ((np.nan, 0.0, 0.1, 0.1),)])
def test_a_bad_keep_out_disc_is_refused_in_one_line(bad: tuple) -> None:
    with pytest.raises(ValueError, match="keep_out must be"):
        Problem(RECT, (0.6, 0.0, 0.0), keep_out=bad)


# ---------------------------------------------------------------- guidance
@pytest.mark.parametrize(("turn_m", "goal_heading"), [(None, True), (0.1, False), (0.1, True)])
def test_cost_to_go_in_the_open_is_the_straight_distance_and_the_turn_to_the_goal(turn_m: float | None,
                                                                                   goal_heading: bool) -> None:
    """In the open V is the straight distance (within the grid's stretch), plus, with layers ending in the
    goal's heading, the turn to it: ρ·|θ − θ_k| to the goal's nearest layer θ_k; else the same in every heading."""
    goal = np.array([0.0, 0.0, 0.7])
    field = cost_to_go(RECT.polygons, RECT.bounding_radius, goal, np.zeros((0, 3)), (),
                       np.array([[-0.5, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, 0.5]]), 0.0, turn_m=turn_m,
                       goal_heading=goal_heading)
    assert field.headings == (1 if turn_m is None else 16)
    a = np.linspace(0, 2 * np.pi, 73)
    p = 0.3 * np.c_[np.cos(a), np.sin(a)]
    goal_layer = 2 * np.pi * field.layer(goal[2]) / 16
    for heading in np.linspace(-np.pi, np.pi, 11):
        turn = 0.1 * abs(wrap_angle(heading - goal_layer)) if turn_m and goal_heading else 0.0
        ratio = (field.at(p, heading) - turn) / 0.3
        assert np.all(ratio >= 1 - 1e-5) and np.all(ratio <= 1 + GRID_STRETCH)
        assert field.at(goal[:2], heading) == pytest.approx(turn, abs=1e-6)


def test_the_turn_to_the_goals_heading_is_made_where_the_footprint_fits() -> None:
    """Through a slot the box passes only lengthwise (heading 0) to a goal turned across it (π/2): from the
    start lengthwise V is the way and one quarter turn after the slot; crosswise, a quarter turn to pass the
    slot and one back. Without the goal's heading, the crosswise start needs the one turn and the other none."""
    goal = np.array([0.3, 0.0, np.pi / 2])
    slot = (wall(0.0, -0.6, 0.0, -0.09, 0.02), wall(0.0, 0.09, 0.0, 0.6, 0.02))
    args = (RECT.polygons, RECT.bounding_radius, goal, np.zeros((0, 3)), slot,
            np.array([[-0.6, -0.6], [0.6, -0.6], [0.6, 0.6], [-0.6, 0.6]]), 0.01)
    start, quarter = np.array([-0.3, 0.0]), 0.1 * np.pi / 2
    to_heading, any_heading = cost_to_go(*args, turn_m=0.1), cost_to_go(*args, turn_m=0.1, goal_heading=False)
    way = any_heading.at(start, 0.0)
    assert way == pytest.approx(0.6, rel=GRID_STRETCH)
    assert any_heading.at(start, np.pi / 2) - way == pytest.approx(quarter, abs=0.02)
    assert to_heading.at(start, 0.0) - way == pytest.approx(quarter, abs=0.02)
    assert to_heading.at(start, np.pi / 2) - way == pytest.approx(2 * quarter, abs=0.02)


def test_a_cost_to_go_with_headings_charges_the_turn_a_slot_needs() -> None:
    """A slot in a wall that the box passes only lengthwise: from the open side, V in the crossing heading
    exceeds V in the passing one by the turn (π/2 at ``turn_m`` per radian), and the one-layer field, free
    where the box fits in some heading, is the passing heading's V for both."""
    goal = np.array([0.3, 0.0, 0.0])
    slot = (wall(0.0, -0.6, 0.0, -0.09, 0.02), wall(0.0, 0.09, 0.0, 0.6, 0.02))   # 0.18 m: 0.12 fits, 0.2 not
    args = (RECT.polygons, RECT.bounding_radius, goal, np.zeros((0, 3)), slot,
            np.array([[-0.6, -0.6], [0.6, -0.6], [0.6, 0.6], [-0.6, 0.6]]), 0.01)
    turned, blind = cost_to_go(*args, turn_m=0.1), cost_to_go(*args)
    start = np.array([-0.3, 0.0])
    passing, crossing = turned.at(start, 0.0), turned.at(start, np.pi / 2)
    assert passing == pytest.approx(0.6, rel=GRID_STRETCH)
    assert crossing - passing == pytest.approx(0.1 * np.pi / 2, abs=0.02)
    assert blind.at(start, np.pi / 2) == pytest.approx(passing, abs=0.01)
    # in the slot itself the passing headings fit and the crossing ones do not (the samples are a cell apart)
    in_slot = tuple(np.round((np.zeros(2) - turned.lo) / turned.cell).astype(int))
    assert turned.free[(0, *in_slot)] and turned.free[(8, *in_slot)]
    assert not turned.free[(3, *in_slot)] and not turned.free[(4, *in_slot)] and not turned.free[(12, *in_slot)]


def test_with_the_pushers_room_a_pocket_the_box_fills_is_a_trap() -> None:
    """A slot open toward the goal (+x), closed behind by the table's edge, 16 cm wide (the box's 12 cm and the
    margins fit lengthwise only). Pushed out lengthwise, the pusher must sit between the box and the edge:
    where that gap is under the pusher's width and the margin the box can be pushed in but not out, so V there
    is the trap's, TRAP_M above the way's; elsewhere, and with the footprint's room alone, V is the way's."""
    from dexpush.problem.guidance import TRAP_M
    goal = np.array([0.3, 0.0, 0.0])
    slot = (wall(-0.6, 0.09, 0.1, 0.09, 0.02), wall(-0.6, -0.09, 0.1, -0.09, 0.02))
    args = (RECT.polygons, RECT.bounding_radius, goal, np.zeros((0, 3)), slot,
            np.array([[-0.5, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, 0.5]]), 0.01)
    fits, pushed = cost_to_go(*args, turn_m=0.1), cost_to_go(*args, turn_m=0.1, pusher_radius=0.01)
    deep, room = np.array([-0.38, 0.0]), np.array([-0.34, 0.0])   # the box's back 2 and 6 cm from the edge
    assert fits.at(deep, 0.0) == pytest.approx(0.68, rel=GRID_STRETCH)
    assert pushed.at(deep, 0.0) - fits.at(deep, 0.0) == pytest.approx(TRAP_M, abs=1e-5)
    for p in (room, np.array([0.0, -0.3]), np.array([0.2, 0.3])):
        assert pushed.at(p, 0.0) == pytest.approx(fits.at(p, 0.0), abs=1e-5)
    # 6 cm from the edge the pusher fits behind the box, so a pushed way leads out
    assert pushed.connects(room)
    with pytest.raises(ValueError, match="pusher_radius"):
        cost_to_go(*args, pusher_radius=0.01)          # the room depends on the heading: layers are needed
    with pytest.raises(ValueError, match="guidance_pusher_room needs guidance_turn_m"):
        CostWeights(guidance_pusher_room=True, guidance_turn_m=None)


def test_cost_to_go_leads_round_a_wall_and_not_through_it() -> None:
    goal = np.array([0.3, 0.0, 0.0])
    barrier = wall(0.0, -0.35, 0.0, 0.5, 0.02)          # open below y = -0.35 only
    field = cost_to_go(RECT.polygons, RECT.bounding_radius, goal, np.zeros((0, 3)), (barrier,),
                       np.array([[-0.6, -0.6], [0.6, -0.6], [0.6, 0.6], [-0.6, 0.6]]), 0.01)
    start = np.array([-0.3, 0.0])
    # down past the wall's end, the footprint's half-width (0.06 m, turned edge-on) and the margin below it,
    # and back up: at least this long, against 0.6 m straight through the wall
    around = 2 * np.hypot(0.3, 0.35 + 0.06 + 0.01)
    assert field.connects(start) and field.at(start) > around
    closed = cost_to_go(RECT.polygons, RECT.bounding_radius, goal, np.zeros((0, 3)),
                        (wall(0.0, -0.6, 0.0, 0.6, 0.02),),
                        np.array([[-0.6, -0.6], [0.6, -0.6], [0.6, 0.6], [-0.6, 0.6]]), 0.01)
    assert not closed.connects(start)


def test_the_running_cost_follows_the_way_only_when_told() -> None:
    """Task IV on the T: by default the running cost's goal distance is the detour round the discs (the terminal
    cost's is ℓ along V); with ``guidance_running`` it is ℓ as well, and the rest of the running cost (the
    pusher's gap, the obstacles) is unchanged."""
    import jax.numpy as jnp

    from dexpush.problem.cost import detour_length_sq, guided_length_sq, obstacle_cost, running_cost

    tee = Shape.tee()
    plain, along = CostWeights(), CostWeights(guidance_running=True)
    scene = TASKS["IV"].problem(tee, plain).scene
    rng = np.random.default_rng(5)
    p = rng.uniform([-0.15, -0.25], [0.45, 0.15], (1000, 2))
    th = rng.uniform(-np.pi, np.pi, len(p))
    x = jnp.asarray(np.c_[p, th, p + rng.normal(0, 0.1, p.shape)], jnp.float32)
    guided = np.asarray(guided_length_sq(x[:, 0], x[:, 1], x[:, 2], scene))
    detour = np.asarray(detour_length_sq(x[:, 0], x[:, 1], scene))
    gap = plain.q_r1 * (guided - detour)
    free = np.asarray(obstacle_cost(x, scene, plain)) == 0          # float32 sums beside a touch's C_pen lose these
    assert free.sum() > 200 and np.mean(np.abs(gap[free]) > 1e-3) > 0.5   # the two distances differ on most states
    change = np.asarray(running_cost(x, scene, along)) - np.asarray(running_cost(x, scene, plain))
    np.testing.assert_allclose(change[free], gap[free], rtol=1e-4, atol=1e-2)


@pytest.mark.parametrize("turn_m", [None, 0.1])
def test_guided_goal_distance_round_discs(turn_m: float | None) -> None:
    """With discs and a guide (Task IV): a field by heading is followed alone; a one-layer field, which lets
    the footprint turn to fit anywhere, with the way round each disc at the footprint's reach beside it (ℓ the
    larger of the two: behind a disc the detour). Never shorter than the straight line."""
    import jax.numpy as jnp

    from dexpush.problem.cost import detour_length_sq, goal_distance_sq, guided_length_sq

    tee = Shape.tee()
    problem = TASKS["IV"].problem(tee, CostWeights(guidance_turn_m=turn_m))
    scene = problem.scene
    assert problem.guide is not None and problem.guide.headings == (1 if turn_m is None else 16)
    assert scene.detour_radius.shape[0] == 3
    rng = np.random.default_rng(3)
    p = rng.uniform([-0.15, -0.25], [0.45, 0.15], (400, 2))
    x = jnp.asarray(np.c_[p, rng.uniform(-np.pi, np.pi, len(p)), np.zeros((len(p), 2))], jnp.float32)
    got = np.asarray(goal_distance_sq(x, scene, 0.0))
    guided = np.asarray(guided_length_sq(x[:, 0], x[:, 1], x[:, 2], scene))
    detour = np.asarray(detour_length_sq(x[:, 0], x[:, 1], scene))
    np.testing.assert_allclose(got, guided if turn_m else np.maximum(guided, detour), rtol=1e-6)
    if turn_m is None:
        assert np.mean(detour > guided * 1.05) > 0.1          # the discs' detour matters somewhere
    straight = np.sum((p - np.asarray(problem.goal[:2])) ** 2, -1)
    assert np.all(got >= straight * (1 - 1e-5))
    # an object with bounds of its own (a robot's reach) follows the cost-to-go alone, which keeps its footprint
    # inside them
    band = ((0.0, -0.3), (0.5, -0.3), (0.5, 0.2), (0.0, 0.2))
    bounded = Problem(tee, problem.goal, problem.obstacles, problem.weights, polygons=problem.polygons,
                      workspace=problem.workspace, object_workspace=band)
    np.testing.assert_allclose(np.asarray(goal_distance_sq(x, bounded.scene, 0.0)),
                               np.asarray(guided_length_sq(x[:, 0], x[:, 1], x[:, 2], bounded.scene)), rtol=1e-6)
    for guide, fits_outside in ((bounded.guide, False), (problem.guide, True)):
        nodes = guide.lo + guide.cell * np.stack(np.meshgrid(*map(np.arange, guide.free.shape[1:]), indexing="ij"),
                                                 -1)
        edge = (nodes[..., 0] < 0.03) & (nodes[..., 0] > -0.03)       # where the footprint would cross x = 0
        assert edge.any() and guide.free.any(0)[edge].any() == fits_outside


def test_discs_alone_keep_the_detour() -> None:
    """Task III (one disc, no bounds) has no cost-to-go of either kind: the detour round the disc alone."""
    tee = Shape.tee()
    for w in (CostWeights(), CostWeights(guidance_turn_m=None)):
        assert TASKS["III"].problem(tee, w).guide is None
        assert TASKS["III"].problem(tee, w).scene.detour_radius.shape[0] == 1


# ---------------------------------------------------------------- tasks
@pytest.mark.parametrize("name", ["rect", "tee", "ellipse"])
def test_task_iv_starts_clear_and_its_goal_is_reachable(name: str) -> None:
    shape = {"rect": Shape.rectangle, "tee": Shape.tee, "ellipse": Shape.ellipse}[name]()
    task = TASKS["IV"]
    problem = task.problem(shape)
    assert problem.guide.connects(task.start)
    for seed in range(10):
        pose, pusher = task.trial_start(shape, seed)
        assert float(problem.clearance(np.r_[pose, pusher][None])[0]) > 0.01


def test_tasks_without_walls_keep_their_pusher_starts() -> None:
    """The redraw rule never fires in Tasks I–III: the pusher is where the first azimuth puts it, at the
    task's clearance from the contour."""
    for key in ("I", "II", "III"):
        for seed in range(20):
            pose, pusher = initial_conditions(TASKS[key], RECT, seed)
            rng = np.random.default_rng(seed)
            rng.uniform(size=3)
            phi = rng.uniform(-np.pi, np.pi)
            r = np.asarray(RECT.contour(np.array(phi))[0], np.float64)
            r = r * (1 + TASKS[key].pusher_clearance_m / np.linalg.norm(r))
            c, s = np.cos(pose[2]), np.sin(pose[2])
            np.testing.assert_array_equal(pusher, pose[:2] + np.array([c * r[0] - s * r[1], s * r[0] + c * r[1]]))


def test_clutter_layouts_are_seeded_valid_and_different() -> None:
    task = TASKS["C"]
    a, b = task.layout(RECT, 3), task.layout(RECT, 4)
    again = type(task)("C", "random clutter", (0.0, 0.0, 0.0)).layout(RECT, 3)
    np.testing.assert_array_equal(a[1], again[1])
    assert a[0].goal == again[0].goal and a[0].goal != b[0].goal
    for problem, start, pusher in (a, b):
        n = len(problem.obstacles) + len(problem.polygons)
        assert 1 <= n <= 8 and problem.workspace is not None
        assert problem.guide.connects(start)
        assert float(problem.clearance(np.r_[start, pusher][None])[0]) > 0.01
        assert np.hypot(*(np.asarray(problem.goal[:2]) - start[:2])) >= task.min_travel_m
    # every layout's cost scene has the same shapes: one compiled program for the family
    assert a[0].scene.polygons.shape == b[0].scene.polygons.shape
    assert a[0].scene.obstacles.shape == b[0].scene.obstacles.shape
    with pytest.raises(ValueError, match="seed="):
        task.problem(RECT)


# ---------------------------------------------------------------- scene files
def test_the_example_scene_loads(tmp_path) -> None:
    layout = load_scene("examples/scenes/tray.toml")
    assert len(layout.obstacles) == 1 and len(layout.polygons) == 2 and layout.workspace == (-0.2, -0.3, 0.6, 0.3)
    Problem(RECT, (0.45, 0.1, np.pi / 2), layout.obstacles, polygons=layout.polygons, workspace=layout.workspace)


@pytest.mark.parametrize("text, message", [
    ("[[disc]]\ncentre = [0, 0]\nradius = -1", "disc 0: radius must be positive"),
    ("[[disk]]\ncentre = [0, 0]", "unknown key 'disk'"),
    ("[[box]]\ncentre = [0, 0]\nsize = [0.1]", "box 0: size must be two numbers"),
    ("[[box]]\ncentre = [0, 0]\nsize = [0.1, 0.1]\nyaw = 3", "box 0: unknown key 'yaw'"),
    ("[[wall]]\nstart = [0, 0]\nend = [0, 0]\nthickness = 0.02", "wall 0: a wall needs two distinct"),
    ("[[polygon]]\ncorners = [[0, 0], [2, 0], [1, 0.2], [2, 2], [0, 2]]", "polygon 0: .*convex"),
    ("workspace = [0, 0, -1, 1]", "workspace: .*x_hi > x_lo"),
    ("workspace = [0, 0", "not valid TOML"),
])
def test_scene_file_mistakes_are_one_line(tmp_path, text: str, message: str) -> None:
    path = tmp_path / "scene.toml"
    path.write_text(text)
    with pytest.raises(ValueError, match=message) as err:
        load_scene(path)
    assert "\n" not in str(err.value)


def test_flags_make_boxes_and_walls() -> None:
    layout = Layout.from_flags([(0.3, 0.0, 0.1, 0.05)], [(0, 0.3, 0.5, 0.3, 0.02)], (-1, -1, 1, 1))
    assert len(layout.polygons) == 2 and layout.workspace == (-1.0, -1.0, 1.0, 1.0)
    with pytest.raises(ValueError, match="box height"):
        Layout.from_flags([(0.3, 0.0, 0.1, -0.05)])


def test_the_guidance_and_layout_figures_draw_a_clutter_layout(tmp_path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from dexpush.viz import plot_guidance, plot_layouts

    problem, start, pusher = TASKS["C"].layout(RECT, 3)
    states = np.array([[*start, *pusher], [*problem.goal, *pusher]])
    plt.close(plot_guidance(RECT, problem, states, title="t", path=tmp_path / "g.png"))
    plt.close(plot_layouts(RECT, [(problem, states, True), (problem, states, False)], path=tmp_path / "l.png"))
    assert (tmp_path / "g.png").stat().st_size > 10_000 and (tmp_path / "l.png").stat().st_size > 5_000


def test_goals_outside_the_workspace_and_custom_clutter_goals_are_refused() -> None:
    from dexpush.cli.config import RunSettings, build_task

    with pytest.raises(ValueError, match="outside the workspace"):
        Problem(RECT, (0.6, 0.3, 0.0), workspace=(0.2, -0.3, 0.6, 0.3))
    with pytest.raises(ValueError, match="outside the workspace"):     # the centre off the guidance's grid too
        Problem(RECT, (2.0, 0.0, 0.0), workspace=(-0.2, -0.2, 0.5, 0.5))
    with pytest.raises(ValueError, match="task C draws its own goal"):
        build_task(RunSettings(task="C", goal=(0.3, 0.0, 0.0)))
    with pytest.raises(ValueError, match="a wall needs two distinct end points"):
        RunSettings(walls=((0.0, 0.0, 0.0, 0.0, 0.02),))


@pytest.mark.parametrize("name", ["rect", "ellipse"])
def test_discs_beside_polygons_cost_what_each_costs_alone(name: str) -> None:
    """The clutter scene's cost (its discs' terms in a computation of their own, beside the polygons'
    gaps and the table's) is the cost of its discs alone plus that of its polygons and table alone."""
    import dataclasses

    import jax
    import jax.numpy as jnp

    from dexpush.problem.cost import obstacle_cost

    shape = Shape.ellipse() if name == "ellipse" else Shape.rectangle()
    problem = TASKS["C"].layout(shape, 3)[0]
    scene, w = problem.scene, problem.weights
    discs = dataclasses.replace(scene, polygons=scene.polygons[:0], polygon_planes=scene.polygon_planes[:0],
                                bounds=scene.bounds[:0])
    regions = dataclasses.replace(scene, obstacles=scene.obstacles[:0])
    rng = np.random.default_rng(7)
    n = 4096
    x = jnp.asarray(np.stack([rng.uniform(-0.5, 0.5, n), rng.uniform(-0.5, 0.5, n), rng.uniform(-np.pi, np.pi, n),
                              rng.uniform(-0.5, 0.5, n), rng.uniform(-0.5, 0.5, n)], -1), jnp.float32)
    cost = jax.jit(lambda x, sc: obstacle_cost(x, sc, w))
    whole, of_discs, of_regions = (np.asarray(cost(x, sc), np.float64) for sc in (scene, discs, regions))
    apart, touch = of_discs + of_regions, (of_discs >= w.C_pen) | (of_regions >= w.C_pen)
    assert 0 < touch.sum() < n and np.any((apart > 0) & ~touch)   # touches, margins and free states all occur
    np.testing.assert_array_equal(whole >= w.C_pen, touch)
    np.testing.assert_allclose(whole[~touch], apart[~touch], rtol=1e-5, atol=1.0)


@pytest.mark.parametrize("bad", [0.0, -0.1, float("nan"), float("inf")])
def test_a_turn_length_that_is_not_positive_is_one_line(bad: float) -> None:
    with pytest.raises(ValueError, match="guidance_turn_m"):
        CostWeights(guidance_turn_m=bad)
    with pytest.raises(ValueError, match="turn_m"):
        cost_to_go(RECT.polygons, RECT.bounding_radius, np.zeros(3), np.zeros((0, 3)), (), None, 0.0, turn_m=bad)


def test_padded_rows_and_grid_blocks_change_no_gap_and_few_shapes_compile() -> None:
    """The scene's half-plane arrays are padded to ROW_BLOCK rows by repeating one (the pusher's gap to a
    pentagon is the least over its own five rows) and the cost-to-go's grid to GRID_BLOCK nodes a side."""
    from dexpush.problem.guidance import GRID_BLOCK
    from dexpush.problem.obstacles import bound_gaps
    from dexpush.problem.scene import ROW_BLOCK

    pentagon = tuple((0.5 * np.cos(a), 0.5 * np.sin(a)) for a in np.linspace(0, 2 * np.pi, 6)[:-1])
    p = Problem(RECT, (0.0, 0.0, 0.0), workspace=pentagon)
    assert p.scene.bounds.shape[0] % ROW_BLOCK == 0 and p.scene.bounds.shape[0] > 5
    rows = workspace_halfplanes(np.asarray(pentagon))
    rng = np.random.default_rng(0)
    tips = rng.uniform(-0.4, 0.4, (50, 2))
    states = np.c_[np.zeros((50, 3)), tips].astype(np.float32)
    padded = np.min([np.asarray(pusher) for _, pusher in bound_gaps(states, p.scene)], 0)
    exact = np.min(rows[:, 2] - tips @ rows[:, :2].T, 1) - RECT.pusher_radius
    assert np.allclose(padded, exact, atol=1e-6)
    assert all(n % GRID_BLOCK == 0 for n in p.guide.values.shape[1:])
