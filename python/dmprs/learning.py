"""The learning loop of the paper (docs/method.md §1): generalize, roll out, execute, score, tell.

    Database -> Generalizer.predict(q) -> DMP -> rollout -> Trajectory -> adapter.execute
      -> Outcome -> task.error(q0, outcome) = eps -> learner.tell(q, eps) -> learner.ask() ...
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

import dmprs
from dmprs._arrays import as_query
from dmprs.adapters import Outcome, Status
from dmprs.errors import DmprsError, InvalidInputError
from dmprs.runlog import RunLog, RunLogError, TrialRecord
from dmprs.tasks.base import Task


class AskTell(Protocol):
    """What the loop needs of a learner (the cma / optuna / nevergrad convention)."""

    def ask(self) -> Any: ...
    def tell(self, q: Any, eps: Any) -> None: ...
    @property
    def converged(self) -> bool: ...


class GeneralizerLike(Protocol):
    def predict(self, q: Any) -> dmprs.DMP: ...


@dataclass(frozen=True)
class LearningResult:
    """What a run did. ``learned_query`` is the last executed query of a successful trial (or,
    if none succeeded, the executed query with the smallest |eps|)."""

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


def _eps_like(q_obj: Any, eps: NDArray[np.float64]) -> Any:
    """eps in the form the learner uses for queries: a float for scalar queries."""
    return float(eps[0]) if np.ndim(q_obj) == 0 else eps


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
    on_trial: Callable[[TrialRecord], None] | None = None,
    meta: dict[str, Any] | None = None,
) -> LearningResult:
    """Learns the query that achieves ``desired_query`` on ``task``, one trial at a time.

    Each trial: ``q = learner.ask()``, ``generalizer.predict(q)`` -> DMP -> ``task.trajectory``
    -> ``adapter.execute`` (checked; the adapter is reset with ``seed + trial``) -> eps =
    ``task.error``. The trial is appended to ``log_dir/trials.jsonl`` and forced to disk before
    ``learner.tell(q, eps)``. A trial that is not ``ok`` (rejected, timeout, error, an invalid
    generalization) is logged and ends the run: it never reaches the learner.

    The run stops when a trial succeeds (``|eps| < tol`` if ``tol`` is given, else
    ``task.success``), when the learner reports convergence, or after ``max_trials`` executed
    trials. With ``resume=True`` the logged trials are replayed into the (fresh, identically
    configured) learner, which must ask the same queries again, and the run continues. With a
    ``database``, a successful (desired query, executed trajectory) is added to it.
    """
    q0 = task.validate_query(desired_query)
    if not isinstance(max_trials, (int, np.integer)) or max_trials < 1:
        raise InvalidInputError(f"max_trials = {max_trials!r} must be a positive integer")
    if tol is not None and not (np.isfinite(tol) and tol > 0):
        raise InvalidInputError(f"tol = {tol!r} must be > 0")
    if resume and log_dir is None:
        raise InvalidInputError("resume=True needs the log_dir of the run to resume")

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
            "max_trials": max_trials, "tol": tol, "seed": seed, "dmprs": dmprs.__version__,
            "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"), **(meta or {}),
        })

    def succeeded(eps: NDArray[np.float64], outcome: Outcome) -> bool:
        if tol is not None:
            return bool(np.all(np.abs(eps) < tol))
        return task.success(q0, outcome)

    def finish(reason: str, converged: bool) -> LearningResult:
        ok = [t for t in trials if t.status == Status.OK.value and t.eps is not None]
        learned = None
        if converged:
            learned = next(t.query for t in reversed(ok) if t.success)
        elif ok:
            learned = min(ok, key=lambda t: float(np.linalg.norm(t.eps))).query
        return LearningResult(trials, converged, learned, reason, None if log is None else log.directory, cut)

    if trials and trials[-1].success:
        return finish("already converged in the log", True)

    with task.adapter:
        while True:
            n_done = sum(1 for t in trials if t.status == Status.OK.value)
            if n_done >= max_trials:
                return finish(f"trial cap of {max_trials} reached", False)
            if getattr(learner, "converged", False) or getattr(learner, "done", False):
                detail = getattr(learner, "status_detail", "") or getattr(learner, "status", "")
                return finish(f"the learner stopped without a successful trial ({detail})", False)
            index = len(trials)
            q_obj = learner.ask()
            q = as_query(q_obj, "the learner's query", task.query_names)
            command = None
            try:
                dmp = generalizer.predict(q)
                command = task.trajectory(dmp)
            except DmprsError as exc:
                outcome: Outcome = Outcome(Status.REJECTED, message=f"generalization failed: {exc}")
            else:
                task.adapter.reset(seed=seed + index)
                try:
                    outcome = task.adapter.execute(command, timeout_s=timeout_s)
                except KeyboardInterrupt:
                    task.adapter.stop()
                    raise
                except Exception as exc:  # noqa: BLE001 - an adapter that raises ends the run cleanly
                    task.adapter.stop()
                    outcome = Outcome(Status.ERROR, message=f"{type(exc).__name__}: {exc}")
            if not outcome.ok:
                record = TrialRecord(index, q, outcome.status.value, message=outcome.message)
                trials.append(record)
                if log is not None:
                    log.append(record, command, outcome)
                if on_trial:
                    on_trial(record)
                return finish(f"trial {index + 1} ended with status {outcome.status.value}: {outcome.message}", False)
            eps = np.atleast_1d(task.error(q0, outcome))
            success = succeeded(eps, outcome)
            scalars = {k: v for k, v in outcome.signals.items() if np.ndim(v) == 0}
            record = TrialRecord(index, q, Status.OK.value, eps, success, scalars, outcome.message)
            trials.append(record)
            if log is not None:
                log.append(record, command, outcome)  # on disk before the learner sees it
            if on_trial:
                on_trial(record)
            if success:
                if database is not None:
                    database.add(q0, outcome.executed if outcome.executed is not None else command)
                return finish(f"success in trial {index + 1}", True)
            learner.tell(q_obj, _eps_like(q_obj, eps))


def _replay(learner: AskTell, trials: list[TrialRecord], query_names: tuple[str, ...], path: Path) -> None:
    """Feeds logged trials to a fresh learner, checking it asks for the same queries."""
    for t in trials:
        if t.success:
            return
        q_obj = learner.ask()
        q = as_query(q_obj, "the learner's query", query_names)
        if not np.allclose(q, t.query, rtol=1e-12, atol=1e-12):
            raise RunLogError(
                f"{path}: trial {t.index} executed query {t.query.tolist()} but the learner now asks "
                f"{q.tolist()}; resume with the learner configured as in the original run")
        learner.tell(q_obj, _eps_like(q_obj, t.eps))
