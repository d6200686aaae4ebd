"""``dmprs reproduce``: the paper's experiments in simulation, and the baselines, as one job.

Parts (paper figure in brackets):

1. Matchbox, demos flipped back + flipped over, every query learner (Fig. 4; paper: 4 trials).
2. Matchbox, both demos flipped back: pi/2 outside the demos (Fig. 7; paper: succeeds).
3. Pouring 0.2 l from bottles of 0.4, 0.5, 0.7 l and 0.25 l (outside the demos' 0.3-1.0 l)
   with golden section, fixed-gain error learning and the root finder (Fig. 9; no count given).
4. Baselines (not in the paper): PoWER and PI² in the full DMP weight space over seeds and
   exploration levels, and the constrained-domain policy gradient, from the same first trial.

Every run goes through :func:`dmprs.parallel.pmap` (local processes by default, or Ray). The
job writes ``report.md``, ``report.json`` and PNG figures into ``out``.
"""

from __future__ import annotations

import json
import os
import statistics
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from dmprs.baselines import BaselineSpec, run_baseline
from dmprs.parallel import pmap

PAPER = {
    "matchbox": "Fig. 4: 4 trials in simulation (eq. 16, K = I); 5 on the real robot",
    "matchbox_both_flipped_back": "Fig. 7: succeeds; trial count not given",
    "pouring": "Fig. 9: converges for several volumes at similar rates; no count given",
    "baselines": "not reported in the paper",
}


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


def run_learning(spec: LearnSpec) -> dict[str, Any]:
    """Runs one learning experiment; returns its trials as plain data."""
    from dmprs import experiments

    r = experiments.run(spec.experiment, learner=spec.learner, max_trials=spec.max_trials,
                        **dict(spec.setup))
    trials = [{
        "query": t.query.tolist(), "status": t.status,
        "eps": None if t.eps is None else t.eps.tolist(), "success": t.success,
        "signals": {k: v for k, v in t.signals.items() if isinstance(v, (int, float, str))},
    } for t in r.trials]
    return {"kind": "learn", "part": spec.part, "experiment": spec.experiment,
            "setup": dict(spec.setup), "learner": spec.learner, "converged": r.converged,
            "trials_to_success": r.trials_to_success, "n_trials": r.n_trials,
            "stop_reason": r.stop_reason,
            "learned_query": None if r.learned_query is None else r.learned_query.tolist(),
            "trials": trials}


def _baseline(spec: BaselineSpec) -> dict[str, Any]:
    out = run_baseline(spec)
    out.update(kind="baseline", part="baselines", setup=dict(spec.setup))
    return out


def _dispatch(spec: LearnSpec | BaselineSpec) -> dict[str, Any]:
    return run_learning(spec) if isinstance(spec, LearnSpec) else _baseline(spec)


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


def _prepare_pouring(specs: list[Any], cache_dir: Path) -> None:
    """Calibrates the pouring demonstrations once, before workers start, into the disk cache."""
    if not any(getattr(s, "experiment", "") == "pouring" for s in specs):
        return
    from dmprs.tasks.pouring import DEMO_VOLUMES, demonstration

    for v in DEMO_VOLUMES:
        demonstration(v, cache_dir=str(cache_dir))


def reproduce(out: str | Path = "out", *, quick: bool = False, backend: str = "local",
              workers: int | None = None,
              progress: Callable[[int, int, dict[str, Any]], None] | None = None) -> dict[str, Any]:
    """Runs the whole job; writes figures and the report into ``out``; returns the report."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    cache = out / ".cache"
    cache.mkdir(exist_ok=True)
    specs = plan(quick)
    start = time.perf_counter()
    # Workers inherit the environment: they read the pouring calibration from this disk cache.
    saved = os.environ.get("DMPRS_CACHE_DIR")
    os.environ["DMPRS_CACHE_DIR"] = saved or str(cache.resolve())
    done = [0]

    def on_result(i: int, r: dict[str, Any]) -> None:
        done[0] += 1
        if progress:
            progress(done[0], len(specs), r)

    try:
        _prepare_pouring(specs, Path(os.environ["DMPRS_CACHE_DIR"]))
        results = pmap(_dispatch, specs, backend=backend, workers=workers, on_result=on_result)
    finally:
        if saved is None:
            del os.environ["DMPRS_CACHE_DIR"]
    report = summarize(results)
    report.update(quick=quick, backend=backend, seconds=round(time.perf_counter() - start, 1))
    (out / "report.json").write_text(json.dumps({"summary": report, "runs": results}, indent=1, default=str))
    figures = write_figures(results, out)
    (out / "report.md").write_text(markdown(report, figures))
    return report


def _stats(values: list[int | None], budget: int | None = None) -> dict[str, Any]:
    ok = [v for v in values if v is not None]
    return {"runs": len(values), "successes": len(ok),
            "median": statistics.median(ok) if len(ok) == len(values) and ok else
            (statistics.median(ok + [float("inf")] * (len(values) - len(ok))) if ok else None),
            "min": min(ok) if ok else None, "max": max(ok) if ok else None, "budget": budget}


def summarize(results: list[dict[str, Any]]) -> dict[str, Any]:
    """The table: per experiment and learner, trials to success (median and range)."""
    rows = []
    for r in results:
        if r["kind"] != "learn":
            continue
        setup = ", ".join(f"{k} {v}" for k, v in r["setup"].items())
        rows.append({"part": r["part"], "experiment": f"{r['experiment']} ({setup})", "learner": r["learner"],
                     **_stats([r["trials_to_success"]]), "paper": PAPER[r["part"]],
                     "stop_reason": None if r["converged"] else r["stop_reason"]})
    groups: dict[tuple, list[dict[str, Any]]] = {}
    for r in results:
        if r["kind"] == "baseline":
            groups.setdefault((r["setup"].get("demos"), r["method"], r["sigma_frac"]), []).append(r)
    for (demos, method, sf), runs in groups.items():
        name = {"power": "PoWER", "pi2": "PI²"}[method]
        rows.append({"part": "baselines", "experiment": f"matchbox (demos {demos})",
                     "learner": f"{name}, sigma {sf} x max abs(w), {len(runs)} seeds",
                     **_stats([r["trials_to_success"] for r in runs], runs[0]["budget"]),
                     "paper": PAPER["baselines"]})
    return {"rows": rows}


def _cell(row: dict[str, Any]) -> str:
    if row["successes"] == 0:
        if row.get("stop_reason"):
            return f"not solved: {row['stop_reason']}"
        return f"none within {row['budget'] or 'the cap'}"
    med = row["median"]
    med_s = f">{row['budget']}" if med == float("inf") else f"{med:g}"
    if row["runs"] == 1:
        return med_s
    return f"{med_s} [{row['min']}-{row['max']}], {row['successes']}/{row['runs']} succeeded"


def markdown(report: dict[str, Any], figures: list[Path]) -> str:
    lines = ["# dmprs reproduction of Nemec, Vuga, Ude (2013)", "",
             f"Run {'--quick' if report.get('quick') else 'in full'} with backend "
             f"`{report.get('backend')}` in {report.get('seconds')} s. Trials count every executed "
             "trial, the first (purely generalized) one included. Deterministic simulators: a "
             "query-space learner gives one run per setting; baselines vary their seed.", "",
             "| experiment | learner | trials to success | paper |", "|---|---|---|---|"]
    for row in report["rows"]:
        lines.append(f"| {row['experiment']} | {row['learner']} | {_cell(row)} | {row['paper']} |")
    lines += ["", "Figures:", ""] + [f"![{p.stem}]({p.name})" for p in figures]
    return "\n".join(lines) + "\n"


def write_figures(results: list[dict[str, Any]], out: Path) -> list[Path]:
    """Figs. 4, 7, 9 in the paper's style and a baseline comparison (needs matplotlib)."""
    try:
        from dmprs.plots import pyplot

        plt = pyplot()
    except Exception:  # noqa: BLE001 - the report is written without figures
        return []
    paths = []
    for part, title, fname in (("matchbox", "Matchbox (Fig. 4)", "fig4_matchbox.png"),
                               ("matchbox_both_flipped_back", "Matchbox, both demos flipped back (Fig. 7)",
                                "fig7_matchbox_extrapolation.png")):
        runs = [r for r in results if r["kind"] == "learn" and r["part"] == part]
        if not runs:
            continue
        fig, ax = plt.subplots(2, 1, figsize=(6.5, 5.5), sharex=True)
        for r in runs:
            n = np.arange(1, len(r["trials"]) + 1)
            q = [np.degrees(t["query"][0]) for t in r["trials"]]
            qa = [np.degrees(t["signals"].get("outcome_angle", np.nan)) for t in r["trials"]]
            line, = ax[0].plot(n, qa, "o-", label=f"{r['learner']}: achieved angle")
            ax[0].plot(n, q, "x:", color=line.get_color(), alpha=0.6)
            ax[1].plot(n, [np.degrees(t["eps"][0]) if t["eps"] else np.nan for t in r["trials"]], "o-",
                       color=line.get_color(), label=r["learner"])
        ax[0].axhline(90, color="grey", ls="--", lw=0.8)
        ax[0].set(ylabel="angle (deg)", title=f"{title}: o achieved, x query")
        ax[1].axhline(0, color="grey", lw=0.8)
        ax[1].set(ylabel="error eps (deg)", xlabel="trial")
        ax[1].xaxis.get_major_locator().set_params(integer=True)
        ax[0].legend(fontsize=7)
        fig.tight_layout()
        paths.append(out / fname)
        fig.savefig(paths[-1], dpi=110)
        plt.close(fig)
    runs = [r for r in results if r["kind"] == "learn" and r["part"] == "pouring" and r["learner"] == "golden"]
    if runs:
        fig, ax = plt.subplots(2, 1, figsize=(6.5, 5.5), sharex=True)
        for r in runs:
            n = np.arange(1, len(r["trials"]) + 1)
            err = [1000 * t["signals"].get("poured_volume", np.nan) - 200 for t in r["trials"]]
            line, = ax[0].plot(n, err, "o-", label=f"bottle {r['setup']['bottle_volume']} l")
            ax[1].plot(n, [t["query"][0] for t in r["trials"]], "o-", color=line.get_color())
        ax[0].axhspan(-10, 10, color="green", alpha=0.1)
        ax[0].set(ylabel="poured - 200 ml (ml)", title="Pouring, golden section (Fig. 9)")
        ax[1].set(ylabel="learned query (l)", xlabel="trial")
        ax[1].xaxis.get_major_locator().set_params(integer=True)
        ax[0].legend(fontsize=7)
        fig.tight_layout()
        paths.append(out / "fig9_pouring.png")
        fig.savefig(paths[-1], dpi=110)
        plt.close(fig)
    base = [r for r in results if r["kind"] == "baseline"]
    if base:
        fig, ax = plt.subplots(figsize=(7, 3.8))
        labels, data = [], []
        for (demos, method) in sorted({(r["setup"].get("demos"), r["method"]) for r in base}):
            rs = [r for r in base if r["setup"].get("demos") == demos and r["method"] == method]
            labels.append(f"{method}\n{demos}")
            data.append([r["trials_to_success"] or r["budget"] for r in rs])
        for demos in sorted({r["setup"].get("demos") for r in base}):
            ql = [r for r in results if r["kind"] == "learn" and r["experiment"] == "matchbox"
                  and r["setup"].get("demos") == demos and r["trials_to_success"]]
            if ql:
                labels.append(f"query learners\n{demos}")
                data.append([r["trials_to_success"] for r in ql])
        ax.boxplot(data, tick_labels=labels)
        ax.set_yscale("log")
        ax.set(ylabel="trials to upright (budget if never)", title="Matchbox: weight space vs query space")
        ax.tick_params(axis="x", labelsize=7)
        fig.tight_layout()
        paths.append(out / "baselines.png")
        fig.savefig(paths[-1], dpi=110)
        plt.close(fig)
    return paths
