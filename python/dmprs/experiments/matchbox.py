"""The matchbox flip-up (paper section 5.1, docs/method.md §8): stand the box upright."""

from __future__ import annotations

import math

from dmprs.errors import InvalidInputError
from dmprs.experiments.base import SCALAR_LEARNERS, ExperimentSetup, LearnerSettings, build
from dmprs.tasks.matchbox import DEMO_SETS, MatchboxFlip
from dmprs.tasks.noise import Noise


def setup(demos: str = "default", *, noise: Noise | None = None, **config: float) -> ExperimentSetup:
    """Two scripted strikes labelled with their measured outcome angles, linear generalization with
    N = 25 kernels (the paper's matchbox setting), desired query pi/2.

    ``demos="default"``: one strike that flips back and one that flips over (paper Fig. 4);
    ``"both_flipped_back"``: two that flip back, so pi/2 lies outside the demos and the
    generalizer extrapolates (Fig. 7). Learners: ``auto`` (the default), ``error`` (eq. 16, K = I, the paper's),
    ``weighted`` (eq. 17 with scale 1 rad, recommended for extrapolation), ``secant``, and the
    bracketing ones between the demos' labels. ``config`` overrides simulation parameters;
    ``noise`` is a :class:`dmprs.tasks.noise.Noise` for the trials (the demos are measured exactly).
    """
    if demos not in DEMO_SETS:
        raise InvalidInputError(f"unknown demonstration set {demos!r}; choose from {', '.join(DEMO_SETS)}")
    task = MatchboxFlip(noise, **config)
    recorded = [task.demonstration(duration) for duration in DEMO_SETS[demos]]
    labels = [float(q[0]) for q, _ in recorded]
    settings = LearnerSettings(low=min(labels), high=max(labels), weight_scale=1.0, task_scale=1.0)
    return build(task, lambda: recorded, math.pi / 2, generalizer={"method": "linear", "n_basis": 25},
                 paper_learner="error", learner_names=SCALAR_LEARNERS, settings=settings)

