"""The gains and constants of the paper's cost, eq. (9) (defaults from its Table II), and the
planner's obstacle margin (docs/controller.md#the-margin)."""

from __future__ import annotations

from dataclasses import dataclass

from dexpush.common.checks import check_nonnegative, check_positive

__all__ = ["CostWeights"]


@dataclass(frozen=True)
class CostWeights:
    """Gains and constants of eq. (9), defaults from the paper's Table II."""

    q_f: float = 5000.0   #: terminal gain
    q_r1: float = 100.0   #: running gain on the decoupled distance
    q_r2: float = 1e4     #: gain of the pusher-proximity ReLU
    c: float = 0.1        #: heading weight in the decoupled distance (m²)
    r_s: float = 0.2      #: pusher may roam this far (m) from the object's reference for free
    C_pen: float = 1e13   #: collision penalty
    #: raise r_s to R_max + r_s_clearance (m) for objects whose inflated contour reaches
    #: beyond r_s − r_s_clearance; None keeps r_s as given. See :meth:`Scene.make`.
    r_s_clearance: float | None = 0.05
    #: the planner keeps object and pusher this far (m) from obstacles: the collision test of the
    #: cost (9e) uses discs grown by it, so a prediction error of up to this much at the obstacle does
    #: not become a touch. A trial still fails only on a real touch (radius as given).
    obstacle_margin_m: float = 0.01
    #: ... and the pusher this far (m) from bounds of its own (a robot arm's reach: ``Problem.pusher_workspace``
    #: and the keep-out discs' pusher radius), which the robot's safety filter holds exactly and where only the
    #: arm's tracking error (p99 3.2–3.9 mm on the simulated FR3) can err: the object's margin there left the pusher
    #: too little room behind an object near the reach's edge. See docs/robot.md#the-pushers-margin-at-the-reach.
    pusher_bound_margin_m: float = 0.003
    #: measure the goal distance of d² round the obstacles (:func:`detour_length_sq`) instead of
    #: straight through them (default); False is the paper's eq. (9) as written.
    #: See docs/controller.md#going-round-obstacles-detour.
    detour: bool = True
    #: inside the margin, clear of the disc, a state costs C_margin per obstacle times its depth into the
    #: margin as a fraction of it (:func:`obstacle_cost`); None charges C_pen there, as the discs grown by
    #: the margin in (9e) would. See docs/controller.md#the-margin.
    C_margin: float | None = 1e9
    #: measure the goal distance of d² along the cost-to-go round every obstacle and inside the workspace
    #: (:mod:`dexpush.problem.guidance`; it supersedes ``detour``) when the problem has boxes, walls or a
    #: workspace bound (scenes of discs only keep the detour); False keeps the detour round the discs.
    #: See docs/workspaces.md#global-guidance.
    guidance: bool = True
    #: the cost-to-go's grid spacing (m)
    guidance_cell_m: float = 0.02
    #: the cost-to-go's length of a turn (m per radian): V has one layer per heading and knows where the
    #: footprint fits in the heading it has; None: one layer, free where it fits in some heading (with the
    #: detour round discs beside it). See docs/workspaces.md#global-guidance.
    guidance_turn_m: float | None = 0.1
    #: with ``guidance_turn_m``, the cost-to-go's way ends in the goal's heading, so V counts the turn to it
    #: where the footprint fits to make it; False: in any heading, the turn left to the heading term of d².
    #: See docs/workspaces.md#the-turn-to-the-goals-heading-2026-12-05.
    guidance_goal_heading: bool = True
    #: with ``guidance_turn_m``, each of the cost-to-go's moves needs room for the pusher behind the object, so
    #: that the way does not lead where the object can be pushed in but not out; False: where the footprint
    #: fits. See docs/workspaces.md#the-pushers-room-2026-12-07.
    guidance_pusher_room: bool = False
    #: the running cost's goal distance too follows the cost-to-go (where there is one), so that running and
    #: terminal cost agree on the way round; False: the straight distance, or the detour round discs.
    #: See docs/workspaces.md#the-running-cost-along-the-way-2026-12-07.
    guidance_running: bool = False

    def __post_init__(self) -> None:
        for name in ("q_f", "q_r1", "q_r2", "c"):
            check_nonnegative(name, getattr(self, name))
        if self.C_margin is not None:
            check_positive("C_margin", self.C_margin, "or None")
            if self.C_margin * 100 > self.C_pen:
                raise ValueError(f"C_margin must be far below C_pen (a touch must cost more than 25 slots inside "
                                 f"the margin): got C_margin={self.C_margin:g}, C_pen={self.C_pen:g}")
        for name in ("r_s", "C_pen"):
            check_positive(name, getattr(self, name))
        check_nonnegative("obstacle_margin_m", self.obstacle_margin_m, "m")
        check_positive("pusher_bound_margin_m", self.pusher_bound_margin_m, "m")
        check_positive("guidance_cell_m", self.guidance_cell_m, "m")
        if not 0.005 <= self.guidance_cell_m <= 0.1:
            raise ValueError(f"guidance_cell_m must be between 0.005 and 0.1 m, got {self.guidance_cell_m!r}")
        if self.guidance_turn_m is not None:
            check_positive("guidance_turn_m", self.guidance_turn_m, "m per radian, or None")
        if self.guidance_pusher_room and self.guidance_turn_m is None:
            raise ValueError("guidance_pusher_room needs guidance_turn_m (the pusher's room depends on the heading)")
        if self.r_s_clearance is not None:
            check_nonnegative("r_s_clearance", self.r_s_clearance, "m, or None")

