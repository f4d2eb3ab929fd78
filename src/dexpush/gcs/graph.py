"""The Graph of Convex Sets: edges, building the graph, solving its convex relaxation, candidate paths."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dexpush.gcs.geometry import region_route
from dexpush.gcs.problem import Problem, start_routes
from dexpush.gcs.settings import PlanningError
from dexpush.gcs.vertices import Vertex, contact_vertex, free_vertex

__all__ = ["Graph", "build_graph", "solve_relaxation", "two_mode_paths"]


def _pose(V: Vertex, which: int) -> list:
    if V.kind != "contact":
        return [V.var("c"), V.var("s"), V.var("x"), V.var("y")]
    return [V.var("c")[which], V.var("s")[which], V.var("x")[which], V.var("y")[which]]


def _contact_point(V: Vertex, P: Problem) -> list:
    f = P.faces[V.face]
    sig = V.var("sigma")
    return [f.a[i] + sig * f.d[i] + P.rho * f.n_out[i] for i in range(2)]


def _connect(gcs: object, u: Vertex, v: Vertex, P: Problem) -> None:
    """An edge u → v with pose continuity and pusher continuity at free/contact borders."""
    e = gcs.AddEdge(u.v, v.v, f"{u.name} -> {v.name}")
    pu, pv = _pose(u, -1), _pose(v, 0)
    for a, b in zip(pu, pv):
        e.AddConstraint(a == b)
    if u.kind == "source":
        for a, b in zip(u.var("q"), v.var("q")[:2]):
            e.AddConstraint(a == b)
    if u.kind == "contact" and v.kind == "free":
        q0 = v.var("q")[:2]
        for a, b in zip(_contact_point(u, P), q0):
            e.AddConstraint(a == b)
    if u.kind == "free" and v.kind == "contact":
        ql = u.var("q")[-2:]
        for a, b in zip(ql, _contact_point(v, P)):
            e.AddConstraint(a == b)


@dataclass
class Graph:
    gcs: object
    source: Vertex
    target: Vertex
    vertices: dict[str, Vertex]


def build_graph(P: Problem) -> Graph:
    from pydrake.geometry.optimization import GraphOfConvexSets, Point

    gcs = GraphOfConvexSets()
    th0, thg = P.start[2], P.goal[2]
    src = gcs.AddVertex(Point(np.array([np.cos(th0), np.sin(th0), *P.start[:2], *P.pusher_body])), "start")
    tgt = gcs.AddVertex(Point(np.array([np.cos(thg), np.sin(thg), *P.goal[:2]])), "goal")
    source = Vertex("source", "start", src, dict(c=0, s=1, x=2, y=3, q=[4, 5]))
    target = Vertex("target", "goal", tgt, dict(c=0, s=1, x=2, y=3))
    verts: dict[str, Vertex] = {}
    contacts = [contact_vertex(gcs, P, f) for f in P.faces]
    for V in contacts:
        verts[V.name] = V
    for f, route in start_routes(P).items():
        V = free_vertex(gcs, P, f"start -> face {f}", route, fixed_start=True)
        verts[V.name] = V
        _connect(gcs, source, V, P)
        _connect(gcs, V, contacts[f], P)
    for i, Ci in enumerate(contacts):
        _connect(gcs, Ci, target, P)
        for j, Cj in enumerate(contacts):
            route = region_route(P.adj, i, j) if i != j else None
            if route is None:
                continue
            V = free_vertex(gcs, P, f"face {i} -> face {j}", route, fixed_start=False)
            verts[V.name] = V
            _connect(gcs, Ci, V, P)
            _connect(gcs, V, Cj, P)
    return Graph(gcs, source, target, verts)


def solve_relaxation(G: Graph, P: Problem
                     ) -> tuple[list[list[Vertex]], dict[str, np.ndarray], float, dict[str, float]]:
    """Solve the convex relaxation; return candidate paths (most flow first), vertex values, cost
    and every vertex's relaxed inflow (by vertex name).

    Candidate paths come from randomized rounding on the relaxed flows (Marcucci et al.):
    walk from the source, taking each outgoing edge with probability proportional to its
    flow, never revisiting a vertex.
    """
    from pydrake.geometry.optimization import GraphOfConvexSetsOptions
    from pydrake.solvers import ClarabelSolver, ScsSolver

    opts = GraphOfConvexSetsOptions()
    opts.convex_relaxation = True
    opts.preprocessing = False
    opts.max_rounded_paths = 0
    solvers = [ClarabelSolver(), ScsSolver()]
    if P.settings.relaxation_solver == "scs":
        solvers.reverse()
    result = None
    for solver in solvers:
        opts.solver = solver
        if solver.solver_id() == ClarabelSolver().solver_id():
            # the GCS perspective constraints are degenerate (equal rows through the flow
            # variables); Clarabel's default regularization 1e-8 stalls on them
            opts.solver_options.SetOption(solver.solver_id(), "static_regularization_constant", 1e-6)
        result = G.gcs.SolveShortestPath(G.source.v, G.target.v, opts)
        if result.is_success():
            break
    if not result.is_success():
        details = result.get_solution_result()
        raise PlanningError(
            f"the GCS convex relaxation failed (Clarabel and SCS: {details}); "
            "the goal may be unreachable within the workspace box or the step bounds")
    by_id = {V.v.id(): V for V in (G.source, G.target, *G.vertices.values())}
    flows = {}
    for e in G.gcs.Edges():
        flows.setdefault(e.u().id(), []).append((e.v().id(), max(float(result.GetSolution(e.phi())), 0.0)))
    rng = np.random.default_rng(0)
    paths: dict[tuple, float] = {}
    for _trial in range(P.settings.rounding_trials):
        node, seen, score, ok = G.source.v.id(), {G.source.v.id()}, 1.0, False
        path = [node]
        while True:
            if node == G.target.v.id():
                ok = True
                break
            out = [(v, f) for v, f in flows.get(node, []) if v not in seen and f > 1e-6]
            if not out:
                break
            w = np.array([f for _, f in out])
            i = int(rng.choice(len(out), p=w / w.sum())) if _trial else int(np.argmax(w))
            node = out[i][0]
            score *= w[i] / w.sum()
            seen.add(node)
            path.append(node)
        if ok:
            paths[tuple(path)] = max(paths.get(tuple(path), 0.0), score)
    if not paths:
        raise PlanningError("the GCS relaxation's flows contain no path from the start to the goal")
    ordered = sorted(paths, key=lambda k: -paths[k])[: P.settings.max_rounded_paths]
    candidates = [[by_id[i] for i in path] for path in ordered]
    values = {V.name: np.asarray(V.v.GetSolution(result), dtype=np.float64)
              for V in (G.source, G.target, *G.vertices.values())}
    inflow: dict[str, float] = {}
    for e in G.gcs.Edges():
        name = by_id[e.v().id()].name
        inflow[name] = inflow.get(name, 0.0) + max(float(result.GetSolution(e.phi())), 0.0)
    return candidates, values, float(result.get_optimal_cost()), inflow


def two_mode_paths(G: Graph, inflow: dict[str, float]) -> list[list[Vertex]]:
    """start → face i → face j → goal for all i ≠ j, most relaxed flow through i and j first."""
    verts = G.vertices
    paths = []
    for name_i, Vi in verts.items():
        for name_j, Vj in verts.items():
            if Vi.kind != "contact" or Vj.kind != "contact" or Vi is Vj:
                continue
            s_i, t_ij = verts.get(f"start -> {name_i}"), verts.get(f"{name_i} -> {name_j}")
            if s_i is None or t_ij is None:
                continue
            score = inflow.get(name_i, 0.0) + inflow.get(name_j, 0.0)
            paths.append((score, [G.source, s_i, Vi, t_ij, Vj, G.target]))
    paths.sort(key=lambda p: -p[0])
    return [p for _, p in paths]
