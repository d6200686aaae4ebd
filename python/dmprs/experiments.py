"""Ready-made learning experiments: a task, its demonstration database, a generalizer and a
learner, wired together the way the paper does it. The CLI (``dmprs learn``) runs these.

Each experiment is an :class:`ExperimentSetup` factory registered in :data:`SETUPS`; the
matchbox and pouring simulations add theirs.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dmprs.errors import InvalidInputError
from dmprs.learning import LearningResult, learn
from dmprs.tasks.base import Task


@dataclass
class ExperimentSetup:
    """Everything ``learn`` needs, plus the defaults the paper uses for this task."""

    task: Task
    database: Any
    generalizer: Any
    desired_query: NDArray[np.float64]
    default_learner: str
    #: learner name -> factory(desired_query, **options)
    learners: dict[str, Callable[..., Any]] = field(default_factory=dict)
    #: search limits for bracketing learners (the demos' queries, method.md §6.2 #9)
    low: float | None = None
    high: float | None = None

    def make_learner(self, name: str | None = None, **options: Any) -> Any:
        name = name or self.default_learner
        if name not in self.learners:
            raise InvalidInputError(
                f"unknown learner {name!r} for {self.task.name}; choose from {', '.join(sorted(self.learners))}")
        return self.learners[name](self.desired_query, **options)


def query_learners(low: float | None, high: float | None, scale: float = 1.0,
                   max_trials: int = 50) -> dict[str, Callable[..., Any]]:
    """The paper's query-space learners by name, for a one-dimensional query."""
    from dmprs import learners as L

    def bracket() -> tuple[float, float]:
        if low is None or high is None:
            raise InvalidInputError("this learner needs search limits (low, high)")
        return low, high

    return {
        "error": lambda q0, **kw: L.ErrorLearning(q0, max_trials=max_trials, **kw),
        "weighted": lambda q0, **kw: L.ErrorLearning(q0, weighted=True, scale=scale, max_trials=max_trials, **kw),
        "secant": lambda q0, **kw: L.ErrorLearning(q0, jacobian="secant", max_trials=max_trials, **kw),
        "golden": lambda q0, **kw: L.GoldenSection(float(q0[0]), *bracket(), mode="paper", max_trials=max_trials, **kw),
        "golden-robust": lambda q0, **kw: L.GoldenSection(float(q0[0]), *bracket(), mode="robust", max_trials=max_trials, **kw),
        "root": lambda q0, **kw: L.RootFinder(float(q0[0]), *bracket(), max_trials=max_trials, **kw),
    }


# --- the analytic task ------------------------------------------------------------------------

def analytic_setup(noise: float = 0.0, tol: float = 0.01, desired: float = 1.5,
                   amplitudes: tuple[float, float] = (0.5, 2.5)) -> ExperimentSetup:
    """Two demonstrations (bumps of the given amplitudes, labelled with their outcomes), linear
    generalization, desired outcome ``desired``."""
    from dmprs import Database, Generalizer
    from dmprs.tasks.analytic import AnalyticTask

    task = AnalyticTask(noise=noise, tol=tol)
    db = Database(query_names=task.query_names, query_units=task.query_units)
    labels = []
    for a in amplitudes:
        label, traj = task.demonstration(a)
        db.add(label, traj)
        labels.append(float(label[0]))
    gen = Generalizer(db, method="linear", n_basis=25)
    return ExperimentSetup(
        task=task, database=db, generalizer=gen,
        desired_query=task.validate_query(desired), default_learner="error",
        learners=query_learners(min(labels), max(labels), scale=1.0),
        low=min(labels), high=max(labels),
    )


SETUPS: dict[str, Callable[..., ExperimentSetup]] = {"analytic": analytic_setup}


def run(name: str, *, learner: str | None = None, learner_options: dict[str, Any] | None = None,
        max_trials: int = 20, tol: float | None = None, log_dir: str | Path | None = None,
        seed: int = 0, on_trial: Callable[..., None] | None = None,
        **setup_options: Any) -> LearningResult:
    """Builds experiment ``name`` and learns it; the run log records how, so it can be resumed."""
    if name not in SETUPS:
        raise InvalidInputError(f"unknown task {name!r}; choose from {', '.join(sorted(SETUPS))}")
    setup = SETUPS[name](**setup_options)
    learner_name = learner or setup.default_learner
    lrn = setup.make_learner(learner_name, **(learner_options or {}))
    meta = {"experiment": name, "setup_options": setup_options, "learner_name": learner_name,
            "learner_options": learner_options or {}}
    return learn(setup.task, setup.generalizer, setup.desired_query, lrn, max_trials=max_trials,
                 tol=tol, log_dir=log_dir, seed=seed, on_trial=on_trial, meta=meta)


def analytic(desired: float = 1.5, learner: str = "error", max_trials: int = 20,
             noise: float = 0.0, log_dir: str | Path | None = None, seed: int = 0) -> LearningResult:
    """The analytic task end to end (see :mod:`dmprs.tasks.analytic`)."""
    return run("analytic", learner=learner, max_trials=max_trials, log_dir=log_dir, seed=seed,
               noise=noise, desired=desired)
