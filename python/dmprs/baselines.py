"""Learning in the full DMP weight space: the baselines the paper cites (PoWER, PI²) but
reports no numbers for (docs/method.md §7). They start from the same first trial as error learning,
theta0 = the weights of G(q0), and every executed rollout counts as a trial.

The return is ``R = exp(-(eps / scale)^2)`` (PoWER, maximized) or the terminal cost
``(eps / scale)^2`` (PI², minimized), with the task's signed error eps (docs/method.md §7.1). A
rollout the adapter rejects (e.g. beyond its acceleration limits) gets the worst value, R = 1e-12
or cost 25, and still counts. Success is the task's own criterion; for PI² it is judged on its
noiseless evaluation rollouts, for PoWER on any rollout (its sample code has no evaluation
rollouts). PI²'s first rollout is its evaluation of theta0; PoWER samples around theta0 from the
first ask, so its first trial is theta0 itself, executed before PoWER asks (and not told to it:
PoWER's update needs rollouts drawn from its own distribution).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from dmprs.dmp import DMP
from dmprs.errors import InvalidInputError

WORST_RETURN = 1e-12
WORST_COST = 25.0


@dataclass(frozen=True)
class BaselineSpec:
    """One baseline run: which experiment, which method, its exploration and seed."""

    experiment: str
    method: str  # "power" | "pi2"
    seed: int
    budget: int = 200
    sigma_frac: float = 0.05  # sigma = sigma_frac x max|w| of each DOF (docs/method.md §7.2)
    scale: float = 0.5  # eps scale of the return (rad for the matchbox, docs/method.md §7.1)
    setup: tuple[tuple[str, Any], ...] = ()


def run_baseline(spec: BaselineSpec) -> dict[str, Any]:
    """Runs one baseline until success or the budget; returns the trial count and history."""
    from dmprs import experiments
    from dmprs import learners as L

    if spec.method not in ("power", "pi2"):
        raise InvalidInputError(f"unknown baseline {spec.method!r}; use 'power' or 'pi2'")
    setup = experiments.SETUPS[spec.experiment](**dict(spec.setup))
    task, q0 = setup.task, setup.desired_query
    dmp0 = setup.generalizer.predict(q0)
    w0 = dmp0.weights
    sigma = np.repeat(spec.sigma_frac * np.maximum(np.abs(w0).max(axis=1), 1e-9), w0.shape[1])
    if spec.method == "power":
        learner: Any = L.PoWER(w0, sigma, seed=spec.seed, max_trials=spec.budget)
    else:
        n_updates = max(1, (spec.budget - 11) // 6 + 1)
        learner = L.PI2(w0, sigma, seed=spec.seed, n_updates=n_updates, max_trials=spec.budget,
                        alpha_x=dmp0.alpha_x, width_factor=dmp0.width_factor)
    history: list[dict[str, Any]] = []
    success_at = None
    with task.adapter:
        for trial in range(spec.budget):
            if learner.done:
                break
            first_power = spec.method == "power" and trial == 0
            theta = w0.ravel() if first_power else learner.ask()
            evaluation = spec.method == "power" or np.array_equal(theta, learner.theta)
            dmp = DMP(theta.reshape(w0.shape), dmp0.goal, dmp0.y0, dmp0.tau,
                      alpha_z=dmp0.alpha_z, beta_z=dmp0.beta_z, alpha_x=dmp0.alpha_x,
                      width_factor=dmp0.width_factor)
            task.adapter.reset(seed=trial)
            outcome = task.adapter.execute(task.trajectory(dmp))
            if outcome.ok:
                eps = float(task.error(q0, outcome)[0])
                success = task.success(q0, outcome)
                value = np.exp(-(eps / spec.scale) ** 2) if spec.method == "power" else (eps / spec.scale) ** 2
                value = max(value, WORST_RETURN) if spec.method == "power" else value
            else:
                eps, success = float("nan"), False
                value = WORST_RETURN if spec.method == "power" else WORST_COST
            history.append({"eps": eps, "success": success, "evaluation": evaluation, "status": outcome.status.value})
            if success and evaluation and success_at is None:
                success_at = trial + 1
                break
            if not first_power:
                learner.tell(theta, value)
    return {"experiment": spec.experiment, "method": spec.method, "seed": spec.seed,
            "sigma_frac": spec.sigma_frac, "budget": spec.budget, "trials_to_success": success_at,
            "n_trials": len(history), "history": history}
