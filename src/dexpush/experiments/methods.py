"""Methods: what turns a :class:`dexpush.problem.problem.Problem` into a controller, and what each can do.

A method is one small subclass of :class:`Method` and one line in :data:`METHODS` (or one
:func:`register_method` call for your own, e.g. in a test or a script):

* ``mppi``: long-horizon MPPI over the C-GVMM with a fixed λ_pred (:class:`MPPI`);
* ``mppi-ukf``: the same, with the UKF estimating λ online (:class:`MPPIWithUKF`, paper Fig. 5);
* ``gcs``: the GCS plan-and-track baseline (:class:`GCS`; needs Drake; no obstacles, exact observations).

What a method declares (class attributes) is what the runner, the benchmark and the command
line ask of it: whether its trials may run in the batched simulator (``batched``), whether it
handles obstacles (``obstacles``) and camera frames (``cameras``), and whether it estimates λ
(``estimates``). :meth:`Method.diagnostics` reports what a finished trial's record carries
beyond the common fields (estimator counters, stall restarts, plan times).
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any, ClassVar

from dexpush.common.interfaces import Controller
from dexpush.control.controller import ControllerSettings, PushingController
from dexpush.experiments.simulate import ESTIMATOR_COUNTERS, TrialResult
from dexpush.problem.problem import Problem

__all__ = ["GCS", "METHODS", "MPPI", "MPPIWithUKF", "Method", "get_method", "method_names", "register_method"]


class Method:
    """A way to solve a pushing problem: subclass it, set ``name``, and implement :meth:`controller`.

    Class attributes (the method's capabilities; the defaults suit a Python controller that runs
    through :func:`dexpush.experiments.runner.run_loop`):

    * ``name``: the name on the command line and in the records;
    * ``description``: one line for ``--help``;
    * ``batched``: trials on the model plant with exact observations may run in the batched
      simulator (:func:`dexpush.experiments.simulate.simulate`, the controller being
      :func:`dexpush.control.policy.policy_step`), with the UKF on where ``estimates``;
    * ``obstacles``: it handles obstacles (else the benchmark skips scenarios that have them);
    * ``regions``: it handles goal regions (:mod:`dexpush.problem.goal_region`);
    * ``cameras``: it works from camera frames (noise, latency, drops), not only exact observations;
    * ``estimates``: it estimates λ online (its records carry the estimate);
    * ``default``: one of the methods ``dexpush bench`` runs when none are named.
    """

    name: ClassVar[str] = ""
    description: ClassVar[str] = ""
    batched: ClassVar[bool] = False
    obstacles: ClassVar[bool] = True
    regions: ClassVar[bool] = True
    cameras: ClassVar[bool] = True
    estimates: ClassVar[bool] = False
    default: ClassVar[bool] = False

    def controller(self, problem: Problem, params: object, seed: int = 0,
                   settings: ControllerSettings | None = None) -> Controller:
        """The controller that solves ``problem``, starting from λ_pred = ``params``."""
        raise NotImplementedError

    def diagnostics(self, result: TrialResult) -> dict[str, Any]:
        """What a finished trial's record carries beyond the common fields (record field → value)."""
        return {}

    def check(self, problem: Problem, exact_observations: bool) -> None:
        """Refuse, with a ``ValueError``, a problem or sensing this method does not support."""
        if problem.has_obstacles and not self.obstacles:
            raise ValueError(f"the {self.name} method has no obstacle support; use a problem without obstacles")
        if problem.region is not None and not self.regions:
            raise ValueError(f"the {self.name} method plans to a goal pose only; a goal region needs mppi or mppi-ukf")
        self.check_sensing(exact_observations)

    def check_sensing(self, exact_observations: bool) -> None:
        """Refuse, with a ``ValueError``, camera frames when this method takes exact observations only."""
        if not exact_observations and not self.cameras:
            raise ValueError(f"the {self.name} method runs with exact observations only; drop it or the camera "
                             "options")


class MPPI(Method):
    """Long-horizon MPPI over the C-GVMM with a fixed λ_pred (:class:`PushingController`)."""

    name = "mppi"
    description = "MPPI with a fixed λ_pred"
    batched = True
    default = True

    def controller(self, problem: Problem, params: object, seed: int = 0,
                   settings: ControllerSettings | None = None) -> Controller:
        settings = replace(settings or ControllerSettings(), estimate_params=self.estimates)
        return PushingController(problem, params=params, settings=settings, seed=seed)

    def diagnostics(self, result: TrialResult) -> dict[str, Any]:
        plans = {} if result.push_plans is None else {"push_plans": result.push_plans}
        return {"stall_resets": result.stall_resets, **plans}


class MPPIWithUKF(MPPI):
    """MPPI with the UKF estimating λ online (paper Fig. 5)."""

    name = "mppi-ukf"
    description = "MPPI with the UKF estimating λ online"
    estimates = True

    def diagnostics(self, result: TrialResult) -> dict[str, Any]:
        out = super().diagnostics(result)
        out.update({name: getattr(result, name) for name in ESTIMATOR_COUNTERS})
        if len(result.params):
            out["params_estimate"] = [round(float(v), 5) for v in result.params[-1]]
        return out


class GCS(Method):
    """The GCS plan-and-track baseline (:mod:`dexpush.gcs`; needs the ``drake`` package)."""

    name = "gcs"
    description = "the GCS plan-and-track baseline (no obstacles; needs the drake package)"
    obstacles = False
    regions = False
    cameras = False

    def controller(self, problem: Problem, params: object, seed: int = 0,
                   settings: ControllerSettings | None = None) -> Controller:
        from dexpush.gcs import GCSTracker  # Drake loads only for this method

        self.check(problem, exact_observations=True)
        settings = settings or ControllerSettings()
        return GCSTracker(problem.shape, problem.goal, params, mu=settings.mu,
                          control_period=settings.mppi.control_period, v_max=settings.mppi.v_max)

    def diagnostics(self, result: TrialResult) -> dict[str, Any]:
        if not result.plan_s:
            return {}
        return {"offline_plan_s": round(float(result.plan_s[0]), 3), "replans": len(result.plan_s) - 1}


#: the methods by name: one line per method
METHODS: dict[str, Method] = {m.name: m for m in (MPPI(), MPPIWithUKF(), GCS())}


def register_method(method: Method) -> Method:
    """Add ``method`` to :data:`METHODS` under ``method.name`` (a name taken is refused)."""
    if not isinstance(method, Method) or not method.name:
        raise ValueError(f"a method is a dexpush Method with a name, got {method!r}")
    if method.name in METHODS and METHODS[method.name] is not method:
        raise ValueError(f"a method named {method.name!r} is registered already")
    METHODS[method.name] = method
    return method


def get_method(name: str | Method) -> Method:
    """The method of that name (a :class:`Method` is returned as is)."""
    if isinstance(name, Method):
        return name
    if name not in METHODS:
        raise ValueError(f"unknown method {name!r}; choose one of {', '.join(METHODS)}")
    return METHODS[name]


def method_names(default_only: bool = False) -> tuple[str, ...]:
    """The registered methods' names (only those ``dexpush bench`` runs by default, with ``default_only``)."""
    return tuple(n for n, m in METHODS.items() if m.default or not default_only)
