"""A pushing problem: what to push, where to, past what, at what cost (:class:`Problem`).

A :class:`Problem` is validated and built once. It holds what every part of an experiment
derives from the object, the goal and the obstacles: the inflated contour's table
(:class:`dexpush.model.cgvmm.Contour`), the cost's view of the world (:class:`Scene`, in the
world frame and in the controller's goal-centred frame), and the tests a trial is judged by
(success: position and heading within tolerance; a touch of an obstacle). The controller, the
batched simulator, the episode loop, the records and the methods take a Problem, so nothing
below re-derives what it holds.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any

import jax.numpy as jnp
import numpy as np

from dexpush.common.checks import check_positive, checked_vector
from dexpush.common.se2 import pose_error
from dexpush.model.cgvmm import Contour
from dexpush.model.shape import Shape
from dexpush.problem.goal_region import (
    AtWall,
    GoalRegion,
    Overhang,
    PoseBox,
    RegionRows,
    dropped,
    in_region,
    region_error,
)
from dexpush.problem.guidance import CostToGo, cost_to_go
from dexpush.problem.obstacles import clearance_jit, collides_jit
from dexpush.problem.regions import convex_polygon, halfplane_corners, workspace_halfplanes
from dexpush.problem.scene import Scene, keep_out_array, obstacle_array
from dexpush.problem.weights import CostWeights

__all__ = ["COST_OUTLINE_EDGES", "COST_PIECE_CORNERS", "SUCCESS_HEADING_DEG", "SUCCESS_POSITION_M", "Problem",
           "is_success", "reached"]

#: the most edges of the footprint outline the cost's disc terms see (a convex footprint with more, an
#: ellipse's 256, is replaced by a circumscribed polygon of this many): the terms are unrolled over edges ×
#: obstacles, and past a size XLA's fused step slows ~10× (docs/performance.md, obstacle terms)
COST_OUTLINE_EDGES = 12
#: the most corners of a footprint piece the cost's polygon gaps see (likewise circumscribed)
COST_PIECE_CORNERS = 12

#: the paper's success test (Sec. IV-B): position error below 8 mm ...
SUCCESS_POSITION_M = 0.008
#: ... and heading error below 3°
SUCCESS_HEADING_DEG = 3.0


def is_success(object_pose: object, goal: object, xp: Any = np, position_m: float = SUCCESS_POSITION_M,
               heading_deg: float = SUCCESS_HEADING_DEG) -> Any:
    """Position error < ``position_m`` and heading error < ``heading_deg`` (``xp`` as in
    :func:`dexpush.common.se2.pose_error`)."""
    pos, head = pose_error(object_pose, goal, xp)
    return (pos < position_m) & (head < heading_deg)


def reached(object_pose: object, scene: Scene, position_m: float, heading_deg: float, xp: Any = jnp) -> Any:
    """The success test on ``scene``'s goal: :func:`is_success` for a goal pose, membership of the region
    (:func:`dexpush.problem.goal_region.in_region`, the heading within ``heading_deg`` where it counts) for a
    goal region."""
    if scene.has_region:
        return in_region(object_pose, scene.goal, scene.reach, scene.keep, scene.keep_point, scene.region_corners,
                         scene.heading_weight, heading_deg, xp)
    return is_success(object_pose, scene.goal, xp, position_m, heading_deg)


@dataclass(frozen=True, eq=False)
class Problem:
    """Push ``shape`` to the pose ``goal`` (x, y, θ in the world frame) without touching the disc
    ``obstacles`` (c_x, c_y, radius) or the convex ``polygons`` (boxes, walls: each a tuple of corners;
    :mod:`dexpush.problem.regions`), and without leaving the convex ``workspace`` (its corners, or a
    rectangle (x_lo, y_lo, x_hi, y_hi); None: unbounded), the object's footprint alone also inside the
    convex ``object_workspace`` and the pusher alone inside the convex ``pusher_workspace`` (likewise; on a
    robot: where its pusher can get round the object, and the arm's reach), and the footprint r_o and the
    pusher's disc r_p clear of the centre of each ``keep_out`` disc (c_x, c_y, r_o, r_p) (on a robot: the arm's
    inner reach round its base), at the cost of eq. (9) with ``weights``;
    success is a position error below ``tolerance_m`` and a heading error below ``tolerance_deg``.
    The goal's footprint must fit: a ``ValueError`` says which obstacle it touches.

    ``goal`` may instead be a region (:mod:`dexpush.problem.goal_region`: :class:`Overhang`, :class:`AtWall`,
    :class:`PoseBox`), kept as ``region``: then ``goal`` becomes a pose in it (the controller's frame origin and
    the plots' marker), the cost's goal distance is to the region, success is being in it, and for an
    :class:`Overhang` the footprint may cross that workspace edge (the pusher may not) while its centre of mass
    crossing it is a drop (:meth:`dropped`), which fails a trial as a touch does.

    Derived once, on construction: ``contour`` (the inflated contour's table), ``scene`` (the
    cost's view, world frame, with an outline of at most :data:`COST_OUTLINE_EDGES` edges),
    ``origin`` and ``local_scene`` (the same in the controller's frame, whose origin is the goal's
    position: float32 keeps its resolution wherever the world frame is), and ``judge_scene`` (the
    footprint's own edges: what :meth:`collides` and :meth:`clearance` judge a trial by; the
    ``object_workspace``, ``pusher_workspace`` and ``keep_out`` left out: they keep the planner where a robot can
    push, and leaving them is no touch), and ``guide`` (the cost-to-go round the obstacles,
    :mod:`dexpush.problem.guidance`; None without polygons, workspace and keep-out discs, or with
    ``weights.guidance`` off).
    """

    shape: Shape
    goal: tuple[float, float, float]
    obstacles: tuple[tuple[float, float, float], ...] = ()
    weights: CostWeights = field(default_factory=CostWeights)
    tolerance_m: float = SUCCESS_POSITION_M
    tolerance_deg: float = SUCCESS_HEADING_DEG
    polygons: tuple[tuple[tuple[float, float], ...], ...] = ()
    workspace: tuple[tuple[float, float], ...] | None = None
    #: (discs, polygons): the cost's scenes hold at least this many, inert ones added far away, so that
    #: a family of problems (the clutter benchmark's seeds) shares compiled code (:meth:`Scene.make`)
    pad_to: tuple[int, int] = (0, 0)
    object_workspace: tuple[tuple[float, float], ...] | None = None
    pusher_workspace: tuple[tuple[float, float], ...] | None = None
    region: GoalRegion | None = None
    keep_out: tuple[tuple[float, float, float, float], ...] = ()
    #: the region's rows in the world frame (:class:`dexpush.problem.goal_region.RegionRows`); None for a goal pose
    region_rows: RegionRows | None = field(init=False, repr=False)
    contour: Contour = field(init=False, repr=False)
    scene: Scene = field(init=False, repr=False)
    origin: np.ndarray = field(init=False, repr=False)
    local_scene: Scene = field(init=False, repr=False)
    judge_scene: Scene = field(init=False, repr=False)
    guide: CostToGo | None = field(init=False, repr=False)

    def __post_init__(self) -> None:
        if not isinstance(self.shape, Shape):
            raise TypeError(f"shape must be a dexpush.Shape, got {type(self.shape).__name__}")
        if not isinstance(self.weights, CostWeights):
            raise ValueError(f"weights must be a CostWeights, got {self.weights!r}")
        region = self.region
        if isinstance(self.goal, Overhang | AtWall | PoseBox):
            region = self.goal
        elif region is not None and not isinstance(region, Overhang | AtWall | PoseBox):
            raise ValueError(f"region must be an Overhang, AtWall or PoseBox, got {region!r}")
        discs = obstacle_array(self.obstacles)
        keep_out = keep_out_array(self.keep_out)
        check_positive("tolerance_m", self.tolerance_m, "m")
        check_positive("tolerance_deg", self.tolerance_deg, "degrees")
        polys = tuple(convex_polygon(p, f"obstacle polygon {i}") for i, p in enumerate(self.polygons))
        bounds, corners = None, None
        if self.workspace is not None:
            bounds = workspace_halfplanes(self.workspace)
            corners = halfplane_corners(bounds)
        goal_rows = None
        if region is not None:
            goal_rows = region.rows(self.shape, bounds, polys, self.weights.obstacle_margin_m)
            goal = region.nominal(self.shape, goal_rows, bounds, self.weights.obstacle_margin_m)
        else:
            goal = checked_vector("goal", self.goal, 3)
        if bounds is not None and not (goal_rows is not None and goal_rows.edge):    # (an overhang's pose is out)
            self._check_goal_inside(goal, bounds)    # before the guidance, whose grid the goal must lie on
        own = {name: None if getattr(self, name) is None else workspace_halfplanes(getattr(self, name))
               for name in ("object_workspace", "pusher_workspace")}     # the object's and the pusher's own
        origin = np.array([goal[0], goal[1], 0.0])
        put = object.__setattr__
        put(self, "goal", tuple(float(v) for v in goal))
        put(self, "obstacles", tuple(tuple(float(v) for v in d) for d in discs))
        put(self, "keep_out", tuple(tuple(float(v) for v in d) for d in keep_out))
        put(self, "polygons", tuple(tuple((float(x), float(y)) for x, y in p) for p in polys))
        put(self, "workspace", None if corners is None else tuple((float(x), float(y)) for x, y in corners))
        for name, rows in own.items():
            put(self, name, None if rows is None else tuple((float(x), float(y)) for x, y in halfplane_corners(rows)))
        object_bounds, pusher_bounds = own["object_workspace"], own["pusher_workspace"]
        edge_bounds = None
        if goal_rows is not None and goal_rows.edge:
            # an overhang's edge bounds the pusher alone: the footprint may cross it
            edge = np.all(np.isclose(bounds, goal_rows.keep[:1, :3]), axis=1)
            edge_bounds, bounds = bounds[edge], bounds[~edge]
        put(self, "region", region)
        put(self, "region_rows", goal_rows)
        guide = None
        # disc-only scenes keep the detour round the discs, a footprint's reach from each, alone
        # (docs/workspaces.md#discs-alone-keep-the-detour-2026-12-05)
        if self.weights.guidance and region is None and (polys or bounds is not None or len(keep_out)):
            if self.weights.guidance_pusher_room and (object_bounds is not None or pusher_bounds is not None
                                                      or len(keep_out)):
                # the pusher's room is measured against the footprint's obstacles and bounds, not a robot's own
                raise ValueError("weights.guidance_pusher_room is for scenes without object_workspace, "
                                 "pusher_workspace or keep_out (a robot's bounds); turn it off for this problem")
            # the object's own bounds (a robot's reach) and keep-out discs bound its way too
            area = [rows for rows in (bounds, object_bounds) if rows is not None]
            guide = cost_to_go(self.shape.polygons, self.shape.bounding_radius, goal,
                               np.concatenate([discs, keep_out[:, :3]]), polys,
                               tuple(halfplane_corners(rows) for rows in area) or None,
                               self.weights.obstacle_margin_m, self.weights.guidance_cell_m,
                               self.weights.guidance_turn_m, self.weights.guidance_goal_heading,
                               self.shape.pusher_radius if self.weights.guidance_pusher_room else None)
        put(self, "guide", guide)
        put(self, "contour", Contour.of(self.shape))
        put(self, "scene", Scene.make(self.shape, goal, discs, self.weights, COST_OUTLINE_EDGES, polys, bounds,
                                      guide, self.pad_to, COST_PIECE_CORNERS, object_bounds,
                                      pusher_bounds, goal_rows, keep_out, edge_bounds))
        put(self, "origin", origin)
        shift = origin * [1.0, 1.0, 0.0]
        # a half-plane n·p ≤ o seen from the origin: n·(p − origin) ≤ o − n·origin
        def seen_from_origin(rows: np.ndarray | None) -> np.ndarray | None:
            return None if rows is None else np.c_[rows[:, :2], rows[:, 2] - rows[:, :2] @ origin[:2]]

        put(self, "local_scene", Scene.make(self.shape, goal - origin, discs - shift, self.weights, COST_OUTLINE_EDGES,
                                            tuple(p - origin[:2] for p in polys), seen_from_origin(bounds),
                                            None if guide is None else guide.shifted(origin), self.pad_to,
                                            COST_PIECE_CORNERS, seen_from_origin(object_bounds),
                                            seen_from_origin(pusher_bounds),
                                            None if goal_rows is None else goal_rows.shifted(origin),
                                            keep_out - np.array([*origin[:2], 0.0, 0.0]),
                                            seen_from_origin(edge_bounds)))
        put(self, "judge_scene", Scene.make(self.shape, goal, discs, self.weights, None, polys, bounds,
                                            pad_to=self.pad_to, region=goal_rows))
        if region is None or isinstance(region, PoseBox):     # (a region's own pose is only a marker)
            self._check_goal_fits()

    def _check_goal_fits(self) -> None:
        """A ``ValueError`` when the goal's footprint touches an obstacle (the workspace is checked first)."""
        if self.obstacles or self.polygons:
            # the pusher far away (and the workspace, which would see it outside, left out): the footprint alone
            at_goal = jnp.asarray([[*self.goal, self.goal[0] + 1e3, self.goal[1] + 1e3]], jnp.float32)
            scene = dataclasses.replace(self.judge_scene, bounds=self.judge_scene.bounds[:0])
            gap = float(np.asarray(clearance_jit(at_goal, scene))[0])
            if gap <= 0:
                raise ValueError(f"the goal pose {self.goal} puts the object's footprint on an obstacle "
                                 f"(overlap {-gap * 1e3:.1f} mm): move the goal or the obstacles")

    def _check_goal_inside(self, goal: np.ndarray, bounds: np.ndarray) -> None:
        """A ``ValueError`` when the goal's footprint leaves the workspace (half-planes ``bounds``)."""
        corners = np.concatenate(self.shape.footprint_world(goal))
        out = float(np.max(corners @ bounds[:, :2].T - bounds[:, 2]))
        if out >= 0:
            raise ValueError(f"the goal pose {tuple(float(v) for v in goal)} puts the object's footprint outside the "
                             f"workspace (by {out * 1e3:.1f} mm): move the goal or widen the workspace")

    @property
    def table(self) -> tuple[float, float, float, float] | None:
        """With an :class:`Overhang` goal, the table top (x_lo, y_lo, x_hi, y_hi) that holds the object up (the
        workspace's bounding box: a physics plant's table, whose edge the object can fall from); else None."""
        if self.region_rows is None or not self.region_rows.edge:
            return None
        c = np.asarray(self.workspace)
        return (*(float(v) for v in c.min(0)), *(float(v) for v in c.max(0)))

    @property
    def has_obstacles(self) -> bool:
        """Whether anything can be touched: a disc, a polygon or the workspace's boundary."""
        return bool(self.obstacles or self.polygons or self.workspace is not None)

    def success(self, object_pose: object, xp: Any = np) -> Any:
        """Whether ``object_pose`` (..., 3) is within the tolerances of the goal (in the goal region)."""
        if xp is jnp:
            return reached(object_pose, self.scene, self.tolerance_m, self.tolerance_deg, jnp)
        q = np.asarray(object_pose, np.float64)
        if self.region_rows is None:
            return is_success(q, np.asarray(self.goal), np, self.tolerance_m, self.tolerance_deg)
        r = self.region_rows
        return in_region(q, self.goal, r.reach, r.keep, r.point, np.concatenate(self.shape.polygons),
                         float(r.heading), self.tolerance_deg, np)

    def goal_error(self, object_pose: object) -> tuple[float, float]:
        """(m, degrees): how far ``object_pose`` (3,) is from the goal pose, or for a goal region how far it is
        from meeting the region's rows (zero inside) and its heading error where the heading counts (else 0)."""
        q = np.asarray(object_pose, np.float64)
        pos, head = pose_error(q, np.asarray(self.goal))
        if self.region_rows is None:
            return float(pos), float(head)
        r = self.region_rows
        out = region_error(q, r.reach, r.keep, r.point, np.concatenate(self.shape.polygons), np)
        return max(float(out), 0.0), float(head) if r.heading else 0.0

    def dropped(self, states: object) -> np.ndarray:
        """(...,) bool: with an :class:`Overhang` goal, whether the object's centre of mass is past the table's
        edge in states (..., ≥ 3) (it falls); all False otherwise."""
        x = np.asarray(states, np.float64)
        return np.asarray(dropped(x[..., :3], self.region_rows, np), bool)

    def collides(self, states: object) -> np.ndarray:
        """(...,) bool: the object's footprint or the pusher touches an obstacle in states (..., 5), or the object
        drops off the table (:meth:`dropped`)."""
        x = jnp.asarray(states, jnp.float32)
        if not self.has_obstacles:
            return np.zeros(x.shape[:-1], bool)
        hit = np.asarray(collides_jit(x, self.judge_scene))
        return hit | self.dropped(states) if self.region_rows is not None else hit

    def clearance(self, states: object) -> np.ndarray:
        """(...,) the smallest gap (m) between an obstacle and the object or the pusher; +inf without obstacles."""
        x = jnp.asarray(states, jnp.float32)
        if not self.has_obstacles:
            return np.full(x.shape[:-1], np.inf)
        return np.asarray(clearance_jit(x, self.judge_scene))

    def check_start(self, object_pose: object, pusher: object, what: str = "the start") -> None:
        """A one-line ``ValueError`` when the object's footprint or the pusher at ``what`` touches an obstacle
        or leaves the workspace."""
        gap = float(self.clearance(np.concatenate([np.ravel(object_pose), np.ravel(pusher)])[None])[0])
        if gap <= 0:
            raise ValueError(f"{what} (object at {tuple(round(float(v), 3) for v in np.ravel(object_pose))}, pusher "
                             f"at {tuple(round(float(v), 3) for v in np.ravel(pusher))}) touches an obstacle or leaves "
                             f"the workspace (by {-gap * 1e3:.1f} mm): move the obstacles or the start")

    def with_weights(self, weights: CostWeights) -> Problem:
        """The same problem at the cost ``weights``."""
        return Problem(self.shape, self.goal if self.region is None else self.region, self.obstacles, weights,
                       self.tolerance_m, self.tolerance_deg, self.polygons, self.workspace, self.pad_to,
                       self.object_workspace, self.pusher_workspace, keep_out=self.keep_out)

