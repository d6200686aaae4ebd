"""CMA-ES (Hansen's ``cma`` package) as a one-candidate-at-a-time ask/tell learner: the black-box
optimizer users would reach for, as a baseline beside the paper's learners.

``cma`` asks and tells a whole population; the learn loops of :mod:`dmprs.loop` and
:mod:`dmprs.baselines` run one trial at a time. :class:`CMAES` hands out the population's
candidates one by one and tells ``cma`` once all of them are scored, so every executed rollout
is one trial. It minimizes

* ``feedback="error"`` (the query space, :func:`dmprs.learn`): the signed error eps (one entry per
  query dimension, docs/method.md §5.3) turned into ``sum(eps^2)``; converged when every
  ``|eps_i| < tol``;
* ``feedback="cost"`` (the weight space, :mod:`dmprs.baselines`): a scalar cost.

Deterministic: ``cma`` draws from numpy's global random state, so :class:`CMAES` keeps its own
copy of that state (seeded with ``seed``) and swaps it in only while ``cma`` samples; the same
seed gives the same candidates, whatever else uses numpy's global state in between, which is
what resuming a logged run needs.

How it fares: against PoWER and PI² in the weight space, the README's baselines table; against
the paper's learners and Bayesian optimization in the query space, docs/method.md §7.3.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dmprs._arrays import as_count, as_float_array
from dmprs._extras import require
from dmprs.candidates import CandidateLearner
from dmprs.errors import InvalidInputError

__all__ = ["CMAES"]

_FEEDBACK = ("error", "cost")


class CMAES(CandidateLearner):
    """CMA-ES from ``x0`` with step ``sigma0`` (a scalar, or one standard deviation per
    coordinate), population ``popsize`` (default cma's ``4 + 3 ln n``), at most ``max_trials``
    told trials, optional box ``lower``/``upper``. With ``first_x0=True`` the first trial is
    ``x0`` itself (the generalized query, as for the paper's learners), recorded but not part of
    a population. ``options`` are passed to ``cma.CMAEvolutionStrategy`` (e.g.
    ``{"tolflatfitness": 5}``: by default cma stops after one generation of equal costs, which a
    saturated outcome such as an over-flipped matchbox gives).
    """

    def __init__(self, x0: ArrayLike, sigma0: ArrayLike, *, seed: int = 0, popsize: int | None = None,
                 max_trials: int = 200, lower: ArrayLike | None = None, upper: ArrayLike | None = None,
                 feedback: str = "error", tol: float | None = None, first_x0: bool = False,
                 options: dict[str, Any] | None = None) -> None:
        require("cma", "dmprs.cmaes.CMAES")
        import cma

        x = np.atleast_1d(as_float_array(x0, "x0", (0, 1))).copy()
        sig = np.broadcast_to(np.atleast_1d(as_float_array(sigma0, "sigma0", (0, 1))), x.shape).copy()
        if not (np.isfinite(x).all() and np.isfinite(sig).all() and (sig > 0).all()):
            raise InvalidInputError("x0 must be finite and sigma0 finite and > 0")
        if feedback not in _FEEDBACK:
            raise InvalidInputError(f"feedback = {feedback!r} is invalid: use one of {_FEEDBACK}")
        if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
            raise InvalidInputError(f"seed = {seed!r} must be a non-negative integer")
        super().__init__(tol=tol, max_trials=max_trials)
        self._feedback = feedback
        opts: dict[str, Any] = {"seed": int(seed) + 1, "verbose": -9, "CMA_stds": sig / sig.max()}
        if popsize is not None:
            opts["popsize"] = as_count(popsize, "popsize", 2)
        opts.update(options or {})
        if lower is not None or upper is not None:
            opts["bounds"] = [None if lower is None else np.broadcast_to(as_float_array(lower, "lower", (0, 1)), x.shape).tolist(),
                              None if upper is None else np.broadcast_to(as_float_array(upper, "upper", (0, 1)), x.shape).tolist()]
        saved = np.random.get_state()
        try:
            np.random.seed(int(seed))
            self._es = cma.CMAEvolutionStrategy(x, float(sig.max()), opts)
            self._rng = np.random.get_state()
        finally:
            np.random.set_state(saved)
        self._x0 = x
        self._first = bool(first_x0)
        self._batch: list[NDArray[np.float64]] = []
        self._scores: list[float] = []

    # --- ask / tell -------------------------------------------------------------------------
    def ask(self) -> NDArray[np.float64]:
        """The next candidate (asking again before :meth:`tell` returns the same one)."""
        self._check_can_ask()
        if self._pending is None:
            if self._first:
                self._pending = self._x0.copy()
            else:
                if not self._batch or len(self._scores) == len(self._batch):
                    self._batch, self._scores = self._sample(), []
                self._pending = np.array(self._batch[len(self._scores)], dtype=np.float64)
        return self._pending.copy()

    def _sample(self) -> list[NDArray[np.float64]]:
        saved = np.random.get_state()
        try:
            np.random.set_state(self._rng)
            batch = [np.asarray(c, dtype=np.float64) for c in self._es.ask()]
            self._rng = np.random.get_state()
        finally:
            np.random.set_state(saved)
        return batch

    def tell(self, q: ArrayLike, feedback: ArrayLike) -> None:
        """Scores the candidate :meth:`ask` returned: eps (``feedback="error"``) or a cost."""
        qq = self._answered(q)
        fb = np.atleast_1d(as_float_array(feedback, "feedback", (0, 1)))
        if not np.isfinite(fb).all():
            raise InvalidInputError(f"feedback {fb.tolist()} is not finite")
        if self._feedback == "error":
            if fb.shape != qq.shape:
                raise InvalidInputError(f"eps has shape {fb.shape}; the query has {qq.shape}")
            score = float(np.sum(fb**2))
        else:
            if fb.size != 1:
                raise InvalidInputError(f"a cost is one number; got shape {fb.shape}")
            score = float(fb[0])
        if self._first:
            self._first = False
        else:
            self._scores.append(score)
            if len(self._scores) == len(self._batch):
                self._es.tell(self._batch, self._scores)
        self._record(qq, fb, score, eps=fb if self._feedback == "error" else None)
        if not self.done and len(self._scores) == len(self._batch) and self._es.stop():
            self._status, self._detail = "stopped", f"cma stopped: {dict(self._es.stop())}"

    # --- what the loops read beyond CandidateLearner's ---------------------------------------
    @property
    def popsize(self) -> int:
        """cma's population size."""
        return int(self._es.popsize)

    @property
    def dim(self) -> int:
        """The dimension of the searched vector."""
        return int(self._x0.size)

    def __repr__(self) -> str:
        return f"CMAES(dim={self.dim}, popsize={self.popsize}, status={self._status!r}, n_trials={self.n_trials})"
