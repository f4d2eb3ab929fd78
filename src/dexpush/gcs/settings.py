"""Settings and the error of the GCS planner (see :mod:`dexpush.gcs`)."""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["GCSSettings", "PlanningError"]


class PlanningError(RuntimeError):
    """The GCS planner found no plan (infeasible relaxation, failed rounding, bad input)."""


@dataclass(frozen=True)
class GCSSettings:
    """Settings of the GCS planner. Defaults are what the benchmark uses.

    Attributes:
        knots: knot points per contact mode (``N``; ``N − 1`` impulses).
        retry_knots: when no path rounds, plan again with each of these knot counts in turn
            (finer steps give the rounding more freedom; on the T in Task II, 9 of 30 start
            states that fail with 5 knots were tried with 7 and rounded, docs/gcs.md).
        mu_margin: plan with ``μ' = mu_margin·μ`` so that the planned contact sticks with a
            margin (a force on the cone's edge would be a coin-flip between stick and slide
            for the C-GVMM).
        max_step_m: bound on the body-frame translation of one step (m).
        max_step_rad: bound on the rotation of one step (rad).
        sigma_margin_m: keep the contact point this far from a face's ends (m).
        free_margin_m: clearance of free pusher motion from the object beyond ρ (m).
        workspace_margin_m: the object stays within the start/goal bounding box grown by this.
        w_path, w_rot, w_free, w_force, w_mode: cost weights (per metre of object path, per
            radian, per metre of free pusher travel, on Σ(c_n² + c_f²), per contact mode).
        rounding_trials, max_rounded_paths: random walks on the relaxed flows, and how many
            distinct paths (most probable first) the nonlinear rounding tries.
        max_enumerated_paths: when none of those rounds, how many two-contact paths
            (ranked by relaxed flow through their faces) to try.
        tight_relaxation: add the products of every pair of linear constraints to the
            relaxation (tighter, ~10× slower); by default only the diagonal bounds.
        relaxation_solver: ``clarabel`` (default) or ``scs``.
        rounding_solver: ``snopt`` (default) or ``ipopt``.
        speed: pusher speed used to time the plan (m/s); below the ±v_max/√2 per-axis clip.
    """

    knots: int = 5
    retry_knots: tuple[int, ...] = (7,)
    mu_margin: float = 0.8
    max_step_m: float = 0.15
    max_step_rad: float = 0.5
    sigma_margin_m: float = 0.005
    free_margin_m: float = 0.004
    workspace_margin_m: float = 0.3
    w_path: float = 1.0
    w_rot: float = 0.05
    w_free: float = 0.2
    w_force: float = 0.1
    w_mode: float = 0.05
    relaxation: str = "mccormick"
    rounding_trials: int = 50
    max_rounded_paths: int = 3
    max_enumerated_paths: int = 12
    heading_pad_rad: float = 0.6
    tight_relaxation: bool = False
    relaxation_solver: str = "clarabel"
    rounding_solver: str = "snopt"
    speed: float = 0.06

    def __post_init__(self) -> None:
        if int(self.knots) < 2 or any(int(k) < 2 for k in self.retry_knots):
            raise ValueError(f"knots must be >= 2, got {self.knots} and retry_knots {self.retry_knots}")
        if not 0.0 < self.mu_margin <= 1.0:
            raise ValueError(f"mu_margin must be in (0, 1], got {self.mu_margin}")
        for name in ("max_step_m", "max_step_rad", "speed"):
            if not float(getattr(self, name)) > 0:
                raise ValueError(f"{name} must be positive, got {getattr(self, name)}")
        if self.relaxation not in ("mccormick", "sdp"):
            raise ValueError(f"relaxation must be mccormick or sdp, got {self.relaxation!r}")
        if self.relaxation_solver not in ("clarabel", "scs"):
            raise ValueError(f"relaxation_solver must be clarabel or scs, got {self.relaxation_solver!r}")
        if self.rounding_solver not in ("snopt", "ipopt"):
            raise ValueError(f"rounding_solver must be snopt or ipopt, got {self.rounding_solver!r}")
