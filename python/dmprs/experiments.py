"""Ready-made learning experiments: a task, its demonstration database, a generalizer and a
learner, wired together the way the paper does it. The CLI (``dmprs learn``) runs these.

Each experiment is an :class:`ExperimentSetup` factory; :data:`SETUPS` lists them all by the name
the CLI uses (``dmprs learn NAME``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from dmprs.errors import InvalidInputError
from dmprs.loop import LearningResult, learn
from dmprs.tasks.base import Task

if TYPE_CHECKING:
    from dmprs.tasks.noise import Noise


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
    #: search limits for bracketing learners (the demos' queries, docs/method.md §6.2 #9)
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

    def bracket() -> dict[str, Any]:
        if low is None or high is None:
            raise InvalidInputError("this learner needs search limits (low, high)")
        return {"low": low, "high": high}

    return {
        "error": lambda q0, **kw: L.ErrorLearning(q0, max_trials=max_trials, **kw),
        "weighted": lambda q0, **kw: L.ErrorLearning(q0, weighted=True, scale=scale, max_trials=max_trials, **kw),
        "secant": lambda q0, **kw: L.ErrorLearning(q0, jacobian="secant", max_trials=max_trials, **kw),
        # the n-D learner of docs/method.md §5.4 (J from probes, Broyden, a trust region of
        # one task scale), here on scalar queries beside the scalar learners
        "broyden": lambda q0, **kw: L.ErrorLearning(q0, jacobian="finite-difference", broyden=True, trust_radius=1.0,
                                                    scale=scale, max_trials=max_trials, **kw),
        "golden": lambda q0, **kw: L.GoldenSection(q0, **bracket(), mode="paper", max_trials=max_trials, **kw),
        "golden-robust": lambda q0, **kw: L.GoldenSection(q0, **bracket(), mode="robust", max_trials=max_trials, **kw),
        "root": lambda q0, **kw: L.IllinoisRootFinder(q0, **bracket(), max_trials=max_trials, **kw),
        # constrained-domain policy gradient (eq. 12): finite differences in q, every trial counted
        "pg": lambda q0, **kw: L.PolicyGradient(q0, scale=scale, max_trials=max_trials, **kw),
        # black-box baseline (dmprs.cmaes): from the same first trial q0, step a quarter of the
        # search range (or ``scale``), within the search limits when there are any
        "cma": lambda q0, **kw: _cma(q0, low, high, scale, max_trials, **kw),
    }


def _cma(q0: NDArray[np.float64], low: float | None, high: float | None, scale: float, max_trials: int,
         **kw: Any) -> Any:
    from dmprs.cmaes import CMAES

    sigma = kw.pop("sigma0", 0.25 * (high - low) if low is not None and high is not None else scale)
    kw.setdefault("max_trials", max_trials)
    return CMAES(q0, sigma, first_x0=True, **kw)


# --- the analytic task ------------------------------------------------------------------------

def analytic_setup(noise: float | Noise = 0.0, tol: float = 0.01, desired: float = 1.5,
                   amplitudes: tuple[float, float] = (0.5, 2.5), execution_noise: float = 0.0) -> ExperimentSetup:
    """Two demonstrations (bumps of the given amplitudes, labelled with their outcomes), linear
    generalization, desired outcome ``desired``."""
    from dmprs.database import Database
    from dmprs.generalize import Generalizer
    from dmprs.tasks.analytic import AnalyticTask

    task = AnalyticTask(noise=noise, tol=tol, execution_noise=execution_noise)
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


# --- pouring (paper section 5, docs/method.md §9) --------------------------------------------

#: Gain of the "fixed" learner for pouring, in litres of assumed volume per litre of poured
#: error: K = 1 l/l is eq. 16 with K = I, untuned and the same at every volume, which is what the
#: paper's fixed-gain attempt did. Its contraction per trial is 1 - K |dV_poured/dq|, and the
#: slope |dV_poured/dq| measured in the simulation is ~0.4 l/l near 0.4-0.5 l but ~0.65 l/l near
#: 0.7 l: one gain gives different learning rates at different volumes (lower volumes would need
#: higher gains, as the paper reports), which golden section avoids. Pass ``fixed_gain`` to try
#: others (the Newton gain 1/|slope| is ~2-2.5 l/l here).
POURING_FIXED_GAIN = 1.0


def pouring_setup(bottle_volume: float = 0.5, target_volume: float = 0.2, tol: float = 0.010,
                  liquid_seed: int = 0, demo_seed: int = 0, fixed_gain: float = POURING_FIXED_GAIN,
                  reseed_liquid: bool = False, cache_dir: str | None = None, noise: Any = None) -> ExperimentSetup:
    """Pour ``target_volume`` (0.2 l) from a bottle holding ``bottle_volume`` l (docs/method.md §9).

    Two scripted demonstrations pour ``target_volume`` from bottles of 0.3 l and 1.0 l (their
    queries are those volumes; their peak tilts are calibrated in the simulation with the liquid
    of ``demo_seed``, and cached, see :func:`dmprs.tasks.pouring.calibrate_peak_tilt`);
    linear generalization with N = 40 kernels; the desired query is the true ``bottle_volume``.
    Learners: ``golden`` (default, the paper's choice, paper mode, bracket [0.3, 1.0] l),
    ``fixed`` (eq. 16 with the scalar gain ``fixed_gain`` in l/l) and the generic query learners
    (``error``, ``weighted`` with scale 0.05 l, ``secant``, ``golden-robust``, ``root``).
    ``noise``: a :class:`dmprs.tasks.noise.Noise` for the trials (the demonstrations stay exact).
    """
    from dmprs.database import Database
    from dmprs.generalize import Generalizer
    from dmprs.tasks.pouring import DEMO_VOLUMES, Pouring, demonstration

    task = Pouring(bottle_volume, target_volume=target_volume, tol=tol,
                   liquid_seed=liquid_seed, reseed_liquid=reseed_liquid, noise=noise)
    gain = float(fixed_gain)
    if not (np.isfinite(gain) and gain > 0):
        raise InvalidInputError(f"fixed_gain = {fixed_gain!r} must be > 0 l/l")
    db = Database(query_names=task.query_names, query_units=task.query_units)
    for volume in DEMO_VOLUMES:
        query, traj, _ = demonstration(volume, task.target_volume, liquid_seed=demo_seed,
                                       cache_dir=cache_dir)
        db.add(query, traj)
    gen = Generalizer(db, method="linear", n_basis=40)
    low, high = min(DEMO_VOLUMES), max(DEMO_VOLUMES)  # the demos' queries (docs/method.md §6.2 #9)
    learners = query_learners(low, high, scale=0.05)  # eq. 17's scale for litres (docs/method.md §5.1)

    def fixed(q0: NDArray[np.float64], **kw: Any) -> Any:
        from dmprs import learners as L

        kw.setdefault("gain", gain)
        kw.setdefault("max_trials", 50)
        return L.ErrorLearning(q0, **kw)

    learners["fixed"] = fixed
    return ExperimentSetup(
        task=task, database=db, generalizer=gen,
        desired_query=task.validate_query(bottle_volume), default_learner="golden",
        learners=learners, low=low, high=high,
    )


# --- matchbox flip-up --------------------------------------------------------------------------

def matchbox_setup(demos: str = "default", noise: Any = None, **config: float) -> ExperimentSetup:
    """Stand the matchbox upright (docs/method.md §8): two scripted strikes labelled with their
    measured outcome angles, linear generalization with N = 25 kernels (the paper's matchbox
    setting), desired query pi/2.

    ``demos="default"``: one strike that flips back and one that flips over (paper Fig. 4);
    ``"both_flipped_back"``: two that flip back, so pi/2 lies outside the demos and the
    generalizer extrapolates (Fig. 7). Learners: ``error`` (default; eq. 16, K = I, the paper's),
    ``weighted`` (eq. 17 with scale 1 rad, recommended for extrapolation), ``secant``, and the
    bracketing ones between the demos' labels. ``config`` overrides simulation parameters;
    ``noise`` is a :class:`dmprs.tasks.noise.Noise` for the trials (the demos are measured exactly).
    """
    from dmprs.database import Database
    from dmprs.generalize import Generalizer
    from dmprs.tasks.matchbox import DEMO_SETS, MatchboxFlip

    if demos not in DEMO_SETS:
        raise InvalidInputError(f"unknown demonstration set {demos!r}; choose from {', '.join(DEMO_SETS)}")
    task = MatchboxFlip(noise, **config)
    db = Database(query_names=task.query_names, query_units=task.query_units)
    labels = []
    for duration in DEMO_SETS[demos]:
        label, traj = task.demonstration(duration)
        db.add(label, traj)
        labels.append(float(label[0]))
    gen = Generalizer(db, method="linear", n_basis=25)
    low, high = min(labels), max(labels)
    return ExperimentSetup(
        task=task, database=db, generalizer=gen,
        desired_query=task.validate_query(np.pi / 2), default_learner="error",
        learners=query_learners(low, high, scale=1.0), low=low, high=high,
    )


# --- the 7-DOF arm in MuJoCo (the robot extra) -------------------------------------------------

def arm_pouring_setup(**options: Any) -> ExperimentSetup:
    """The paper's pouring on the 7-DOF arm (docs/arm.md): see
    :func:`dmprs.tasks.arm_pouring.experiment.arm_pouring_setup`."""
    from dmprs.tasks.arm_pouring.experiment import arm_pouring_setup as setup  # it builds on this module

    return setup(**options)


def arm_throwing_setup(**options: Any) -> ExperimentSetup:
    """Throwing into a basket with the 7-DOF arm, a 2-D query (docs/throwing.md): see
    :func:`dmprs.tasks.arm_throwing.experiment.arm_throwing_setup`."""
    from dmprs.tasks.arm_throwing.experiment import arm_throwing_setup as setup  # it builds on this module

    return setup(**options)


SETUPS: dict[str, Callable[..., ExperimentSetup]] = {
    "analytic": analytic_setup,
    "matchbox": matchbox_setup,
    "pouring": pouring_setup,
    "arm-pouring": arm_pouring_setup,
    "arm-throwing": arm_throwing_setup,
}


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


def matchbox(demos: str = "default", learner: str = "error", max_trials: int = 20,
             log_dir: str | Path | None = None, seed: int = 0, **config: Any) -> LearningResult:
    """The matchbox flip-up end to end (see :mod:`dmprs.tasks.matchbox`)."""
    return run("matchbox", learner=learner, max_trials=max_trials, log_dir=log_dir, seed=seed,
               demos=demos, **config)


def pouring(bottle_volume: float = 0.5, learner: str = "golden", max_trials: int = 20,
            log_dir: str | Path | None = None, seed: int = 0, **setup_options: Any) -> LearningResult:
    """Pouring end to end (see :mod:`dmprs.tasks.pouring`): learn the assumed bottle volume that
    pours 0.2 l from a bottle holding ``bottle_volume`` l. ``learner``: ``"golden"`` (the
    paper's), ``"fixed"`` (fixed-gain error learning), ``"root"``, ``"secant"``, ... ``seed``
    draws the simulated liquid of the bottle (the demonstrations keep ``demo_seed``, 0)."""
    setup_options.setdefault("liquid_seed", seed)
    return run("pouring", learner=learner, max_trials=max_trials, log_dir=log_dir, seed=seed,
               bottle_volume=bottle_volume, **setup_options)


def arm_pouring(bottle_volume: float = 0.5, learner: str = "golden", max_trials: int = 6,
                log_dir: str | Path | None = None, seed: int = 0, **setup_options: Any) -> LearningResult:
    """The paper's pouring on the 7-DOF arm end to end (docs/arm.md): learn the assumed bottle
    volume whose generalized Cartesian movement pours 0.2 l from a bottle holding
    ``bottle_volume`` l. ``learner``: ``"golden"`` (the paper's) or ``"root"``, ..."""
    return run("arm-pouring", learner=learner, max_trials=max_trials, log_dir=log_dir, seed=seed,
               bottle_volume=bottle_volume, **setup_options)


def arm_throwing(target: tuple[float, float] = (1.0, 0.0), learner: str | None = None, max_trials: int = 15,
                 log_dir: str | Path | None = None, seed: int = 0, **setup_options: Any) -> LearningResult:
    """Throw the ball into a basket at ``target`` (x, y in m) with the 7-DOF arm
    (docs/throwing.md), learned in the 2-D query space."""
    return run("arm-throwing", learner=learner, max_trials=max_trials, log_dir=log_dir, seed=seed,
               target=tuple(float(v) for v in target), **setup_options)
