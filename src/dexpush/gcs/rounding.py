"""From the relaxation to a plan: the local nonlinear solve on a path (exact SE(2) steps), and its timing.

:func:`round_path` solves the plan on one path of the graph with the exact dynamics,
warm-started from the relaxation (or from an interpolation start → goal when the relaxation
did not use the path); :func:`timed_reference` samples the rounded plan with the pusher at
``settings.speed``.
"""

from __future__ import annotations

import numpy as np

from dexpush.gcs.geometry import Face
from dexpush.gcs.problem import Problem, free_route_rows
from dexpush.gcs.settings import PlanningError
from dexpush.gcs.vertices import Vertex

__all__ = ["round_path", "timed_reference"]


def _sinc(z: object) -> object:
    """sin(z)/z by its series (|z| ≤ 0.25 here: error < 1e-9), safe at z = 0 for autodiff."""
    z2 = z * z
    return 1 - z2 / 6 + z2 * z2 / 120 - z2 * z2 * z2 / 5040


def _exact_step(P: Problem, f: Face, pose: tuple, sigma: object, cn: object, cf: object,
                cos: object = np.cos, sin: object = np.sin) -> tuple:
    """Pose after one impulse: the SE(2) exponential of the constant body twist δ = M·w."""
    vx, vy, w = P.twist(P.step_wrench(f, sigma, cn, cf))
    th, x, y = pose
    mid, k = th + w / 2, _sinc(w / 2)
    return th + w, x + k * (cos(mid) * vx - sin(mid) * vy), y + k * (sin(mid) * vx + cos(mid) * vy)


def _interpolated_values(path: list[Vertex], P: Problem) -> dict[str, np.ndarray]:
    """A warm start for a path the relaxation did not use: poses interpolated start → goal."""
    N = P.settings.knots
    contacts = [V for V in path if V.kind == "contact"]
    th0 = P.start[2]
    thg = P.goal[2] + 2 * np.pi * np.round((th0 - P.goal[2]) / (2 * np.pi))
    lam = np.linspace(0, 1, len(contacts) * N)
    poses = np.stack([P.start[0] + lam * (P.goal[0] - P.start[0]), P.start[1] + lam * (P.goal[1] - P.start[1]),
                      th0 + lam * (thg - th0)], -1)
    out: dict[str, np.ndarray] = {}
    for m, V in enumerate(contacts):
        f = P.faces[V.face]
        val = np.zeros(max(max(np.atleast_1d(i)) for i in V.index.values()) + 1)
        seg = poses[m * N:(m + 1) * N]
        val[V.index["c"]], val[V.index["s"]] = np.cos(seg[:, 2]), np.sin(seg[:, 2])
        val[V.index["x"]], val[V.index["y"]] = seg[:, 0], seg[:, 1]
        val[V.index["sigma"]] = (f.sigma_lo + f.sigma_hi) / 2
        val[V.index["cn"]] = 0.02
        out[V.name] = val
    for V in path:
        if V.kind == "free":
            anchor = np.mean([P.faces[r].pusher_point((P.faces[r].sigma_lo + P.faces[r].sigma_hi) / 2, P.rho)
                              + 0.02 * P.faces[r].n_out for r in V.route], axis=0)
            val = np.zeros(4 + 2 * V.knots)
            val[4:] = np.tile(anchor, V.knots)
            out[V.name] = val
    return out


def round_path(path: list[Vertex], values: dict[str, np.ndarray], P: Problem) -> tuple[dict, float]:
    """The local nonlinear solve on the relaxation's path (exact dynamics, warm-started)."""
    import pydrake.symbolic as sym
    from pydrake.solvers import IpoptSolver, MathematicalProgram, SnoptSolver

    S, N = P.settings, P.settings.knots
    prog = MathematicalProgram()
    guess: list[tuple[object, object]] = []
    values = values or _interpolated_values(path, P)
    # unwrap the relaxation's headings along the path, starting from the measured start
    th_prev = P.start[2]
    contacts, frees = [], []
    for V in path[1:-1]:
        val = values[V.name]
        if V.kind == "contact":
            c, s = val[V.index["c"]], val[V.index["s"]]
            th = np.unwrap(np.concatenate([[th_prev], np.arctan2(s, c)]))[1:]
            th_prev = th[-1]
            vars_ = dict(th=prog.NewContinuousVariables(N, "th"), x=prog.NewContinuousVariables(N, "x"),
                         y=prog.NewContinuousVariables(N, "y"), sigma=prog.NewContinuousVariables(1, "sig")[0],
                         cn=prog.NewContinuousVariables(N - 1, "cn"), cf=prog.NewContinuousVariables(N - 1, "cf"))
            guess += [(vars_["th"], th), (vars_["x"], val[V.index["x"]]), (vars_["y"], val[V.index["y"]]),
                      (vars_["sigma"], val[V.index["sigma"]]), (vars_["cn"], np.maximum(val[V.index["cn"]], 0)),
                      (vars_["cf"], val[V.index["cf"]])]
            contacts.append((V, vars_))
        else:
            q = prog.NewContinuousVariables(V.knots, 2, "q")
            guess.append((q, val[V.index["q"]].reshape(V.knots, 2)))
            frees.append((V, q))
    thg = P.goal[2] + 2 * np.pi * np.round((th_prev - P.goal[2]) / (2 * np.pi))
    for var, g in guess:
        prog.SetInitialGuess(var, g)

    prev_pose = (P.start[2], P.start[0], P.start[1])
    cost = 0
    order = {V.name: i for i, V in enumerate(path)}
    for V, var in contacts:
        f = P.faces[V.face]
        th, x, y, sig, cn, cf = (var[k] for k in ("th", "x", "y", "sigma", "cn", "cf"))
        for a, b in zip((th[0], x[0], y[0]), prev_pose):
            prog.AddConstraint(a == b)
        prog.AddBoundingBoxConstraint(f.sigma_lo, f.sigma_hi, sig)
        prog.AddBoundingBoxConstraint(0, S.max_step_m, cn)
        for k in range(N - 1):
            prog.AddLinearConstraint(cf[k] <= P.mu * cn[k])
            prog.AddLinearConstraint(cf[k] >= -P.mu * cn[k])
            _vx, _vy, w = P.twist(P.step_wrench(f, sig, cn[k], cf[k]))
            prog.AddConstraint(w, -S.max_step_rad, S.max_step_rad)
            nxt = _exact_step(P, f, (th[k], x[k], y[k]), sig, cn[k], cf[k], sym.cos, sym.sin)
            for a, b in zip((th[k + 1], x[k + 1], y[k + 1]), nxt):
                prog.AddConstraint(a - b, 0, 0)
            dx, dy = x[k + 1] - x[k], y[k + 1] - y[k]
            cost += S.w_path * sym.sqrt(dx * dx + dy * dy + 1e-8) + S.w_rot * sym.sqrt(w * w + 1e-8)
            cost += S.w_force * (cn[k] * cn[k] + cf[k] * cf[k])
        cost += S.w_mode
        prev_pose = (th[-1], x[-1], y[-1])
    for a, b in zip(prev_pose, (thg, P.goal[0], P.goal[1])):
        prog.AddConstraint(a == b)
    # free motions: knots in their regions, ends on the neighbouring contact points
    by_name = {V.name: var for V, var in contacts}
    for V, q in frees:
        i = order[V.name]
        for knot, region in free_route_rows(P, V.route, fixed_start=path[i - 1].kind == "source"):
            prog.AddLinearConstraint(region.A, np.full(len(region.b), -np.inf), region.b, q[knot])
        before, after = path[i - 1], path[i + 1]
        start = P.pusher_body if before.kind == "source" else \
            P.faces[before.face].pusher_point(by_name[before.name]["sigma"], P.rho)
        end = P.faces[after.face].pusher_point(by_name[after.name]["sigma"], P.rho)
        for a, b in zip(q[0], start):
            prog.AddConstraint(a == b)
        for a, b in zip(q[-1], end):
            prog.AddConstraint(a == b)
        for m in range(V.knots - 1):
            # scalar Expression arithmetic: numpy's object-array subtraction checks the FPU
            # flags afterwards and reports a spurious 'invalid value' from Drake's internals
            dx, dy = q[m + 1, 0] - q[m, 0], q[m + 1, 1] - q[m, 1]
            cost += S.w_free * sym.sqrt(dx * dx + dy * dy + 1e-8)
    prog.AddCost(cost)

    from pydrake.solvers import SolverOptions

    solvers = [SnoptSolver()] if S.rounding_solver == "snopt" else [IpoptSolver()]
    options = SolverOptions()
    options.SetOption(IpoptSolver().solver_id(), "max_iter", 300)
    options.SetOption(SnoptSolver().solver_id(), "Major iterations limit", 300)
    result = None
    for solver in solvers:
        result = solver.Solve(prog, None, options)
        if result.is_success():
            break
    if result is None or not result.is_success():
        raise PlanningError(f"rounding the GCS relaxation failed ({result.get_solver_id().name()}: "
                            f"{result.get_solution_result()}) on the path {' -> '.join(V.name for V in path)}")
    sol = {"contacts": [(V, {k: np.atleast_1d(result.GetSolution(v)) for k, v in var.items()}) for V, var in contacts],
           "frees": [(V, result.GetSolution(q)) for V, q in frees]}
    return sol, float(result.get_optimal_cost())


def timed_reference(path: list[Vertex], sol: dict, P: Problem, dt: float
                     ) -> tuple[list[np.ndarray], np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Sample the rounded plan every ``dt`` seconds with the pusher at ``settings.speed``."""
    speed = P.settings.speed
    t_acc, samples = 0.0, []            # rows: t, θ, x, y, pusher x, pusher y, face
    pose = np.array([P.start[2], P.start[0], P.start[1]])
    contacts = iter(sol["contacts"])
    frees = iter(sol["frees"])
    knots = []

    def world(pose: np.ndarray, q: np.ndarray) -> np.ndarray:
        c, s = np.cos(pose[0]), np.sin(pose[0])
        return pose[1:] + np.array([c * q[0] - s * q[1], s * q[0] + c * q[1]])

    samples.append([0.0, *pose, *world(pose, P.pusher_body), -1])
    for V in path[1:-1]:
        if V.kind == "free":
            _, q = next(frees)
            for m in range(len(q) - 1):
                a, b = world(pose, q[m]), world(pose, q[m + 1])
                length = float(np.linalg.norm(b - a))
                if length < 1e-9:
                    continue
                n = max(2, int(np.ceil(length / (speed * dt))) + 1)
                for lam in np.linspace(0, 1, n)[1:]:
                    samples.append([t_acc + lam * length / speed, *pose, *(a + lam * (b - a)), -1])
                t_acc += length / speed
        else:
            _, v = next(contacts)
            f = P.faces[V.face]
            qc = f.pusher_point(v["sigma"][0], P.rho)
            knots.append(np.stack([v["x"], v["y"], v["th"]], -1))
            pose = np.array([v["th"][0], v["x"][0], v["y"][0]])
            for k in range(len(v["cn"])):
                vx, vy, w = P.twist(P.step_wrench(f, v["sigma"][0], v["cn"][k], v["cf"][k]))
                body_speed = float(np.hypot(vx - w * qc[1], vy + w * qc[0]))   # |v + ω × q|
                duration = max(body_speed / speed, dt)
                n = max(2, int(np.ceil(duration / dt)) * 4 + 1)
                for lam in np.linspace(0, 1, n)[1:]:
                    th, x, y = _exact_step(P, f, tuple(pose), v["sigma"][0], lam * v["cn"][k], lam * v["cf"][k])
                    p = np.array([th, x, y])
                    samples.append([t_acc + lam * duration, *p, *world(p, qc), f.index])
                t_acc += duration
                pose = np.array(samples[-1][1:4])
    arr = np.array(samples)
    times = np.arange(0.0, arr[-1, 0] + dt, dt)
    ref = np.stack([np.interp(times, arr[:, 0], arr[:, i]) for i in range(1, 6)], -1)
    face = arr[np.clip(np.searchsorted(arr[:, 0], times), 0, len(arr) - 1), 6].astype(int)
    poses = ref[:, [1, 2, 0]]
    return knots, times, poses, ref[:, 3:5], face
