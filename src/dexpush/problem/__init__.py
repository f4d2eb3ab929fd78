"""What a pushing experiment asks for: the object, the goal, the obstacles and the cost of eq. (9)
(the problem a method solves, a *task* in MuJoCo MPC's sense)."""

from dexpush.problem.problem import Problem
from dexpush.problem.weights import CostWeights

__all__ = ["CostWeights", "Problem"]
