"""The reproduction's table: trials to success per experiment and learner, against the paper."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from dmprs.baselines import METHODS
from dmprs.reproduce.parts import PARTS
from dmprs.reproduce.plan import SEED_KEYS
from dmprs.reproduce.stats import cell, trial_stats

PAPER = {
    "matchbox": "Fig. 4: 4 trials in simulation (eq. 16, K = I); 5 on the real robot",
    "matchbox_both_flipped_back": "Fig. 7: succeeds; trial count not given",
    "pouring": "Fig. 9: converges for several volumes at similar rates; no count given",
    "arm_pouring": "Fig. 9 on the KUKA LWR arm: converges for several volumes; no count given",
    "baselines": "not reported in the paper",
}



def _first_signals(run: dict[str, Any]) -> dict[str, Any]:
    """The numeric signals of a run's first, purely generalized trial."""
    return {k: v for k, v in run["trials"][0]["signals"].items() if isinstance(v, (int, float))} \
        if run["trials"] else {}


def _learn_rows(results: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """One row per setting and learner: the runs that differ only in a seed (:data:`SEED_KEYS`)
    are one setting, with their trials to success as median, range and success count, and each
    run's seed, count and first trial's signals kept in ``per_run``.
    """
    groups: dict[tuple[Any, ...], list[dict[str, Any]]] = {}
    for r in results:
        if r["kind"] == "learn":
            setting = tuple((k, v) for k, v in r["setup"].items() if k not in SEED_KEYS)
            groups.setdefault((r["part"], r["experiment"], setting, r["learner"]), []).append(r)
    rows = []
    for (part, experiment, setting, learner), runs in groups.items():
        failed = [r["stop_reason"] for r in runs if not r["converged"]]
        rows.append({"part": part, "experiment": f"{experiment} ({', '.join(f'{k} {v}' for k, v in setting)})",
                     "setting": dict(setting), "learner": learner,
                     **trial_stats([r["trials_to_success"] for r in runs], max(r["n_trials"] for r in runs)
                                   if failed else None),
                     "paper": PAPER[part], "stop_reason": failed[0] if len(failed) == len(runs) else None,
                     "per_run": [{"seeds": {k: r["setup"][k] for k in SEED_KEYS if k in r["setup"]},
                                  "trials_to_success": r["trials_to_success"],
                                  "first_signals": _first_signals(r)} for r in runs]})
    return rows


def summarize(results: list[dict[str, Any]]) -> dict[str, Any]:
    """The table: per experiment and learner, trials to success (median and range), and each
    part's section (its Markdown and the data it was written from).
    """
    rows = _learn_rows(results)
    groups: dict[tuple, list[dict[str, Any]]] = {}
    for r in results:
        if r["kind"] == "baseline":
            groups.setdefault((r["setup"].get("demos"), r["method"], r["sigma_frac"]), []).append(r)
    for (demos, method, sf), runs in groups.items():
        name = METHODS[method].name
        rows.append({"part": "baselines", "experiment": f"matchbox (demos {demos})",
                     "setting": {"demos": demos, "method": method, "sigma_frac": sf, "name": name},
                     "learner": f"{name}, sigma {sf} x max abs(w), {len(runs)} seeds",
                     **trial_stats([r["trials_to_success"] for r in runs], runs[0]["budget"]),
                     "paper": PAPER["baselines"]})
    sections = []
    for part in PARTS:
        if any(r.get("kind") == part.kind for r in results):
            data = part.summarize(results)
            sections.append({"kind": part.kind, "title": part.title, "data": data, "markdown": part.markdown_of(data)})
    return {"rows": rows, "sections": sections}


def markdown(report: dict[str, Any], figures: list[Path]) -> str:
    """The whole report as markdown, figures linked."""
    lines = ["# dmprs reproduction of Nemec, Vuga, Ude (2013)", "",
             (f"Run {'--quick' if report.get('quick') else 'in full'} with backend "
              f"`{report.get('backend')}` in {report.get('seconds')} s. Trials count every executed "
              "trial, the first (purely generalized) one included. A query-space learner gives one run "
              "per setting in the deterministic simulators and one per liquid wherever a granular liquid "
              "is poured (its outcome is chaotic), and baselines vary their seed: several runs give the "
              "median [range] and the successes."), "",
             "| experiment | learner | trials to success | paper |", "|---|---|---|---|"]
    for row in report["rows"]:
        lines.append(f"| {row['experiment']} | {row['learner']} | {cell(row)} | {row['paper']} |")
    for section in report.get("sections", []):
        lines += ["", f"## {section['title']}", "", section["markdown"].rstrip()]
    lines += [f"\n{note}" for note in report.get("skipped", [])]
    if report.get("timing"):
        lines += ["", "## Where the time went", "",
                  ("Each part's runs, their wall-clock and CPU seconds summed over the workers, and when in "
                   "the job its last run finished; then each experiment of a part that has more than one."), "",
                  "| part | runs | run time (s) | CPU time (s) | finished at (s) |", "|---|---:|---:|---:|---:|"]
        lines += [f"| {p['part']} | {p['runs']} | {p['seconds']:.1f} | {p.get('cpu_seconds', 0.0):.1f} | "
                  f"{p['finished_at']} |" for p in report["timing"]]
        per_experiment = [(p["part"], name, runs, seconds) for p in report["timing"]
                          if len(p.get("experiments", {})) > 1
                          for name, (runs, seconds) in sorted(p["experiments"].items(), key=lambda e: -e[1][1])]
        if per_experiment:
            lines += ["", "| part | experiment | runs | run time (s) |", "|---|---|---:|---:|"]
            lines += [f"| {part} | {name} | {runs:g} | {seconds:.1f} |" for part, name, runs, seconds in per_experiment]
    lines += ["", "Figures:", ""] + [f"![{p.stem}]({p.name})" for p in figures]
    return "\n".join(lines) + "\n"
