"""Shapes: contour tables against closed forms, inflation, star-shapedness and bad input."""

from __future__ import annotations

import functools
import math

import jax
import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

import reference as ref
from dexpush import Shape


def test_table_error_bound() -> None:
    """Hermite-interpolated table vs closed-form contours: radial error < 1e-6 m, tangent
    direction < 5 mrad (rect; the curvature jumps where faces meet corner arcs)."""
    phi = np.random.default_rng(0).uniform(-np.pi, np.pi, 5000)
    cases = [
        (Shape.rectangle(), functools.partial(ref.rect_radius, half_w=0.10, half_h=0.06, rho=0.01)),
        (Shape.ellipse(), functools.partial(ref.ellipse_radius, a=0.10, b=0.06, rho=0.01)),
    ]
    for (shape, radius), tangent_tol, n in zip(cases, (5e-3, 1e-5), (5000, 500)):
        p = phi[:n]                 # the ellipse's reference radius is a slow bisection: 500 azimuths
        with jax.enable_x64(True):  # measure the table, not float32 round-off
            r, dr = (np.asarray(a, np.float64) for a in shape.contour(p))
        expected = np.array([radius(a) for a in p])
        assert np.max(np.abs(np.linalg.norm(r, axis=-1) - expected)) < 1e-6, shape.name
        # tangent direction against a finite difference of the closed form
        fd = np.array([ref.contour(radius, a)[1] for a in p])
        cosang = np.sum(dr * fd, -1) / np.linalg.norm(dr, axis=-1) / np.linalg.norm(fd, axis=-1)
        angle = np.arccos(np.clip(cosang, -1, 1))  # largest where a face meets a corner arc
        assert np.max(angle) < tangent_tol, shape.name


def test_inflated_rectangle_has_rounded_corners_of_pusher_radius() -> None:
    for rho in (0.005, 0.01, 0.02):
        shape = Shape.rectangle(0.2, 0.12, pusher_radius=rho)
        # azimuths that hit the (+,+) corner arc
        a0, a1 = math.atan2(0.06, 0.10 + rho), math.atan2(0.06 + rho, 0.10)
        phi = np.linspace(a0, a1, 50)[1:-1]
        r, _ = shape.contour(phi)
        d = np.linalg.norm(np.asarray(r, np.float64) - [0.10, 0.06], axis=-1)
        np.testing.assert_allclose(d, rho, atol=2e-6)
        # and flat faces at distance ρ from the box
        r, _ = shape.contour(np.array([0.0, np.pi / 2, np.pi]))
        np.testing.assert_allclose(np.abs(np.asarray(r)).max(-1), [0.10 + rho, 0.06 + rho, 0.10 + rho], atol=1e-6)


def test_tee_matches_spec_and_is_star_shaped_about_bar_centre() -> None:
    tee = Shape.tee()
    bar, stem = tee.polygons
    assert np.allclose(np.ptp(bar, 0), [0.20, 0.05]) and np.allclose(np.ptp(stem, 0), [0.05, 0.15])
    assert np.isclose(stem[:, 1].min(), -0.175) and np.isclose(stem[:, 1].max(), -0.025)
    r, _ = tee.contour(np.array([-np.pi / 2]))
    np.testing.assert_allclose(np.asarray(r)[0], [0.0, -0.185], atol=1e-6)
    # about the T's centroid (y ≈ −0.054) it is not star-shaped
    centroid_y = (0.20 * 0.05 * 0.0 + 0.05 * 0.15 * -0.1) / (0.20 * 0.05 + 0.05 * 0.15)
    with pytest.raises(ValueError, match="not star-shaped"):
        Shape.union([bar, stem], reference=(0.0, centroid_y - 0.02))


@pytest.mark.parametrize("verts, reference", [
    # U opening upwards, reference in the bottom bar under the gap: rays go up into the gap
    ([[0, 0], [0.3, 0], [0.3, 0.3], [0.2, 0.3], [0.2, 0.1], [0.1, 0.1], [0.1, 0.3], [0, 0.3]], (0.15, 0.05)),
    # C opening to the right, reference in the left bar
    ([[0, 0], [0.3, 0], [0.3, 0.1], [0.1, 0.1], [0.1, 0.2], [0.3, 0.2], [0.3, 0.3], [0, 0.3]], (0.05, 0.15)),
])
def test_non_star_shaped_polygon_rejected(verts, reference) -> None:
    with pytest.raises(ValueError, match="not star-shaped about its reference"):
        Shape.polygon(verts, reference=reference, pusher_radius=0.005)


@pytest.mark.parametrize("call, match", [
    (lambda: Shape.polygon([[0, 0], [1, 0], [2, 0]]), "degenerate"),
    (lambda: Shape.polygon([[0, 0], [1, 0]]), "at least 3"),
    (lambda: Shape.polygon([[0, 0], [1, np.nan], [0, 1]]), "NaN"),
    (lambda: Shape.polygon(np.zeros((4, 3))), r"\(n, 2\)"),
    (lambda: Shape.polygon([[0, 0], [1, 0], [0, 1]], reference=(2, 2)), "not inside"),
    (lambda: Shape.rectangle(0.2, -0.1), "positive"),
    (lambda: Shape.rectangle(pusher_radius=0.0), "pusher_radius"),
    (lambda: Shape.ellipse(0.1, 0.05, pusher_radius=float("nan")), "pusher_radius"),
    (lambda: Shape.union([]), "at least one polygon"),
])
def test_bad_shapes_give_clear_errors(call, match) -> None:
    with pytest.raises(ValueError, match=match):
        call()


@settings(max_examples=6, deadline=None)   # each example builds a 2048-entry table; the bound was set on 150
@given(n=st.integers(3, 9), seed=st.integers(0, 10**6), rho=st.floats(0.002, 0.02))
@example(n=4, seed=0, rho=0.002)   # the worst case found: a 190° gap between corners, ρ = 2 mm
def test_random_convex_polygons_contour_is_at_pusher_radius(n: int, seed: int, rho: float) -> None:
    """Every contour point of an inflated convex polygon is exactly ρ from the footprint."""
    rng = np.random.default_rng(seed)
    # corners on a circle with gaps of at least 0.3 rad: convex, no slivers
    gaps = 0.3 + rng.dirichlet(np.ones(n)) * (2 * np.pi - 0.3 * n)
    ang = np.cumsum(gaps)
    verts = 0.1 * np.stack([np.cos(ang), np.sin(ang)], -1)
    shape = Shape.polygon(verts, reference=verts.mean(0), pusher_radius=rho)
    pts = shape.contour_points(200)
    a, b = shape.edges
    ab = b - a
    ap = pts[:, None, :] - a
    t = np.clip(np.sum(ap * ab, -1) / np.sum(ab * ab, -1), 0, 1)
    d = np.linalg.norm(ap - t[..., None] * ab, axis=-1).min(-1)
    # the 2048-entry Hermite table rounds the corner arcs: worst 25 µm over 150 random
    # polygons (the example above); docs/conventions.md#plants allows the pusher 1 mm into the object
    np.testing.assert_allclose(d, rho, atol=5e-5)


def test_contour_works_under_jit_and_vmap() -> None:
    shape = Shape.ellipse()
    phi = np.linspace(-3, 3, 12).reshape(3, 4)
    r1, dr1 = shape.contour(phi)
    r2, dr2 = jax.jit(jax.vmap(shape.contour))(phi)
    assert r2.shape == (3, 4, 2) and dr2.shape == (3, 4, 2)
    np.testing.assert_allclose(np.asarray(r1), np.asarray(r2), rtol=1e-6)
    np.testing.assert_allclose(np.asarray(dr1), np.asarray(dr2), atol=1e-5)  # float32 cancellation


def test_a_polygon_of_a_thousand_corners_builds_and_its_contour_is_at_the_pusher_radius() -> None:
    from dexpush.model.shape import distance_to_polygons

    ang = np.sort(np.random.default_rng(0).uniform(-np.pi, np.pi, 1000))
    r = 0.08 + 0.02 * np.sin(5 * ang)
    shape = Shape.polygon(np.stack([r * np.cos(ang), r * np.sin(ang)], -1))
    assert len(shape.polygons[0]) == 1000
    phi = np.linspace(-np.pi, np.pi, 997, endpoint=False)
    with jax.enable_x64(True):
        pts = np.asarray(shape.contour(phi)[0], np.float64)
    d = distance_to_polygons(pts, shape.polygons)
    assert np.max(np.abs(d - shape.pusher_radius)) < 1e-5


def test_a_ray_through_a_concave_corner_is_no_special_case() -> None:
    """An L whose reference sees its inner corner exactly along the 45° ray."""
    ell = Shape.polygon([[0, 0], [0.1, 0], [0.1, 0.03], [0.03, 0.03], [0.03, 0.1], [0, 0.1]], reference=(0.015, 0.015))
    assert np.all(np.isfinite(ell.radius_table)) and np.all(ell.radius_table > 0)
