"""One trial, the unit every learning loop repeats (docs/method.md §4-§7):

    DMP -> task.trajectory -> adapter.execute (checked) -> outcome validated -> eps -> logged

:func:`run_trial` is the only place that executes a trial, for the query-space loop
(:func:`dmprs.loop.learn`) and the weight-space baselines (:mod:`dmprs.baselines`) alike. It never
raises for what happens inside the trial: a DMP that cannot be built, an adapter that raises or
returns garbage, a task whose error is not finite all become a logged trial whose status is not
``ok``, so a bad trial can neither poison a learner nor lose the run.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, TypeVar

import numpy as np
from numpy.typing import NDArray

from dmprs.adapters.spec import Outcome, Status
from dmprs.errors import DmprsError
from dmprs.runlog import RunLog, TrialRecord
from dmprs.tasks.base import Task

if TYPE_CHECKING:
    from dmprs.generalize import GeneralizedDMP
    from dmprs.trajectory import AnyTrajectory


@dataclass(frozen=True)
class TrialResult:
    """A finished trial: its log record, what was commanded and what the adapter returned."""

    record: TrialRecord
    command: AnyTrajectory | None
    outcome: Outcome

    @property
    def ok(self) -> bool:
        """Whether the execution ran to its end (status OK)."""
        return self.record.status == Status.OK.value


def run_trial(
    task: Task,
    index: int,
    query: NDArray[np.float64],
    make_dmp: Callable[[], GeneralizedDMP],
    desired_query: NDArray[np.float64],
    *,
    seed: int,
    timeout_s: float | None = None,
    tol: float | None = None,
    log: RunLog | None = None,
) -> TrialResult:
    """Runs trial ``index`` and logs it (forced to disk) before returning.

    ``query`` is what the learner asked (a task query, or a weight vector for the baselines);
    ``make_dmp()`` builds the DMP to execute from it. The adapter is reset with ``seed + index``.
    The trial succeeds when ``|eps| < tol`` if ``tol`` is given, else by ``task.success``.
    """
    command: AnyTrajectory | None = None
    try:
        command = task.trajectory(make_dmp())
    except DmprsError as exc:
        outcome = Outcome(Status.REJECTED, message=f"generalization failed: {exc}")
    else:
        outcome = _execute(task, command, seed + index, timeout_s)
    eps: NDArray[np.float64] | None = None
    success = False
    if outcome.status is Status.OK:
        try:
            eps, success = _score(task, desired_query, outcome, tol)
        except _BadOutcome as exc:
            outcome = Outcome(Status.ERROR, signals=_loggable(outcome.signals), executed=outcome.executed,
                              message=str(exc))
    record = TrialRecord(index, np.asarray(query, dtype=float), outcome.status.value, eps, success,
                         _scalars(outcome.signals), outcome.message)
    if log is not None:
        log.append(record, command, outcome)  # on disk before any learner sees the trial
    return TrialResult(record, command, outcome)


def _execute(task: Task, command: AnyTrajectory, seed: int, timeout_s: float | None) -> Outcome:
    """The adapter's outcome, or an ``error`` outcome if it raised or returned something else."""
    adapter = task.adapter
    adapter.reset(seed=seed)
    try:
        outcome = adapter.execute(command, timeout_s=timeout_s)
    except KeyboardInterrupt:
        adapter.stop()
        raise
    except Exception as exc:  # noqa: BLE001 - an adapter that raises ends the run cleanly
        adapter.stop()
        return Outcome(Status.ERROR, message=f"{adapter.spec.name} raised {type(exc).__name__}: {exc}")
    if not isinstance(outcome, Outcome) or not isinstance(outcome.status, Status):
        status = getattr(outcome, "status", outcome)
        return Outcome(Status.ERROR, message=(
            f"{adapter.spec.name} returned {type(outcome).__name__} with status {status!r}; "
            "execute() must return a dmprs.adapters.Outcome whose status is a Status"))
    if outcome.status is Status.OK or not isinstance(outcome.signals, Mapping):
        problems = adapter.spec.signal_problems(outcome.signals)
        if problems:
            return Outcome(Status.ERROR, signals=_loggable(outcome.signals), executed=outcome.executed,
                           message=f"{adapter.spec.name} returned bad signals: {'; '.join(problems)}")
    return outcome


T = TypeVar("T")

class _BadOutcome(Exception):
    """An ok outcome the task cannot score."""


def _score(task: Task, desired_query: NDArray[np.float64], outcome: Outcome,
           tol: float | None) -> tuple[NDArray[np.float64], bool]:
    eps = _scoring(task, outcome, lambda: np.atleast_1d(np.asarray(task.error(desired_query, outcome),
                                                                    dtype=float)))
    if eps.shape != desired_query.shape:
        raise _BadOutcome(f"{task.name}: the error has shape {eps.shape}; the query has "
                          f"{desired_query.shape}")
    if not np.isfinite(eps).all():
        raise _BadOutcome(f"{task.name}: the measured error is not finite (eps = {eps.tolist()}); "
                          f"signals {_describe(outcome.signals)}")
    if tol is not None:
        return eps, bool(np.all(np.abs(eps) < tol))
    return eps, _scoring(task, outcome, lambda: bool(task.success(desired_query, outcome)))


def _scoring(task: Task, outcome: Outcome, score: Callable[[], T]) -> T:
    """``score()``, the task's own code; whatever it raises becomes a _BadOutcome naming it."""
    try:
        return score()
    except Exception as exc:  # noqa: BLE001 - whatever the signals did to the scoring, log it
        raise _BadOutcome(f"{task.name} cannot score the outcome ({type(exc).__name__}: {exc}); "
                          f"signals {_describe(outcome.signals)}") from None


def _scalars(signals: Mapping[str, Any]) -> dict[str, Any]:
    """The scalar signals, for the trial's log line (arrays go to its npz file)."""
    return {k: v for k, v in _loggable(signals).items() if np.ndim(v) == 0}


def _loggable(signals: Any) -> dict[str, Any]:
    """Numbers, strings and numeric arrays; anything else as its repr, so logging cannot fail."""
    if not isinstance(signals, Mapping):
        return {}
    out: dict[str, Any] = {}
    for k, v in signals.items():
        if isinstance(v, (bool, int, float, str, np.generic)):
            out[str(k)] = v.item() if isinstance(v, np.generic) else v
        else:
            arr = np.asarray(v) if isinstance(v, (list, tuple, np.ndarray)) else None
            numeric = arr is not None and arr.dtype.kind in "biuf"
            out[str(k)] = arr if numeric else repr(v)
    return out


def _describe(signals: Mapping[str, Any]) -> str:
    items = []
    for k, v in signals.items():
        text = repr(v) if np.ndim(v) == 0 else f"array of shape {np.shape(v)}"
        items.append(f"{k}={text[:40]}")
    return "{" + ", ".join(items) + "}"
