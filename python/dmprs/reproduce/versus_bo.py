"""Reproduction part "Bayesian optimization beside the query-space learners": trials to success
per experiment for the paper's learner, the project's default learner (``auto``), Bayesian
optimization (:class:`dmprs.bayesopt.BayesOpt`, with one random start and with the package's
default of five) and CMA-ES, every one from the same first trial (the generalized query), in the
same search limits, judged by the same tolerance.

Deterministic learners on the deterministic simulators run once per setting; the others run
:data:`SEEDS` times: the optimizers' seed, the arm's liquid, the throw's basket or the noisy
robot's noise draw or the juggled ball (its drop and restitution) differ from run to run (the same
index for every learner).
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from dmprs import experiments
from dmprs._extras import available, install_hint
from dmprs.experiments import ExperimentSetup, needs
from dmprs.experiments.arm_pouring import MAX_TRIALS as ARM_MAX_TRIALS
from dmprs.loop import learn
from dmprs.plots import pyplot, save_figure
from dmprs.reproduce.noisy import NOISE as NOISY_ROBOT
from dmprs.reproduce.part import Part
from dmprs.reproduce.stats import cell, trial_stats
from dmprs.reproduce.throwing import baskets
from dmprs.tasks.noise import Noise

TITLE = "Bayesian optimization beside the query-space learners (docs/method.md §7.3)"
SEEDS = 5
#: the learners that draw random numbers: they run once per seed everywhere
RANDOMIZED = ("bo", "bo-default", "cma")
#: the columns: the paper's learner for each experiment, the project's default learner, and the
#: black-box optimizers
COLUMNS = ("paper", "auto", "bo", "bo-default", "cma")


@dataclass(frozen=True)
class Setting:
    """One experiment setting of the comparison."""

    name: str
    experiment: str
    options: tuple[tuple[str, Any], ...]
    max_trials: int
    #: what varies per seed besides the learner's own seed: "" (nothing), "liquid", "basket", "noise",
    #: "ball" (the juggled ball's drop and restitution)
    draw: str = ""


SETTINGS = (
    Setting("matchbox, demos flipped back + over", "matchbox", (("demos", "default"),), 30),
    Setting("matchbox, both demos flipped back", "matchbox", (("demos", "both_flipped_back"),), 30),
    *(Setting(f"pouring from {v} l, 5 liquids", "pouring", (("bottle_volume", v),), 15, draw="liquid")
      for v in (0.4, 0.5, 0.7, 0.25)),
    Setting("arm pouring from 0.5 l, 5 liquids", "arm-pouring", (("bottle_volume", 0.5),), ARM_MAX_TRIALS,
            draw="liquid"),
    *(Setting(f"throwing into a 2 cm basket {region} the demos' range, 5 baskets", "arm-throwing",
              (("tol", 0.02), ("region", region)), 15, draw="basket") for region in ("inside", "outside")),
    Setting("matchbox on a noisy robot (flipped back + over), 5 noise draws", "matchbox", (("demos", "default"),), 20,
            draw="noise"),
    Setting("arm juggling to a 0.27 m apex, 5 balls", "arm-juggling", (("desired", 0.27),), 15, draw="ball"),
)


@dataclass(frozen=True)
class VersusSpec:
    """One learning run of the comparison: ``column``'s learner on setting ``setting`` with draw
    ``seed``.
    """

    setting: int
    column: str
    seed: int
    kind: str = "versus"

    @property
    def label(self) -> str:
        """The run's name in progress lines and errors."""
        return f"versus BO: {SETTINGS[self.setting].name} / {self.column} / seed {self.seed}"


def _runnable(s: Setting) -> bool:
    """Whether the optional package setting ``s`` needs, if any, is installed."""
    need = needs(s.experiment)
    return need is None or available(need)


def plan_versus(quick: bool = False) -> list[VersusSpec]:
    """Every column on every setting, :data:`SEEDS` runs where something is drawn (the arm's
    settings only with MuJoCo installed); ``quick``: the default learner and Bayesian
    optimization on the matchbox with both demos flipped back.
    """
    if quick:
        return [VersusSpec(1, column, 0) for column in ("auto", "bo")]
    return [VersusSpec(i, column, seed) for i, s in enumerate(SETTINGS) if _runnable(s)
            for column in COLUMNS for seed in range(SEEDS if s.draw or column in RANDOMIZED else 1)]


def left_out(quick: bool = False) -> list[str]:
    """The settings :func:`plan_versus` leaves out because a package they need is missing."""
    missing = Counter(need for s in SETTINGS if (need := needs(s.experiment)) and not available(need))
    if quick:
        return []
    return [f"{TITLE}: {count} setting(s) not run: they need {need} ({install_hint(need)})"
            for need, count in sorted(missing.items())]


def prepare(setting: int, seed: int) -> tuple[ExperimentSetup, int]:
    """Setting ``setting`` of :data:`SETTINGS` with draw ``seed``: its experiment and the seed its
    trials are reset with.
    """
    s = SETTINGS[setting]
    options = dict(s.options)
    trial_seed = 0
    if s.draw == "liquid":
        options["liquid_seed"] = seed
    elif s.draw == "basket":
        options["target"] = baskets(SEEDS)[options.pop("region")][seed]
    elif s.draw == "ball":
        options["ball_seed"] = seed
    elif s.draw == "noise":
        execution, measurement, contact = NOISY_ROBOT[s.experiment]
        options["noise"] = Noise(execution=execution, measurement=measurement, contact=contact)
        trial_seed = 1000 * seed
    return experiments.make(s.experiment, **options), trial_seed


def run_versus(spec: VersusSpec) -> dict[str, Any]:
    """Learns one run of the comparison; plain data."""
    s = SETTINGS[spec.setting]
    setup, trial_seed = prepare(spec.setting, spec.seed)
    learner = setup.paper_learner if spec.column == "paper" else spec.column
    made = setup.make_learner(learner, **({"seed": spec.seed} if learner in RANDOMIZED else {}))
    r = learn(setup.task, setup.generalizer, setup.desired_query, made, max_trials=s.max_trials, seed=trial_seed)
    return {"kind": "versus", "setting": spec.setting, "name": s.name, "column": spec.column, "learner": learner,
            "seed": spec.seed, "max_trials": s.max_trials, "converged": r.converged,
            "trials_to_success": r.trials_to_success, "stop_reason": r.stop_reason,
            "queries": [t.query.tolist() for t in r.trials]}


def summarize_versus(results: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """One row per setting and column: the learner and its trials to success over the runs."""
    runs = [r for r in results if r.get("kind") == "versus"]
    rows = []
    for key in sorted({(r["setting"], COLUMNS.index(r["column"])) for r in runs}):
        group = [r for r in runs if (r["setting"], COLUMNS.index(r["column"])) == key]
        failed = [r["stop_reason"] for r in group if not r["converged"]]
        rows.append({"setting": key[0], "name": group[0]["name"], "column": group[0]["column"],
                     "learner": group[0]["learner"],
                     **trial_stats([r["trials_to_success"] for r in group], group[0]["max_trials"]),
                     "stop_reason": failed[0] if failed and len(failed) == len(group) else None})
    return rows


def markdown_versus(rows: list[dict[str, Any]]) -> str:
    """The comparison as one table: a row per setting, a column per learner."""
    heads = {"paper": "paper's learner", "auto": "auto (the default)", "bo": "BO, 1 random start",
             "bo-default": "BO, 5 random starts (package default)", "cma": "CMA-ES"}
    columns = [c for c in COLUMNS if any(r["column"] == c for r in rows)]
    lines = ["| experiment (trial cap) | " + " | ".join(heads[c] for c in columns) + " |",
             "|---|" + "---|" * len(columns)]
    for i in sorted({r["setting"] for r in rows}):
        mine = {r["column"]: r for r in rows if r["setting"] == i}
        first = next(iter(mine.values()))
        cells = [f"{mine[c]['learner']}: {_cell(mine[c])}" if c == "paper" and c in mine
                 else (_cell(mine[c]) if c in mine else "-") for c in columns]
        lines.append(f"| {first['name']} ({first['budget'] or SETTINGS[i].max_trials}) | " + " | ".join(cells) + " |")
    lines += ["", ("Trials to success, the first (generalized) one included: one run, or median [range] over the "
                   "runs with the successes where some failed; a median beyond the cap is written >cap.")]
    return "\n".join(lines) + "\n"


def _cell(row: dict[str, Any]) -> str:
    return cell({**row, "stop_reason": None})


def figure_versus(results: list[dict[str, Any]], out: str | Path) -> Path:
    """Median trials to success per setting and learner, the range as a bar, failures at the cap
    hatched; ``out/versus_bo.png``.
    """
    plt = pyplot()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    rows = summarize_versus(results)
    settings = sorted({r["setting"] for r in rows})
    columns = [c for c in COLUMNS if any(r["column"] == c for r in rows)]
    fig, ax = plt.subplots(figsize=(10, 0.5 + 0.55 * len(settings) * 1.6))
    height = 0.8 / len(columns)
    for j, c in enumerate(columns):
        for k, i in enumerate(settings):
            row = next((r for r in rows if r["setting"] == i and r["column"] == c), None)
            if row is None:
                continue
            y = k + (j - (len(columns) - 1) / 2) * height
            cap = SETTINGS[i].max_trials
            med = cap if row["median"] is None else row["median"]
            ax.barh(y, med, height, color=f"C{j}", hatch="//" if row["median"] is None else None,
                    label=c if k == 0 else None, alpha=0.85)
            if row["min"] is not None and row["runs"] > 1:
                ax.plot([row["min"], row["max"]], [y, y], "k-", lw=1)
    ax.set_yticks(np.arange(len(settings)), [SETTINGS[i].name for i in settings], fontsize=7)
    ax.invert_yaxis()
    ax.set(xlabel="trials to success (median; line: range; hatched: median beyond the cap)",
           title="Query-space learners against Bayesian optimization and CMA-ES")
    ax.legend(fontsize=7, loc="lower right")
    return save_figure(fig, out / "versus_bo.png")


PART = Part(
    "versus", TITLE, plan=plan_versus, run=run_versus, summarize=summarize_versus, markdown_of=markdown_versus,
    figure=figure_versus, needs="bayes_opt", left_out=left_out,
)
