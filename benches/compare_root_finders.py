"""Trials to |eps| < tol for the query learners of dmprs.learners on synthetic monotone maps.

    python benches/compare_root_finders.py

Prints a markdown table (pasted into benches/README.md, section "Query learners: trials to
converge"). Every executed trial counts, the first (pure generalization, q = q0) included.
The maps are synthetic stand-ins for the paper's tasks, not the simulations: q is in outcome
units, eps = q0 - q_a(q) (docs/method.md §5.3: eps > 0 means the query must increase).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from dmprs import learners as L

MAX_TRIALS = 50


@dataclass
class Case:
    name: str
    q_a: Callable[[float, float, np.random.Generator], float]  # (q, q0, rng) -> q_a
    q0s: tuple[float, ...]
    low: float
    high: float
    tol: float
    seeds: int = 1


def sine(q, q0, rng):
    return q + 0.3 * math.sin(q)


def pouring_like(q, q0, rng):
    # Flat at low volumes, steep at high ones ("much higher gains were needed for low bottle
    # volumes", paper §5): slope 0 at q = 0.3, 3 at q = 1.0.
    return 0.3 + 0.7 * max(q - 0.3, 0.0) ** 3 / 0.7**3


def matchbox_like(q, q0, rng):
    # The outcome jumps across the target (paper Fig. 2c): falls back below the window, flips
    # over above it, upright (q_a = q0) only on [q0 - 0.07, q0 - 0.03].
    if q < q0 - 0.07:
        return q - 0.15
    if q <= q0 - 0.03:
        return q0
    return q + 0.15


def noisy_sine(q, q0, rng):
    return q + 0.3 * math.sin(q) + 0.003 * rng.standard_normal()


CASES = [
    Case("q + 0.3 sin q", sine, (0.5, 1.0, 1.5), 0.3, 1.8, 1e-3),
    Case("pouring-like, flat then steep (q0 = 0.4, 0.5, 0.7)", pouring_like, (0.4, 0.5, 0.7), 0.3, 1.0, 0.01),
    Case("matchbox-like jump across zero, 0.04-wide window", matchbox_like, (0.8, 1.0, 1.2), 0.5, 1.5, 0.01),
    Case("q + 0.3 sin q + N(0, 0.003²), 50 seeds", noisy_sine, (1.0,), 0.3, 1.8, 0.01, seeds=50),
]

LEARNERS: dict[str, Callable[[Case, float], L._Learner]] = {
    "golden, paper": lambda c, q0: L.GoldenSection(q0, low=c.low, high=c.high, mode="paper", tol=c.tol, max_trials=MAX_TRIALS),
    "golden, robust": lambda c, q0: L.GoldenSection(q0, low=c.low, high=c.high, mode="robust", tol=c.tol, max_trials=MAX_TRIALS),
    "Illinois root finder": lambda c, q0: L.IllinoisRootFinder(q0, low=c.low, high=c.high, tol=c.tol, max_trials=MAX_TRIALS),
    "error learning, K = I": lambda c, q0: L.ErrorLearning(q0, low=c.low, high=c.high, tol=c.tol, max_trials=MAX_TRIALS),
    "error learning, secant": lambda c, q0: L.ErrorLearning(
        q0, jacobian="secant", low=c.low, high=c.high, tol=c.tol, max_trials=MAX_TRIALS
    ),
}


def trials(case: Case, make, q0: float, seed: int) -> int | str:
    """Trials until |eps| < tol, or the status the learner stopped with otherwise."""
    rng = np.random.default_rng(seed)
    learner = make(case, q0)
    while not learner.done:
        q = learner.ask()
        learner.tell(q, q0 - case.q_a(float(q[0]), q0, rng))
    return learner.n_trials if learner.converged else f"{learner.status} after {learner.n_trials}"


def cell(counts: list[int | str]) -> str:
    ok = [n for n in counts if isinstance(n, int)]
    if not ok and len(set(counts)) == 1:
        return f"never: {counts[0]}"
    text = f"{np.mean(ok):.1f}" if len(counts) > 3 else " / ".join(f"✗ ({n})" if isinstance(n, str) else str(n) for n in counts)
    failed = len(counts) - len(ok)
    if len(counts) > 3:
        text += f" (max {max(ok)})"
        if failed:
            text += f", {failed} failed"
    return text


def main() -> None:
    names = list(LEARNERS)
    print("| test function | tol | " + " | ".join(names) + " |")
    print("|---|---|" + "---|" * len(names))
    for case in CASES:
        row = []
        for name in names:
            counts = [trials(case, LEARNERS[name], q0, s) for q0 in case.q0s for s in range(case.seeds)]
            row.append(cell(counts))
        print(f"| {case.name} | {case.tol:g} | " + " | ".join(row) + " |")


if __name__ == "__main__":
    main()
