"""One planning problem: the plan it produces and what the graph, the rounding and the timing share."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from dexpush.gcs.geometry import Face, Region, contact_faces, free_regions, region_graph, region_route
from dexpush.gcs.settings import GCSSettings, PlanningError
from dexpush.model.shape import Shape

__all__ = ["Plan", "Problem", "free_route_rows", "make_problem", "start_routes"]


@dataclass
class Plan:
    """A rounded GCS plan and its timed reference.

    Attributes:
        modes: the path's vertex names (``start``, ``free i→j``, ``face j``, ..., ``goal``).
        knots: per contact mode, (N, 3) object poses at the knots.
        times, poses, pusher, face: the timed reference sampled every ``dt`` seconds:
            object pose (T, 3), pusher centre (T, 2) and the face in contact (−1 free).
        relaxation_cost, rounded_cost: objective of the convex relaxation and of the
            rounded plan (their ratio bounds the optimality gap).
        relaxation_s, rounding_s: wall time of the two solves (s); ``planning_s`` is all of it.
    """

    modes: list[str]
    knots: list[np.ndarray]
    times: np.ndarray
    poses: np.ndarray
    pusher: np.ndarray
    face: np.ndarray
    relaxation_cost: float
    rounded_cost: float
    relaxation_s: float
    rounding_s: float
    planning_s: float
    params: np.ndarray = field(default_factory=lambda: np.zeros(3))

    @property
    def duration(self) -> float:
        return float(self.times[-1])

    def commands(self) -> np.ndarray:
        """Pusher velocities (T−1, 2) that move the pusher along the reference."""
        return np.diff(self.pusher, axis=0) / np.diff(self.times)[:, None]


@dataclass
class Problem:
    """Everything the graph, the rounding and the timing share."""

    shape: Shape
    faces: list[Face]
    regions_rho: list[Region]        #: offset ρ (where a contact starts and ends)
    regions_free: list[Region]       #: offset ρ + margin (free motion)
    adj: list[list[int]]
    M: np.ndarray
    mu: float                        #: μ' = mu_margin·μ
    start: np.ndarray                #: (3,) object pose
    pusher_body: np.ndarray          #: (2,) start pusher in {B}
    goal: np.ndarray
    lo: np.ndarray                   #: workspace box of the object position
    hi: np.ndarray
    settings: GCSSettings

    @property
    def heading_range(self) -> tuple[float, float]:
        """Headings the plan may pass: start to (unwrapped) goal, padded."""
        th0 = self.start[2]
        thg = self.goal[2] + 2 * np.pi * np.round((th0 - self.goal[2]) / (2 * np.pi))
        pad = self.settings.heading_pad_rad
        return min(th0, thg) - pad, max(th0, thg) + pad

    @property
    def rho(self) -> float:
        return self.shape.pusher_radius

    def step_wrench(self, f: Face, sigma: object, cn: object, cf: object) -> tuple:
        """Body wrench [f_x, f_y, τ] of the impulse (c_n, c_f) at σ on face f (any algebra)."""
        n_in, t = -f.n_out, f.tangent
        qx = f.a[0] + sigma * f.d[0] + self.rho * f.n_out[0]
        qy = f.a[1] + sigma * f.d[1] + self.rho * f.n_out[1]
        fx, fy = cn * n_in[0] + cf * t[0], cn * n_in[1] + cf * t[1]
        return fx, fy, qx * fy - qy * fx

    def translation(self, fx: object, fy: object, omega: object) -> tuple:
        """(δx, δy) of eq. 5 with the moment eliminated through δθ = M₂·[f; τ] = ω."""
        M = self.M
        tau = (omega - M[2, 0] * fx - M[2, 1] * fy) / M[2, 2]
        return M[0, 0] * fx + M[0, 1] * fy + M[0, 2] * tau, M[1, 0] * fx + M[1, 1] * fy + M[1, 2] * tau

    def twist(self, wrench: tuple) -> tuple:
        M = self.M
        return tuple(M[i, 0] * wrench[0] + M[i, 1] * wrench[1] + M[i, 2] * wrench[2] for i in range(3))


def make_problem(shape: Shape, start: np.ndarray, pusher: np.ndarray, goal: np.ndarray,
                 params: np.ndarray, mu: float, settings: GCSSettings) -> Problem:
    """The problem of pushing ``shape`` from ``start`` (pusher at ``pusher``, world frame) to ``goal``."""
    from dexpush.model.cgvmm import limit_surface_matrix

    faces = contact_faces(shape, settings.sigma_margin_m)
    rho = shape.pusher_radius
    regions_rho = free_regions(shape, faces, rho)
    regions_free = free_regions(shape, faces, rho + settings.free_margin_m)
    c, s = np.cos(start[2]), np.sin(start[2])
    pb = np.array([[c, s], [-s, c]]) @ (pusher - start[:2])
    lo = np.minimum(start[:2], goal[:2]) - settings.workspace_margin_m
    hi = np.maximum(start[:2], goal[:2]) + settings.workspace_margin_m
    return Problem(shape, faces, regions_rho, regions_free, region_graph(regions_free),
                   limit_surface_matrix(params), settings.mu_margin * mu, start, pb, goal, lo, hi, settings)


def free_route_rows(P: Problem, route: list[int], fixed_start: bool) -> list[tuple[int, Region]]:
    """(knot index, region) pairs of a free motion along ``route`` (free vertices in :mod:`dexpush.gcs`)."""
    rows: list[tuple[int, Region]] = []
    if not fixed_start:
        rows.append((0, P.regions_rho[route[0]]))
    rows.append((1, P.regions_free[route[0]]))
    for h in range(1, len(route)):
        rows += [(h + 1, P.regions_free[route[h - 1]]), (h + 1, P.regions_free[route[h]])]
    L = len(route) - 1
    rows += [(L + 2, P.regions_free[route[-1]]), (L + 3, P.regions_rho[route[-1]])]
    return rows


def start_routes(P: Problem) -> dict[int, list[int]]:
    """For every face, the shortest chain of regions from the start pusher to it."""
    q = P.pusher_body
    starts = [i for i, r in enumerate(P.regions_rho) if r.contains(q, 5e-4)]
    if not starts:
        raise PlanningError(
            f"the pusher's start {q.round(4).tolist()} (object frame) is in no collision-free region: "
            "it overlaps the object or is too far from it")
    routes = {}
    for f in range(len(P.faces)):
        cands = [r for r in (region_route(P.adj, s0, f) for s0 in starts) if r is not None]
        if cands:
            routes[f] = min(cands, key=len)
    return routes
