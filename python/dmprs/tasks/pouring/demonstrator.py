"""The scripted demonstrator of the pouring task: the tilt profile whose peak is calibrated in
the simulation to pour the target volume, for the demonstrations' bottles (docs/method.md §9.1).
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dmprs.dmp import DMP
from dmprs.tasks.liquid import TARGET_VOLUME
from dmprs.tasks.pouring.calibration import Calibration, calibrate_peak_tilt
from dmprs.tasks.pouring.profile import tilt_profile
from dmprs.trajectory import Trajectory

#: the demonstrations' bottle volumes (l) (docs/method.md §9.1)
DEMO_VOLUMES = (0.3, 1.0)


def demonstration(bottle_volume: float, target_volume: float = TARGET_VOLUME, *,
                  liquid_seed: int = 0, cache_dir: str | os.PathLike[str] | None = None,
                  ) -> tuple[NDArray[np.float64], Trajectory, Calibration]:
    """A scripted demonstration: (query ``[bottle_volume]``, the tilt profile that pours
    ``target_volume``, its calibration).
    """
    cal = calibrate_peak_tilt(bottle_volume, target_volume, liquid_seed=liquid_seed, cache_dir=cache_dir)
    return np.array([cal.bottle_volume]), tilt_profile(cal.peak_tilt), cal


def demonstration_dmp(bottle_volume: float, target_volume: float = TARGET_VOLUME, *,
                      n_basis: int = 40, liquid_seed: int = 0,
                      cache_dir: str | os.PathLike[str] | None = None) -> Any:
    """The DMP (N = 40, docs/method.md §9.3) fitted to the scripted demonstration for ``bottle_volume``."""
    _, traj, _ = demonstration(bottle_volume, target_volume, liquid_seed=liquid_seed, cache_dir=cache_dir)
    return DMP.fit(traj.t, traj.y, n_basis=n_basis, yd=traj.yd, ydd=traj.ydd)
