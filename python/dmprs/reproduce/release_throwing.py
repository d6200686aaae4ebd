"""Reproduction part "the final-velocity throw beside today's": the arm learns the same
unseen baskets as :mod:`dmprs.reproduce.throwing` with the final-velocity throw
(:mod:`dmprs.tasks.arm_throwing.release`: the movement up to the release a DMP with a final
velocity, generalized with its release state, then a braking movement), with the same
generalizers, learners, basket sizes and trial cap, on the exact robot. The table puts its
trials to success beside today's throw's for the same baskets, read from the throwing part's
runs of the same reproduction (a row whose baskets today's runs do not cover says so).

Wiring as :mod:`dmprs.reproduce.throwing`, whose spec and runner it reuses:
:func:`plan_release` (the specs, ``kind`` :data:`KIND`), :func:`run_release`,
:func:`summarize_release`, :func:`markdown_release`, :func:`figure_release` (the miss per trial,
both throws).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from dmprs.plots import pyplot, save_figure
from dmprs.reproduce.part import Part
from dmprs.reproduce.stats import trial_stats
from dmprs.reproduce.throwing import ThrowingSpec, baskets, run_throwing

KIND = "throwing-release"
#: today's exact-robot runs of the throwing part (plan_throwing), which this part repeats:
#: (basket radius m, generalizers, learners)
SETTINGS = ((0.05, ("linear", "lwr-gp", "lwr-gp-affine"), ("secant", "error", "cma")),
            (0.02, ("linear",), ("secant", "error", "finite-difference", "broyden")))


def plan_release(quick: bool = False) -> list[ThrowingSpec]:
    """Full: the throwing part's exact-robot runs (10 inside and 10 outside baskets; 5 cm with
    the three generalizers x secant, error, CMA-ES; 2 cm with linear x secant, error,
    finite-difference, Broyden) with the final-velocity throw. Quick: the throwing part's quick
    runs (two inside baskets and one outside, linear, secant).
    """
    if quick:
        b = baskets(2)
        return [ThrowingSpec(t, region, "linear", "secant", kind=KIND) for region in ("inside", "outside")
                for t in b[region][: 2 if region == "inside" else 1]]
    b = baskets(10)
    return [ThrowingSpec(t, region, gen, lrn, tol=tol, kind=KIND) for tol, gens, learners in SETTINGS
            for gen in gens for lrn in learners for region in ("inside", "outside") for t in b[region]]


def run_release(spec: ThrowingSpec) -> dict[str, Any]:
    """Learns ``spec`` with the final-velocity throw (:func:`dmprs.reproduce.throwing.run_throwing`)."""
    return run_throwing(spec, release=True)


def _key(r: dict[str, Any]) -> tuple[float, str, str, str]:
    return (-r["tol"], r["region"], r["generalizer"], r["learner"])


def summarize_release(results: list[dict[str, Any]]) -> dict[str, Any]:
    """Per basket radius, region, generalizer and learner: trials to success (median, range,
    successes) of the final-velocity throw and, over the same baskets, of today's throw (the
    throwing part's exact-robot runs in ``results``; None where it has none). ``demos``: the
    demonstrations' measured landings with either encoding and the largest distance between them.
    """
    mine = [r for r in results if r.get("kind") == KIND]
    today = [r for r in results if r.get("kind") == "throwing" and r["noise"] is None]
    rows = []
    for k in sorted({_key(r) for r in mine}):
        group = [r for r in mine if _key(r) == k]
        targets = {tuple(r["target"]) for r in group}
        theirs = [r for r in today if _key(r) == k and tuple(r["target"]) in targets]
        tol, region, gen, lrn = -k[0], *k[1:]
        budget = group[0]["max_trials"]
        rows.append({"part": KIND, "region": region, "generalizer": gen, "tol": tol, "learner": lrn,
                     "experiment": f"{len(group)} basket{'' if len(group) == 1 else 's'} of {100 * tol:g} cm {region} the demos' range, {gen}, "
                     "exact robot",
                     "final_velocity": trial_stats([r["trials_to_success"] for r in group], budget),
                     "today": trial_stats([r["trials_to_success"] for r in theirs], budget) if theirs else None,
                     "today_baskets": len({tuple(r["target"]) for r in theirs})})
    demos: dict[str, Any] = {}
    for name, runs in (("today", today), ("final_velocity", mine)):
        if runs:
            demos[name] = runs[0]["demos"]
    if len(demos) == 2:
        demos["max_shift"] = float(np.linalg.norm(np.subtract(demos["today"], demos["final_velocity"]), axis=1).max())
    return {"rows": rows, "demos": demos}


def _cell(stats: dict[str, Any] | None) -> str:
    if stats is None:
        return "not run"
    med = "-" if stats["median"] is None else f"{stats['median']:g} [{stats['min']}-{stats['max']}]"
    return f"{stats['successes']}/{stats['runs']}, {med}"


def markdown_release(data: dict[str, Any]) -> str:
    """The table: the final-velocity throw's trials to success beside today's."""
    lines = [("Trials to success (succeeded/runs, median [range]; the first, purely generalized, trial counts) "
             "on the same baskets, today's throw (one DMP for the whole throw) beside the final-velocity throw "
             "(the movement up to the release a DMP with a final velocity, generalized with its release "
             "position and velocity, then a braking movement; docs/throwing.md)."), "",
             "| baskets | learner | today's throw | final-velocity throw |", "|---|---|---|---|"]
    for r in data["rows"]:
        lines.append(f"| {r['experiment']} | {r['learner']} | {_cell(r['today'])} | {_cell(r['final_velocity'])} |")
    demos = data["demos"]
    if "max_shift" in demos:
        lines += ["", (f"The demonstrations' measured landings with the final-velocity encoding are within "
                  f"{100 * demos['max_shift']:.1f} cm of today's encoding's (the same scripted throws).")]
    return "\n".join(lines) + "\n"


def figure_release(results: list[dict[str, Any]], out: str | Path) -> Path | None:
    """The distance of the landing from the basket per trial, today's throw beside the
    final-velocity throw (linear, secant; the 2 cm baskets where they were run, else the 5 cm
    ones; inside and outside); ``out/throwing_release.png``.
    """
    def runs(kind: str, tol: float) -> list[dict[str, Any]]:
        return [r for r in results if r.get("kind") == kind and r["noise"] is None and r["tol"] == tol
                and r["generalizer"] == "linear" and r["learner"] == "secant"]

    tol = 0.02 if runs(KIND, 0.02) else 0.05
    if not runs(KIND, tol):
        return None
    plt = pyplot()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    fig, axes = plt.subplots(1, 2, figsize=(10.0, 4.0), sharey=True, squeeze=False)
    for ax, (kind, title) in zip(axes[0], (("throwing", "today's throw"), (KIND, "final-velocity throw")), strict=True):
        for r in runs(kind, tol):
            miss = [t["miss"] for t in r["trials"] if t["miss"] is not None]
            color = "C0" if r["region"] == "inside" else "C3"
            ax.plot(range(1, len(miss) + 1), miss, "o-", color=color, ms=3, lw=0.8, alpha=0.7)
        ax.axhline(tol, color="k", lw=0.8, ls="--")
        ax.set_yscale("log")
        ax.xaxis.get_major_locator().set_params(integer=True)
        ax.set(xlabel="trial", title=f"{title}, {100 * tol:g} cm baskets (blue inside, red outside)")
        ax.title.set_fontsize(9)
    axes[0][0].set_ylabel("distance of the landing from the basket (m)")
    return save_figure(fig, out / "throwing_release.png")


PART = Part(
    KIND, "The final-velocity throw beside today's throw (docs/throwing.md)",
    plan=plan_release, run=run_release, summarize=summarize_release, markdown_of=markdown_release,
    figure=figure_release, needs="mujoco",
)
