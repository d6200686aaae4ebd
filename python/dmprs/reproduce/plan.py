"""What the reproduction runs: one spec per learning run or baseline run."""

from __future__ import annotations

import importlib.util
from dataclasses import dataclass, field
from typing import Any

from dmprs.baselines import BaselineSpec
from dmprs.reproduce.parts import PARTS


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


def plan(quick: bool = False) -> list[Any]:
    """The runs of the job; ``quick`` runs every part at small scale. The parts of
    :data:`dmprs.reproduce.parts.PARTS` whose extra is installed follow the paper's experiments."""
    specs: list[Any] = []
    query_learners = ["error"] if quick else ["error", "weighted", "secant", "broyden", "golden-robust", "root", "pg"]
    for part, demos in (("matchbox", "default"), ("matchbox_both_flipped_back", "both_flipped_back")):
        for learner in (["weighted"] if quick and demos != "default" else query_learners):
            specs.append(LearnSpec(part, "matchbox", learner, 30, (("demos", demos),)))
    volumes = [0.5] if quick else [0.4, 0.5, 0.7, 0.25]
    pour_learners = ["golden"] if quick else ["golden", "golden-robust", "fixed", "root", "broyden"]
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
        # CMA-ES, the black-box optimizer users would reach for, at the middle exploration level
        for seed in seeds:
            specs.append(BaselineSpec("matchbox", "cma", seed, budget, sigmas[len(sigmas) // 2], 0.5,
                                      (("demos", demos),)))
    if importlib.util.find_spec("mujoco") is not None:
        # the paper's pouring on the 7-DOF arm (Fig. 9 on the robot; docs/arm.md): golden section
        # as the paper, the root finder beside it; floor 0.4-0.9 l within 6 trials each
        for v in [0.6] if quick else [0.4, 0.5, 0.6, 0.7, 0.8, 0.9]:
            for learner in ["golden"] if quick else ["golden", "root"]:
                specs.append(LearnSpec("arm_pouring", "arm-pouring", learner, 6, (("bottle_volume", v),)))
    for extra in PARTS:
        if extra.available():
            specs += extra.plan(quick)
    return specs
