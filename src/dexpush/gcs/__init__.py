"""The GCS pushing planner: the paper's offline baseline (Graesdal et al., RSS 2024, ref. [26]).

Planar pushing is planned as a shortest path in a Graph of Convex Sets (Drake's
``GraphOfConvexSets``), then rounded to a feasible plan with a local nonlinear solve.

Graph
    * **Contact vertices**, one per face f of the footprint's outer boundary (a T has 8).
      The pusher sticks to the face at a contact point ``q(σ) = a + σ·d + ρ·n_out``
      (σ ∈ [σ_lo, σ_hi], constant in the mode) for ``N`` knots. Between knots k and k+1 it
      applies a contact impulse ``f_k = c_n·n̂ + c_f·t̂`` inside the (shrunk) friction cone
      ``|c_f| ≤ μ'·c_n``. Quasi-static dynamics with the same ellipsoidal limit surface as
      the C-GVMM (eq. 5): the body twist over the step is ``δ_k = M(λ)·[f_k; τ_k]`` with
      ``M = A_bf·L̃·A_bfᵀ`` and the moment ``τ_k = q(σ) × f_k``. The pose update is
      ``θ_{k+1} = θ_k + δθ_k``, ``p_{k+1} = p_k + R(θ_k)·(δx, δy)`` (first order; the
      rounding uses the exact SE(2) exponential). Poses are written with
      ``(c_k, s_k) = (cos θ_k, sin θ_k)`` and ``c_k² + s_k² = 1``.
    * **Free vertices**: contact-free pusher motion with the object at rest, one vertex
      per ordered pair of faces (and one per face from the start). The pusher's body-frame
      knots pass through a fixed chain of convex collision-free regions (one per face: the
      half-plane in front of the face, cut by a half-plane of every other convex piece),
      so every segment lies inside one convex region.
    * **Edges** carry continuity: the object pose, and the pusher position where a free
      motion ends or starts at a contact point. The source is the measured start (object
      pose and pusher), the target the goal pose.

Relaxation and rounding
    The bilinear constraints (SO(2), R(θ)·δ, σ·c_n) make every contact vertex a small
    nonconvex QCQP. By default (``relaxation="mccormick"``) each bilinear term gets its
    McCormick envelope, with ``(c, s)`` kept in the convex hull of the arc of headings
    between start and goal (padded by ``heading_pad_rad``): every vertex is a polyhedron
    and the graph's convex relaxation is a small conic program, solved by Clarabel (SCS
    as fallback). ``relaxation="sdp"`` is the paper's band-sparse semidefinite (Shor)
    relaxation instead — one PSD moment matrix per pair of consecutive knots, Drake's
    ``MakeSemidefiniteRelaxation`` with variable groups — tighter but ~30–100× slower with
    open-source solvers (docs/gcs.md). Candidate paths are random walks on the relaxed
    flows (most probable first); the plan on a path is rounded by a local nonlinear solve
    (SNOPT, or IPOPT) with the exact SE(2) step, warm-started from the relaxation. When no
    candidate rounds, the two-contact paths through the faces with the most relaxed flow
    are tried.

Costs: object path length (Σ‖Δp‖), rotation (Σ|δθ|), pusher travel in free motion
(Σ‖Δq‖), a small force regulariser and a constant cost per contact mode.

A plan is timed afterwards: the pusher moves at ``settings.speed`` along it. Quasi-static
pushing has no intrinsic time scale, so this changes nothing in the plan's geometry.

Modules
    * :mod:`~dexpush.gcs.settings`: :class:`GCSSettings` and :class:`PlanningError`.
    * :mod:`~dexpush.gcs.geometry`: faces (:func:`contact_faces`) and collision-free
      regions (:func:`free_regions`) in the object frame, the graph of overlapping regions.
    * :mod:`~dexpush.gcs.problem`: one planning problem (the shared data, eq. 5's wrench
      and twist) and the :class:`Plan` it produces.
    * :mod:`~dexpush.gcs.vertices`: the graph's convex sets (McCormick or SDP contact
      modes, free motions) and their costs.
    * :mod:`~dexpush.gcs.graph`: edges, the graph, its convex relaxation, candidate paths.
    * :mod:`~dexpush.gcs.rounding`: the nonlinear rounding with the exact SE(2) step, and
      the timed reference.
    * :mod:`~dexpush.gcs.planner`: :func:`plan_push`, the entry point.
    * :mod:`~dexpush.gcs.tracker`: :class:`GCSTracker`, plans executed in closed loop.

Drake is imported only inside the functions that build and solve, so importing this
package is cheap.
"""

from dexpush.gcs.geometry import Face, Region, contact_faces, free_regions
from dexpush.gcs.planner import plan_push
from dexpush.gcs.problem import Plan
from dexpush.gcs.settings import GCSSettings, PlanningError
from dexpush.gcs.tracker import GCSTracker

__all__ = ["Face", "GCSSettings", "GCSTracker", "Plan", "PlanningError", "Region", "contact_faces", "free_regions",
           "plan_push"]
