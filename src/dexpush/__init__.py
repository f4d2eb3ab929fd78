"""dexpush: contact-aware, goal-oriented planar pushing (Lee & Kim: C-GVMM, long-horizon MPPI, UKF).

The stable public API (names and settings fields kept from version 0.2 on; see docs/api.md):

* the model: :class:`Shape`, :func:`cgvmm`, :func:`contact_solution`;
* the controller: :class:`PushingController` (``reset``, ``command``, ``act``, ``params``,
  ``set_params``) with :class:`ControllerSettings`, :class:`MPPISettings`, :class:`UKFSettings`;
* sensing: :class:`SensorSettings`, :class:`Camera`;
* the loop: the :class:`Plant` and :class:`Controller` protocols, :class:`Observation`,
  :func:`run_loop` (any plant, any controller, toward a :class:`Task`) and :func:`run_episode` (a
  benchmark trial by name).
"""

from dexpush.common import xla_options  # noqa: F401  (first: sets XLA_FLAGS before any JAX backend starts)
from dexpush.common.interfaces import Controller, Observation, Plant
from dexpush.control.controller import ControllerSettings, PushingController
from dexpush.control.estimator import UKFSettings
from dexpush.control.mppi import MPPISettings
from dexpush.experiments.runner import run_episode, run_loop
from dexpush.experiments.scenarios import Task
from dexpush.model.cgvmm import LAMBDA_TRUE, MODE_NAMES, cgvmm, contact_solution, force_motion
from dexpush.model.shape import Shape
from dexpush.world.sensing import Camera, SensorSettings

__all__ = ["LAMBDA_TRUE", "MODE_NAMES", "Camera", "Controller", "ControllerSettings", "MPPISettings", "Observation",
           "Plant", "PushingController", "SensorSettings", "Shape", "Task", "UKFSettings", "cgvmm", "contact_solution",
           "force_motion", "run_episode", "run_loop"]
__version__ = "0.4.0"
