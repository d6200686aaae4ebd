"""The juggling task: bounce the ball on the paddle to a desired apex height (paddle juggling,
Schaal, Sternad & Atkeson 1996), a periodic movement whose outcome depends on its rhythm.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dmprs._arrays import as_count, as_scalar
from dmprs.adapters import Outcome
from dmprs.errors import InvalidInputError
from dmprs.periodic import PeriodicDMP
from dmprs.sim.juggle_scene import home
from dmprs.tasks.arm_juggling.adapter import CONTROL_PERIOD, ArmJugglingAdapter
from dmprs.tasks.base import Task
from dmprs.trajectory import Trajectory

if TYPE_CHECKING:
    from dmprs.generalize import GeneralizedDMP

#: m: a trial succeeds when the apex is within this of the desired one
SUCCESS_TOLERANCE = 0.01
#: m: the apexes the task accepts (measured, docs/juggling.md): the scripted rhythms of periods
#: 0.2-0.8 s bounce the ball steadily to 0.056-0.84 m; at 0.8 s the shoulder A2 runs at 99 % of its
#: velocity limit, so a higher apex needs a faster paddle than the arm has, and below 5 cm the
#: ball (4 cm across) barely leaves the paddle
REACH = (0.05, 0.8)
#: full-amplitude periods of a trial's rhythm, and the periods it fades in and out over
PERIODS = 14
RAMP = 1.0


def rhythm_trajectory(dmp: GeneralizedDMP, dt: float, rest: ArrayLike, periods: int = PERIODS,
                      ramp: float = RAMP) -> Trajectory:
    """What the arm executes for a periodic DMP: its :class:`~dmprs.periodic_stepper.PeriodicStepper`
    at control period ``dt`` from the DMP's start at rest, fading in over ``ramp`` periods,
    ``periods`` periods at full amplitude, then fading out over ``ramp`` periods to rest at
    ``rest``; positions, velocities and accelerations at every control period.
    """
    if not isinstance(dmp, PeriodicDMP):
        raise InvalidInputError(f"the juggling task executes a dmprs.PeriodicDMP, not a {type(dmp).__name__}")
    stepper = dmp.stepper(dt, ramp=ramp)
    n = math.ceil((ramp + periods) * dmp.period / dt)
    rows = [tuple(v.copy() for v in stepper.step()) for _ in range(n)]
    stepper.stop(np.asarray(rest, dtype=float))
    # the fade-out's spring settles within a few of its time constants; bound the loop all the same
    for _ in range(math.ceil((ramp + 4.0) * dmp.period / dt)):
        if stepper.done():
            break
        rows.append(tuple(v.copy() for v in stepper.step()))
    y, yd, ydd = (np.array(c) for c in zip(*rows, strict=True))
    return Trajectory(np.arange(len(y), dtype=np.float64) * dt, y, yd, ydd)


class ArmJuggling(Task):
    """Bounce the ball to the desired apex height ``h`` (m above the paddle's face at rest).

    Query: the apex in m; ``eps = h* - apex`` (``sign = +1``: the query is in outcome units);
    success within ``tol`` (1 cm). An apex outside :data:`REACH` is refused
    (:meth:`validate_query`). The generalized DMP is periodic; :meth:`trajectory` runs it with
    :func:`rhythm_trajectory` (fade in, :data:`PERIODS` periods, fade out to rest at home).
    ``seed``: the scene's :class:`~dmprs.sim.juggle_scene.Drop` (how the ball is started, its
    restitution).
    """

    name = "arm-juggling"
    query_names = ("apex",)
    query_units = ("m",)
    sign = 1.0

    def __init__(self, tol: float = SUCCESS_TOLERANCE, seed: int = 0) -> None:
        super().__init__(ArmJugglingAdapter(as_count(seed, "seed", 0)))
        self.tol = as_scalar(tol, "tol", positive=True)

    def validate_query(self, query: ArrayLike, name: str = "desired_query") -> NDArray[np.float64]:
        """An apex the ball can be bounced to (:data:`REACH`); others are refused, not simulated."""
        q = super().validate_query(query, name)
        low, high = REACH
        if not low <= q[0] <= high:
            raise InvalidInputError(
                f"{name} = {q[0]:.6g} m is outside the apexes this task reaches, {low:g} to {high:g} m above the "
                "paddle at rest (a higher apex needs a paddle faster than the arm's joint speed limits; a lower "
                "one is less than a bounce)")
        return q

    def trajectory(self, dmp: GeneralizedDMP) -> Trajectory:
        """The rhythm the arm executes for the periodic DMP ``dmp`` (:func:`rhythm_trajectory`)."""
        return rhythm_trajectory(dmp, CONTROL_PERIOD, home())

    def measure(self, outcome: Outcome) -> NDArray[np.float64]:
        """The apex (m)."""
        return np.array([float(outcome.signals["apex"])])
