"""What both MuJoCo arm tasks declare about the arm (the KUKA LBR iiwa 14 of
:mod:`dmprs.sim.arm_model`): seven joints in rad with the data sheet's position and velocity
limits, a home configuration every trajectory must start at, and the tracking signal.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from dmprs.adapters import AdapterSpec, SignalSpec
from dmprs.sim import arm_model

#: rad: a joint trajectory must start at the home configuration within this
START_TOLERANCE = 1e-3
#: the samples a joint trajectory needs (a DMP fit needs three; so does the servo's interpolation)
MIN_SAMPLES = 3
#: the signal every arm trial reports: how well the servo followed the command
TRACKING_ERROR = SignalSpec("tracking_error", "rad", "largest joint tracking error while moving")


def spec(name: str, *, home: Sequence[float] | NDArray[np.float64], control_period: float, max_duration: float,
         signals: Sequence[SignalSpec]) -> AdapterSpec:
    """The adapter spec of a task on the iiwa: its joints ``a1..a7`` (rad) with their limits,
    starting at ``home`` (rad), and the task's ``signals``.
    """
    return AdapterSpec(
        name=name,
        dof_names=arm_model.JOINT_NAMES,
        dof_units=("rad",) * len(arm_model.JOINT_NAMES),
        control_period=control_period,
        signals=tuple(signals),
        position_min=tuple(-x for x in arm_model.JOINT_LIMITS),
        position_max=arm_model.JOINT_LIMITS,
        velocity_max=arm_model.VELOCITY_LIMITS,
        start_pose=tuple(float(x) for x in home),
        start_tolerance=START_TOLERANCE,
        max_duration=max_duration,
        min_samples=MIN_SAMPLES,
    )
