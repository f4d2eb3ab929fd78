"""Global guidance: the object's cost-to-go round the obstacles (:class:`CostToGo`, :func:`cost_to_go`).

MPPI samples a few seconds ahead and follows the gradient of eq. (9) within them; behind an obstacle
the straight-line goal distance ‖p − g‖ has a local minimum where no sample finds the way round. The
cost-to-go V(p) is the length of the shortest path of the object's reference point from p to the goal
through the positions where the footprint fits in some heading, computed once per problem:

1. The obstacles' signed distance D (discs, convex polygons, the workspace boundary) on a grid of
   spacing h (``CostWeights.guidance_cell_m``).
2. Free positions: p is free when, for one of :data:`HEADINGS` headings θ, every sample q of the
   footprint (its outline every h/2 and its inside every h) has D(p + R(θ)q) > the planner's margin
   (a min over shifted copies of the grid: an erosion).
3. V on the free positions by Dijkstra from the goal over a 16-neighbour grid (its path lengths are at
   most :data:`GRID_STRETCH` longer than straight lines); elsewhere the nearest reachable node's V plus
   the distance to it, so that V is finite everywhere and points back into free space.

With a turn length ρ (``turn_m``, m per radian) V has one layer per heading θ_k = 2πk/K, K = :data:`HEADINGS`:
node (k, i, j) is free where the footprint fits in θ_k, the grid moves stay in their layer, a turn to a
neighbouring layer at a node free in both costs ρ·2π/K, and the goal is the goal's node in the layer of the
goal's heading (``goal_heading``; otherwise every heading at the goal's node, the turn left to the cost's
heading term). V(p, θ) is then the length of the way from p that the footprint can take in the heading it
has, turning where it fits, to the goal pose: in the open ‖p − g‖ + ρ·|θ − θ_g| (up to the grid's stretch
and the layers' spacing); without ρ it is the way for a footprint that turns to fit anywhere at no cost.

With ``pusher_radius`` (opt-in, ``CostWeights.guidance_pusher_room``) a move also needs room for the pusher
behind the object: a move in direction u from node (k, i, j) is an edge only where a disc of that radius,
touching the footprint in θ_k at its support point in direction −u (the outline point farthest back, the one
nearest the line through the reference among ties), keeps the margin to every obstacle. A pusher cannot pull,
so no way leads out of a pocket the object fills, and the graph is directed (Dijkstra runs on its transpose,
from the goal). A node where the footprint fits but no way leads to the goal is a trap: its V is the nearest
reached node's plus the distance plus :data:`TRAP_M`, so that the planner does not push the object in. Three
approximations: a turn between layers needs no room (turning in place is a push off the centre, from
somewhere); a move checks the room where the object starts it only; and nodes where the footprint does not
fit keep the nearest reached node's V without the trap's addition (the obstacle cost holds the object there).

The cost (:func:`dexpush.problem.cost.guided_length_sq`) uses ℓ = max(‖p − g‖, (V(p, θ) − h)/(1 + κ)), κ =
:data:`GRID_STRETCH`: ℓ is the straight-line distance wherever the way to the goal is straight and free
and the heading is the goal's (so the cost there is eq. (9)'s), the path round otherwise, and, with the goal's
heading, longer by the turn still to make (ρ·|θ − θ_g| less h, in the open), so the footprint is drawn to
turn where it fits rather than carried into a place where it cannot.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra

from dexpush.model.polygons import inside_polygon
from dexpush.problem.regions import point_gap

__all__ = ["GRID_BLOCK", "GRID_STRETCH", "HEADINGS", "TRAP_M", "CostToGo", "cost_to_go", "nearest_layer"]

#: the headings tried for a free position (every 360°/HEADINGS)
HEADINGS = 16
#: the 16-neighbour grid's worst stretch of a straight line, interpolation included (2.75 % measured over
#: every direction at 0.4 m; tests/test_guidance.py), rounded up
GRID_STRETCH = 0.03
#: the grid's node counts are rounded up to multiples of this (its far side then lies up to this many cells
#: beyond the workspace, where no node is free), so that problems of one family (a robot's placed tasks) give V
#: arrays of a few shapes and the planner compiles a few times rather than once per problem
GRID_BLOCK = 8
#: with the pusher's room, what V adds (m) where the footprint fits but no pushed way leads to the goal
TRAP_M = 0.2
_MOVES = np.array([(1, 0), (0, 1), (-1, 0), (0, -1), (1, 1), (-1, 1), (-1, -1), (1, -1),
                   (2, 1), (1, 2), (-1, 2), (-2, 1), (-2, -1), (-1, -2), (1, -2), (2, -1)])


@dataclass(frozen=True, eq=False)
class CostToGo:
    """V on a grid: ``values[k, i, j]`` (m) at the node ``lo + (i, j)·cell`` in heading layer k, θ_k = 2πk/K
    (K = ``values.shape[0]``; with one layer V holds for every heading); ``free`` marks the nodes where the
    footprint fits (in layer k's heading, or in some heading with one layer), ``reached`` those of them
    connected to the goal; ``build_s`` is how long :func:`cost_to_go` took."""

    values: np.ndarray
    free: np.ndarray
    reached: np.ndarray
    lo: np.ndarray
    cell: float
    build_s: float

    @property
    def headings(self) -> int:
        """K, the number of heading layers (1: V does not depend on the heading)."""
        return int(self.values.shape[0])

    def layer(self, heading: float) -> int:
        """The layer whose heading is nearest ``heading`` (rad)."""
        return nearest_layer(heading, self.headings)

    def shifted(self, origin: np.ndarray) -> CostToGo:
        """The same field in a frame whose origin is at ``origin`` (x, y, ...) of this one."""
        return CostToGo(self.values, self.free, self.reached, self.lo - np.asarray(origin, np.float64)[:2],
                        self.cell, self.build_s)

    def connects(self, point: object) -> bool:
        """Whether the footprint fits at ``point`` (x, y) in some heading and a free path leads from there
        to the goal (at the nearest node)."""
        i = np.round((np.asarray(point, np.float64)[:2] - self.lo) / self.cell).astype(int)
        reached = self.reached.any(0)
        return bool(np.all((i >= 0) & (i < reached.shape)) and reached[tuple(i)])

    def at(self, points: np.ndarray, headings: np.ndarray | float = 0.0) -> np.ndarray:
        """V at points (..., 2) in ``headings`` (rad; unused with one layer): bilinear between nodes, linear
        between layers; beyond the grid, plus the distance to it."""
        p = np.asarray(points, np.float64)
        n = np.array(self.values.shape[1:]) - 1
        u = (p - self.lo) / self.cell
        uc = np.clip(u, 0, n)
        i = np.minimum(np.floor(uc).astype(int), n - 1)
        f = uc - i
        v = self.values
        layers = ((1 - f[..., 0]) * (1 - f[..., 1]) * v[:, i[..., 0], i[..., 1]]
                  + f[..., 0] * (1 - f[..., 1]) * v[:, i[..., 0] + 1, i[..., 1]]
                  + (1 - f[..., 0]) * f[..., 1] * v[:, i[..., 0], i[..., 1] + 1]
                  + f[..., 0] * f[..., 1] * v[:, i[..., 0] + 1, i[..., 1] + 1])
        val = layers[0]
        if self.headings > 1:
            t = np.mod(np.broadcast_to(np.asarray(headings, np.float64), val.shape) / (2 * np.pi), 1.0) * self.headings
            k0 = np.floor(t).astype(int) % self.headings
            ft = t - np.floor(t)
            pick = np.take_along_axis
            val = ((1 - ft) * pick(layers, k0[None], 0)[0]
                   + ft * pick(layers, ((k0 + 1) % self.headings)[None], 0)[0])
        return val + np.hypot(*np.moveaxis(u - uc, -1, 0)) * self.cell


def nearest_layer(heading: float, layers: int) -> int:
    """The index k of the heading θ_k = 2πk/``layers`` nearest ``heading`` (rad)."""
    return int(np.round(heading * layers / (2 * np.pi))) % layers


def _footprint_samples(polygons: tuple[np.ndarray, ...], cell: float) -> np.ndarray:
    """Points (n, 2) in {B}: each polygon's outline every cell/2 and its inside every cell."""
    lo, hi = np.min(np.concatenate(polygons), 0), np.max(np.concatenate(polygons), 0)
    gx, gy = np.meshgrid(np.arange(lo[0], hi[0], cell), np.arange(lo[1], hi[1], cell), indexing="ij")
    grid = np.stack([gx.ravel(), gy.ravel()], -1)
    inside = np.zeros(len(grid), bool)
    for p in polygons:
        inside |= inside_polygon(grid, p).reshape(-1).astype(bool)
    return np.concatenate([_outline(polygons, cell / 2), grid[inside]])


def _outline(polygons: tuple[np.ndarray, ...], step: float) -> np.ndarray:
    """Points (n, 2) along each polygon's outline, at most ``step`` apart, from each corner on."""
    pts = []
    for p in polygons:
        for a, b in zip(p, np.roll(p, -1, axis=0), strict=True):
            k = max(int(np.ceil(np.hypot(*(b - a)) / step)), 1)
            pts.append(a + (b - a) * (np.arange(k) / k)[:, None])
    return np.concatenate(pts)


def cost_to_go(footprint: tuple[np.ndarray, ...], reach: float, goal: object, discs: np.ndarray,
               polygons: tuple[np.ndarray, ...], workspace: np.ndarray | tuple[np.ndarray, ...] | None,
               margin: float, cell: float = 0.02, turn_m: float | None = None,
               goal_heading: bool = True, pusher_radius: float | None = None) -> CostToGo:
    """The cost-to-go of the module docstring for a footprint (its polygons in {B}, ``reach`` its largest
    distance from the reference) pushed to ``goal`` (x, y, θ) past ``discs`` (M, 3), convex ``polygons`` and
    inside the convex ``workspace`` corners, or inside each of a tuple of them (None: unbounded), keeping
    ``margin`` (m) clear, on a grid of ``cell`` (m). The grid spans the workspace, or the goal and the
    obstacles with room for the footprint round them. ``turn_m`` (m per radian) gives V one layer per
    heading, a turn at a node costing ``turn_m`` per radian, and with ``goal_heading`` the way ends in the
    goal's heading (else in any); None gives one layer, free where the footprint fits in some heading.
    ``pusher_radius`` (m; needs ``turn_m``) makes each move need the pusher's room behind the object."""
    t0 = time.perf_counter()
    if turn_m is not None and not (np.isfinite(turn_m) and turn_m > 0):
        raise ValueError(f"turn_m must be positive (m per radian) or None, got {turn_m!r}")
    if pusher_radius is not None and (turn_m is None or not (np.isfinite(pusher_radius) and pusher_radius > 0)):
        raise ValueError(f"pusher_radius must be positive and needs turn_m (the pusher's room depends on the "
                         f"heading), got pusher_radius={pusher_radius!r}, turn_m={turn_m!r}")
    g = np.asarray(goal, np.float64)
    areas = () if workspace is None else (workspace,) if isinstance(workspace, np.ndarray) else tuple(workspace)
    if areas:
        lo, hi = np.max([np.min(a, 0) for a in areas], 0), np.min([np.max(a, 0) for a in areas], 0)
    else:
        pts = [g[None, :2], *(p for p in polygons)]
        if len(discs):
            pts += [discs[:, :2] - discs[:, 2:3], discs[:, :2] + discs[:, 2:3]]
        pts = np.concatenate(pts)
        pad = 2 * reach + 0.1
        lo, hi = pts.min(0) - pad, pts.max(0) + pad
    lo = g[:2] - np.ceil((g[:2] - lo) / cell - 1e-9) * cell           # the goal is a node
    shape = np.maximum(np.ceil((hi - lo) / cell - 1e-9).astype(int) + 1, 2)
    shape = -(-shape // GRID_BLOCK) * GRID_BLOCK          # a few grid sizes: a family of problems shares compiled code
    # room for the footprint's samples (and the pusher behind it) beyond the grid
    extra = int(np.ceil((reach + (pusher_radius or 0.0)) / cell)) + 1
    ix = np.arange(-extra, shape[0] + extra) * cell + lo[0]
    iy = np.arange(-extra, shape[1] + extra) * cell + lo[1]
    nodes = np.stack(np.meshgrid(ix, iy, indexing="ij"), -1)
    d = np.full(nodes.shape[:2], np.inf)
    for cx, cy, r in discs:
        d = np.minimum(d, np.hypot(nodes[..., 0] - cx, nodes[..., 1] - cy) - r)
    for p in polygons:
        d = np.minimum(d, point_gap(nodes, p))
    for a in areas:
        d = np.minimum(d, -point_gap(nodes, np.asarray(a, np.float64)))
    clear = d > margin
    samples = _footprint_samples(footprint, cell)
    fits = np.ones((HEADINGS, *shape), bool)
    for k in range(HEADINGS):
        th = 2 * np.pi * k / HEADINGS
        c, s = np.cos(th), np.sin(th)
        offsets = np.unique(np.round(samples @ np.array([[c, s], [-s, c]]) / cell).astype(int), axis=0)
        for di, dj in offsets:
            fits[k] &= clear[extra + di:extra + di + shape[0], extra + dj:extra + dj + shape[1]]
    room = None if pusher_radius is None else _pusher_room(footprint, d > pusher_radius + margin, extra, shape,
                                                           cell, pusher_radius)
    goal_node = tuple(np.round((g[:2] - lo) / cell).astype(int))
    if turn_m is None:
        free = fits.any(0, keepdims=True)
        free[(0, *goal_node)] = True
        sources = [(0, *goal_node)]
        turn = 0.0
    else:
        free = fits
        goal_layer = nearest_layer(g[2], HEADINGS)
        free[(goal_layer, *goal_node)] = True
        sources = ([(goal_layer, *goal_node)] if goal_heading
                   else [(k, *goal_node) for k in range(HEADINGS) if free[(k, *goal_node)]])
        turn = turn_m * 2 * np.pi / HEADINGS
    values, reached = _geodesic(free, sources, cell, turn, room)
    return CostToGo(values.astype(np.float32), free, reached, lo.astype(np.float64), float(cell),
                    time.perf_counter() - t0)


def _support_points(outline: np.ndarray, directions: np.ndarray, cell: float) -> np.ndarray:
    """For each unit direction w (n, 2) in {B}, the ``outline`` point (of (P, 2)) farthest along w, the one
    nearest the line through the reference along w among those within a quarter cell of the farthest."""
    along = directions @ outline.T                                                # (n, P)
    across = np.abs(directions[:, :1] * outline[:, 1] - directions[:, 1:] * outline[:, 0])
    near_back = along >= along.max(1, keepdims=True) - cell / 4
    return outline[np.argmin(np.where(near_back, across, np.inf), axis=1)]


def _pusher_room(polygons: tuple[np.ndarray, ...], pusher_clear: np.ndarray, extra: int, shape: np.ndarray,
                 cell: float, radius: float) -> np.ndarray:
    """``room[m, k, i, j]``: with the object at node (i, j) in heading θ_k, a pusher disc of ``radius`` fits
    (``pusher_clear`` on the grid padded by ``extra``) where it touches the footprint on the side of move m's
    direction, so that it can push the object the other way."""
    outline = _outline(polygons, cell / 4)
    moves = _MOVES / np.hypot(*_MOVES.T)[:, None]
    room = np.empty((len(_MOVES), HEADINGS, *shape), bool)
    for k in range(HEADINGS):
        th = 2 * np.pi * k / HEADINGS
        c, s = np.cos(th), np.sin(th)
        to_body = moves @ np.array([[c, -s], [s, c]])                                # w in {B}, rows
        centres = _support_points(outline, to_body, cell) + radius * to_body
        offsets = np.round(centres @ np.array([[c, s], [-s, c]]) / cell).astype(int)  # in {W}, cells
        for m, (di, dj) in enumerate(offsets):
            room[m, k] = pusher_clear[extra + di:extra + di + shape[0], extra + dj:extra + dj + shape[1]]
    return room


def _window(free: np.ndarray, di: int, dj: int, oi: int = 0, oj: int = 0) -> np.ndarray:
    """``free`` (..., nx, ny) at the nodes (i + oi, j + oj) for every start node (i, j) of a move (di, dj) that
    stays on the grid."""
    nx, ny = free.shape[-2:]
    i0, j0 = max(0, -di), max(0, -dj)
    return free[..., i0 + oi:i0 + oi + nx - abs(di), j0 + oj:j0 + oj + ny - abs(dj)]


def _geodesic(free: np.ndarray, sources: list[tuple[int, int, int]], cell: float,
              turn: float, room: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Path lengths (m) to the nearest of ``sources`` over the free nodes (K, nx, ny): in each layer a
    16-neighbour grid (a move's end nodes and the nodes it passes between must be free: no cutting a corner;
    with ``room`` (moves, K, nx, ny) a move also needs the pusher's room behind the object at the object's
    start, src + (di, dj), of the edge src → src + (di, dj)),
    and between neighbouring layers (k, k + 1 mod K) at a node free in both a turn of length ``turn``. A node
    no path reaches gets its layer's nearest reached node's length plus the straight distance to it (the
    nearest in any layer where its layer has none), plus :data:`TRAP_M` at a free one with ``room``. Also the
    reached nodes."""
    n_k, nx, ny = free.shape
    index = np.arange(n_k * nx * ny).reshape(n_k, nx, ny)
    rows, cols, lengths = [], [], []
    for m, (di, dj) in enumerate(_MOVES):  # in every layer at once
        ok = _window(free, di, dj) & _window(free, di, dj, di, dj)
        if room is not None:
            # the edge src → src + (di, dj) is the object's move back from src + (di, dj), pushed from that side
            ok &= _window(room[m], di, dj, di, dj)
        if di and dj:     # a diagonal passes (i + si, j) and (i, j + sj); a knight's move (i + si, j + sj) too
            si, sj = int(np.sign(di)), int(np.sign(dj))
            for oi, oj in {(si, 0), (0, sj), (si, sj), (di - si, dj - sj)} - {(0, 0), (di, dj)}:
                ok &= _window(free, di, dj, oi, oj)
        src = _window(index, di, dj)[ok]
        rows.append(src)
        cols.append(src + di * ny + dj)
        lengths.append(np.full(src.shape, np.hypot(di, dj) * cell))
    if n_k > 1:
        both = free & np.roll(free, -1, axis=0)
        a, b = index[both], np.roll(index, -1, axis=0)[both]
        rows += [a, b]
        cols += [b, a]
        lengths += [np.full(a.shape, turn)] * 2
    graph = coo_matrix((np.concatenate(lengths), (np.concatenate(rows), np.concatenate(cols))),
                       shape=(index.size, index.size)).tocsr()
    dist = dijkstra(graph, indices=[index[s] for s in sources], min_only=True).reshape(n_k, nx, ny)
    reached = np.isfinite(dist)
    out = np.empty_like(dist)
    for k in range(n_k):
        near = reached[k] if reached[k].any() else reached.any(0)
        lengths_k = dist[k] if reached[k].any() else np.where(reached, dist, np.inf).min(0)
        steps, (ii, jj) = ndimage.distance_transform_edt(~near, return_indices=True)
        out[k] = np.where(near, lengths_k, lengths_k[ii, jj] + steps * cell)
    if room is not None:
        out += np.where(free & ~reached, TRAP_M, 0.0)
    return out, reached
