"""The cost's footprint outline: at most COST_OUTLINE_EDGES edges, containing the footprint, and trials
judged by the footprint itself."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from dexpush import Shape
from dexpush.model.polygons import circumscribed, convex_hull, inside_polygon
from dexpush.problem.problem import COST_OUTLINE_EDGES, Problem


@settings(max_examples=40, deadline=None)
@given(points=st.lists(st.tuples(st.floats(-0.1, 0.1), st.floats(-0.1, 0.1)), min_size=8, max_size=60),
       edges=st.integers(3, 40))
def test_a_circumscribed_polygon_contains_the_polygon(points, edges) -> None:
    hull = convex_hull(np.asarray(points))
    if len(hull) < 3:
        return
    area2 = np.sum(hull[:, 0] * np.roll(hull[:, 1], -1) - np.roll(hull[:, 0], -1) * hull[:, 1])
    if abs(area2) < 1e-6:
        return
    outline = circumscribed(hull, edges)
    assert len(outline) == edges
    # every corner of the polygon lies inside the outline, or on it (to round-off)
    shrunk = hull.mean(0) + (hull - hull.mean(0)) * (1 - 1e-9)
    assert np.all(inside_polygon(shrunk, outline) | (np.linalg.norm(shrunk - hull, axis=1) < 1e-9))


def test_the_ellipse_is_seen_by_the_cost_through_12_edges_within_5_mm() -> None:
    from dexpush.model.polygons import distance_to_polygons

    shape = Shape.ellipse()
    a, _ = shape.outline_edges(COST_OUTLINE_EDGES)
    assert len(shape.edges[0]) == 256 and len(a) == COST_OUTLINE_EDGES
    assert float(distance_to_polygons(a, shape.polygons).max()) < 5e-3       # 4.9 mm at the corners
    rect = Shape.rectangle()
    np.testing.assert_array_equal(rect.outline_edges(COST_OUTLINE_EDGES)[0], rect.edges[0])   # few edges: itself


def test_a_problem_plans_with_the_outline_and_judges_with_the_footprint() -> None:
    ang = 2 * np.pi * (np.arange(48) + 0.5) / 48
    shape = Shape.polygon(0.1 * np.stack([np.cos(ang), np.sin(ang)], -1))     # 48 edges: the judge's compile is short
    problem = Problem(shape, (0.6, 0.0, 0.0), ((0.3, 0.0, 0.05),))
    assert problem.scene.edge_a.shape[0] == COST_OUTLINE_EDGES == problem.local_scene.edge_a.shape[0]
    assert problem.judge_scene.edge_a.shape[0] == 48
    # the object 0.1 mm from the disc: judged by the footprint itself
    gap = 0.05 + 0.1 * np.cos(np.pi / 48) + 1e-4
    x = np.array([0.3 - gap, 0.0, 0.0, -0.5, 0.0])
    assert 0.0 < float(problem.clearance(x)) < 2e-4 and not bool(problem.collides(x))
