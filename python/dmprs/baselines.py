"""Learning in the full DMP weight space: the baselines the paper cites (PoWER, PI²) but
reports no numbers for (docs/method.md §7). They start from the same first trial as error
learning, theta0 = the weights of G(q0), and every executed rollout counts as a trial.

The return is ``R = exp(-(eps / scale)^2)`` (PoWER, maximized) or the terminal cost
``(eps / scale)^2`` (PI², minimized), with the task's signed error eps (docs/method.md §7.1). A
rollout the adapter rejects (e.g. beyond its acceleration limits) gets the worst value, R = 1e-12
or cost 25, and still counts. Success is the task's own criterion; for PI² it is judged on its
noiseless evaluation rollouts, for PoWER on any rollout (its sample code has no evaluation
rollouts). PI²'s first rollout is its evaluation of theta0; PoWER samples around theta0 from the
first ask, so its first trial is theta0 itself, executed before PoWER asks (and not told to it:
PoWER's update needs rollouts drawn from its own distribution).

Every rollout runs through :func:`dmprs.trial.run_trial`, so with a ``log_dir`` it is logged like
a query-space trial (the weight vector is the trial's query) and the run can be resumed.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dmprs import experiments
from dmprs._core import __version__
from dmprs.adapters.spec import Status
from dmprs.cmaes import CMAES
from dmprs.dmp import DMP
from dmprs.errors import InvalidInputError, RunLogError
from dmprs.learners import PI2, PoWER
from dmprs.loop import AskTell
from dmprs.runlog import RunLog, TrialRecord
from dmprs.trial import run_trial

WORST_RETURN = 1e-12
WORST_COST = 25.0


@dataclass(frozen=True)
class BaselineSpec:
    """One baseline run: which experiment, which method, its exploration and seed."""

    experiment: str
    method: str  # "power" | "pi2" | "cma"
    seed: int
    budget: int = 200
    sigma_frac: float = 0.05  # sigma = sigma_frac x max|w| of each DOF (docs/method.md §7.2)
    scale: float = 0.5  # eps scale of the return (rad for the matchbox, docs/method.md §7.1)
    setup: tuple[tuple[str, Any], ...] = ()


@dataclass(frozen=True)
class _Method:
    """What differs between the weight-space learners, in one place."""

    name: str
    make: Callable[[BaselineSpec, DMP, NDArray[np.float64]], AskTell]
    #: the learner's feedback for a rollout's eps (None: the rollout was not ok)
    feedback: Callable[[float | None, float], float]
    #: theta0 is executed before the learner's first ask, and not told to it
    theta0_first: bool
    #: whether a rollout of theta counts as an evaluation (success is judged only on those)
    evaluation: Callable[[AskTell, NDArray[np.float64]], bool]


def _power(spec: BaselineSpec, dmp0: DMP, sigma: NDArray[np.float64]) -> AskTell:

    return PoWER(dmp0.weights, sigma, seed=spec.seed, max_trials=spec.budget)


def _pi2(spec: BaselineSpec, dmp0: DMP, sigma: NDArray[np.float64]) -> AskTell:

    n_updates = max(1, (spec.budget - 11) // 6 + 1)
    return PI2(dmp0.weights, sigma, seed=spec.seed, n_updates=n_updates, max_trials=spec.budget,
               alpha_x=dmp0.alpha_x, width_factor=dmp0.width_factor)


#: cma stops by itself after one generation of equal costs (all rollouts rejected, or every box
#: flipped over alike); as a baseline it spends its budget like PoWER and PI² instead
CMA_BUDGET_OPTIONS = {"tolflatfitness": 10**9, "tolfun": 0, "tolfunhist": 0}


def _cma(spec: BaselineSpec, dmp0: DMP, sigma: NDArray[np.float64]) -> AskTell:

    # sigma per weight as PoWER's exploration; the cost of PI²; theta0 executed first, as PoWER
    return CMAES(dmp0.weights.ravel(), sigma, seed=spec.seed, max_trials=spec.budget, feedback="cost",
                 options=CMA_BUDGET_OPTIONS)


METHODS = {
    "power": _Method(
        "PoWER", _power,
        feedback=lambda eps, scale: WORST_RETURN if eps is None else max(math.exp(-(eps / scale) ** 2), WORST_RETURN),
        theta0_first=True, evaluation=lambda learner, theta: True),
    "pi2": _Method(
        "PI²", _pi2,
        feedback=lambda eps, scale: WORST_COST if eps is None else (eps / scale) ** 2,
        theta0_first=False,
        # the core knows which rollout of an update is its noiseless evaluation
        evaluation=lambda learner, theta: bool(learner.asked_evaluation)),  # type: ignore[attr-defined]
    "cma": _Method(
        "CMA-ES", _cma,
        feedback=lambda eps, scale: WORST_COST if eps is None else (eps / scale) ** 2,
        theta0_first=True, evaluation=lambda learner, theta: True),
}


def run_baseline(spec: BaselineSpec, log_dir: str | Path | None = None, *,
                 resume: bool = False) -> dict[str, Any]:
    """Runs one baseline until an evaluation rollout succeeds or the budget is spent; returns
    the trial count and history. With ``log_dir`` every rollout is logged (and ``resume=True``
    continues a logged run).
    """
    if spec.method not in METHODS:
        raise InvalidInputError(f"unknown baseline {spec.method!r}; choose from {', '.join(METHODS)}")
    method = METHODS[spec.method]
    setup = experiments.make(spec.experiment, **dict(spec.setup))
    task, q0 = setup.task, setup.desired_query
    dmp0 = setup.generalizer.predict(q0)
    if not isinstance(dmp0, DMP):
        raise InvalidInputError(f"{spec.experiment}: the weight-space baselines learn joint-space DMPs; this "
                                "experiment's demonstrations are poses")
    w0 = dmp0.weights
    sigma = np.repeat(spec.sigma_frac * np.maximum(np.abs(w0).max(axis=1), 1e-9), w0.shape[1])
    learner = method.make(spec, dmp0, sigma)

    log, logged = _open_log(spec, task.name, log_dir, resume)
    history: list[dict[str, Any]] = []
    success_at = None

    def with_weights(theta: NDArray[np.float64]) -> Callable[[], DMP]:
        return lambda: DMP(theta.reshape(w0.shape), dmp0.goal, dmp0.start, dmp0.tau,
                           alpha_z=dmp0.alpha_z, beta_z=dmp0.beta_z, alpha_x=dmp0.alpha_x,
                           width_factor=dmp0.width_factor)

    with task.adapter:
        for index in range(spec.budget):
            if learner.done:
                break
            first = method.theta0_first and index == 0
            theta = w0.ravel() if first else learner.ask()
            evaluation = method.evaluation(learner, theta)
            if index < len(logged):
                record = _replayed(logged[index], theta, log)
            else:
                record = run_trial(task, index, theta, with_weights(theta), q0, seed=0, log=log).record
            ok = record.status == Status.OK.value and record.eps is not None
            eps = float(record.eps[0]) if ok and record.eps is not None else None
            history.append({"eps": float("nan") if eps is None else eps, "success": record.success,
                            "evaluation": evaluation, "status": record.status})
            if record.success and evaluation:
                success_at = index + 1
                break
            if not first:
                learner.tell(theta, method.feedback(eps, spec.scale))
    return {"experiment": spec.experiment, "method": spec.method, "seed": spec.seed,
            "sigma_frac": spec.sigma_frac, "budget": spec.budget, "trials_to_success": success_at,
            "n_trials": len(history), "history": history}


def _open_log(spec: BaselineSpec, task_name: str, log_dir: str | Path | None,
              resume: bool) -> tuple[RunLog | None, list[TrialRecord]]:
    if log_dir is None:
        if resume:
            raise InvalidInputError("resume=True needs the log_dir of the run to resume")
        return None, []
    if resume:
        log = RunLog(log_dir)
        log.meta()
        logged, _ = log.read()
        log.repair()
        return log, logged
    meta = {"task": task_name, "baseline": spec.method, "experiment": spec.experiment,
            "seed": spec.seed, "budget": spec.budget, "sigma_frac": spec.sigma_frac,
            "scale": spec.scale, "setup_options": dict(spec.setup), "dmprs": __version__,
            "created": time.strftime("%Y-%m-%dT%H:%M:%S%z")}
    return RunLog.create(log_dir, meta), []


def _replayed(record: TrialRecord, theta: NDArray[np.float64], log: RunLog | None) -> TrialRecord:
    """A logged rollout, checked to be the one the (identically seeded) learner asks again."""
    if record.query.shape != theta.shape or not np.array_equal(record.query, theta):
        where = log.trials_path if log is not None else "the log"
        raise RunLogError(f"{where}: rollout {record.index} executed other weights than the learner "
                          "now asks; resume with the baseline configured as in the original run")
    return record
