"""What the reproduction runs: one spec per learning run or baseline run."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from dmprs.baselines import BaselineSpec


@dataclass(frozen=True)
class LearnSpec:
    """One query-space learning run."""

    part: str
    experiment: str
    learner: str
    max_trials: int
    setup: tuple[tuple[str, Any], ...] = field(default=())

    @property
    def label(self) -> str:
        opts = ", ".join(f"{k}={v}" for k, v in self.setup)
        return f"{self.experiment}({opts}) / {self.learner}"


def plan(quick: bool = False) -> list[LearnSpec | BaselineSpec]:
    """The runs of the job; ``quick`` runs every part at small scale."""
    specs: list[LearnSpec | BaselineSpec] = []
    query_learners = ["error"] if quick else ["error", "weighted", "secant", "golden-robust", "root", "pg"]
    for part, demos in (("matchbox", "default"), ("matchbox_both_flipped_back", "both_flipped_back")):
        for learner in (["weighted"] if quick and demos != "default" else query_learners):
            specs.append(LearnSpec(part, "matchbox", learner, 30, (("demos", demos),)))
    volumes = [0.5] if quick else [0.4, 0.5, 0.7, 0.25]
    pour_learners = ["golden"] if quick else ["golden", "golden-robust", "fixed", "root"]
    for v in volumes:
        for learner in pour_learners:
            specs.append(LearnSpec("pouring", "pouring", learner, 7 if quick else 15, (("bottle_volume", v),)))
    seeds = range(2) if quick else range(10)
    budget = 30 if quick else 200
    sigmas = [0.1] if quick else [0.02, 0.05, 0.1]
    for demos in (["both_flipped_back"] if quick else ["default", "both_flipped_back"]):
        for method in ("power", "pi2"):
            for sf in sigmas:
                for seed in seeds:
                    specs.append(BaselineSpec("matchbox", method, seed, budget, sf, 0.5, (("demos", demos),)))
    return specs
