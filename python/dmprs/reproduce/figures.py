"""The reproduction's figures: the paper's Figs. 4, 7 and 9 and the baseline comparison."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from dmprs.experiments.arm_pouring import frame_strip
from dmprs.plots import pyplot, save_figure
from dmprs.reproduce.parts import PARTS


def write_figures(results: list[dict[str, Any]], out: Path) -> list[Path]:
    """Figs. 4, 7, 9 in the paper's style and a baseline comparison (needs matplotlib)."""
    try:

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
        paths.append(save_figure(fig, out / fname))
    for part, tol_ml, title, fname in (
            ("pouring", 10, "Pouring, golden section (Fig. 9)", "fig9_pouring.png"),
            ("arm_pouring", 20, "Pouring with the 7-DOF arm (MuJoCo), golden section, liquid 0",
             "fig9_arm_pouring.png")):
        # one liquid's runs (the first drawn): every liquid's would hide the learning in clutter
        runs = [r for r in results if r["kind"] == "learn" and r["part"] == part and r["learner"] == "golden"
                and r["setup"].get("liquid_seed", 0) == 0]
        if not runs:
            continue
        fig, ax = plt.subplots(2, 1, figsize=(6.5, 5.5), sharex=True)
        for r in runs:
            n = np.arange(1, len(r["trials"]) + 1)
            err = [1000 * t["signals"].get("poured_volume", np.nan) - 200 for t in r["trials"]]
            line, = ax[0].plot(n, err, "o-", label=f"bottle {r['setup']['bottle_volume']} l")
            ax[1].plot(n, [t["query"][0] for t in r["trials"]], "o-", color=line.get_color())
        ax[0].axhspan(-tol_ml, tol_ml, color="green", alpha=0.1)
        ax[0].set(ylabel="poured - 200 ml (ml)", title=title)
        ax[1].set(ylabel="learned query (l)", xlabel="trial")
        ax[1].xaxis.get_major_locator().set_params(integer=True)
        ax[0].legend(fontsize=7)
        paths.append(save_figure(fig, out / fname))
    if any(r["kind"] == "learn" and r["part"] == "arm_pouring" for r in results):

        strip = frame_strip(out)  # None, with a one-line note, where no OpenGL backend is available
        if strip is not None:
            paths.append(Path(strip))
    base = [r for r in results if r["kind"] == "baseline"]
    if base:
        fig, ax = plt.subplots(figsize=(9, 3.8))
        labels, data = [], []
        for (demos, method) in sorted({(r["setup"].get("demos"), r["method"]) for r in base}):
            rs = [r for r in base if r["setup"].get("demos") == demos and r["method"] == method]
            labels.append(f"{method}\n{str(demos).replace('_', ' ')}")
            data.append([r["trials_to_success"] or r["budget"] for r in rs])
        for demos in sorted({r["setup"].get("demos") for r in base}):
            ql = [r for r in results if r["kind"] == "learn" and r["experiment"] == "matchbox"
                  and r["setup"].get("demos") == demos and r["trials_to_success"]]
            if ql:
                labels.append(f"query learners\n{str(demos).replace('_', ' ')}")
                data.append([r["trials_to_success"] for r in ql])
        ax.boxplot(data, tick_labels=labels)
        ax.set_yscale("log")
        ax.set(ylabel="trials to upright (budget if never)", title="Matchbox: weight space vs query space")
        ax.tick_params(axis="x", labelsize=7)
        paths.append(save_figure(fig, out / "baselines.png"))
    for extra in PARTS:
        if any(r.get("kind") == extra.kind for r in results):
            path = extra.figure(results, out)
            if path is not None:
                paths.append(Path(path))
    return paths
