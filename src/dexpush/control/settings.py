"""The controller's settings (:class:`ControllerSettings`) and their small groups.

Each group is one mechanism of the controller beside the paper's MPPI and UKF, with its
defaults and where it is measured:

* :class:`StallSettings`: the stall watch (docs/controller.md#stalls);
* :class:`EndgameSettings`: the colder temperature near the goal (docs/controller.md#the-endgame-temperature);
* :class:`ProposalSettings`: contact proposals among MPPI's samples (docs/controller.md#contact-proposals);
* :class:`PushPlanSettings`: a push chosen after a stall (docs/workspaces.md#a-push-plan-after-a-stall-2026-12-07);
* :class:`PredictionMarginSettings`: the obstacle margin's growth with the prediction from a late
  frame (docs/controller.md#the-margin-grows-with-the-prediction).

The flat names these fields had (``stall_after_s``, ``endgame_temperature``, ...) are still read,
with a ``FutureWarning`` (:func:`dexpush.common.settings.grouped`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from dexpush.common.checks import check_nonnegative, check_positive, check_whole
from dexpush.common.settings import grouped
from dexpush.control.estimator import UKFSettings
from dexpush.control.mppi import MPPISettings
from dexpush.control.push_plan import EndgamePushSettings, PushPlanSettings
from dexpush.model.cgvmm import MU_C
from dexpush.problem.problem import SUCCESS_HEADING_DEG, SUCCESS_POSITION_M
from dexpush.problem.weights import CostWeights

__all__ = ["ControllerSettings", "EndgamePushSettings", "EndgameSettings", "PredictionMarginSettings",
           "ProposalSettings", "PushPlanSettings", "StallSettings"]


@dataclass(frozen=True)
class StallSettings:
    """The stall watch (:func:`dexpush.control.policy.watch_progress`): restart the planner from a zero
    warm start when the object has come no closer to the goal, in position or in heading, for
    ``after_s`` seconds out of contact."""

    after_s: float | None = 4.0       #: the patience (s); None: no stall watch
    #: progress is an improvement of the position error by this much (m) or of the heading error by
    #: ``progress_deg``, whichever of the two errors is the larger in these units
    progress_m: float = 0.005
    progress_deg: float = 2.0
    contact_gap_m: float = 0.005      #: the clock runs only while the pusher is farther than this from the contour ...
    #: ... and the object is not within both of these of the goal (m, degrees): the success tolerances,
    #: where the object is done; short of them a stall near the goal searches the endgame's push
    #: (``push_plan.endgame``)
    min_distance_m: float = SUCCESS_POSITION_M
    min_heading_deg: float = SUCCESS_HEADING_DEG
    backoff: float = 2.0              #: each restart without progress makes the next wait this many times longer
    #: after a stall the planner looks this many times further ahead (every slot Δt_k after the first
    #: stretched), until the object comes closer again or is within ``endgame.distance_m`` of the goal (not
    #: stretched there: the endgame needs the fine slots); 1 keeps the paper's horizon
    horizon_scale: float = 2.0

    def __post_init__(self) -> None:
        if self.after_s is not None:
            check_positive("stall.after_s", self.after_s, "s, or None")
        check_positive("stall.progress_m", self.progress_m, "m")
        check_positive("stall.contact_gap_m", self.contact_gap_m, "m")
        check_positive("stall.progress_deg", self.progress_deg, "degrees")
        check_nonnegative("stall.min_distance_m", self.min_distance_m, "m")
        check_nonnegative("stall.min_heading_deg", self.min_heading_deg, "degrees")
        for name in ("backoff", "horizon_scale"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int | float) or not 1.0 <= v < float("inf"):
                raise ValueError(f"stall.{name} must be a finite number >= 1, got {v!r}")


@dataclass(frozen=True)
class EndgameSettings:
    """MPPI's relative temperature τ near the goal: a last push of 1–3 cm is found by few samples,
    and at the default τ their weight is shared with many that hover."""

    temperature: float | None = 0.005  #: τ within ``distance_m`` of the goal; None: ``mppi.temperature`` everywhere
    distance_m: float = 0.04           #: the position error (m, round the obstacles) below which it applies

    def __post_init__(self) -> None:
        if self.temperature is not None:
            check_positive("endgame.temperature", self.temperature, "or None")
        check_nonnegative("endgame.distance_m", self.distance_m, "m")


@dataclass(frozen=True)
class ProposalSettings:
    """Contact proposals (:mod:`dexpush.control.proposals`): ``count`` of MPPI's exploring samples walk
    round the object to evenly spaced contact points, then push; 0 samples only noise."""

    count: int = 0
    clearance_m: float = 0.015        #: the walks' radial distance from the inflated contour

    def __post_init__(self) -> None:
        check_whole("proposals.count", self.count, 0)
        check_positive("proposals.clearance_m", self.clearance_m, "m")


@dataclass(frozen=True)
class PredictionMarginSettings:
    """With :meth:`PushingController.act`, the plan's obstacle margin grows by ``gain`` times the distance
    (m) the object's footprint was predicted forward from the newest frame to the present (latency,
    lost frames), up to ``max_m`` more: that prediction's error grows with it. 0 keeps the margin at
    ``weights.obstacle_margin_m``, as does the binary margin (``weights.C_margin`` None)."""

    gain: float = 0.5
    max_m: float = 0.02

    def __post_init__(self) -> None:
        check_nonnegative("prediction_margin.gain", self.gain)
        check_nonnegative("prediction_margin.max_m", self.max_m, "m")


@grouped({"stall_after_s": ("stall", "after_s"), "stall_progress_m": ("stall", "progress_m"),
          "stall_progress_deg": ("stall", "progress_deg"), "stall_contact_gap_m": ("stall", "contact_gap_m"),
          "stall_min_distance_m": ("stall", "min_distance_m"), "stall_min_heading_deg": ("stall", "min_heading_deg"),
          "stall_backoff": ("stall", "backoff"), "stall_horizon_scale": ("stall", "horizon_scale"),
          "endgame_temperature": ("endgame", "temperature"), "endgame_distance_m": ("endgame", "distance_m"),
          "contact_proposals": ("proposals", "count"), "proposal_clearance_m": ("proposals", "clearance_m"),
          "prediction_margin_gain": ("prediction_margin", "gain"),
          "prediction_margin_max_m": ("prediction_margin", "max_m")})
@dataclass(frozen=True)
class ControllerSettings:
    """Everything the controller needs besides the problem (object, goal, obstacles, cost weights)."""

    mppi: MPPISettings = field(default_factory=MPPISettings)
    #: the cost weights of eq. (9) of a problem built from a shape (``PushingController(shape, goal, ...)``,
    #: ``Task.problem``); a :class:`dexpush.problem.problem.Problem` carries its own
    weights: CostWeights = field(default_factory=CostWeights)
    mu: float = MU_C              #: pusher–object friction μ_c assumed by the model
    estimate_params: bool = False #: run the UKF (paper Fig. 5) and plan with its estimate
    #: with the UKF: charge each sample the larger of its obstacle costs under the estimate and under λ_pred's start
    #: (a second rollout per sample where the problem has obstacles; without the UKF it changes nothing;
    #: docs/robot.md#the-obstacle-cost-under-the-estimate-and-the-start)
    obstacles_under_start: bool = True
    ukf: UKFSettings = field(default_factory=UKFSettings)
    ukf_substeps: int = 10        #: Euler substeps per period in the UKF's window replay
    stall: StallSettings = field(default_factory=StallSettings)
    endgame: EndgameSettings = field(default_factory=EndgameSettings)
    proposals: ProposalSettings = field(default_factory=ProposalSettings)
    push_plan: PushPlanSettings = field(default_factory=PushPlanSettings)
    prediction_margin: PredictionMarginSettings = field(default_factory=PredictionMarginSettings)

    def __post_init__(self) -> None:
        for name, kind in (("mppi", MPPISettings), ("weights", CostWeights), ("ukf", UKFSettings),
                           ("stall", StallSettings), ("endgame", EndgameSettings), ("proposals", ProposalSettings),
                           ("push_plan", PushPlanSettings), ("prediction_margin", PredictionMarginSettings)):
            if not isinstance(getattr(self, name), kind):
                raise ValueError(f"{name} must be a {kind.__name__}, got {getattr(self, name)!r}")
        check_positive("mu", self.mu, "pusher–object friction coefficient")
        for name in ("estimate_params", "obstacles_under_start"):
            if not isinstance(getattr(self, name), bool | np.bool_):
                raise ValueError(f"{name} must be True or False, got {getattr(self, name)!r}")
        check_whole("ukf_substeps", self.ukf_substeps, 1)
        exploring = self.mppi.num_samples - round(self.mppi.refine_fraction * self.mppi.num_samples)
        if self.proposals.count > exploring - 1:
            raise ValueError(f"proposals.count must be at most the exploring samples less one ({exploring - 1}), "
                             f"got {self.proposals.count!r}")
