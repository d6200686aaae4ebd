"""Ready-made learning experiments: a task, its demonstration database, a generalizer and the
learners, wired together the way the paper does it (:mod:`dmprs.experiments.base`). The command
line (``dmprs learn NAME``), the reproduction and the Gymnasium environments build them from
:data:`EXPERIMENTS`.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from dmprs.errors import InvalidInputError
from dmprs.experiments import analytic, arm_juggling, arm_pouring, arm_throwing, matchbox, pouring
from dmprs.experiments.base import DEFAULT_LEARNER, LEARNERS, ExperimentSetup, LearnerSettings, learner_help
from dmprs.loop import LearningResult, learn
from dmprs.runlog import TrialRecord

__all__ = ["DEFAULT_LEARNER", "EXPERIMENTS", "LEARNERS", "ExperimentSetup", "LearnerSettings", "learner_help", "make",
           "needs", "run"]

#: Every experiment by the name the command line uses, with the function that sets it up.
EXPERIMENTS: dict[str, Callable[..., ExperimentSetup]] = {
    "analytic": analytic.setup,
    "matchbox": matchbox.setup,
    "pouring": pouring.setup,
    "arm-pouring": arm_pouring.setup,
    "arm-throwing": arm_throwing.setup,
    "arm-juggling": arm_juggling.setup,
}

#: The optional package (an extra) an experiment needs beyond the core install.
_NEEDS = {"arm-pouring": "mujoco", "arm-throwing": "mujoco", "arm-juggling": "mujoco"}


def needs(name: str) -> str | None:
    """The optional package experiment ``name`` needs, or None."""
    return _NEEDS.get(name)


def make(name: str, **setup_options: Any) -> ExperimentSetup:
    """Sets up experiment ``name`` with ``setup_options`` (see each module's ``setup``)."""
    if name not in EXPERIMENTS:
        raise InvalidInputError(f"unknown experiment {name!r}; choose from {', '.join(sorted(EXPERIMENTS))}")
    return EXPERIMENTS[name](**setup_options)


def run(name: str, *, learner: str | None = None, learner_options: dict[str, Any] | None = None,
        max_trials: int = 20, tol: float | None = None, log_dir: str | Path | None = None,
        seed: int = 0, on_trial: Callable[[TrialRecord], None] | None = None,
        **setup_options: Any) -> LearningResult:
    """Sets up experiment ``name`` and learns it; the run log records how, so that ``dmprs
    resume`` can rebuild it.
    """
    setup = make(name, **setup_options)
    learner_name = learner or DEFAULT_LEARNER
    lrn = setup.make_learner(learner_name, **(learner_options or {}))
    meta = {"experiment": name, "setup_options": setup_options, "learner_name": learner_name,
            "learner_options": learner_options or {}}
    return learn(setup.task, setup.generalizer, setup.desired_query, lrn, max_trials=max_trials,
                 tol=tol, log_dir=log_dir, seed=seed, on_trial=on_trial, meta=meta)
