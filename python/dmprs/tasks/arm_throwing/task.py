"""The throwing task: hit a basket at (x, y) on the floor (the paper's example of a query, section
3: "the relationship between the basket positions and the DMP parameters")."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dmprs.adapters import Outcome
from dmprs.errors import InvalidInputError
from dmprs.tasks.arm_throwing.adapter import ArmThrowingAdapter
from dmprs.tasks.base import Task
from dmprs.tasks.noise import Noise

#: m: a throw hits the basket when it lands within this of the target (a basket 10 cm across)
TOLERANCE = 0.05


class ArmThrowing(Task):
    """Throw the ball so that it lands at the desired ``(x, y)`` (m) on the floor.

    Query: the landing point (x, y) in m; ``eps = target - landing`` (``sign = +1``: the query is
    in outcome units, as for the matchbox); success when the landing is within ``tol`` (5 cm) of
    the target (the Euclidean distance, a round basket). ``noise`` goes to the adapter.
    """

    name = "arm-throwing"
    query_names = ("x", "y")
    query_units = ("m", "m")
    sign = 1.0

    def __init__(self, tol: float = TOLERANCE, noise: Noise | None = None) -> None:
        super().__init__(ArmThrowingAdapter(noise))
        tol_f = float(tol)
        if not (math.isfinite(tol_f) and tol_f > 0):
            raise InvalidInputError(f"tol = {tol!r} must be > 0 m")
        self.tol = tol_f

    def measure(self, outcome: Outcome) -> NDArray[np.float64]:
        return np.array([float(outcome.signals["landing_x"]), float(outcome.signals["landing_y"])])

    def success(self, desired_query: ArrayLike, outcome: Outcome) -> bool:
        return bool(np.linalg.norm(self.error(desired_query, outcome)) < self.tol)
