"""The reproduction's table: trials to success per experiment and learner, against the paper."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from dmprs.baselines import METHODS
from dmprs.reproduce.parts import PARTS
from dmprs.reproduce.stats import trial_stats

PAPER = {
    "matchbox": "Fig. 4: 4 trials in simulation (eq. 16, K = I); 5 on the real robot",
    "matchbox_both_flipped_back": "Fig. 7: succeeds; trial count not given",
    "pouring": "Fig. 9: converges for several volumes at similar rates; no count given",
    "arm_pouring": "Fig. 9 on the KUKA LWR arm: converges for several volumes; no count given",
    "baselines": "not reported in the paper",
}



def summarize(results: list[dict[str, Any]]) -> dict[str, Any]:
    """The table: per experiment and learner, trials to success (median and range)."""
    rows = []
    for r in results:
        if r["kind"] != "learn":
            continue
        setup = ", ".join(f"{k} {v}" for k, v in r["setup"].items())
        rows.append({"part": r["part"], "experiment": f"{r['experiment']} ({setup})", "learner": r["learner"],
                     **trial_stats([r["trials_to_success"]]), "paper": PAPER[r["part"]],
                     "stop_reason": None if r["converged"] else r["stop_reason"]})
    groups: dict[tuple, list[dict[str, Any]]] = {}
    for r in results:
        if r["kind"] == "baseline":
            groups.setdefault((r["setup"].get("demos"), r["method"], r["sigma_frac"]), []).append(r)
    for (demos, method, sf), runs in groups.items():
        name = METHODS[method].name
        rows.append({"part": "baselines", "experiment": f"matchbox (demos {demos})",
                     "learner": f"{name}, sigma {sf} x max abs(w), {len(runs)} seeds",
                     **trial_stats([r["trials_to_success"] for r in runs], runs[0]["budget"]),
                     "paper": PAPER["baselines"]})
    sections = [{"kind": part.kind, "title": part.title, "markdown": part.markdown(results)}
                for part in PARTS if any(r.get("kind") == part.kind for r in results)]
    return {"rows": rows, "sections": sections}


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
    """The whole report as markdown, figures linked."""
    lines = ["# dmprs reproduction of Nemec, Vuga, Ude (2013)", "",
             (f"Run {'--quick' if report.get('quick') else 'in full'} with backend "
              f"`{report.get('backend')}` in {report.get('seconds')} s. Trials count every executed "
              "trial, the first (purely generalized) one included. Deterministic simulators: a "
              "query-space learner gives one run per setting; baselines vary their seed."), "",
             "| experiment | learner | trials to success | paper |", "|---|---|---|---|"]
    for row in report["rows"]:
        lines.append(f"| {row['experiment']} | {row['learner']} | {_cell(row)} | {row['paper']} |")
    for section in report.get("sections", []):
        lines += ["", f"## {section['title']}", "", section["markdown"].rstrip()]
    lines += [f"\n{note}" for note in report.get("skipped", [])]
    lines += ["", "Figures:", ""] + [f"![{p.stem}]({p.name})" for p in figures]
    return "\n".join(lines) + "\n"
