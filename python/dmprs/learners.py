r"""Ask/tell learners: in the query space (Nemec, Vuga, Ude 2013) and, as baselines, in the full
DMP weight space.

Every learner has the shape of cma, optuna and nevergrad::

    learner = dmprs.learners.GoldenSection(0.5, low=0.3, high=1.0)
    while not learner.done:
        q = learner.ask()                 # 1-D float64 array: the query to execute next
        eps = run_trial(q)                # one physical trial
        learner.tell(q, eps)              # q must be the array ask() returned
    learner.best.q                        # the best executed query

Query learners (:class:`ErrorLearning`, :class:`GoldenSection`, :class:`IllinoisRootFinder`,
:class:`PolicyGradient`) are told the signed error ``eps = q0 - q_a`` (paper eq. 13), one
entry per query dimension, with the sign convention of docs/method.md §5.3:

    **eps > 0 means the query must increase.**

For a task outcome ``y`` with target ``y*`` that is ``eps = s * (y* - y)`` with
``s = sign(dy/dq)``: ``+1`` for the matchbox (the query is the outcome-angle label, so
``eps = pi/2 - phi``, the negative of the paper's eq. 18), ``-1`` for pouring (a larger assumed
bottle volume pours less: ``eps = V_poured - V*``). With the wrong sign every learner walks away
from the root; with search limits it stops with ``status == "hit-bound"`` instead of looping.

The baselines are told per rollout: :class:`PoWER` a return ``R > 0`` (maximized), :class:`PI2`
a cost (minimized), one terminal cost or one per time step.

All learners: ``ask()`` twice without ``tell`` returns the same query; ``tell`` without a pending
``ask``, or of another query, raises :class:`~dmprs.errors.LearnerStateError`; so does ``ask``
after the learner stopped. NaN, inf or a wrong number of entries raise
:class:`~dmprs.errors.InvalidInputError`. Queries come back as 1-D float64 arrays, also for the
scalar learners (so that one learn loop serves all of them); a Python float is accepted wherever
a one-entry query or error is expected.

Every query learner is built as ``Learner(q0, *, low=None, high=None, ...)`` with ``q0`` a float
or a 1-D array (the bracketing learners :class:`GoldenSection` and :class:`IllinoisRootFinder`
require ``low`` and ``high``); the baselines as ``Baseline(theta0, sigma, *, seed=None, ...)``. An
option left at ``None`` takes the default of the learner's configuration in the Rust core
(``crates/learners``, e.g. ``ErrorLearningConfig::default``), which also validates every value.

Common properties: ``status`` (``"running"``, ``"converged"``, ``"bracketed"``,
``"trial-cap"``, ``"hit-bound"``, ``"diverged"``), ``status_detail``, ``done``, ``converged``,
``best`` and ``history`` (:class:`Trial` tuples), ``n_trials``. A learner never asks a
non-finite query: when a step, a gain or a return overflows it stops with ``"diverged"``.
"""

from __future__ import annotations

import numbers
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dmprs import _core as _native
from dmprs._arrays import as_count, as_float_array, short
from dmprs.errors import InvalidInputError

__all__ = [
    "PI2",
    "ErrorLearning",
    "GoldenSection",
    "IllinoisRootFinder",
    "PoWER",
    "PolicyGradient",
    "Trial",
]


class Trial(NamedTuple):
    """One executed trial: the query (or weight vector), what was told about it, and the
    learner's figure of merit (lower is better: max |eps_i| for query learners, the total cost for
    PI², ``-R`` for PoWER).
    """

    q: NDArray[np.float64]
    feedback: NDArray[np.float64]
    score: float


# Conversions only: types and shapes become what the core takes. The core validates the values
# (finite, positive, low < high, ...) and holds the defaults (None: the default).


def _vector(value: Any, name: str) -> NDArray[np.float64]:
    """A scalar or 1-D array as a 1-D float64 array."""
    return np.atleast_1d(as_float_array(value, name, (0, 1)))


def _optional_vector(value: Any, name: str, n: int) -> NDArray[np.float64] | None:
    """None, or a 1-D array; a scalar is repeated for all ``n`` dimensions."""
    if value is None:
        return None
    v = _vector(value, name)
    if v.shape == (1,) and n > 1:
        v = np.full(n, v[0])
    return v


def _matrix(value: Any, name: str) -> float | NDArray[np.float64]:
    """A scalar (times I), a diagonal (n,) or an (n, n) matrix."""
    m = as_float_array(value, name, (0, 1, 2))
    return float(m.reshape(-1)[0]) if np.ndim(value) == 0 else m


def _real(value: Any, name: str) -> float | None:
    if value is None:
        return None
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise InvalidInputError(f"{name} must be a real number; got {short(value)}")
    try:
        return float(value)
    except OverflowError:
        raise InvalidInputError(f"{name} = {short(value)} does not fit a 64-bit float") from None


def _count(value: Any, name: str) -> int | None:
    """None, or a non-negative integer the core can hold (< 2**64)."""
    if value is None:
        return None
    n = as_count(value, name, 0)
    if n >= 2**64:
        raise InvalidInputError(f"{name} = {n} is invalid: must be < 2**64")
    return n


def _text(value: Any, name: str) -> str | None:
    if value is None or isinstance(value, str):
        return value
    raise InvalidInputError(f"{name} must be a string; got {value!r}")


def _flag(value: Any, name: str) -> bool | None:
    if value is None:
        return None
    if not isinstance(value, (bool, np.bool_)):
        raise InvalidInputError(f"{name} must be True or False; got {value!r}")
    return bool(value)


class _Learner:
    """The ask/tell interface shared by every learner (see the module docs)."""

    __slots__ = ("_core",)
    _core: _native._AskTell
    _feedback_name = "eps"

    def ask(self) -> NDArray[np.float64]:
        """The next query (1-D float64) to execute. Asking again before :meth:`tell` returns
        the same query.
        """
        return self._core.ask()

    def tell(self, q: ArrayLike, feedback: ArrayLike) -> None:
        """Reports the outcome of executing ``q``, the query :meth:`ask` returned."""
        self._core.tell(_vector(q, "q"), _vector(feedback, self._feedback_name))

    @property
    def status(self) -> str:
        """``"running"``, ``"converged"``, ``"bracketed"``, ``"trial-cap"``, ``"hit-bound"`` or
        ``"diverged"``.
        """
        return self._core.status

    @property
    def status_detail(self) -> str:
        """The status with its detail, e.g. which limit was hit."""
        return self._core.status_detail

    @property
    def done(self) -> bool:
        """True once the learner has stopped (any status but ``"running"``)."""
        return self._core.status != "running"

    @property
    def converged(self) -> bool:
        """True when a trial met the tolerance (``status == "converged"``)."""
        return self._core.converged

    @property
    def best(self) -> Trial | None:
        """The executed trial with the lowest score (None before the first tell). When
        converged it is the last executed trial (docs/method.md §6.2 fix 2).
        """
        b = self._core.best
        return None if b is None else Trial(*b)

    @property
    def history(self) -> list[Trial]:
        """Every told trial, in order."""
        return [Trial(*t) for t in self._core.history]

    @property
    def n_trials(self) -> int:
        """Trials told so far (every executed trial counts, probes and perturbations too)."""
        return self._core.n_told

    @property
    def dim(self) -> int:
        """The length of the query vectors."""
        return self._core.dim

    def __repr__(self) -> str:
        return f"{type(self).__name__}(dim={self.dim}, status={self.status!r}, n_trials={self.n_trials})"


class ErrorLearning(_Learner):
    r"""Error learning in the query space, paper eqs. 16 and 17 (docs/method.md §5).

    ::

        q_{m+1} = q_m + w_m K J^{-1} eps_m
        w_m = 1                       (eq. 16, weighted=False)
        w_m = exp(-||eps_m/scale||^2) (eq. 17, weighted=True; scale in units of eps)

    ``gain`` is eq. 16's K: a scalar (times I), a diagonal ``(n,)`` or an ``(n, n)`` matrix.
    ``jacobian`` is the estimate J of dq_a/dq that turns the step into a Newton step:

    * ``"identity"`` — J = I: the paper's matchbox setting (K = I).
    * ``"secant"`` — secant slope (n = 1) / Broyden update (n > 1), starting from I.
    * ``"finite-difference"`` — J from trials at q0 + delta e_j after the first trial at q0
      (n extra trials, docs/method.md §5.2 item 4).
    * an ``(n, n)`` array (a scalar for n = 1) — a fixed J.

    With ``broyden=True`` any starting J (a fixed one, or the finite differences) is refined by
    Broyden's update from every later trial (``"secant"`` always is). ``trust_radius`` (in
    units of ``scale``) holds every step inside a trust region that doubles after a trial that
    reduced ||eps|| (up to 10x its start) and halves after one that did not, the next step then
    starting from the best trial: the step control for maps far from linear (docs/method.md §5.4).

    Estimated J's must have a positive symmetric part and singular values in [0.1, 10], else I
    is used (the §5.2 safeguard). ``low``/``high`` (scalars or ``(n,)``) clip the queries; after
    ``pin_limit`` trials pinned at a limit with eps pointing past it the learner stops with
    ``"hit-bound"``. Without limits a run whose |eps| keeps growing stops with ``"diverged"``.
    Converged when every ``|eps_i| < tol``. The first trial is q0 (the pure generalization).
    """

    __slots__ = ()
    _core: _native.ErrorLearning

    def __init__(
        self,
        q0: ArrayLike,
        *,
        low: ArrayLike | None = None,
        high: ArrayLike | None = None,
        gain: ArrayLike | None = None,
        weighted: bool | None = None,
        scale: float | None = None,
        jacobian: str | ArrayLike | None = None,
        delta: float | None = None,
        tol: float | None = None,
        max_trials: int | None = None,
        pin_limit: int | None = None,
        broyden: bool | None = None,
        trust_radius: float | None = None,
    ) -> None:
        q = _vector(q0, "q0")
        n = q.shape[0]
        self._core = _native.ErrorLearning(
            q,
            low=_optional_vector(low, "low", n),
            high=_optional_vector(high, "high", n),
            gain=None if gain is None else _matrix(gain, "gain"),
            weighted=_flag(weighted, "weighted"),
            scale=_real(scale, "scale"),
            jacobian=jacobian if jacobian is None or isinstance(jacobian, str) else _matrix(jacobian, "jacobian"),
            delta=_real(delta, "delta"),
            tol=_real(tol, "tol"),
            max_trials=_count(max_trials, "max_trials"),
            pin_limit=_count(pin_limit, "pin_limit"),
            broyden=_flag(broyden, "broyden"),
            trust_radius=_real(trust_radius, "trust_radius"),
        )

    @property
    def jacobian(self) -> NDArray[np.float64]:
        """The current estimate J of dq_a/dq, ``(n, n)``."""
        return self._core.jacobian


class GoldenSection(_Learner):
    r"""Golden-section error learning for a scalar query (the paper's algorithm box,
    docs/method.md §6).

    Each trial moves 61.8 % of the way from q towards the limit sign(eps) points to::

        if eps > 0: q_l = q; q = q_l + 0.618 (q_h - q_l)
        else:       q_h = q; q = q_l + 0.382 (q_h - q_l)

    ``mode="paper"``: the box plus the fixes of §6.2 — stop on ``|eps| < tol``, the answer is the
    last *executed* query (``best``), ``max_trials``. q0 outside [low, high] is kept as the paper
    has it (the bracket can invert). ``mode="robust"``: also widens [low, high] to contain q0,
    expands a limit no trial has confirmed when a trial lands within 5 % (of the initial width)
    of it (the k-th expansion adds 1.618**k times the initial width; at most ``max_expansions``
    per side, then ``"hit-bound"``), and stops with ``"bracketed"`` when the bracket is narrower
    than ``q_tol`` (default 1e-4 (high - low)), e.g. when eps jumps across zero (paper
    Fig. 2c). Both modes stop with ``"hit-bound"`` once the bracket has collapsed onto a limit no
    trial confirmed (wrong sign convention, or a root outside the limits).

    ``noise`` (the standard deviation of a reading of eps, in eps units; off by default, either
    mode) guards the bracket against a noisy sign (docs/method.md §6.5): a reading with
    ``|eps| < 2 noise`` is repeated at the same q (up to ``max_repeats`` readings, default 3) and
    the sign of their mean moves the limit; and after 3 readings of one sign in a row the limit
    they point to is tried again, as is a limit a stop would rest on, and re-opened to the one
    it replaced if the new reading contradicts it (``reopened`` counts these). One wrong sign
    then costs trials, not the run.
    """

    __slots__ = ()
    _core: _native.GoldenSection

    def __init__(
        self,
        q0: ArrayLike,
        *,
        low: ArrayLike | None = None,
        high: ArrayLike | None = None,
        mode: str | None = None,
        tol: float | None = None,
        q_tol: float | None = None,
        max_trials: int | None = None,
        max_expansions: int | None = None,
        noise: float | None = None,
        max_repeats: int | None = None,
    ) -> None:
        self._core = _native.GoldenSection(
            _vector(q0, "q0"),
            low=_optional_vector(low, "low", 1),
            high=_optional_vector(high, "high", 1),
            mode=_text(mode, "mode"),
            tol=_real(tol, "tol"),
            q_tol=_real(q_tol, "q_tol"),
            max_trials=_count(max_trials, "max_trials"),
            max_expansions=_count(max_expansions, "max_expansions"),
            noise=_real(noise, "noise"),
            max_repeats=_count(max_repeats, "max_repeats"),
        )

    @property
    def bracket(self) -> tuple[float, float]:
        """The current search limits (q_l, q_h)."""
        return self._core.bracket

    @property
    def reopened(self) -> int:
        """How many limits the noise guard re-opened (0 without ``noise``)."""
        return self._core.reopened


class IllinoisRootFinder(_Learner):
    r"""A superlinear bracketing root finder for a scalar query, beyond the paper: a drop-in
    replacement for :class:`GoldenSection` (same first trial q0, same limits, same eps).

    With both ends of the bracket tried it takes the regula-falsi point with the Illinois
    modification; while one end is still an untried limit it takes the eq. 16 step with K = I
    (a secant slope once two trials give one). Every candidate is projected so that the bracket
    after the m-th trial is no wider than ``W1 * 0.618**(m-1)``, golden section's worst case from
    the same first trial: it never needs more trials than golden section does in the worst case
    (a property test checks this on random monotone maps), and far fewer on smooth maps.
    Stops on ``|eps| < tol``, a bracket narrower than ``q_tol`` (``"bracketed"``, or
    ``"hit-bound"`` when an end is an untried limit), or ``max_trials``. [low, high] is widened
    to contain q0. With ``max_expansions`` > 0 a limit no trial confirmed is moved outwards when a
    trial next to it says the root lies beyond it, as :class:`GoldenSection`'s robust mode does
    (at most that many times per side; docs/method.md §6.4).
    """

    __slots__ = ()
    _core: _native.IllinoisRootFinder

    def __init__(
        self,
        q0: ArrayLike,
        *,
        low: ArrayLike | None = None,
        high: ArrayLike | None = None,
        tol: float | None = None,
        q_tol: float | None = None,
        max_trials: int | None = None,
        max_expansions: int | None = None,
    ) -> None:
        self._core = _native.IllinoisRootFinder(
            _vector(q0, "q0"),
            low=_optional_vector(low, "low", 1),
            high=_optional_vector(high, "high", 1),
            tol=_real(tol, "tol"),
            q_tol=_real(q_tol, "q_tol"),
            max_trials=_count(max_trials, "max_trials"),
            max_expansions=_count(max_expansions, "max_expansions"),
        )

    @property
    def bracket(self) -> tuple[float, float]:
        """The current bracket (a, b)."""
        return self._core.bracket

    @property
    def expansions(self) -> tuple[int, int]:
        """How often the lower and the upper limit were expanded."""
        return self._core.expansions


class PolicyGradient(_Learner):
    r"""Constrained-domain policy gradient, paper eq. 12 (docs/method.md §4), with central finite
    differences::

        J(q)    = ||eps(q) / scale||^2                       (the cost of reward (1), eq. 14)
        g_i     = (J(q + delta e_i) - J(q - delta e_i)) / (2 delta)
        q_{m+1} = q_m - alpha_m g,  alpha_m = alpha0 / (m + 1)**decay    (Robbins-Monro)

    Each update executes the centre q_m (if ``evaluate_center``; the first is q0) and the 2n
    perturbed queries; **every one is a trial** and is asked and told like any other. ``tell``
    takes eps, as for the other query learners, and the learner forms J itself, so it drops into
    the same loop. ``alpha0`` defaults to ``scale**2 / 2`` (a Newton step on q_a = q), ``delta``
    to ``0.05 * scale``. Converged when a told query has every ``|eps_i| < tol``.
    """

    __slots__ = ()
    _core: _native.PolicyGradient

    def __init__(
        self,
        q0: ArrayLike,
        *,
        low: ArrayLike | None = None,
        high: ArrayLike | None = None,
        alpha0: float | None = None,
        delta: float | None = None,
        scale: float | None = None,
        decay: float | None = None,
        evaluate_center: bool | None = None,
        tol: float | None = None,
        max_trials: int | None = None,
        pin_limit: int | None = None,
    ) -> None:
        q = _vector(q0, "q0")
        n = q.shape[0]
        self._core = _native.PolicyGradient(
            q,
            low=_optional_vector(low, "low", n),
            high=_optional_vector(high, "high", n),
            alpha0=_real(alpha0, "alpha0"),
            decay=_real(decay, "decay"),
            delta=_real(delta, "delta"),
            scale=_real(scale, "scale"),
            evaluate_center=_flag(evaluate_center, "evaluate_center"),
            tol=_real(tol, "tol"),
            max_trials=_count(max_trials, "max_trials"),
            pin_limit=_count(pin_limit, "pin_limit"),
        )

    @property
    def center(self) -> NDArray[np.float64]:
        """The current iterate q_m."""
        return self._core.center


def _weights(theta0: Any) -> tuple[NDArray[np.float64], int | None]:
    """A flat weight vector; a (D, N) array is flattened in C order (theta[d*N + j])."""
    t = as_float_array(theta0, "theta0", (1, 2))
    if t.ndim == 2:
        return np.ascontiguousarray(t.reshape(-1)), t.shape[0]
    return t, None


class PoWER(_Learner):
    r"""PoWER over a flat DMP weight vector (Kober & Peters; docs/method.md §7.1), a baseline the
    paper cites but does not report numbers for.

    ``ask()`` returns ``theta_i = mean + N(0, diag(sigma**2))``; ``tell(theta, R)`` takes the
    rollout's return ``R > 0`` (maximized; e.g. ``R = exp(-(eps/s)**2)``). After every rollout
    the mean moves to the return-weighted average of the ``n_best`` best rollouts so far
    (importance sampling, each weighted by its inverse sampling variance); with
    ``adapt_variance`` the exploration variance follows the best ``variance_window`` rollouts,
    clipped to [0.1, 10] x sigma**2. Converged when a return reaches ``target_return``.
    Deterministic for a ``seed``. ``theta0`` may be the ``(D, N)`` weights of a DMP; queries are
    always flat (C order).
    """

    __slots__ = ()
    _core: _native.PoWER
    _feedback_name = "return"

    def __init__(
        self,
        theta0: ArrayLike,
        sigma: ArrayLike,
        *,
        seed: int | None = None,
        n_best: int | None = None,
        adapt_variance: bool | None = None,
        variance_window: int | None = None,
        target_return: float | None = None,
        max_trials: int | None = None,
    ) -> None:
        t, _ = _weights(theta0)
        self._core = _native.PoWER(
            t,
            _vector(sigma, "sigma"),
            seed=_count(seed, "seed"),
            n_best=_count(n_best, "n_best"),
            adapt_variance=_flag(adapt_variance, "adapt_variance"),
            variance_window=_count(variance_window, "variance_window"),
            target_return=_real(target_return, "target_return"),
            max_trials=_count(max_trials, "max_trials"),
        )

    @property
    def mean(self) -> NDArray[np.float64]:
        """The current mean weight vector."""
        return self._core.mean

    @property
    def variance(self) -> NDArray[np.float64]:
        """The current exploration variance per weight."""
        return self._core.variance


class PI2(_Learner):
    r"""PI² over a flat DMP weight vector (Theodorou, Buchli, Schaal 2010; docs/method.md §7.2), a
    baseline the paper cites but does not report numbers for.

    Each update asks one noiseless evaluation rollout (theta itself) and then ``n_rollouts``
    noisy ones (``n_rollouts - n_reuse`` after the first update: the ``n_reuse`` cheapest of the
    previous batch are reused). The noise is constant during a rollout and annealed linearly,
    ``sigma * max(0.1, (n_updates - u) / n_updates)``. ``tell(theta, costs)`` takes one terminal
    cost or ``n_steps`` costs r_0..r_{T-1} per time step (minimized). The update weights the
    rollouts by ``exp(-h * normalized cost-to-go)`` per time step, projects the noise on the
    basis vector g_i of paper eq. 4 (``projection=True``) and averages over time with weights
    ``(T - i) * Psi_j``; the basis is that of an ``n_dof`` x N DMP (``alpha_x``,
    ``width_factor``) sampled at T phases from 1 to exp(-alpha_x). With a terminal-only cost and
    ``projection=False`` this is exactly PI^BB, ``theta += sum_k P_k eps_k``. Converged when an
    evaluation rollout's total cost is <= ``cost_tol``. Deterministic for a ``seed``.
    ``theta0`` may be ``(D, N)`` weights (then ``n_dof = D``); queries are always flat (C order).
    """

    __slots__ = ()
    _core: _native.PI2
    _feedback_name = "costs"

    def __init__(
        self,
        theta0: ArrayLike,
        sigma: ArrayLike,
        *,
        seed: int | None = None,
        n_rollouts: int | None = None,
        n_reuse: int | None = None,
        h: float | None = None,
        n_updates: int | None = None,
        n_dof: int | None = None,
        n_steps: int | None = None,
        alpha_x: float | None = None,
        width_factor: float | None = None,
        projection: bool | None = None,
        cost_tol: float | None = None,
        max_trials: int | None = None,
    ) -> None:
        t, d = _weights(theta0)
        n_dof = _count(n_dof, "n_dof")
        if n_dof is None:
            n_dof = d
        elif d is not None and n_dof != d:
            raise InvalidInputError(f"n_dof = {n_dof} does not match theta0 of shape ({d}, {t.size // d})")
        self._core = _native.PI2(
            t,
            _vector(sigma, "sigma"),
            seed=_count(seed, "seed"),
            n_rollouts=_count(n_rollouts, "n_rollouts"),
            n_reuse=_count(n_reuse, "n_reuse"),
            h=_real(h, "h"),
            n_updates=_count(n_updates, "n_updates"),
            n_dof=n_dof,
            n_steps=_count(n_steps, "n_steps"),
            alpha_x=_real(alpha_x, "alpha_x"),
            width_factor=_real(width_factor, "width_factor"),
            projection=_flag(projection, "projection"),
            cost_tol=_real(cost_tol, "cost_tol"),
            max_trials=_count(max_trials, "max_trials"),
        )

    @property
    def theta(self) -> NDArray[np.float64]:
        """The current weight vector."""
        return self._core.theta

    @property
    def n_updates_done(self) -> int:
        """PI² updates completed."""
        return self._core.n_updates_done

    @property
    def asked_evaluation(self) -> bool:
        """Whether the query :meth:`ask` returned last is an update's noiseless evaluation
        rollout of the current theta (success is judged on those), not an exploration one.
        """
        return self._core.asked_evaluation
