"""The minimum-jerk profile, the one smooth point-to-point movement every scripted demonstrator
of dmprs is built from (the matchbox strike, the pouring tilt, the analytic bump, the demo reach;
docs/method.md §8.3, §9.3).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray


def min_jerk(s: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """``m(s) = 10 s^3 - 15 s^4 + 6 s^5`` and its first and second derivatives in ``s``, for the
    normalized time ``s`` (clipped to [0, 1], so the profile rests at 0 before and at 1 after).

    Divide the derivatives by the duration (squared) for time derivatives. m, m' and m'' are 0 at
    s = 0, and m = 1, m' = m'' = 0 at s = 1: the movement starts and ends at rest.
    """
    u: NDArray[np.float64] = np.clip(np.asarray(s, dtype=np.float64), 0.0, 1.0)
    # Powers as products: numpy's `**` is a CPU-chosen pow kernel (dmprs.portable).
    u2 = u * u
    u3 = u2 * u
    u4 = u2 * u2
    return (10 * u3 - 15 * u4 + 6 * (u4 * u),
            30 * u2 - 60 * u3 + 30 * u4,
            60 * u - 180 * u2 + 120 * u3)
