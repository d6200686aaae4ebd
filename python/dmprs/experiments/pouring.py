"""Pouring 0.2 l from a bottle of unknown volume (paper section 5.2, docs/method.md §9), in the
2-D pymunk simulation.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from dmprs._arrays import as_scalar
from dmprs.experiments.base import SCALAR_LEARNERS, ExperimentSetup, LearnerSettings, build
from dmprs.tasks.noise import Noise
from dmprs.tasks.pouring import DEMO_VOLUMES, SUCCESS_TOLERANCE, TARGET_VOLUME, Pouring, demonstration
from dmprs.trajectory import Trajectory

#: Gain of the "fixed" learner for pouring, in litres of assumed volume per litre of poured
#: error: K = 1 l/l is eq. 16 with K = I, untuned and the same at every volume, which is what the
#: paper's fixed-gain attempt did. Its contraction per trial is 1 - K |dV_poured/dq|, and the
#: slope |dV_poured/dq| measured in the simulation differs between 0.4-0.5 l and 0.7 l
#: (docs/method.md §9.2): one gain gives different learning rates at different volumes (lower
#: volumes would need higher gains, as the paper reports), which golden section avoids. Pass
#: ``fixed_gain`` to try others.
FIXED_GAIN = 1.0
#: l: eq. 17's scale and the step scale of the policy gradient and Broyden (docs/method.md §5.1)
SCALE = 0.05


def setup(bottle_volume: float = 0.5, target_volume: float = TARGET_VOLUME, tol: float = SUCCESS_TOLERANCE,
          liquid_seed: int = 0, demo_seed: int = 0, fixed_gain: float = FIXED_GAIN,
          reseed_liquid: bool = False, cache_dir: str | None = None, noise: Noise | None = None,
          demo_volumes: tuple[float, ...] = DEMO_VOLUMES) -> ExperimentSetup:
    """Pour ``target_volume`` (0.2 l) from a bottle holding ``bottle_volume`` l (docs/method.md §9).

    Two scripted demonstrations pour ``target_volume`` from bottles of ``demo_volumes``, 0.3 l
    and 1.0 l (their
    queries are those volumes; their peak tilts are calibrated in the simulation with the liquid
    of ``demo_seed``, and cached, see :func:`dmprs.tasks.pouring.calibrate_peak_tilt`);
    linear generalization with N = 40 kernels; the desired query is the true ``bottle_volume``.
    Learners: ``auto`` (the default), ``golden`` (the paper's choice, paper mode, bracket [0.3, 1.0] l),
    ``fixed`` (eq. 16 with the scalar gain ``fixed_gain`` in l/l) and the scalar query learners.
    ``noise``: a :class:`dmprs.tasks.noise.Noise` for the trials (the demonstrations stay exact).
    """
    task = Pouring(bottle_volume, target_volume=target_volume, tol=tol, liquid_seed=liquid_seed,
                   reseed_liquid=reseed_liquid, noise=noise)
    gain = as_scalar(fixed_gain, "fixed_gain", positive=True)
    def demos() -> list[tuple[NDArray[np.float64], Trajectory]]:
        return [demonstration(v, task.target_volume, liquid_seed=demo_seed, cache_dir=cache_dir)[:2]
                for v in demo_volumes]

    settings = LearnerSettings(low=min(demo_volumes), high=max(demo_volumes), weight_scale=SCALE,
                               task_scale=SCALE, gain=gain)
    return build(task, demos, bottle_volume, generalizer={"method": "linear", "n_basis": 40},
                 paper_learner="golden", learner_names=(*SCALAR_LEARNERS, "fixed"), settings=settings)
