"""What every experiment is made of: a task, the database of its demonstrations, their
generalizer, the desired query, and the query-space learners that may learn it.

:data:`LEARNERS` is the one table of learners by name: each experiment offers some of them with
its own :class:`LearnerSettings` (search limits, scales, probe steps), and the command line's
help is written from it.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dmprs import learners as L
from dmprs._arrays import short
from dmprs._extras import require
from dmprs.bayesopt import BayesOpt
from dmprs.cmaes import CMAES
from dmprs.database import Database
from dmprs.errors import InvalidInputError
from dmprs.generalize import Generalizer
from dmprs.loop import AskTell
from dmprs.tasks.base import Task
from dmprs.trajectory import AnyTrajectory

__all__ = ["DEFAULT_LEARNER", "LEARNERS", "ExperimentSetup", "LearnerKind", "LearnerSettings", "build", "database_of", "learner_help", "search_box"]


@dataclass(frozen=True)
class LearnerSettings:
    """An experiment's choices for its learners; ``None`` leaves a learner's own default.

    ``low``/``high`` bound the bracketing learners (the demos' queries, docs/method.md §6.2 #9);
    ``weight_scale`` is eq. 17's scale (in units of eps); ``task_scale`` the scale of a step for
    the policy gradient, Broyden's trust region and, without limits, CMA-ES; ``probe`` the
    finite-difference step; ``weighted_jacobian`` the J of the weighted learner; ``cma_sigma``
    CMA-ES's first step (default: a quarter of the search range, else ``task_scale``); ``gain``
    the fixed K of the ``fixed`` learner; ``box`` the (lower, upper) search box of Bayesian
    optimization (default, set by :func:`build`: :func:`search_box` of the demos' queries).
    """

    max_trials: int = 50
    low: float | None = None
    high: float | None = None
    weight_scale: float | None = None
    task_scale: float | None = None
    probe: float | None = None
    trust_radius: float = 1.0
    weighted_jacobian: str | None = None
    cma_sigma: float | None = None
    gain: float | None = None
    box: tuple[tuple[float, ...], tuple[float, ...]] | None = None

    def bracket(self, learner: str) -> tuple[float, float]:
        """The search limits (low, high), or an error naming ``learner``, which needs them."""
        if self.low is None or self.high is None:
            raise InvalidInputError(f"the learner {learner!r} needs search limits (low, high), which this "
                                    "experiment does not have")
        return self.low, self.high


@dataclass(frozen=True)
class LearnerKind:
    """A learner by name: what it is (the command line's help) and how an experiment builds one
    from its settings, the first query q0 and the caller's options.
    """

    name: str
    summary: str
    make: Callable[[LearnerSettings, NDArray[np.float64], dict[str, Any]], AskTell]


def _cma(s: LearnerSettings, q0: NDArray[np.float64], kw: dict[str, Any]) -> AskTell:
    # From the same first trial q0; a quarter of the search range per step, within the limits.
    if s.cma_sigma is not None:
        default = s.cma_sigma
    elif s.low is not None and s.high is not None:
        default = 0.25 * (s.high - s.low)
    else:
        default = 1.0 if s.task_scale is None else s.task_scale
    sigma = kw.pop("sigma0", default)
    kw.setdefault("max_trials", s.max_trials)
    return CMAES(q0, sigma, first_x0=True, **kw)


def _bo(random_starts: int) -> Callable[[LearnerSettings, NDArray[np.float64], dict[str, Any]], AskTell]:
    def make(s: LearnerSettings, q0: NDArray[np.float64], kw: dict[str, Any]) -> AskTell:
        lower, upper = s.box if s.box is not None else search_box([], q0)
        kw.setdefault("max_trials", s.max_trials)
        kw.setdefault("random_starts", random_starts)
        return BayesOpt(q0, lower=lower, upper=upper, **kw)
    return make


def _auto(s: LearnerSettings, q0: NDArray[np.float64], kw: dict[str, Any]) -> AskTell:
    # One-dimensional queries between the demos' queries: the root finder, which needs no more
    # trials than golden section's worst case (docs/method.md §6.4) and expands a limit when the
    # root lies beyond it; otherwise (n-D, or no limits) error learning with Broyden's secant
    # estimate of J (§5.4), which needs no probe trials.
    if q0.size == 1 and s.low is not None and s.high is not None:
        kw.setdefault("max_expansions", AUTO_EXPANSIONS)
        return L.IllinoisRootFinder(q0, low=s.low, high=s.high, max_trials=s.max_trials, **kw)
    return L.ErrorLearning(q0, jacobian="secant", max_trials=s.max_trials, **kw)


def _golden(name: str, mode: str, s: LearnerSettings, q0: NDArray[np.float64], kw: dict[str, Any]) -> AskTell:
    low, high = s.bracket(name)
    return L.GoldenSection(q0, low=low, high=high, mode=mode, max_trials=s.max_trials, **kw)


def _root(s: LearnerSettings, q0: NDArray[np.float64], kw: dict[str, Any]) -> AskTell:
    low, high = s.bracket("root")
    return L.IllinoisRootFinder(q0, low=low, high=high, max_trials=s.max_trials, **kw)


def _fixed(s: LearnerSettings, q0: NDArray[np.float64], kw: dict[str, Any]) -> AskTell:
    if s.gain is None:
        raise InvalidInputError("the learner 'fixed' needs the experiment's gain K, which it does not set")
    kw.setdefault("gain", s.gain)
    kw.setdefault("max_trials", s.max_trials)
    return L.ErrorLearning(q0, **kw)


#: how often the ``auto`` learner may expand each limit (golden section's robust mode allows as many)
AUTO_EXPANSIONS = 4
#: the learner of ``dmprs learn`` and :meth:`ExperimentSetup.make_learner` when none is named
DEFAULT_LEARNER = "auto"

LEARNERS: dict[str, LearnerKind] = {k.name: k for k in (
    LearnerKind("auto", "the project's default: the root finder expanding its limits for a 1-D query, Broyden's "
                "secant for n-D", _auto),
    LearnerKind("error", "eq. 16 with K = J = I (the paper's matchbox learner)",
                lambda s, q0, kw: L.ErrorLearning(q0, max_trials=s.max_trials, **kw)),
    LearnerKind("weighted", "eq. 17: steps weighted by exp(-|eps / scale|^2)",
                lambda s, q0, kw: L.ErrorLearning(
                    q0, jacobian=kw.pop("jacobian", s.weighted_jacobian), weighted=True,
                    scale=kw.pop("scale", s.weight_scale), max_trials=s.max_trials, **kw)),
    LearnerKind("secant", "error learning with the secant (Broyden) estimate of J",
                lambda s, q0, kw: L.ErrorLearning(q0, jacobian="secant", max_trials=s.max_trials, **kw)),
    LearnerKind("finite-difference", "error learning with J from n probe trials",
                lambda s, q0, kw: L.ErrorLearning(q0, jacobian="finite-difference", delta=kw.pop("delta", s.probe),
                                                  max_trials=s.max_trials, **kw)),
    # docs/method.md §5.4: J from probes, refined by Broyden, steps in a trust region
    LearnerKind("broyden", "J from probes, Broyden's update, a trust region (docs/method.md §5.4)",
                lambda s, q0, kw: L.ErrorLearning(
                    q0, jacobian="finite-difference", delta=kw.pop("delta", s.probe), broyden=True,
                    trust_radius=kw.pop("trust_radius", s.trust_radius), scale=kw.pop("scale", s.task_scale),
                    max_trials=s.max_trials, **kw)),
    LearnerKind("golden", "golden section between the demos' queries, the paper's box (pouring)",
                lambda s, q0, kw: _golden("golden", "paper", s, q0, kw)),
    LearnerKind("golden-robust", "golden section that expands its bracket beyond the demos",
                lambda s, q0, kw: _golden("golden-robust", "robust", s, q0, kw)),
    LearnerKind("root", "the Illinois root finder on the bracket of the demos' queries", _root),
    LearnerKind("pg", "constrained-domain policy gradient, eq. 12 (every probe a trial)",
                lambda s, q0, kw: L.PolicyGradient(q0, scale=kw.pop("scale", s.task_scale),
                                                   max_trials=s.max_trials, **kw)),
    LearnerKind("cma", "CMA-ES in the query space from the same first trial (black-box baseline)", _cma),
    LearnerKind("bo", "Bayesian optimization (bayesian-optimization's GP) from the same first trial, one "
                "random trial, then the model (black-box baseline)", _bo(1)),
    LearnerKind("bo-default", "the same with the package's default of 5 random trials before the model", _bo(5)),
    LearnerKind("fixed", "eq. 16 with the experiment's fixed gain K (pouring: 1 l/l)", _fixed),
)}

#: The learners a one-dimensional experiment offers.
SCALAR_LEARNERS = ("auto", "error", "weighted", "secant", "broyden", "golden", "golden-robust", "root", "pg", "cma", "bo",
                   "bo-default")


def learner_help() -> str:
    """The command line's help for ``--learner``: every learner with what it is."""
    return "; ".join(f"{k.name}: {k.summary}" for k in LEARNERS.values())


@dataclass
class ExperimentSetup:
    """Everything :func:`dmprs.learn` needs, and the learners this experiment offers with its
    settings. ``make_learner(name)`` builds one starting from the desired query;
    ``paper_learner`` is the one the paper used for this experiment.
    """

    task: Task
    database: Database
    generalizer: Generalizer
    desired_query: NDArray[np.float64]
    paper_learner: str
    learner_names: tuple[str, ...]
    settings: LearnerSettings = field(default_factory=LearnerSettings)

    @property
    def low(self) -> float | None:
        """The lower bound of the query, or None."""
        return self.settings.low

    @property
    def high(self) -> float | None:
        """The upper bound of the query, or None."""
        return self.settings.high

    def make_learner(self, name: str | None = None, q0: ArrayLike | None = None, **options: Any) -> AskTell:
        """The learner ``name`` (default: :data:`DEFAULT_LEARNER`) from ``q0`` (default: the
        desired query), with ``options`` passed on to its class.
        """
        name = name or DEFAULT_LEARNER
        if name not in self.learner_names:
            raise InvalidInputError(
                f"unknown learner {name!r} for {self.task.name}; choose from {', '.join(sorted(self.learner_names))}")
        start = self.desired_query if q0 is None else self.task.validate_query(q0, "q0")
        return LEARNERS[name].make(self.settings, start, dict(options))


def ros2_domain(robot: Any, domain_id: Any) -> int | None:
    """The ROS 2 domain of a robot option: ``robot = "ros2"`` (a served or real robot, through the
    ``ros2`` extra) on ``domain_id`` (None: ``ROS_DOMAIN_ID``'s, else 0); None for ``"sim"`` (the
    scene in this process).
    """
    if robot == "sim":
        return None
    if robot != "ros2":
        raise InvalidInputError(f"robot = {short(robot)} is invalid: use 'sim' or 'ros2'")
    require("cyclonedds", "robot='ros2'")
    from dmprs.ros2.names import domain_id as resolved  # the ros2 extra's, known to be there now

    return resolved(domain_id)


def search_box(queries: Iterable[ArrayLike], q0: ArrayLike) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """The box a black-box optimizer searches: the smallest box holding the demos' ``queries``
    and the desired query ``q0`` (which may lie beyond the demos, as the matchbox's pi/2 does with
    both demos flipped back), widened by a tenth of its extent on each side (a throw beyond the
    demos' landings asks a little beyond its basket; much wider boxes ask for bottles of no volume
    or throws faster than the arm's joints allow). A zero extent is taken as 1 (the query's unit).
    """
    points = np.array([np.atleast_1d(np.asarray(q, dtype=np.float64)) for q in (*queries, q0)])
    lo, hi = points.min(axis=0), points.max(axis=0)
    margin = np.where(hi > lo, 0.1 * (hi - lo), 1.0)
    return tuple((lo - margin).tolist()), tuple((hi + margin).tolist())


def database_of(task: Task, demos: Iterable[tuple[ArrayLike, AnyTrajectory]]) -> Database:
    """The database of ``task``'s demonstrations ``(query, trajectory)``, with its query names
    and units.
    """
    db = Database(query_names=task.query_names, query_units=task.query_units)
    for query, trajectory in demos:
        db.add(query, trajectory)
    return db


def build(task: Task, demos: Callable[[], Iterable[tuple[ArrayLike, AnyTrajectory]]], desired_query: ArrayLike, *,
          generalizer: dict[str, Any], paper_learner: str, learner_names: tuple[str, ...],
          settings: LearnerSettings, desired_name: str = "desired_query") -> ExperimentSetup:
    """The one way from a task's demonstrations to an experiment: their database, its
    generalizer (``Generalizer(db, **generalizer)``) and the desired query. The task checks the
    desired query first, under the caller's name for it, and only then are the demonstrations
    asked for (``demos()``): a refusal costs no demonstration.
    """
    desired = task.validate_query(desired_query, desired_name)
    db = database_of(task, demos())
    if settings.box is None:
        settings = dataclasses.replace(settings, box=search_box(db.queries, desired))
    return ExperimentSetup(task, db, Generalizer(db, **generalizer), desired, paper_learner, learner_names,
                           settings)
