"""What every black-box optimizer shares as a one-candidate-at-a-time learner of the learn loops
(:mod:`dmprs.loop`, :mod:`dmprs.baselines`): the pending query that ``tell`` must answer, the
told trials and why the learner stopped. :class:`dmprs.cmaes.CMAES` and
:class:`dmprs.bayesopt.BayesOpt` add how they choose the next candidate.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dmprs._arrays import as_count, as_float_array, as_scalar
from dmprs.errors import LearnerStateError
from dmprs.learners import Trial

__all__ = ["CandidateLearner"]


class CandidateLearner:
    """The state of an ask/tell learner with at most one candidate out at a time: at most
    ``max_trials`` told trials, converged when every ``|eps_i| < tol`` (with ``tol`` given).
    """

    def __init__(self, *, tol: float | None, max_trials: int) -> None:
        self._tol = None if tol is None else as_scalar(tol, "tol", positive=True)
        self._max_trials = as_count(max_trials, "max_trials", 1)
        self._pending: NDArray[np.float64] | None = None
        self._history: list[Trial] = []
        self._status = "running"
        self._detail = "running"

    def _check_can_ask(self) -> None:
        if self.done:
            raise LearnerStateError(f"{type(self).__name__} has stopped ({self._detail}); ask() after done")

    def _answered(self, q: ArrayLike) -> NDArray[np.float64]:
        """``q`` as the pending candidate it must be (what ``tell`` answers)."""
        if self._pending is None:
            raise LearnerStateError("tell() without a pending ask()")
        qq = np.atleast_1d(as_float_array(q, "q", (0, 1)))
        if qq.shape != self._pending.shape or not np.array_equal(qq, self._pending):
            raise LearnerStateError(f"tell() of {qq.tolist()}, but the pending query is {self._pending.tolist()}")
        return qq

    def _record(self, q: NDArray[np.float64], feedback: NDArray[np.float64], score: float, *,
                eps: NDArray[np.float64] | None) -> None:
        """Keeps a told trial and stops on success (every ``|eps_i| < tol``; ``eps`` None: the
        feedback is no error) or at the trial cap.
        """
        self._history.append(Trial(q.copy(), feedback.copy(), score))
        self._pending = None
        if eps is not None and self._tol is not None and np.all(np.abs(eps) < self._tol):
            self._status, self._detail = "converged", f"converged: every |eps| < {self._tol:g}"
        elif len(self._history) >= self._max_trials:
            self._status, self._detail = "trial-cap", f"trial cap of {self._max_trials} reached"

    # --- what the loops read ----------------------------------------------------------------
    @property
    def done(self) -> bool:
        """Whether it stopped: it asks nothing more."""
        return self._status != "running"

    @property
    def converged(self) -> bool:
        """Whether a told trial succeeded."""
        return self._status == "converged"

    @property
    def status(self) -> str:
        """``running``, ``converged``, ``trial-cap``, or a reason of the optimizer's own."""
        return self._status

    @property
    def status_detail(self) -> str:
        """Why it stopped, in words."""
        return self._detail

    @property
    def history(self) -> list[Trial]:
        """Every told trial, in order."""
        return list(self._history)

    @property
    def best(self) -> Trial | None:
        """The told trial with the lowest score, or None before any."""
        return min(self._history, key=lambda t: t.score) if self._history else None

    @property
    def n_trials(self) -> int:
        """How many trials were told."""
        return len(self._history)
