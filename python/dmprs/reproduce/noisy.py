"""Reproduction part "a noisy robot" (the paper's real-robot Figs. 6 and 11):
trials to success over 10 noise seeds for the matchbox and 2-D pouring, with execution and
measurement noise (:class:`dmprs.tasks.noise.Noise`) drawn from each trial's seed; and golden
section's bracket under measurement noise up to 5 times the tolerance, with and without its
noise guard (:class:`BracketSpec`, on the analytic task, whose root is known).

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

from dmprs import experiments
from dmprs.experiments import analytic
from dmprs.learners import GoldenSection
from dmprs.loop import learn
from dmprs.plots import pyplot, save_figure
from dmprs.reproduce.part import Part
from dmprs.tasks.noise import Noise
from dmprs.trial import run_trial

#: noise levels per experiment: (execution, measurement, contact). Matchbox: 0.5 mm fingertip
#: tracking, 1 deg on the measured angle, 5 % friction and restitution; pouring: 0.01 rad tilt
#: tracking, 3 ml on the poured volume (a kitchen scale).
NOISE = {"matchbox": (0.0005, math.radians(1.0), 0.05), "pouring": (0.01, 0.003, 0.0)}
#: success is judged on the noisy reading; for pouring the reading can be lucky, so the table
#: also counts successes whose noise-free error is within the task's 10 ml (the matchbox's
#: success, the upright regime, is physical: no reading involved)
TRUE_TOL = {"pouring": 0.010}
#: "golden-guarded" is "golden-robust" with its noise guard set to the measurement noise
LEARNERS = {"matchbox": ("error", "golden", "golden-robust", "golden-guarded"),
            "pouring": ("golden", "golden-robust", "golden-guarded", "root")}
GUARDED = "golden-guarded"
#: the bracket study on the analytic task (tolerance 0.01 m): measurement noise sigma = 0.003 m
#: and a share of outliers (readings with another N(0, 0.5^2) m, wrong-signed about half the time)
BRACKET_SIGMA, OUTLIER_SCALE = 0.003, 0.5
BRACKET_OUTLIERS = (0.0, 0.05, 0.1, 0.2)


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
        """The run's name in progress lines and errors."""
        return f"noisy {self.experiment} / {self.learner} / seed {self.noise_seed}"


@dataclass(frozen=True)
class BracketSpec:
    """Golden section (robust mode) on the analytic task with measurement noise and a share
    ``outliers`` of outlier readings, with or without its noise guard, over ``seeds`` noise
    seeds. Each seed runs twice: spending ``max_trials`` with the tolerance off, so that what is
    measured is the bracket; and as a user would, stopping on a reading within the tolerance.
    """

    outliers: float
    guard: bool
    seeds: int = 50
    max_trials: int = 20
    kind: str = "noisy"

    @property
    def label(self) -> str:
        """The run's name in progress lines and errors."""
        return f"noisy bracket / outliers {self.outliers:g} / {'guarded' if self.guard else 'unguarded'}"


def plan_noisy(quick: bool = False) -> list[NoisySpec | BracketSpec]:
    """10 noise seeds per experiment and learner, and the bracket study; ``quick``: 2 matchbox
    seeds with the paper's learner, and the bracket study at twice the tolerance.
    """
    if quick:
        return [*(NoisySpec("matchbox", "error", s) for s in range(2)), BracketSpec(0.1, False),
                BracketSpec(0.1, True)]
    return [*(NoisySpec(e, lrn, s) for e, learners in LEARNERS.items() for lrn in learners for s in range(10)),
            *(BracketSpec(p, guard) for p in BRACKET_OUTLIERS for guard in (False, True))]


def run_bracket(spec: BracketSpec) -> dict[str, Any]:
    """Per seed: how far the root q* of the noise-free map lies outside the final bracket, and
    whether the run stopped on a reading whose noise-free error is within the tolerance; plain data.
    """

    def golden(noise: Noise, guard: float | None, max_trials: int, tol: float, seed: int) -> tuple[Any, Any]:
        setup = analytic.setup(noise=noise)
        lrn = GoldenSection(setup.desired_query, low=setup.low, high=setup.high, mode="robust",
                            tol=tol, max_trials=max_trials, noise=guard)
        return lrn, learn(setup.task, setup.generalizer, setup.desired_query, lrn, max_trials=max_trials,
                          tol=tol, seed=seed)

    exact, _ = golden(Noise(), None, 60, 1e-12, 0)  # q* to 1e-9 of the bracket: 60 trials of 0.618
    q_star = 0.5 * sum(exact.bracket)
    # where the signs stop meaning anything: |true eps| < 2 sigma within delta of q* (the slope
    # from a secant over two trials of the exact run near q*)
    (qa, ea), (qb, eb) = [(float(h.q[0]), float(h.feedback[0])) for h in exact.history[-8:-6]]
    delta = 2.0 * BRACKET_SIGMA * abs((qb - qa) / (eb - ea))
    noise = Noise(measurement=BRACKET_SIGMA, outliers=spec.outliers, outlier_scale=OUTLIER_SCALE * (spec.outliers > 0))
    guard = BRACKET_SIGMA if spec.guard else None
    exact_setup = analytic.setup()
    runs = []
    for k in range(spec.seeds):
        lrn, _ = golden(noise, guard, spec.max_trials, 1e-12, 1000 * k)
        lo, hi = sorted(lrn.bracket)
        _, used = golden(noise, guard, spec.max_trials, exact_setup.task.tol, 1000 * k)
        true_ok = used.converged and abs(_exact_error(exact_setup, used.learned_query)) < exact_setup.task.tol
        runs.append({"outside": max(lo - q_star, q_star - hi, 0.0) / delta, "reopened": lrn.reopened,
                     "converged": used.converged, "truly_within_tol": true_ok, "trials": used.n_trials})
    return {"kind": "noisy", "study": "bracket", "outliers": spec.outliers, "guard": spec.guard,
            "sigma": BRACKET_SIGMA, "max_trials": spec.max_trials, "q_star": q_star, "delta": delta, "runs": runs}


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


def _exact_error(setup: Any, q: Any) -> float:
    """The noise-free eps of query q on an experiment setup's task."""
    with setup.task.adapter:
        t = run_trial(setup.task, 0, q, lambda: setup.generalizer.predict(q), setup.desired_query, seed=0)
    assert t.record.eps is not None  # the exact analytic task always scores
    return float(t.record.eps[0])


def run_noisy(spec: NoisySpec | BracketSpec) -> dict[str, Any]:
    """Learns ``spec``'s experiment on the noisy robot (trial k is reset with seed
    ``1000 noise_seed + k``), or runs a bracket study; plain data.
    """
    if isinstance(spec, BracketSpec):
        return run_bracket(spec)
    execution, measurement, contact = NOISE[spec.experiment]
    noise = Noise(execution=execution, measurement=measurement, contact=contact)
    learner, options = spec.learner, {}
    if learner == GUARDED:
        learner, options = "golden-robust", {"noise": measurement}
    r = experiments.run(spec.experiment, learner=learner, learner_options=options, max_trials=spec.max_trials,
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
    runs that saw a wrong-signed error (and how many of them still succeeded).
    """
    rows: list[dict[str, Any]] = []
    learning = [r for r in results if r.get("kind") == "noisy" and r.get("study") != "bracket"]
    keys = sorted({(r["experiment"], r["learner"]) for r in learning})
    for exp, lrn in keys:
        runs = [r for r in learning if r["experiment"] == exp and r["learner"] == lrn]
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
    studies = [r for r in results if r.get("kind") == "noisy" and r.get("study") == "bracket"]
    for r in sorted(studies, key=lambda r: (r["outliers"], r["guard"])):
        runs = r["runs"]
        rows.append({"study": "bracket", "outliers": r["outliers"], "sigma": r["sigma"], "guard": r["guard"],
                     "seeds": len(runs), "trials": r["max_trials"], "delta": r["delta"],
                     "held": sum(run["outside"] <= 1.0 for run in runs),
                     "max_outside": max(run["outside"] for run in runs),
                     "reopened": sum(run["reopened"] for run in runs),
                     "truly_within_tol": sum(run["truly_within_tol"] for run in runs),
                     "median_trials": statistics.median(run["trials"] for run in runs)})
    return rows


def markdown_noisy(rows: list[dict[str, Any]]) -> str:
    """The noisy-robot table of the report."""
    lines = [("| experiment | learner | noise (execution, measurement, contact) | succeeded | trials to success "
             "median [range] | success also without the reading's noise | runs with a wrong-signed error (of them "
             "succeeded) |"), "|---|---|---|---|---|---|---|"]
    for r in (r for r in rows if r.get("study") != "bracket"):
        med = "-" if r["median_trials"] is None else f"{r['median_trials']:g} [{r['min_trials']}-{r['max_trials']}]"
        noise = ", ".join(f"{v:.3g}" for v in r["noise"])
        lines.append(f"| {r['experiment']} | {r['learner']} | {noise} | {r['successes']}/{r['seeds']} | {med} | "
                     f"{r['truly_within_tol']}/{r['seeds']} | "
                     f"{r['runs_with_wrong_sign']} ({r['succeeded_despite_wrong_sign']}) |")
    bracket = [r for r in rows if r.get("study") == "bracket"]
    if bracket:
        lines += ["", ("| outliers (sigma 0.003, tolerance 0.01) | golden-robust | seeds | final bracket within delta "
                  "of the root, 20 trials | farthest root outside it (x delta) | limits re-opened | stopping at the "
                  "tolerance: truly within it | trials, median |"), "|---|---|---|---|---|---|---|---|"]
        for r in bracket:
            lines.append(f"| {100 * r['outliers']:.0f} % | {'noise guard' if r['guard'] else 'unguarded'} | "
                         f"{r['seeds']} | {r['held']}/{r['seeds']} | {r['max_outside']:.1f} | {r['reopened']} | "
                         f"{r['truly_within_tol']}/{r['seeds']} | {r['median_trials']:g} |")
        lines += ["", (f"delta = {bracket[0]['delta']:.4f}: within it of the root |eps| < 2 sigma, and no sign "
                       "can be trusted.")]
    return "\n".join(lines) + "\n"


def figure_noisy(results: list[dict[str, Any]], out: str | Path) -> Path:
    """The measured error per trial of every noisy run (the paper's Figs. 6 and 11 way),
    one panel per experiment; written to ``out/noisy_robot.png``.
    """
    plt = pyplot()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    results = [r for r in results if r.get("study") != "bracket"]
    exps = sorted({r["experiment"] for r in results if r.get("kind") == "noisy"})
    fig, axes = plt.subplots(len(exps), 1, figsize=(6.5, 2.8 * len(exps)), squeeze=False)
    for ax, exp in zip(axes[:, 0], exps, strict=True):
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
    return save_figure(fig, out / "noisy_robot.png")


PART = Part(
    "noisy", "A noisy robot (matchbox and 2-D pouring; docs/growing.md)",
    plan=plan_noisy, run=run_noisy, summarize=summarize_noisy, markdown_of=markdown_noisy, figure=figure_noisy, needs=None,
)
