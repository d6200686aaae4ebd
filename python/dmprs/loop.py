"""The paper's learning loop in the query space (docs/method.md §1, §4-§6): ask, generalize, run
the trial, tell.

    learner.ask() = q -> Generalizer.predict(q) -> DMP -> run_trial (roll out, check, execute,
      score, log) -> eps -> learner.tell(q, eps) -> learner.ask() ...

One trial is :func:`dmprs.trial.run_trial`; this module adds what a run is made of: the stop
rules, resuming from the trial log, and adding a success to the database.
"""

from __future__ import annotations

import functools
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dmprs._arrays import as_query
from dmprs._core import __version__
from dmprs.adapters.spec import Status
from dmprs.database import DUPLICATE_POLICIES
from dmprs.errors import DmprsError, InvalidInputError, RunLogError
from dmprs.portable import norm
from dmprs.runlog import RunLog, TrialRecord
from dmprs.tasks.base import Task
from dmprs.trial import run_trial

if TYPE_CHECKING:
    from dmprs.generalize import GeneralizedDMP


class AskTell(Protocol):
    """What the loops read of a learner (the cma / optuna / nevergrad convention); every learner
    of :mod:`dmprs.learners` has it.
    """

    def ask(self) -> Any:
        """The next query to try."""
    def tell(self, q: Any, feedback: Any) -> None:
        """The feedback (eps) of the query just asked."""
    @property
    def done(self) -> bool:
        """The learner stopped: it asks nothing more."""
    @property
    def converged(self) -> bool:
        """Whether a told trial succeeded."""
    @property
    def status(self) -> str:
        """Why it stopped (``running`` while it asks)."""
    @property
    def status_detail(self) -> str:
        """The status in words."""


class GeneralizerLike(Protocol):
    """What the loop reads of a generalizer (:class:`dmprs.Generalizer` has it)."""
    def predict(self, q: Any) -> GeneralizedDMP:
        """The DMP for query ``q``."""


@dataclass(frozen=True)
class LearningResult:
    """What a run did. ``learned_query`` is the last executed query of a successful trial (or,
    if none succeeded, the executed query with the smallest |eps|).
    """

    trials: list[TrialRecord]
    converged: bool
    learned_query: NDArray[np.float64] | None
    stop_reason: str
    log_dir: Path | None = None
    cut_note: str | None = None

    @property
    def n_trials(self) -> int:
        """Executed trials, counting the first, purely generalized one (docs/method.md §11 #8)."""
        return sum(1 for t in self.trials if t.status == Status.OK.value)

    @property
    def trials_to_success(self) -> int | None:
        """1-based index of the first successful trial, or None."""
        for i, t in enumerate(self.trials):
            if t.success:
                return i + 1
        return None


def _feedback_like(asked: Any, eps: NDArray[np.float64]) -> Any:
    """eps in the form the learner uses for queries: a float for scalar queries."""
    return float(eps[0]) if np.ndim(asked) == 0 else eps


def learn(
    task: Task,
    generalizer: GeneralizerLike,
    desired_query: ArrayLike,
    learner: AskTell,
    max_trials: int = 20,
    tol: float | None = None,
    log_dir: str | Path | None = None,
    *,
    resume: bool = False,
    seed: int = 0,
    timeout_s: float | None = None,
    database: Any | None = None,
    database_policy: str = "replace",
    on_trial: Callable[[TrialRecord], None] | None = None,
    meta: dict[str, Any] | None = None,
) -> LearningResult:
    """Learns the query that achieves ``desired_query`` on ``task``, one trial at a time.

    Each trial: ``q = learner.ask()``, then :func:`dmprs.trial.run_trial` with
    ``generalizer.predict(q)`` (the adapter is reset with ``seed + trial``), appended to
    ``log_dir/trials.jsonl`` and forced to disk before ``learner.tell(q, eps)``. A trial that is
    not ``ok`` (rejected, timeout, error, an invalid generalization, an outcome the task cannot
    score) is logged and ends the run: it never reaches the learner.

    The run stops when a trial succeeds (``|eps| < tol`` if ``tol`` is given, else
    ``task.success``), when the learner stops (``learner.done``), or after ``max_trials``
    executed trials. With ``resume=True`` the logged trials are replayed into the (fresh,
    identically configured) learner, which must ask the same queries again, and the run
    continues. With a ``database``, a successful (desired query, executed trajectory) is added
    to it with ``on_duplicate=database_policy`` (default ``"replace"``: re-learning a query the
    database has replaces its demo, so a grown database stays one demo per query and every
    generalizer can use it; see :meth:`dmprs.Database.add`). If the database still refuses it
    (e.g. ``"refuse"`` and a repeat, or another number of DOFs), the run's result is kept and its
    ``stop_reason`` says why.
    """
    q0 = task.validate_query(desired_query)
    if isinstance(max_trials, bool) or not isinstance(max_trials, (int, np.integer)) or max_trials < 1:
        raise InvalidInputError(f"max_trials = {max_trials!r} must be a positive integer")
    if tol is not None and not (np.isfinite(tol) and tol > 0):
        raise InvalidInputError(f"tol = {tol!r} must be > 0")
    if resume and log_dir is None:
        raise InvalidInputError("resume=True needs the log_dir of the run to resume")
    if database_policy not in DUPLICATE_POLICIES:
        raise InvalidInputError(f"database_policy = {database_policy!r} is invalid: use one of {DUPLICATE_POLICIES}")

    log: RunLog | None = None
    trials: list[TrialRecord] = []
    cut = None
    if log_dir is not None and resume:
        log = RunLog(log_dir)
        log.meta()
        trials, cut = log.read()
        log.repair()
        _replay(learner, [t for t in trials if t.status == Status.OK.value], task.query_names, log.trials_path)
    elif log_dir is not None:
        log = RunLog.create(log_dir, {
            "task": task.name, "desired_query": q0, "query_names": task.query_names,
            "query_units": task.query_units, "learner": type(learner).__name__,
            "max_trials": max_trials, "tol": tol, "seed": seed, "dmprs": __version__,
            "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"), **(meta or {}),
        })

    def finish(reason: str, converged: bool) -> LearningResult:
        ok = [t for t in trials if t.status == Status.OK.value and t.eps is not None]
        learned = None
        if converged:
            learned = next(t.query for t in reversed(ok) if t.success)
        elif ok:
            learned = min(ok, key=lambda t: norm(np.asarray(t.eps))).query
        return LearningResult(trials, converged, learned, reason, None if log is None else log.directory, cut)

    if trials and trials[-1].success:
        return finish("already converged in the log", True)

    with task.adapter:
        while True:
            n_done = sum(1 for t in trials if t.status == Status.OK.value)
            if n_done >= max_trials:
                return finish(f"trial cap of {max_trials} reached", False)
            if learner.done:
                return finish(f"the learner stopped without a successful trial ({learner.status_detail})", False)
            asked = learner.ask()
            q = as_query(asked, "the learner's query", task.query_names)
            result = run_trial(task, len(trials), q, functools.partial(generalizer.predict, q), q0, seed=seed,
                               timeout_s=timeout_s, tol=tol, log=log)
            record = result.record
            trials.append(record)
            if on_trial:
                on_trial(record)
            if not result.ok:
                return finish(f"trial {record.index + 1} ended with status {record.status}: {record.message}",
                              False)
            assert record.eps is not None  # an ok trial is scored
            if record.success:
                reason = f"success in trial {record.index + 1}"
                if database is not None:
                    executed = result.outcome.executed
                    try:
                        database.add(q0, executed if executed is not None else result.command,
                                     on_duplicate=database_policy)
                    except DmprsError as exc:  # the run succeeded: keep it, say what the database refused
                        reason += f"; not added to the database: {exc}"
                return finish(reason, True)
            learner.tell(asked, _feedback_like(asked, record.eps))


def _replay(learner: AskTell, trials: list[TrialRecord], query_names: tuple[str, ...], path: Path) -> None:
    """Feeds logged trials to a fresh learner, checking it asks for the same queries."""
    for t in trials:
        if t.success:
            return
        asked = learner.ask()
        q = as_query(asked, "the learner's query", query_names)
        if not np.allclose(q, t.query, rtol=1e-12, atol=1e-12):
            raise RunLogError(
                f"{path}: trial {t.index} executed query {t.query.tolist()} but the learner now asks "
                f"{q.tolist()}; resume with the learner configured as in the original run")
        assert t.eps is not None
        learner.tell(asked, _feedback_like(asked, t.eps))
