"""The arm-pouring task: scoring like the 2-D pouring, and the pose trajectory of a generalized
DMP.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from dmprs.sim.arm_scene import HOME_POSE
from dmprs.tasks.arm_pouring.adapter import CAPACITY, ArmPouringAdapter
from dmprs.tasks.arm_pouring.poses import tangent_to_pose
from dmprs.tasks.liquid import TARGET_VOLUME, PouringTask
from dmprs.trajectory import CartesianTrajectory

if TYPE_CHECKING:
    from dmprs.generalize import GeneralizedDMP

#: l: success when |V_poured - V*| is below this. Set above the granular outcome's noise floor
#: (docs/arm.md): the 2-D scene's 10 ml lies below that floor on the arm.
SUCCESS_TOLERANCE = 0.020


class ArmPouring(PouringTask):
    """Pour ``target_volume`` (0.2 l) with the arm from a bottle holding ``bottle_volume`` l;
    scored as :class:`~dmprs.tasks.liquid.PouringTask`, with a success tolerance set above the
    granular outcome's noise floor. Adapter options go to :class:`ArmPouringAdapter`.
    """

    name = "arm-pouring"
    capacity = CAPACITY

    def __init__(self, bottle_volume: float = 0.5, target_volume: float = TARGET_VOLUME,
                 tol: float = SUCCESS_TOLERANCE, **adapter_options: Any) -> None:
        adapter = ArmPouringAdapter(bottle_volume, **adapter_options)
        super().__init__(adapter, adapter.bottle_volume, target_volume, tol)

    def trajectory(self, dmp: GeneralizedDMP) -> CartesianTrajectory:
        """The pose trajectory of a generalized DMP, rolled out at the adapter's control period: a
        ``CartesianDMP``'s rollout, or a 6-D DMP of :func:`demonstration_tangent`'s coordinates
        (position, rotation vector from upright) turned back into poses.
        """
        out = dmp.rollout(dt=self.adapter.spec.control_period)
        if isinstance(out, CartesianTrajectory):
            return out

        return CartesianTrajectory.from_pose(out.t, tangent_to_pose(out.y, np.asarray(HOME_POSE[3:])))
