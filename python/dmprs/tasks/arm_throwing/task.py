"""The throwing task: hit a basket at (x, y) on the floor (the paper's example of a query, section
3: "the relationship between the basket positions and the DMP parameters").
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dmprs._arrays import as_scalar
from dmprs.adapters import Outcome
from dmprs.dmp import DMP
from dmprs.errors import InvalidInputError
from dmprs.portable import norm
from dmprs.sim.throw_scene import reach
from dmprs.tasks.arm_throwing.adapter import ArmThrowingAdapter
from dmprs.tasks.arm_throwing.release import release_sequence
from dmprs.tasks.base import Task
from dmprs.tasks.noise import Noise

if TYPE_CHECKING:
    from dmprs.generalize import GeneralizedDMP
    from dmprs.trajectory import AnyTrajectory

#: m: a throw hits the basket when it lands within this of the target (a basket 10 cm across)
SUCCESS_TOLERANCE = 0.05


class ArmThrowing(Task):
    """Throw the ball so that it lands at the desired ``(x, y)`` (m) on the floor.

    Query: the landing point (x, y) in m; ``eps = target - landing`` (``sign = +1``: the query is
    in outcome units, as for the matchbox); success when the landing is within ``tol`` (5 cm) of
    the target (the Euclidean distance, a round basket); a target the ball cannot reach is refused
    (:meth:`validate_query`). ``noise`` goes to the adapter. A DMP with a final velocity is the
    movement up to the release of the final-velocity throw: :meth:`trajectory` appends its
    braking (:mod:`dmprs.tasks.arm_throwing.release`).
    """

    name = "arm-throwing"
    query_names = ("x", "y")
    query_units = ("m", "m")
    sign = 1.0

    def __init__(self, tol: float = SUCCESS_TOLERANCE, noise: Noise | None = None) -> None:
        super().__init__(ArmThrowingAdapter(noise))
        self.tol = as_scalar(tol, "tol", positive=True)

    def validate_query(self, query: ArrayLike, name: str = "desired_query") -> NDArray[np.float64]:
        """A landing point the ball can reach (:func:`dmprs.sim.throw_scene.reach`); a basket
        beyond it is refused, not simulated.
        """
        q = super().validate_query(query, name)
        r, span = norm(q), reach()
        if not span.low <= r <= span.high:
            raise InvalidInputError(
                f"{name} = ({q[0]:.6g}, {q[1]:.6g}) m is {r:.4g} m from the arm's base, beyond the task's reach: "
                f"a ball lands {span.low:.3g} to {span.high:.3g} m from the base's axis (outside the pedestal; "
                f"at most a {span.release_speed:.3g} m/s release, the iiwa's joint speed limits, from "
                f"{span.release_height:.3g} m up, without drag)")
        return q

    def trajectory(self, dmp: GeneralizedDMP) -> AnyTrajectory:
        """The rollout of ``dmp`` at the adapter's control period; a DMP with a final velocity
        (the final-velocity throw up to its release) hands over to its braking movement, and the
        :class:`dmprs.Sequence` of both is rolled out (:func:`~dmprs.tasks.arm_throwing.release.release_sequence`).
        """
        if isinstance(dmp, DMP) and np.any(dmp.final_velocity != 0.0):
            return release_sequence(dmp).rollout(dt=self.adapter.spec.control_period)
        return super().trajectory(dmp)

    def measure(self, outcome: Outcome) -> NDArray[np.float64]:
        """The landing point (x, y) in m."""
        return np.array([float(outcome.signals["landing_x"]), float(outcome.signals["landing_y"])])

    def success(self, desired_query: ArrayLike, outcome: Outcome) -> bool:
        """Whether the ball landed within ``tol`` of the target (a round basket)."""
        return bool(norm(self.error(desired_query, outcome)) < self.tol)
