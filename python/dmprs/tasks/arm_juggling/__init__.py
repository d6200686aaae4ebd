"""Paddle juggling with the 7-DOF arm in MuJoCo (Schaal, Sternad & Atkeson 1996): the arm of
:mod:`dmprs.sim.arm_model` holds a paddle and bounces a ball; the query is the ball's apex height
(m above the paddle at rest), which the rhythm's period sets (:mod:`dmprs.sim.juggle_scene`,
docs/juggling.md).

* :class:`ArmJugglingAdapter` executes a joint-space :class:`~dmprs.Trajectory` (7 DOFs, rad)
  with the iiwa's limits and returns the apex; its seed draws how the ball is started.
* :class:`ArmJuggling` scores it: ``eps = target - apex`` (m), success within 1 cm; it runs a
  periodic DMP as fade-in, a fixed number of periods and fade-out.
* :func:`rhythm_period` is the scripted demonstrator (one period of a level paddle moving
  sinusoidally); :data:`DEMO_PERIODS` the demonstrations' periods.
"""

from dmprs.tasks.arm_juggling.adapter import CONTROL_PERIOD, ArmJugglingAdapter
from dmprs.tasks.arm_juggling.demonstrator import DEMO_PERIODS, paddle_amplitude, rhythm_period
from dmprs.tasks.arm_juggling.task import (
    PERIODS,
    RAMP,
    REACH,
    SUCCESS_TOLERANCE,
    ArmJuggling,
    rhythm_trajectory,
)

__all__ = [
    "CONTROL_PERIOD",
    "DEMO_PERIODS",
    "PERIODS",
    "RAMP",
    "REACH",
    "SUCCESS_TOLERANCE",
    "ArmJuggling",
    "ArmJugglingAdapter",
    "paddle_amplitude",
    "rhythm_period",
    "rhythm_trajectory",
]
