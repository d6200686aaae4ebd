"""Reproduction part "a noisy robot" (issue 16 item 5; the paper's real-robot Figs. 6 and 11):
trials to success over 10 noise seeds for the matchbox and 2-D pouring, with execution and
measurement noise (:class:`dmprs.tasks.noise.Noise`) drawn from each trial's seed.

Besides trials to success it counts, per run, the trials whose *measured* error had the wrong
sign (the noise-free error is rebuilt from the signals the noise does not touch: the disc count
for pouring, ``phi_max``/``phi_after`` for the matchbox), and whether the run still succeeded:
that is what corrupts a golden-section bracket (docs/growing.md, "A noisy robot").

Wiring as :mod:`dmprs.reproduce.growing`: :func:`plan_noisy`, :func:`run_noisy` (picklable
specs through :func:`dmprs.parallel.pmap`), :func:`summarize_noisy`, :func:`figure_noisy`.
"""

from __future__ import annotations

import math
import statistics
from dataclasses import dataclass
from pathlib import Path
from typing import Any

#: noise levels per experiment: (execution, measurement, contact). Matchbox: 0.5 mm fingertip
#: tracking, 1 deg on the measured angle, 5 % friction and restitution; pouring: 0.01 rad tilt
#: tracking, 3 ml on the poured volume (a kitchen scale).
NOISE = {"matchbox": (0.0005, math.radians(1.0), 0.05), "pouring": (0.01, 0.003, 0.0)}
#: success is judged on the noisy reading; for pouring the reading can be lucky, so the table
#: also counts successes whose noise-free error is within the task's 10 ml (the matchbox's
#: success, the upright regime, is physical: no reading involved)
TRUE_TOL = {"pouring": 0.010}
LEARNERS = {"matchbox": ("error", "golden", "golden-robust"), "pouring": ("golden", "golden-robust", "root")}


@dataclass(frozen=True)
class NoisySpec:
    """One learning run on a noisy robot."""

    experiment: str  # "matchbox" | "pouring"
    learner: str
    noise_seed: int
    max_trials: int = 20
    kind: str = "noisy"

    @property
    def label(self) -> str:
        return f"noisy {self.experiment} / {self.learner} / seed {self.noise_seed}"


def plan_noisy(quick: bool = False) -> list[NoisySpec]:
    """10 noise seeds per experiment and learner; ``quick``: 2 matchbox seeds, paper learner."""
    if quick:
        return [NoisySpec("matchbox", "error", s) for s in range(2)]
    return [NoisySpec(e, lrn, s) for e, learners in LEARNERS.items() for lrn in learners for s in range(10)]


def _true_eps(experiment: str, signals: dict[str, Any]) -> float | None:
    """The error the noise-free measurement would give (eps > 0: the query must increase)."""
    if experiment == "pouring":
        n = signals.get("poured_particles")
        return None if n is None else n * 0.002 - 0.2
    regime, phi_max, after = signals.get("regime"), signals.get("phi_max"), signals.get("phi_after")
    if regime is None or phi_max is None:
        return None
    angle = phi_max if regime == "flipped_back" else after
    return None if angle is None or not math.isfinite(angle) else math.pi / 2 - angle


def run_noisy(spec: NoisySpec) -> dict[str, Any]:
    """Learns ``spec``'s experiment on the noisy robot (trial k is reset with seed
    ``1000 noise_seed + k``); plain data."""
    from dmprs import experiments
    from dmprs.tasks.noise import Noise

    execution, measurement, contact = NOISE[spec.experiment]
    noise = Noise(execution=execution, measurement=measurement, contact=contact)
    r = experiments.run(spec.experiment, learner=spec.learner, max_trials=spec.max_trials,
                        seed=1000 * spec.noise_seed, noise=noise)
    trials = []
    for t in r.trials:
        eps = None if t.eps is None else float(t.eps[0])
        true = _true_eps(spec.experiment, t.signals)
        trials.append({"query": float(t.query[0]), "eps": eps, "true_eps": true, "success": t.success,
                       "wrong_sign": eps is not None and true is not None and eps * true < 0})
    return {"kind": "noisy", "experiment": spec.experiment, "learner": spec.learner,
            "noise_seed": spec.noise_seed, "noise": list(NOISE[spec.experiment]), "max_trials": spec.max_trials,
            "converged": r.converged, "trials_to_success": r.trials_to_success, "stop_reason": r.stop_reason,
            "wrong_signs": sum(t["wrong_sign"] for t in trials), "trials": trials}


def summarize_noisy(results: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Per experiment and learner: successes, median and range of trials to success, and the
    runs that saw a wrong-signed error (and how many of them still succeeded)."""
    rows = []
    keys = sorted({(r["experiment"], r["learner"]) for r in results if r.get("kind") == "noisy"})
    for exp, lrn in keys:
        runs = [r for r in results if r.get("kind") == "noisy" and r["experiment"] == exp and r["learner"] == lrn]
        ok = [r["trials_to_success"] for r in runs if r["trials_to_success"] is not None]
        hit = [r for r in runs if r["wrong_signs"]]
        tol = TRUE_TOL.get(exp)
        true_ok = [r for r in runs if r["converged"] and (
            tol is None or abs(r["trials"][r["trials_to_success"] - 1]["true_eps"] or 0.0) < tol)]
        rows.append({"experiment": exp, "learner": lrn, "seeds": len(runs), "successes": len(ok),
                     "median_trials": statistics.median(ok) if ok else None,
                     "min_trials": min(ok) if ok else None, "max_trials": max(ok) if ok else None,
                     "truly_within_tol": len(true_ok), "runs_with_wrong_sign": len(hit),
                     "succeeded_despite_wrong_sign": sum(r["converged"] for r in hit),
                     "noise": runs[0]["noise"], "cap": runs[0]["max_trials"]})
    return rows


def markdown_noisy(rows: list[dict[str, Any]]) -> str:
    lines = [("| experiment | learner | noise (execution, measurement, contact) | succeeded | trials to success "
             "median [range] | success also without the reading's noise | runs with a wrong-signed error (of them "
             "succeeded) |"), "|---|---|---|---|---|---|---|"]
    for r in rows:
        med = "-" if r["median_trials"] is None else f"{r['median_trials']:g} [{r['min_trials']}-{r['max_trials']}]"
        noise = ", ".join(f"{v:.3g}" for v in r["noise"])
        lines.append(f"| {r['experiment']} | {r['learner']} | {noise} | {r['successes']}/{r['seeds']} | {med} | "
                     f"{r['truly_within_tol']}/{r['seeds']} | "
                     f"{r['runs_with_wrong_sign']} ({r['succeeded_despite_wrong_sign']}) |")
    return "\n".join(lines) + "\n"


def figure_noisy(results: list[dict[str, Any]], out: str | Path) -> Path:
    """The measured error per trial of every noisy run (the paper's Figs. 6 and 11 way),
    one panel per experiment; written to ``out/noisy_robot.png``."""
    from dmprs.plots import pyplot

    plt = pyplot()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    exps = sorted({r["experiment"] for r in results if r.get("kind") == "noisy"})
    fig, axes = plt.subplots(len(exps), 1, figsize=(6.5, 2.8 * len(exps)), squeeze=False)
    for ax, exp in zip(axes[:, 0], exps):
        runs = [r for r in results if r.get("kind") == "noisy" and r["experiment"] == exp]
        learners = sorted({r["learner"] for r in runs})
        colors = {lrn: f"C{i}" for i, lrn in enumerate(learners)}
        unit, factor = ("ml", 1000.0) if exp == "pouring" else ("deg", 180.0 / math.pi)
        for r in runs:
            eps = [factor * t["eps"] if t["eps"] is not None else math.nan for t in r["trials"]]
            ax.plot(range(1, len(eps) + 1), eps, "o-", ms=3, lw=0.8, alpha=0.6, color=colors[r["learner"]],
                    label=r["learner"] if r["noise_seed"] == 0 else None)
        ax.axhline(0, color="grey", lw=0.8)
        ax.set(ylabel=f"measured error ({unit})", title=f"{exp}, noisy robot, {len(runs)} runs")
        ax.legend(fontsize=7)
    axes[-1, 0].set(xlabel="trial")
    fig.tight_layout()
    path = out / "noisy_robot.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
