"""The analytic task (:mod:`dmprs.tasks.analytic`): two demonstrated bumps labelled with their
outcomes, linear generalization, a physics-free check of the learning loop.
"""

from __future__ import annotations

from dmprs.experiments.base import SCALAR_LEARNERS, ExperimentSetup, LearnerSettings, build
from dmprs.tasks.analytic import AnalyticTask
from dmprs.tasks.noise import Noise


def setup(noise: float | Noise = 0.0, tol: float = 0.01, desired: float = 1.5,
          amplitudes: tuple[float, float] = (0.5, 2.5), execution_noise: float = 0.0) -> ExperimentSetup:
    """Two demonstrations (bumps of the given amplitudes, labelled with their outcomes), linear
    generalization, desired outcome ``desired``.
    """
    task = AnalyticTask(noise=noise, tol=tol, execution_noise=execution_noise)
    demos = [task.demonstration(a) for a in amplitudes]
    labels = [float(q[0]) for q, _ in demos]
    settings = LearnerSettings(low=min(labels), high=max(labels), weight_scale=1.0, task_scale=1.0)
    return build(task, lambda: demos, desired, generalizer={"method": "linear", "n_basis": 25}, paper_learner="error",
                 learner_names=SCALAR_LEARNERS, settings=settings)
