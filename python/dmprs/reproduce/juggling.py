"""Reproduction part "paddle juggling": the 7-DOF arm learns to bounce a ball to unseen apex
heights from two demonstration rhythms, a periodic task learned in query space, with the paper's
learners (the root finder, golden section, Broyden) and the project's default (``auto``), over
several ball seeds (each a physically different drop and ball: :class:`dmprs.sim.juggle_scene.Drop`).

Every run starts from the desired apex (the pure generalization, counted as the first trial) and
stops at the first trial within 1 cm, or after :data:`MAX_TRIALS`. The floors: a median of at
most 3 trials, every run within 8. Bayesian optimization from the same first trial is a row of
:mod:`dmprs.reproduce.versus_bo`.

Wiring as :mod:`dmprs.reproduce.throwing`: :func:`plan_juggling` (picklable specs),
:func:`run_juggling`, :func:`summarize_juggling` (table rows), :func:`figure_juggling` (the
apex per trial).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from dmprs.experiments import arm_juggling
from dmprs.loop import learn
from dmprs.plots import pyplot, save_figure
from dmprs.reproduce.part import Part
from dmprs.reproduce.stats import cell, trial_stats

MAX_TRIALS = 15
#: the floors: median trials to success, and the most any run may take
FLOOR_MEDIAN = 3
FLOOR_MAX = 8
#: m: unseen apexes between the demonstrations' (about 0.12 and 0.42 m)
APEXES = (0.17, 0.22, 0.27, 0.32, 0.37)
#: the ball seeds every apex is learned with
BALL_SEEDS = (0, 1, 2, 3, 4)
#: the paper's learners and the project's default
LEARNERS = ("root", "golden", "broyden", "auto")
PAPER = "not in the paper; the project's floors: median <= 3 trials, every run <= 8"


@dataclass(frozen=True)
class JugglingSpec:
    """One learning run: bounce the ball of ``ball_seed`` to ``apex`` m with ``learner``."""

    apex: float
    learner: str
    ball_seed: int
    max_trials: int = MAX_TRIALS
    kind: str = "juggling"

    @property
    def label(self) -> str:
        """The run's name in progress lines and errors."""
        return f"juggling to {self.apex} m / {self.learner} / ball seed {self.ball_seed}"


def plan_juggling(quick: bool = False) -> list[JugglingSpec]:
    """Full: :data:`APEXES` x :data:`LEARNERS` x :data:`BALL_SEEDS`. Quick: one apex, ``auto``
    and the root finder, two seeds.
    """
    if quick:
        return [JugglingSpec(APEXES[2], learner, seed) for learner in ("auto", "root") for seed in BALL_SEEDS[:2]]
    return [JugglingSpec(apex, learner, seed) for learner in LEARNERS for apex in APEXES for seed in BALL_SEEDS]


def run_juggling(spec: JugglingSpec) -> dict[str, Any]:
    """Learns ``spec``; plain data (every trial's query and measured apex)."""
    setup = arm_juggling.setup(spec.apex, ball_seed=spec.ball_seed)
    r = learn(setup.task, setup.generalizer, setup.desired_query, setup.make_learner(spec.learner),
              max_trials=spec.max_trials)
    trials = [{"query": float(t.query[0]), "status": t.status, "success": t.success,
               "apex": t.signals.get("apex"), "apex_spread": t.signals.get("apex_spread")} for t in r.trials]
    return {"kind": "juggling", "apex": spec.apex, "learner": spec.learner, "ball_seed": spec.ball_seed,
            "max_trials": spec.max_trials, "converged": r.converged, "trials_to_success": r.trials_to_success,
            "stop_reason": r.stop_reason, "demos": [float(label[0]) for label, _ in arm_juggling.demonstrations()],
            "trials": trials}


def summarize_juggling(results: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Per learner: trials to success over every apex and seed (median, range, successes) against
    the floors, and the same per apex.
    """
    runs = [r for r in results if r.get("kind") == "juggling"]
    rows = []
    for learner in [name for name in LEARNERS if any(r["learner"] == name for r in runs)]:
        mine = [r for r in runs if r["learner"] == learner]
        for apex in [None, *sorted({r["apex"] for r in mine})]:
            group = [r for r in mine if apex is None or r["apex"] == apex]
            stats = trial_stats([r["trials_to_success"] for r in group], group[0]["max_trials"])
            failed = [r["stop_reason"] for r in group if not r["converged"]]
            what = "every apex" if apex is None else f"apex {apex:g} m"
            seeds = len({r["ball_seed"] for r in group})
            meets = stats["median"] is not None and stats["median"] <= FLOOR_MEDIAN and \
                stats["successes"] == stats["runs"] and stats["max"] <= FLOOR_MAX
            rows.append({"part": "juggling", "learner": learner, "apex": apex, **stats, "paper": PAPER,
                         "experiment": f"arm juggling, {what}, {seeds} ball seeds",
                         "meets_floor": meets if apex is None else None,
                         "stop_reason": failed[0] if failed and not stats["successes"] else None,
                         "failures": failed})
    return rows


def markdown_juggling(rows: list[dict[str, Any]]) -> str:
    """The juggling table of the report."""
    lines = ["| experiment | learner | trials to success median [range] | floor (median <= 3, all <= 8) |",
             "|---|---|---|---|"]
    for r in rows:
        met = "-" if r["meets_floor"] is None else ("met" if r["meets_floor"] else "not met")
        lines.append(f"| {r['experiment']} | {r['learner']} | {cell(r)} | {met} |")
    return "\n".join(lines) + "\n"


def figure_juggling(results: list[dict[str, Any]], out: str | Path) -> Path:
    """The measured apex per trial, one panel per learner: the demos' apexes, each run's trials
    joined in order (coloured by the desired apex, dashed), the 1 cm band around it;
    ``out/juggling.png``.
    """
    plt = pyplot()
    from matplotlib.ticker import MaxNLocator  # matplotlib is there once pyplot() returned

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    runs = [r for r in results if r.get("kind") == "juggling"]
    learners = [name for name in LEARNERS if any(r["learner"] == name for r in runs)] or ["auto"]
    apexes = sorted({r["apex"] for r in runs})
    fig, axes = plt.subplots(1, len(learners), figsize=(4.2 * len(learners), 4.0), squeeze=False, sharey=True)
    for ax, learner in zip(axes[0], learners, strict=True):
        mine = [r for r in runs if r["learner"] == learner]
        for r in mine[:1]:
            for k, d in enumerate(r["demos"]):
                ax.axhline(d, color="k", lw=0.8, ls=":", label="demonstrations' apexes" if k == 0 else None)
        for i, apex in enumerate(apexes):
            color = f"C{i}"
            ax.axhspan(apex - 0.01, apex + 0.01, color=color, alpha=0.15, label="desired +- 1 cm" if i == 0 else None)
            for r in (r for r in mine if r["apex"] == apex):
                pts = [(k + 1, t["apex"]) for k, t in enumerate(r["trials"]) if t["apex"] is not None]
                if pts:
                    ax.plot(*zip(*pts, strict=True), "o-", color=color, ms=3, lw=0.7, alpha=0.8)
        ax.set(xlabel="trial", title=f"{learner}: apex per trial")
        ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    axes[0][0].set_ylabel("measured apex (m)")
    axes[0][0].legend(fontsize=7, loc="upper left")
    return save_figure(fig, out / "juggling.png")


PART = Part(
    "juggling", "Paddle juggling with the 7-DOF arm, a periodic task learned in query space (docs/juggling.md)",
    plan=plan_juggling, run=run_juggling, summarize=summarize_juggling, markdown_of=markdown_juggling,
    figure=figure_juggling, needs="mujoco",
)
