"""dexpush: contact-aware, goal-oriented planar pushing (Lee & Kim, C-GVMM + MPPI + UKF)."""

from dexpush.geometry import Shape
from dexpush.model import LAMBDA_TRUE, MODE_NAMES, cgvmm, contact_solution, force_motion

__all__ = ["LAMBDA_TRUE", "MODE_NAMES", "Shape", "cgvmm", "contact_solution", "force_motion"]
__version__ = "0.1.0"
