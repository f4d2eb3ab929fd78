"""Shapes: footprints, the pusher-inflated contour and its radial function.

A :class:`Shape` is a planar object footprint (a polygon, a union of polygons, or an
ellipse) together with the pusher radius ρ. The contour the motion model uses is the
footprint inflated by ρ (the Minkowski sum with a disc), so the pusher can be treated as
its centre point; corners of polygons become circular arcs of radius ρ.

The model needs the radial function of that contour about the reference point,

    r(φ) = R(φ)·[cos φ, sin φ]ᵀ          (contour point in {B} at azimuth φ)
    ∂φ r = R'(φ)·[cos φ, sin φ]ᵀ + R(φ)·[−sin φ, cos φ]ᵀ,

at arbitrary φ inside jit-compiled, batched rollouts. It is precomputed once per shape
as a periodic table of R and R' on ``table_size`` equally spaced azimuths and evaluated
with cubic Hermite interpolation (R and R' are both exact at the nodes, so the
interpolant is C¹ and ``dr`` is the exact derivative of the interpolated ``r``).

Resolution and error (``table_size = 2048``, Δφ = 3.1e-3 rad), measured against
closed-form contours on 20 000 random azimuths (``tests/test_geometry.py::
test_table_error_bound`` asserts the bounds): radial error 6.0e-7 m on the inflated
``rect`` and 2.8e-11 m on the ``ellipse``; tangent direction error 3.3e-3 rad on the
``rect``, only where a flat face meets a corner arc (the curvature jumps there; 7.9e-3 at
1024 entries, 2.1e-3 at 4096), and 1.6e-7 rad on the ellipse.

Star-shapedness: the contour must be crossed exactly once by every ray from the
reference. Construction checks it on the inflated shape exactly: each of the table's rays
meets every polygon's interior and every edge's capsule in intervals, which must cover one
segment [0, R]; otherwise a ``ValueError`` names the first azimuth where a ray leaves and
re-enters the shape (e.g. a U or C opening). R is then refined by bisection on the distance
test (40 halvings of the ray's sample-grid bracket).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field

import jax.numpy as jnp
import numpy as np

from dexpush.common.checks import check_positive
from dexpush.model.kernel import kernel_point
from dexpush.model.polygons import (
    MAX_CORNERS,
    MAX_SHAPE_M,
    as_polygon,
    circumscribed,
    distance_to_polygons,
    inside_polygon,
    is_convex,
)
from dexpush.model.radial_table import (
    check_table_size,
    concave_corners,
    dradius_from_normal,
    radial_table_polygons,
    table_azimuths,
)
from dexpush.model.shape_file import read_shape_file

__all__ = ["Shape", "contour_lookup", "distance_to_polygons", "hermite_coefficients", "is_convex"]



@dataclass(frozen=True, eq=False)
class Shape:
    """A pushed object's footprint, the pusher radius, and the inflated contour's radial table.

    Build one with :meth:`rectangle`, :meth:`ellipse`, :meth:`tee`, :meth:`polygon` or
    :meth:`union`. All lengths are in metres, in the body frame {B} whose origin is the
    reference point.

    Attributes:
        name: a label used in plots and file names.
        polygons: the footprint as counter-clockwise polygons (an ellipse is stored as a
            fine polygon for collision checks and drawing only).
        pusher_radius: ρ, the pusher's radius.
        radius_table: R(φ_i) of the inflated contour on φ_i = −π + i·2π/table_size.
        dradius_table: R'(φ_i).
        origin: where the reference point lies in the frame the corners were given in
            (the body frame is that frame shifted by ``origin``; not rotated).
        corners: (n_c, 6) concave corners of the inflated contour, rows
            ``[c_x, c_y, n1_x, n1_y, n2_x, n2_y]``: where a pusher centre touches two faces
            at once, with the two faces' inward unit normals
            (:func:`dexpush.model.radial_table.concave_corners`; none for convex shapes).
    """

    name: str
    polygons: tuple[np.ndarray, ...]
    pusher_radius: float
    radius_table: np.ndarray = field(repr=False)
    dradius_table: np.ndarray = field(repr=False)
    origin: tuple[float, float] = (0.0, 0.0)
    corners: np.ndarray = field(default_factory=lambda: np.zeros((0, 6)), repr=False)

    # ------------------------------------------------------------------ constructors
    @staticmethod
    def rectangle(width: float = 0.20, height: float = 0.12, pusher_radius: float = 0.01,
                  *, name: str = "rect", table_size: int = 2048) -> Shape:
        """An axis-aligned ``width × height`` box centred on the reference point."""
        _check_positive(width=width, height=height)
        w, h = width / 2, height / 2
        verts = np.array([[-w, -h], [w, -h], [w, h], [-w, h]])
        return Shape.union([verts], pusher_radius=pusher_radius, name=name, table_size=table_size)

    @staticmethod
    def tee(bar_width: float = 0.20, bar_height: float = 0.05, stem_width: float = 0.05,
            stem_height: float = 0.15, pusher_radius: float = 0.01, *, name: str = "tee",
            table_size: int = 2048) -> Shape:
        """A T: a top bar centred on the reference point and a stem hanging below it.

        With the defaults (docs/conventions.md#shapes) the bar is 0.20 × 0.05 m about (0, 0) and the stem
        0.05 × 0.15 m spans y ∈ [−0.175, −0.025]. The reference (0, 0) lies in the T's
        kernel; the T is not star-shaped about its centroid.
        """
        _check_positive(bar_width=bar_width, bar_height=bar_height, stem_width=stem_width,
                        stem_height=stem_height)
        bw, bh, sw = bar_width / 2, bar_height / 2, stem_width / 2
        bar = np.array([[-bw, -bh], [bw, -bh], [bw, bh], [-bw, bh]])
        stem = np.array([[-sw, -bh - stem_height], [sw, -bh - stem_height], [sw, -bh], [-sw, -bh]])
        return Shape.union([bar, stem], pusher_radius=pusher_radius, name=name, table_size=table_size)

    @staticmethod
    def ellipse(a: float = 0.10, b: float = 0.06, pusher_radius: float = 0.01, *,
                name: str = "ellipse", table_size: int = 2048) -> Shape:
        """An ellipse with semi-axes ``a`` (along x) and ``b`` (along y) about its centre.

        The inflated contour is the ellipse's parallel curve at distance ρ, computed in
        closed form; the stored footprint polygon (256 corners) is only for collision
        checks and drawing.
        """
        _check_positive(a=a, b=b)
        rho = _check_pusher_radius(pusher_radius)
        table_size = check_table_size(table_size)
        t = np.linspace(-np.pi, np.pi, 256, endpoint=False)
        footprint = np.stack([a * np.cos(t), b * np.sin(t)], -1)
        # parallel curve q(t) = p(t) + ρ n(t); polar angle is monotone in t (convex)
        t = np.linspace(-np.pi, np.pi, 64 * table_size, endpoint=False)
        n = np.stack([b * np.cos(t), a * np.sin(t)], -1)
        n /= np.linalg.norm(n, axis=-1, keepdims=True)
        q = np.stack([a * np.cos(t), b * np.sin(t)], -1) + rho * n
        phi_q = np.arctan2(q[:, 1], q[:, 0])
        order = np.argsort(phi_q)
        phi_q, q, n = phi_q[order], q[order], n[order]
        phi = table_azimuths(table_size)
        R = np.interp(phi, phi_q, np.linalg.norm(q, axis=-1), period=2 * np.pi)
        # the parallel curve's outward normal is the ellipse's normal at the same parameter
        nx = np.interp(phi, phi_q, n[:, 0], period=2 * np.pi)
        ny = np.interp(phi, phi_q, n[:, 1], period=2 * np.pi)
        n_out = np.stack([nx, ny], -1) / np.hypot(nx, ny)[:, None]
        dR = dradius_from_normal(phi, R, n_out)
        return Shape(name, (footprint,), rho, R, dR)

    @staticmethod
    def polygon(vertices: object, reference: tuple[float, float] | None = (0.0, 0.0),
                pusher_radius: float = 0.01, *, name: str = "polygon",
                table_size: int = 2048) -> Shape:
        """A simple polygon given by its corners (either orientation) in any frame.

        ``reference`` is the point, in the same frame, that becomes the body-frame origin;
        the contour must be star-shaped about it. ``None`` chooses one (see :meth:`union`).
        """
        return Shape.union([vertices], reference=reference, pusher_radius=pusher_radius,
                           name=name, table_size=table_size)

    @staticmethod
    def union(polygons: list[object], reference: tuple[float, float] | None = (0.0, 0.0),
              pusher_radius: float = 0.01, *, name: str = "union",
              table_size: int = 2048) -> Shape:
        """The union of simple polygons (they may overlap), inflated by the pusher radius.

        ``reference`` (in the corners' frame) becomes the body-frame origin: the point whose
        pose the controller steers to the goal. ``None`` chooses a point in the shape's kernel
        near its area centroid (:func:`dexpush.model.kernel.kernel_point`); ``shape.origin`` says
        which.
        """
        if len(polygons) == 0:
            raise ValueError("a shape needs at least one polygon")
        rho = _check_pusher_radius(pusher_radius)
        table_size = check_table_size(table_size)
        corners = [as_polygon(p, f"polygon {i}") for i, p in enumerate(polygons)]
        if sum(map(len, corners)) > MAX_CORNERS:
            raise ValueError(f"the polygons have {sum(map(len, corners))} corners together; a shape may have at most "
                             f"{MAX_CORNERS} (simplify the outline, or drop repeated polygons)")
        ref = (kernel_point(corners, rho, table_size=table_size) if reference is None
               else np.asarray(reference, dtype=np.float64))
        if ref.shape != (2,) or not np.all(np.isfinite(ref)):
            raise ValueError(f"reference must be a finite (x, y) pair, got {reference!r}")
        polys = tuple(p - ref for p in corners)
        if not any(inside_polygon(np.zeros((1, 2)), p)[0] for p in polys):
            raise ValueError(
                f"the reference point {tuple(ref)} is not inside the shape; "
                "choose a reference in the shape's kernel")
        R, dR = radial_table_polygons(polys, rho, table_size)
        bad = ~(np.isfinite(R) & np.isfinite(dR))
        if np.any(bad):
            raise ValueError(
                f"the contour seen from the reference point {tuple(ref)} is degenerate at azimuth "
                f"{np.degrees(table_azimuths(table_size)[np.argmax(bad)]):.1f}° (a ray grazes the boundary); "
                "move the reference further inside the shape")
        corners = concave_corners(polys, rho, R, dR)
        return Shape(name, polys, rho, R, dR, (float(ref[0]), float(ref[1])), corners)

    @staticmethod
    def from_file(path: str | os.PathLike, *, table_size: int = 2048) -> Shape:
        """A shape from a TOML file's ``[shape]`` table (lengths in metres;
        :mod:`dexpush.model.shape_file` has the format and its checks)::

            [shape]
            polygons = [[[0, 0], [0.2, 0], [0.2, 0.05], [0.05, 0.05], [0.05, 0.15], [0, 0.15]]]
            # or:  ellipse = [0.10, 0.06]

        See ``docs/conventions.md#shapes``.
        """
        spec = read_shape_file(path)
        if spec.ellipse is not None:
            return Shape.ellipse(*spec.ellipse, pusher_radius=spec.pusher_radius, name=spec.name,
                                 table_size=table_size)
        return Shape.union(spec.polygons, reference=spec.reference, pusher_radius=spec.pusher_radius,
                           name=spec.name, table_size=table_size)

    # ------------------------------------------------------------------ queries
    @property
    def coefficients(self) -> np.ndarray:
        """The (table_size, 4) cubic coefficients of R(φ) (see :func:`hermite_coefficients`)."""
        return hermite_coefficients(self.radius_table, self.dradius_table)

    @property
    def table_size(self) -> int:
        return int(self.radius_table.shape[0])

    @property
    def edges(self) -> tuple[np.ndarray, np.ndarray]:
        """All footprint edges as (start (E, 2), end (E, 2)) arrays, for collision checks."""
        a = np.concatenate(self.polygons)
        b = np.concatenate([np.roll(p, -1, axis=0) for p in self.polygons])
        return a, b

    def outline_edges(self, max_edges: int) -> tuple[np.ndarray, np.ndarray]:
        """Edges (start, end) of an outline that contains the footprint with at most ``max_edges`` sides:
        the footprint's own edges when it has no more, a circumscribed polygon
        (:func:`dexpush.model.polygons.circumscribed`) for a convex footprint with more (an ellipse's
        256), the footprint's edges otherwise. The cost's obstacle terms unroll every edge, so their
        time and compile time grow with the count; a circumscribed outline only ever keeps the object
        farther from an obstacle."""
        a, b = self.edges
        if len(a) <= max_edges or len(self.polygons) != 1 or not is_convex(self.polygons[0]):
            return a, b
        outline = circumscribed(self.polygons[0], max_edges)
        return outline, np.roll(outline, -1, axis=0)

    @property
    def footprint_box(self) -> np.ndarray:
        """(x_lo, y_lo, x_hi, y_hi), the footprint's bounding box in {B}."""
        pts = np.concatenate(self.polygons)
        return np.concatenate([pts.min(0), pts.max(0)])

    @property
    def bounding_radius(self) -> float:
        """Largest distance from the reference to the inflated contour."""
        return float(self.radius_table.max())

    def contour(self, phi: object) -> tuple[jnp.ndarray, jnp.ndarray]:
        """Contour point r(φ) and tangent ∂φ r of the inflated contour, each (..., 2).

        Works on any array of azimuths, inside ``jax.jit`` and ``jax.vmap``.
        """
        phi = jnp.asarray(phi)
        if not jnp.issubdtype(phi.dtype, jnp.floating):
            phi = phi.astype(jnp.float32)
        R, dR = contour_lookup(self.coefficients, phi)
        c, s = jnp.cos(phi), jnp.sin(phi)
        r = jnp.stack([R * c, R * s], -1)
        dr = jnp.stack([dR * c - R * s, dR * s + R * c], -1)
        return r, dr

    def contour_points(self, n: int = 512) -> np.ndarray:
        """The inflated contour sampled at ``n`` azimuths (numpy, for plots)."""
        phi = np.linspace(-np.pi, np.pi, n, endpoint=False)
        return np.asarray(self.contour(phi)[0], dtype=np.float64)

    def footprint_world(self, pose: object) -> list[np.ndarray]:
        """Footprint polygons placed at ``pose = (x, y, θ)`` in the world (numpy)."""
        x, y, th = np.asarray(pose, dtype=np.float64)[:3]
        Rm = np.array([[np.cos(th), -np.sin(th)], [np.sin(th), np.cos(th)]])
        return [p @ Rm.T + np.array([x, y]) for p in self.polygons]


def hermite_coefficients(radius_table: np.ndarray, dradius_table: np.ndarray) -> np.ndarray:
    """Per-interval cubic coefficients (n, 4) of the periodic Hermite interpolant of R.

    On interval i, with t = (φ − φ_i)/Δφ ∈ [0, 1): R = c0 + c1·t + c2·t² + c3·t³.
    One row per interval means one gather per lookup inside the rollouts.
    """
    n = radius_table.shape[0]
    h = 2 * np.pi / n
    p0, p1 = radius_table, np.roll(radius_table, -1)
    m0, m1 = dradius_table * h, np.roll(dradius_table, -1) * h
    return np.stack([p0, m0, -3 * p0 - 2 * m0 + 3 * p1 - m1, 2 * p0 + m0 - 2 * p1 + m1], -1)


def contour_lookup(coefficients: jnp.ndarray, phi: jnp.ndarray) -> tuple[jnp.ndarray, jnp.ndarray]:
    """Evaluate the periodic cubic table (see :func:`hermite_coefficients`): (R(φ), R'(φ)).

    The table is cast to φ's dtype, so float64 inputs give float64 outputs.
    """
    n = coefficients.shape[0]
    h = 2 * np.pi / n
    s = (phi + np.pi) * (1.0 / h)
    i0 = jnp.floor(s)
    t = s - i0
    c = jnp.asarray(coefficients, dtype=phi.dtype)[i0.astype(jnp.int32) % n]
    c0, c1, c2, c3 = c[..., 0], c[..., 1], c[..., 2], c[..., 3]
    R = c0 + t * (c1 + t * (c2 + t * c3))
    dR = (c1 + t * (2 * c2 + t * (3 * c3))) * (1.0 / h)
    return R, dR


# ---------------------------------------------------------------------- construction helpers
def _check_positive(**values: float) -> None:
    for k, v in values.items():
        if check_positive(k, v, "a length in metres") > MAX_SHAPE_M:
            raise ValueError(f"{k} must be at most {MAX_SHAPE_M:g} m (lengths are in metres), got {v!r}")


def _check_pusher_radius(rho: object) -> float:
    try:
        return _check_positive(pusher_radius=rho) or float(rho)   # type: ignore[arg-type]
    except ValueError:
        raise ValueError(f"pusher_radius must be a number in (0, {MAX_SHAPE_M:g}] (metres), got {rho!r}; for an "
                         "ideal point pusher use a small radius such as 1e-4") from None

