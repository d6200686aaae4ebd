"""The demonstrator's movement: a minimum-jerk tilt up, a hold, a minimum-jerk tilt back to
upright (docs/method.md §9.3).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from dmprs.errors import InvalidInputError
from dmprs.profiles import min_jerk
from dmprs.tasks.pouring.adapter import CONTROL_PERIOD
from dmprs.trajectory import Trajectory

#: the demonstrations' timing (s): min-jerk up, hold, min-jerk down (docs/method.md §9.3)
DEMO_TIMING = (1.0, 1.0, 1.0)


def tilt_profile(peak: float, timing: tuple[float, float, float] = DEMO_TIMING,
                 dt: float = CONTROL_PERIOD) -> Trajectory:
    """Minimum-jerk up to ``peak`` rad, hold, minimum-jerk back to 0 (docs/method.md §9.3), with exact
    velocities and accelerations.
    """
    peak = float(peak)
    if not math.isfinite(peak):
        raise InvalidInputError(f"peak = {peak!r} must be a finite tilt in rad")
    up, hold, down = (float(x) for x in timing)
    if min(up, down) <= 0 or hold < 0:
        raise InvalidInputError(f"timing = {timing!r}: up and down must be > 0 s, hold >= 0 s")
    total = up + hold + down
    n = round(total / dt) + 1
    t = np.linspace(0.0, total, n)

    def mj(s: NDArray[np.float64], d: float) -> tuple[NDArray[np.float64], ...]:
        m, dm, ddm = min_jerk(s)
        return m, dm / d, ddm / d**2

    a = mj(t / up, up)
    b = mj((t - up - hold) / down, down)
    y, yd, ydd = (peak * (a[i] - b[i]) for i in range(3))
    return Trajectory(t, y, yd, ydd)
