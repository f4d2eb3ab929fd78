"""What the cost of eq. (9) knows about the world: the goal, the obstacles (discs and convex polygons),
the workspace, the object's footprint and the cost-to-go that guides it round them, as arrays that can
be passed into jit (:class:`Scene`)."""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial

import jax
import jax.numpy as jnp
import numpy as np

from dexpush.model.convex_pieces import convex_pieces
from dexpush.model.polygons import circumscribed, is_convex
from dexpush.model.shape import Shape
from dexpush.problem.goal_region import RegionRows
from dexpush.problem.guidance import CostToGo
from dexpush.problem.regions import halfplanes
from dexpush.problem.weights import CostWeights

__all__ = ["INERT_M", "JUDGE_PIECE_CORNERS", "ROW_BLOCK", "Scene", "footprint_pieces", "keep_out_array",
           "obstacle_array", "padded_polygons", "padded_rows"]

#: the most corners of a footprint piece the polygon gaps see by default (the judge's scene): a
#: circumscribed 64-gon lies within 0.13 mm of the ellipse's 256-gon
JUDGE_PIECE_CORNERS = 64

#: half-plane arrays (workspace, the object's and the pusher's bounds) hold a multiple of this many rows
ROW_BLOCK = 4

#: where the inert obstacles of a padded scene lie (m along x and y): far beyond any margin
INERT_M = 1000.0


@dataclass(frozen=True)
class Scene:
    """What the cost needs to know about the world: goal, obstacles and the object's footprint.

    Built with :meth:`make`; the arrays are jnp so that a Scene can be passed into jit.
    """

    goal: jnp.ndarray            #: (3,) goal pose [x, y, θ]
    obstacles: jnp.ndarray       #: (M, 3) discs [c_x, c_y, radius]; M may be 0
    edge_a: jnp.ndarray          #: (E, 2) footprint edge starts in {B}
    edge_b: jnp.ndarray          #: (E, 2) footprint edge ends in {B}
    r_s: jnp.ndarray             #: the effective free-roaming radius of the pusher (m)
    pusher_radius: float
    #: (M,) radius ρ_m (m) of the disc around obstacle m that the goal distance detours round
    #: (:func:`detour_length_sq`); empty without ``CostWeights.detour``
    detour_radius: jnp.ndarray = None  # type: ignore[assignment]
    #: the margin (m) this plan keeps from the obstacles: ``CostWeights.obstacle_margin_m``, or less
    #: where the object or the pusher is already nearer (:func:`plan_margin`)
    margin: jnp.ndarray = None  # type: ignore[assignment]
    #: (P, K, 2) convex obstacle polygons' corners, counter-clockwise, padded by repeating the last corner
    polygons: jnp.ndarray = None  # type: ignore[assignment]
    #: (P, K, 3) their edges as half-planes [n_x, n_y, o] (n·p ≤ o inside), padded by repeating a row
    polygon_planes: jnp.ndarray = None  # type: ignore[assignment]
    #: (H, 3) the workspace as half-planes [n_x, n_y, o]: footprint and pusher stay where n·p ≤ o; H may be 0
    bounds: jnp.ndarray = None  # type: ignore[assignment]
    #: (Q, V, 2) the footprint's convex pieces in {B} (at most ``max_edges`` corners each), padded like
    #: ``polygons``; and (Q, V, 3) their half-planes (:func:`footprint_pieces`)
    pieces: jnp.ndarray = None  # type: ignore[assignment]
    piece_planes: jnp.ndarray = None  # type: ignore[assignment]
    #: (K, N_x, N_y) the cost-to-go V on its grid, K heading layers (:class:`dexpush.problem.guidance.CostToGo`);
    #: (0, 0, 0) without one. ``guide_lo`` (2,) is the grid's first node, ``guide_cell`` its spacing (m).
    guide: jnp.ndarray = None  # type: ignore[assignment]
    guide_lo: jnp.ndarray = None  # type: ignore[assignment]
    guide_cell: jnp.ndarray = None  # type: ignore[assignment]
    #: (H', 3) half-planes [n_x, n_y, o] the footprint alone stays within (where a robot's pusher can get round
    #: it); H' may be 0
    object_bounds: jnp.ndarray = None  # type: ignore[assignment]
    #: (H'', 3) half-planes the pusher alone stays within, ``pusher_margin`` from them (a robot arm's reach, which
    #: its safety filter holds); H'' may be 0
    pusher_bounds: jnp.ndarray = None  # type: ignore[assignment]
    #: a goal region (:mod:`dexpush.problem.goal_region`): (G, 4) reach rows and (K, 4) keep rows [n_x, n_y, o, δ],
    #: the (2,) point in {B} the keep rows hold, the footprint's (C, 2) corners in {B} its success test reads, and
    #: 1 where the heading counts (0: any heading); G = K = 0 for a goal pose
    reach: jnp.ndarray = None  # type: ignore[assignment]
    keep: jnp.ndarray = None  # type: ignore[assignment]
    keep_point: jnp.ndarray = None  # type: ignore[assignment]
    region_corners: jnp.ndarray = None  # type: ignore[assignment]
    heading_weight: jnp.ndarray = None  # type: ignore[assignment]
    #: (R, 4) discs [c_x, c_y, r_object, r_pusher] the footprint keeps r_object clear of and the pusher's disc
    #: r_pusher clear of (a robot arm's inner reach round its base); R may be 0
    keep_out: jnp.ndarray = None  # type: ignore[assignment]
    #: the margin (m) this plan keeps the pusher from bounds of its own (``pusher_bounds``, the keep-out discs'
    #: r_pusher): ``CostWeights.pusher_bound_margin_m``, or less where the pusher is already nearer
    #: (:func:`dexpush.problem.cost.plan_margin`)
    pusher_margin: jnp.ndarray = None  # type: ignore[assignment]
    #: (H''', 3) half-planes the pusher alone stays within at the obstacles' ``margin`` (an overhang goal's table
    #: edge, which the footprint may cross); H''' may be 0
    edge_bounds: jnp.ndarray = None  # type: ignore[assignment]

    @property
    def has_region(self) -> bool:
        """Whether the goal is a region (:mod:`dexpush.problem.goal_region`) rather than a pose."""
        return bool(self.reach.shape[0] or self.keep.shape[0])

    @property
    def has_obstacles(self) -> bool:
        """Whether there is anything to keep clear of: a disc, a polygon or a workspace boundary."""
        return bool(self.obstacles.shape[0] or self.polygons.shape[0] or self.bounds.shape[0]
                    or self.object_bounds.shape[0] or self.pusher_bounds.shape[0] or self.keep_out.shape[0]
                    or self.edge_bounds.shape[0])

    @staticmethod
    def make(shape: Shape, goal: object, obstacles: object = (), weights: CostWeights | None = None,
             max_edges: int | None = None, polygons: tuple[np.ndarray, ...] = (),
             bounds: np.ndarray | None = None, guide: CostToGo | None = None,
             pad_to: tuple[int, int] = (0, 0), max_piece_corners: int = JUDGE_PIECE_CORNERS,
             object_bounds: np.ndarray | None = None, pusher_bounds: np.ndarray | None = None,
             region: RegionRows | None = None, keep_out: object = (), edge_bounds: np.ndarray | None = None) -> Scene:
        """The cost's view of a task; with ``max_edges``, the footprint's outline has at most that many
        edges where the footprint is convex (:meth:`dexpush.model.shape.Shape.outline_edges`), and its
        convex pieces (what the polygon gaps see) at most ``max_piece_corners`` corners.
        ``polygons`` are convex obstacle polygons (checked by
        :func:`dexpush.problem.regions.convex_polygon`), ``bounds`` the workspace's half-planes
        (:func:`dexpush.problem.regions.workspace_halfplanes`), ``object_bounds`` and ``pusher_bounds`` the
        half-planes that bound the object alone (where a robot's pusher can get round it) and the pusher alone
        (the arm's reach), ``edge_bounds`` half-planes that bound the pusher alone at the obstacles' margin (an
        overhang goal's table edge), ``keep_out`` discs (c_x, c_y, r_object, r_pusher) about which the footprint stays
        r_object and the pusher's disc r_pusher away (the arm's inner reach), ``guide`` the cost-to-go,
        ``region`` a goal region's rows (the goal distance is then to the region, with no detour:
        :func:`dexpush.problem.cost.goal_distance_sq`), all in the frame of ``goal``. ``pad_to`` (discs, polygons): add
        inert ones 1 km away up to these counts, so that the problems of one family (a clutter benchmark's seeds) have
        arrays of one shape and share compiled code.

        The effective r_s is max(r_s, R_max + r_s_clearance), R_max the largest radius of
        the inflated contour. Table II's r_s = 0.2 m suits the paper's objects, but the
        standard T reaches 0.187 m from its reference: with r_s = 0.2 the ReLU term (9d)
        charges q_r2 = 1e4 per metre and step for walking around the stem, which traps
        the pusher on one side of it (docs/controller.md).
        """
        w = weights or CostWeights()
        g = np.asarray(goal, dtype=np.float64)
        if g.shape != (3,) or not np.all(np.isfinite(g)):
            raise ValueError(f"goal must be a finite pose (x, y, θ), got {goal!r}")
        obs = obstacle_array(obstacles)
        n_discs, n_polys = pad_to
        if len(obs) < n_discs:
            obs = np.concatenate([obs, [[INERT_M + i, INERT_M, 1e-3] for i in range(n_discs - len(obs))]])
        if len(polygons) < n_polys:
            sliver = np.array([[0.0, 0.0], [1e-3, 0.0], [0.0, 1e-3]])
            polygons = (*polygons, *(sliver + np.array([INERT_M, INERT_M + i]) for i in range(n_polys - len(polygons))))
        a, b = shape.edges if max_edges is None else shape.outline_edges(max_edges)
        r_s = w.r_s if w.r_s_clearance is None else max(w.r_s, shape.bounding_radius + w.r_s_clearance)
        rho = np.zeros(0)
        if w.detour and len(obs) and region is None:
            # no orientation of the footprint reaches an obstacle while the reference stays this far
            # from it; capped at the goal's distance, so that the goal itself is never inside a detour disc
            reach = float(np.max(np.hypot(a[:, 0], a[:, 1])))
            rho = np.minimum(obs[:, 2] + w.obstacle_margin_m + reach, np.hypot(*(g[None, :2] - obs[:, :2]).T))
        poly, planes = padded_polygons(polygons)
        pieces, piece_planes = padded_polygons(footprint_pieces(shape, max_piece_corners))
        bounds, object_bounds, pusher_bounds, edge_bounds = (padded_rows(b) for b in (bounds, object_bounds,
                                                                                     pusher_bounds, edge_bounds))
        keep_out = keep_out_array(keep_out)
        values, lo, cell = (np.zeros((0, 0, 0)), np.zeros(2), 1.0) if guide is None else (guide.values, guide.lo,
                                                                                           guide.cell)
        f32 = partial(jnp.asarray, dtype=jnp.float32)
        if region is None:
            reach, keep, point, heading = np.zeros((0, 4)), np.zeros((0, 4)), np.zeros(2), 1.0
            corners = np.zeros((0, 2))
        else:
            reach, keep, point, heading = region.reach, region.keep, region.point, float(region.heading)
            corners = np.concatenate(shape.polygons)
        return Scene(jnp.asarray(g), jnp.asarray(obs), jnp.asarray(a), jnp.asarray(b), jnp.asarray(r_s),
                     shape.pusher_radius, jnp.asarray(rho), jnp.asarray(w.obstacle_margin_m),
                     jnp.asarray(poly), jnp.asarray(planes), jnp.asarray(bounds), jnp.asarray(pieces),
                     jnp.asarray(piece_planes), f32(values), f32(lo), f32(cell), jnp.asarray(object_bounds),
                     jnp.asarray(pusher_bounds), jnp.asarray(reach), jnp.asarray(keep), jnp.asarray(point),
                     jnp.asarray(corners), jnp.asarray(heading), jnp.asarray(keep_out),
                     pusher_margin=jnp.asarray(w.pusher_bound_margin_m), edge_bounds=jnp.asarray(edge_bounds))


jax.tree_util.register_dataclass(
    Scene, data_fields=["goal", "obstacles", "edge_a", "edge_b", "r_s", "detour_radius", "margin", "polygons",
                        "polygon_planes", "bounds", "pieces", "piece_planes", "guide", "guide_lo", "guide_cell",
                        "object_bounds", "pusher_bounds", "reach", "keep", "keep_point", "region_corners",
                        "heading_weight", "keep_out", "pusher_margin", "edge_bounds"],
    meta_fields=["pusher_radius"])


def padded_polygons(polygons: tuple[np.ndarray, ...] | list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Convex counter-clockwise polygons as one (P, K, 2) corner array and one (P, K, 3) half-plane array
    (:func:`dexpush.problem.regions.halfplanes`), K the most corners of any: a shorter polygon repeats its
    last corner and its last half-plane, which changes no separation (a minimum over corners, a maximum
    over planes)."""
    if not len(polygons):
        return np.zeros((0, 3, 2)), np.zeros((0, 3, 3))
    k = max(len(p) for p in polygons)
    corners = np.stack([np.concatenate([p, np.repeat(p[-1:], k - len(p), 0)]) for p in polygons])
    planes = [halfplanes(p) for p in polygons]
    return corners, np.stack([np.concatenate([h, np.repeat(h[-1:], k - len(h), 0)]) for h in planes])


def footprint_pieces(shape: Shape, max_edges: int | None = None) -> list[np.ndarray]:
    """The footprint as convex pieces in {B} (:func:`dexpush.model.convex_pieces.convex_pieces` of each
    polygon); with ``max_edges``, a piece with more corners is replaced by its circumscribed polygon of
    that many (the ellipse's 256-gon), which only ever keeps the object farther from an obstacle."""
    pieces = [q for p in shape.polygons for q in ([p] if is_convex(p) else convex_pieces(p))]
    if max_edges is not None:
        pieces = [circumscribed(q, max_edges) if len(q) > max_edges else q for q in pieces]
    return pieces


def obstacle_array(obstacles: object) -> np.ndarray:
    """Disc obstacles as a float64 (M, 3) array [c_x, c_y, radius]; one disc may be given as (3,).
    Anything else (e.g. (x, y) pairs) is refused with a ``ValueError``."""
    try:
        obs = np.asarray(obstacles, dtype=np.float64) if len(obstacles) else np.zeros((0, 3))
    except (TypeError, ValueError) as exc:
        raise ValueError(f"obstacles must be discs (c_x, c_y, radius), got {obstacles!r}") from exc
    obs = obs[None] if obs.shape == (3,) else obs
    if obs.ndim != 2 or obs.shape[1] != 3:
        raise ValueError(f"obstacles must be discs (c_x, c_y, radius): an (M, 3) array, got shape {obs.shape}")
    if not np.all(np.isfinite(obs)) or np.any(obs[:, 2] <= 0):
        raise ValueError(f"obstacles must be finite discs (c_x, c_y, radius > 0), got {obstacles!r}")
    return obs



def keep_out_array(keep_out: object) -> np.ndarray:
    """Keep-out discs as a float64 (R, 4) array [c_x, c_y, r_object, r_pusher]; anything else, or a radius below
    zero, is refused with a ``ValueError``."""
    try:
        k = np.asarray(keep_out, dtype=np.float64) if len(keep_out) else np.zeros((0, 4))
    except (TypeError, ValueError) as exc:
        raise ValueError(f"keep_out must be discs (c_x, c_y, r_object, r_pusher), got {keep_out!r}") from exc
    if k.ndim != 2 or k.shape[1] != 4 or not np.all(np.isfinite(k)) or np.any(k[:, 2:] < 0):
        raise ValueError(f"keep_out must be finite discs (c_x, c_y, r_object >= 0, r_pusher >= 0), got {keep_out!r}")
    return k


def padded_rows(rows: object, block: int = ROW_BLOCK) -> np.ndarray:
    """Half-plane rows (H, 3) (None: none) padded to a multiple of ``block`` by repeating the last, which changes
    no gap (a least over the rows), so that problems whose bounds have a few corners more or less (a robot's
    reach clipped by a task's area) share compiled code."""
    r = np.zeros((0, 3)) if rows is None else np.asarray(rows, np.float64).reshape(-1, 3)
    return np.concatenate([r, np.repeat(r[-1:], -len(r) % block, 0)]) if len(r) else r
