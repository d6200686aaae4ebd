"""What every simulated pour records, the 2-D bottle's (:mod:`dmprs.sim.pouring_scene`) and the
arm's (:mod:`dmprs.sim.arm_scene`) alike: the liquid in the glass over time and where each
particle ended.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray


@dataclass(frozen=True, kw_only=True)
class PourRecord:
    """``times``: every physics step's time from 0. ``sample_times``/``glass_counts``:
    particles in the glass over time. ``region``: the final region of every particle (its
    scene's constants); ``positions``: the final particle centres. ``n_bottle + n_glass +
    n_spilled = n_particles`` (each scene says how it counts them). ``interrupted`` is true when
    ``should_stop`` ended the pour early (then the counts are of that moment).
    """

    times: NDArray[np.float64]
    sample_times: NDArray[np.float64]
    glass_counts: NDArray[np.int64]
    region: NDArray[np.int8]
    positions: NDArray[np.float64]
    n_particles: int
    n_bottle: int
    n_glass: int
    n_spilled: int
    interrupted: bool = False
