"""Which Bayesian optimization to run beside the query-space learners: Optuna's GP sampler against
the bayesian-optimization package (what the reproduction runs), on the settings of the
reproduction's comparison, in the same run.

Optuna's GP sampler needs torch, which the project does not depend on (from PyPI it brings about
3 GB of CUDA packages); install it by hand to run this (``pip install optuna torch``). Every
optimizer starts from the same first trial, the generalized query q0 (enqueued for Optuna), in the
same search box (:func:`dmprs.experiments.base.search_box`), minimizing |eps|, and stops at the
task's tolerance or the setting's trial cap. Optuna runs with its defaults (10 random trials before
the GP) and with one random start (q0, then the GP: ``n_startup_trials=2``).

    python benches/compare_bo.py [seeds] [setting index ...]
"""

from __future__ import annotations

import sys
import time
from typing import Any

import numpy as np

from dmprs.learners import Trial
from dmprs.loop import learn
from dmprs.reproduce.stats import cell, trial_stats
from dmprs.reproduce.versus_bo import SETTINGS, prepare


class OptunaGP:
    """Optuna's GPSampler as an ask/tell learner of dmprs's loop."""

    def __init__(self, q0: Any, lower: Any, upper: Any, seed: int, startup: int | None) -> None:
        import optuna

        optuna.logging.set_verbosity(optuna.logging.WARNING)
        kw = {} if startup is None else {"n_startup_trials": startup}
        self._study = optuna.create_study(sampler=optuna.samplers.GPSampler(seed=seed, **kw))
        self._dist = {f"q{i}": optuna.distributions.FloatDistribution(float(lo), float(hi))
                      for i, (lo, hi) in enumerate(zip(lower, upper, strict=True))}
        self._study.enqueue_trial({k: float(v) for k, v in zip(self._dist, np.atleast_1d(q0), strict=True)})
        self._trial: Any = None
        self.history: list[Trial] = []

    def ask(self) -> np.ndarray:
        if self._trial is None:
            self._trial = self._study.ask(self._dist)
        return np.array([self._trial.params[k] for k in self._dist])

    def tell(self, q: Any, eps: Any) -> None:
        score = float(np.linalg.norm(np.atleast_1d(eps)))
        self._study.tell(self._trial, score)
        self.history.append(Trial(np.atleast_1d(q), np.atleast_1d(eps), score))
        self._trial = None

    done = False
    converged = False
    status = "running"
    status_detail = "running"


def run(setting: int, name: str, seed: int) -> int | None:
    setup, trial_seed = prepare(setting, seed)
    cap = SETTINGS[setting].max_trials
    if name.startswith("optuna"):
        lower, upper = setup.settings.box or ((), ())
        learner: Any = OptunaGP(setup.desired_query, lower, upper, seed, None if name == "optuna-gp" else 2)
    else:
        learner = setup.make_learner(name, **({"seed": seed} if name.startswith("bo") else {}))
    r = learn(setup.task, setup.generalizer, setup.desired_query, learner, max_trials=cap, seed=trial_seed)
    return r.trials_to_success


def main() -> None:
    seeds = int(sys.argv[1]) if len(sys.argv) > 1 else 5
    chosen = [int(a) for a in sys.argv[2:]] or [i for i, s in enumerate(SETTINGS) if not s.experiment.startswith("arm-")]
    names = ("auto", "bo", "bo-default", "optuna-gp-1", "optuna-gp")
    print("| setting (cap) | " + " | ".join(names) + " |")
    print("|---|" + "---|" * len(names))
    for i in chosen:
        s = SETTINGS[i]
        cells = []
        for name in names:
            start = time.perf_counter()
            n = 1 if name == "auto" and not s.draw else seeds
            counts = [run(i, name, k) for k in range(n)]
            row = {**trial_stats(counts, s.max_trials), "stop_reason": None}
            cells.append(f"{cell(row)} ({time.perf_counter() - start:.0f} s)")
        print(f"| {s.name} ({s.max_trials}) | " + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    main()
