"""Bayesian optimization (the ``bayesian-optimization`` package) as a one-query-at-a-time
ask/tell learner in the query space: the tuner users reach for to set a few parameters in few
trials, as a baseline beside the paper's learners.

It searches a box ``[lower, upper]`` for the query whose signed error eps (one entry per query
dimension, docs/method.md §5.3) is smallest, maximizing ``-|eps|`` with the package's own model
and acquisition: a Gaussian process with a Matérn 5/2 kernel (its hyperparameters refitted to
every trial) and the upper confidence bound. It is told the size of the error only: the sign that
the paper's learners step along is what a black-box optimizer does not use.

Like the paper's learners it starts from the generalized query q0 (the first trial), then draws
``random_starts`` uniform points in the box (the package's ``maximize`` draws 5 by default; the
learner ``"bo"`` of :mod:`dmprs.experiments` draws one, the setting that needed fewest trials when
tuned on the matchbox and pouring from 0.4 l), then asks the model.

Deterministic: every random draw (the starts, the acquisition's optimizer restarts, the kernel's
fitting restarts) comes from one ``numpy.random.RandomState(seed)`` the learner owns, so the same
seed and the same told errors give the same queries, which is what resuming a logged run needs.
"""

from __future__ import annotations

import contextlib
import io
import warnings
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dmprs._arrays import as_count, as_float_array
from dmprs._extras import require
from dmprs.candidates import CandidateLearner
from dmprs.errors import InvalidInputError
from dmprs.portable import norm

__all__ = ["BayesOpt"]


class BayesOpt(CandidateLearner):
    """Bayesian optimization from ``x0`` within ``lower``/``upper`` (one bound per query
    dimension, or a scalar for all), ``random_starts`` uniform draws after ``x0``, at most
    ``max_trials`` told trials, converged when every ``|eps_i| < tol``.
    """

    def __init__(self, x0: ArrayLike, *, lower: ArrayLike, upper: ArrayLike, seed: int = 0,
                 random_starts: int = 0, max_trials: int = 200, tol: float | None = None) -> None:
        require("bayes_opt", "dmprs.bayesopt.BayesOpt")
        from bayes_opt import BayesianOptimization

        x = np.atleast_1d(as_float_array(x0, "x0", (0, 1))).copy()
        lo = np.broadcast_to(np.atleast_1d(as_float_array(lower, "lower", (0, 1))), x.shape).copy()
        hi = np.broadcast_to(np.atleast_1d(as_float_array(upper, "upper", (0, 1))), x.shape).copy()
        if not (np.isfinite(x).all() and np.isfinite(lo).all() and np.isfinite(hi).all()):
            raise InvalidInputError("x0, lower and upper must be finite")
        if not (lo < hi).all() or not ((lo <= x) & (x <= hi)).all():
            raise InvalidInputError(f"the box [{lo.tolist()}, {hi.tolist()}] must be non-empty and hold "
                                    f"x0 = {x.tolist()}")
        if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
            raise InvalidInputError(f"seed = {seed!r} must be a non-negative integer")
        super().__init__(tol=tol, max_trials=max_trials)
        self._keys = [f"q{i:03d}" for i in range(x.size)]  # sorted like the package sorts them
        self._opt = BayesianOptimization(f=None, pbounds={k: (float(a), float(b)) for k, a, b in zip(self._keys, lo, hi, strict=True)},
                                         random_state=np.random.RandomState(int(seed)), verbose=0,
                                         allow_duplicate_points=True)
        starts = as_count(random_starts, "random_starts", 0)
        self._queue = [x.copy(), *(self._array(p) for p in self._opt.random_sample(starts))] if starts else [x.copy()]
        self._x0, self._lower, self._upper = x, lo, hi

    def _array(self, params: Any) -> NDArray[np.float64]:
        if isinstance(params, dict):
            return np.array([float(params[k]) for k in self._keys], dtype=np.float64)
        return np.asarray(params, dtype=np.float64).reshape(-1).copy()

    # --- ask / tell -------------------------------------------------------------------------
    def ask(self) -> NDArray[np.float64]:
        """The next query (asking again before :meth:`tell` returns the same one)."""
        self._check_can_ask()
        if self._pending is None:
            if self._queue:
                self._pending = self._queue.pop(0)
            else:
                with warnings.catch_warnings():
                    # the kernel's fit reaching a bound of its length scale is a note, not an error
                    warnings.simplefilter("ignore")
                    q = self._array(self._opt.suggest())
                self._pending = np.clip(q, self._lower, self._upper)
        return self._pending.copy()

    def tell(self, q: ArrayLike, feedback: ArrayLike) -> None:
        """Scores the query :meth:`ask` returned with its signed error eps."""
        qq = self._answered(q)
        eps = np.atleast_1d(as_float_array(feedback, "feedback", (0, 1)))
        if not np.isfinite(eps).all():
            raise InvalidInputError(f"eps {eps.tolist()} is not finite")
        if eps.shape != qq.shape:
            raise InvalidInputError(f"eps has shape {eps.shape}; the query has {qq.shape}")
        score = norm(eps)
        # the package prints a red "Data point ... is not unique" line for each repeated query
        with contextlib.redirect_stdout(io.StringIO()):
            self._opt.register(dict(zip(self._keys, qq.tolist(), strict=True)), -score)
        self._record(qq, eps, score, eps=eps)

    @property
    def box(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The searched box (lower, upper)."""
        return self._lower.copy(), self._upper.copy()

    def __repr__(self) -> str:
        return f"BayesOpt(dim={self._x0.size}, status={self._status!r}, n_trials={self.n_trials})"
