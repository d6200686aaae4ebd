"""The arm-pouring task: scoring like the 2-D pouring, and the pose trajectory of a generalized
DMP."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dmprs._arrays import as_scalar
from dmprs.adapters import Outcome
from dmprs.errors import InvalidInputError
from dmprs.tasks.arm_pouring.adapter import CAPACITY, TARGET_VOLUME, ArmPouringAdapter, _check_volume
from dmprs.tasks.arm_pouring.poses import tangent_to_pose
from dmprs.tasks.base import Task
from dmprs.trajectory import CartesianTrajectory

if TYPE_CHECKING:
    from dmprs.cartesian import CartesianDMP
    from dmprs.dmp import DMP

#: l: success when |V_poured - V*| is below this. Set above the granular outcome's noise floor
#: (docs/arm.md): the 2-D scene's 10 ml lies below that floor on the arm.
SUCCESS_TOLERANCE = 0.020


class ArmPouring(Task):
    """Pour ``target_volume`` (0.2 l) with the arm from a bottle holding ``bottle_volume`` l.

    Query: the assumed bottle volume (l); ``eps = V_poured - V*`` (``sign = -1``); success when
    ``|eps| < tol`` (l; the default is set from the measured noise floor, docs/arm.md). Adapter
    options go to :class:`ArmPouringAdapter`.
    """

    adapter: ArmPouringAdapter
    name = "arm-pouring"
    query_names = ("bottle_volume",)
    query_units = ("l",)
    sign = -1.0

    def __init__(self, bottle_volume: float = 0.5, target_volume: float = TARGET_VOLUME,
                 tol: float = SUCCESS_TOLERANCE, **adapter_options: Any) -> None:
        adapter = ArmPouringAdapter(bottle_volume, **adapter_options)
        super().__init__(adapter)
        self.bottle_volume = adapter.bottle_volume
        self.target_volume = _check_volume(target_volume, "target_volume", capacity=self.bottle_volume)
        self.tol = as_scalar(tol, "tol", positive=True)

    def validate_query(self, query: ArrayLike, name: str = "desired_query") -> NDArray[np.float64]:
        q = super().validate_query(query, name)
        if not 0 < q[0] <= CAPACITY:
            raise InvalidInputError(f"{name} = {q[0]:g} l: a bottle volume must be > 0 and at most the simulated "
                                    f"bottle's capacity of {CAPACITY:g} l")
        return q

    def trajectory(self, dmp: DMP | CartesianDMP) -> CartesianTrajectory:
        """The pose trajectory of a generalized DMP, rolled out at the adapter's control period: a
        ``CartesianDMP``'s rollout, or a 6-D DMP of :func:`demonstration_tangent`'s coordinates
        (position, rotation vector from upright) turned back into poses."""
        out = dmp.rollout(dt=self.adapter.spec.control_period)
        if isinstance(out, CartesianTrajectory):
            return out
        from dmprs.sim.arm_scene import HOME_POSE

        return CartesianTrajectory.from_pose(out.t, tangent_to_pose(out.y, np.asarray(HOME_POSE[3:])))

    def measure(self, outcome: Outcome) -> NDArray[np.float64]:
        return np.array([float(outcome.signals["poured_volume"])])

    def target(self, desired_query: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.array([self.target_volume])

