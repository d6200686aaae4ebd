"""Throwing a ball into a basket with the 7-DOF arm in MuJoCo (the paper's own
example of a query: "the relationship between the basket positions and the DMP parameters"). The
arm of :mod:`dmprs.sim.arm_model` holds a cup with a ball at its flange; the query is where the
ball lands on the floor (x, y), m (:mod:`dmprs.sim.throw_scene`, docs/throwing.md).

* :class:`ArmThrowingAdapter` executes a joint-space :class:`~dmprs.Trajectory` (7 DOFs, rad) with
  the iiwa's limits and returns the landing point; optional execution and measurement noise.
* :class:`ArmThrowing` scores it: ``eps = target - landing`` (m), success within 5 cm.
* :func:`throw_trajectory` is the scripted demonstrator (base turn, then a minimum-jerk swing of
  A2, A4, A6); :data:`DEMOS` the demonstrations' (strength, yaw).
* :mod:`dmprs.tasks.arm_throwing.release`: the final-velocity throw, a throw split at its release
  into a DMP with a final velocity and a braking movement (docs/throwing.md).
"""

from dmprs.tasks.arm_throwing.adapter import CONTROL_PERIOD, ArmThrowingAdapter
from dmprs.tasks.arm_throwing.demonstrator import DEMOS, SWING, SWING_TIME, TURN_TIME, throw_trajectory
from dmprs.tasks.arm_throwing.task import SUCCESS_TOLERANCE, ArmThrowing

__all__ = [
    "CONTROL_PERIOD",
    "DEMOS",
    "SUCCESS_TOLERANCE",
    "SWING",
    "SWING_TIME",
    "TURN_TIME",
    "ArmThrowing",
    "ArmThrowingAdapter",
    "throw_trajectory",
]
