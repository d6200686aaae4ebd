"""What the reproduction runs: one spec per learning run or baseline run."""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from typing import Any

from dmprs._extras import available, install_hint
from dmprs.baselines import BaselineSpec
from dmprs.experiments import needs
from dmprs.experiments.arm_pouring import MAX_TRIALS
from dmprs.reproduce.part import LIQUID_SEEDS
from dmprs.reproduce.parts import PARTS

#: l: the bottles the arm learns to pour from
ARM_VOLUMES = (0.4, 0.5, 0.6, 0.7, 0.8, 0.9)
#: setup keys that draw a run's randomness rather than define its setting: runs that differ only
#: in these are one setting, reported by their median, range and success count
SEED_KEYS = ("liquid_seed",)


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
        """The run's name in progress lines and errors."""
        opts = ", ".join(f"{k}={v}" for k, v in self.setup)
        return f"{self.experiment}({opts}) / {self.learner}"


def _needs(spec: Any) -> str | None:
    """The optional package a spec of the paper's experiments needs, if any."""
    if isinstance(spec, BaselineSpec) and spec.method == "cma":
        return "cma"
    if isinstance(spec, LearnSpec):
        return needs(spec.experiment)
    return None


def _paper_specs(quick: bool) -> list[Any]:
    """The runs of the paper's experiments and the baselines, whatever is installed."""
    specs: list[Any] = []
    query_learners = ["error"] if quick else ["error", "weighted", "secant", "broyden", "golden-robust", "root", "pg"]
    for part, demos in (("matchbox", "default"), ("matchbox_both_flipped_back", "both_flipped_back")):
        for learner in (["weighted"] if quick and demos != "default" else query_learners):
            specs.append(LearnSpec(part, "matchbox", learner, 30, (("demos", demos),)))
    volumes = [0.5] if quick else [0.4, 0.5, 0.7, 0.25]
    pour_learners = ["golden"] if quick else ["golden", "golden-robust", "fixed", "root", "broyden"]
    for v in volumes:
        for learner in pour_learners:
            for seed in LIQUID_SEEDS[:1] if quick else LIQUID_SEEDS:
                specs.append(LearnSpec("pouring", "pouring", learner, 7 if quick else 15,
                                       (("bottle_volume", v), ("liquid_seed", seed))))
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
    # the paper's pouring on the 7-DOF arm (Fig. 9 on the robot; docs/arm.md): golden section
    # as the paper, the root finder beside it, each over several liquids
    for v in [0.6] if quick else ARM_VOLUMES:
        for learner in ["golden"] if quick else ["golden", "root"]:
            for seed in LIQUID_SEEDS[:1] if quick else LIQUID_SEEDS:
                specs.append(LearnSpec("arm_pouring", "arm-pouring", learner, MAX_TRIALS,
                                       (("bottle_volume", v), ("liquid_seed", seed))))
    return specs


def plan(quick: bool = False) -> list[Any]:
    """The runs of the job; ``quick`` runs every part at small scale. Runs whose optional package
    is missing are left out (:func:`skipped` says which); the parts of
    :data:`dmprs.reproduce.parts.PARTS` whose extra is installed follow the paper's experiments.
    """
    specs = [s for s in _paper_specs(quick) if (need := _needs(s)) is None or available(need)]
    for extra in PARTS:
        if extra.available():
            specs += extra.plan(quick)
    return specs


def skipped(quick: bool = False) -> list[str]:
    """One line per group of runs :func:`plan` leaves out, naming the extra that brings them."""
    missing = Counter(
        (need, s.method if isinstance(s, BaselineSpec) else s.experiment)
        for s in _paper_specs(quick) if (need := _needs(s)) is not None and not available(need))
    notes = [f"{n} run(s) of {what} not run: they need {need} ({install_hint(need)})"
             for (need, what), n in missing.items()]
    notes += [f"{part.title}: not run, it needs {part.needs} ({install_hint(part.needs)})"
              for part in PARTS if part.needs is not None and not part.available()]
    notes += [line for part in PARTS if part.available() for line in part.left_out(quick)]
    if not available("matplotlib"):
        notes.append(f"figures: not drawn, they need matplotlib ({install_hint('matplotlib')})")
    return notes
