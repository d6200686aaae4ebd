"""Reproduction part "reach, pour and return as one sequence" (docs/arm.md): the arm runs its three
movements as one :class:`dmprs.Sequence` in the servo loop (:mod:`dmprs.experiments.arm_sequence`),
and the same movements one after another, each ending at rest, with the same liquids. Its truths:
the sequence does not stop at its joins (the commanded and the measured mouth move there), a join
is no rougher than the rest of the movement (the velocity goes on by one Euler step, the
acceleration and the measured velocity change no more across a join than within a movement),
and it pours within the task's tolerance.

Wiring as :mod:`dmprs.reproduce.online`: :func:`plan_sequence` (picklable specs),
:func:`run_sequence`, :func:`summarize_sequence` (one row per execution),
:func:`markdown_sequence`, :func:`figure_sequence`.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dmprs.experiments import arm_sequence as seq
from dmprs.plots import pyplot, save_figure
from dmprs.portable import arctan2, norms
from dmprs.reproduce.part import LIQUID_SEEDS, Part
from dmprs.tasks.arm_pouring import SUCCESS_TOLERANCE, TARGET_VOLUME

KIND = "arm-sequence"
#: s between the samples of the curves a result keeps for the figure
CURVE_PERIOD = 0.01
#: what each execution is, in the report
SETTINGS = {"sequence": f"one Sequence: the phases overlapping by {seq.OVERLAP:g} s, the reach and the pour "
                        "ending moving (final velocities)",
            "stops": "the same movements one after another, each from rest to rest"}


@dataclass(frozen=True)
class SequenceSpec:
    """One execution (:data:`~dmprs.experiments.arm_sequence.EXECUTIONS`) with one liquid."""

    execution: str
    liquid_seed: int = 0
    kind: str = KIND

    @property
    def label(self) -> str:
        """The run's name in progress lines and errors."""
        return f"arm sequence {self.execution} (liquid {self.liquid_seed})"


def plan_sequence(quick: bool = False) -> list[SequenceSpec]:
    """Both executions with every liquid of :data:`LIQUID_SEEDS` (``quick``: the first)."""
    return [SequenceSpec(ex, seed) for ex in seq.EXECUTIONS for seed in (LIQUID_SEEDS[:1] if quick else LIQUID_SEEDS)]


def _change(values: NDArray[np.float64], steps: NDArray[np.int64]) -> list[float]:
    """The largest one-step change of ``values`` (K, 6) into the steps ``steps``, linear and angular."""
    jump = np.abs(values[steps] - values[steps - 1])
    return [float(jump[:, :3].max()), float(jump[:, 3:].max())]


def result_of(run: seq.SequenceRun, spec: SequenceSpec) -> dict[str, Any]:
    """One execution as plain data: when it ended, what it poured, and at each join the
    commanded and measured speeds (m/s, rad/s), the velocity's departure from one Euler step
    (``v[J] - v[J-1] - a[J-1] dt``), and the change of the commanded acceleration and of the
    measured velocity into the join's step, beside the largest such change into any other step
    of the movement; the curves of the figure.
    """
    times, joins = run.run.times, run.joins
    dt = float(times[1] - times[0])
    others = np.setdiff1d(np.flatnonzero((times > 0) & (times <= run.end_time)), joins)
    c = run.commands
    v, a, m = seq.twist(c), seq.twist(c, 2), seq.twist(run.measured)
    every = slice(None, None, max(1, round(CURVE_PERIOD / dt)))
    return {"execution": spec.execution, "liquid_seed": spec.liquid_seed, "end_time": run.end_time,
            "poured_ml": 1000 * run.poured_volume, "error_ml": 1000 * (run.poured_volume - TARGET_VOLUME),
            "tolerance_ml": 1000 * SUCCESS_TOLERANCE,
            "within": bool(abs(run.poured_volume - TARGET_VOLUME) < SUCCESS_TOLERANCE),
            "still": run.still_time, "tracking_error": run.run.tracking_error,
            "joins": [{"t": float(times[j]), "commanded": [float(norms(v[j, :3])), float(norms(v[j, 3:]))],
                       "measured": [float(norms(m[j, :3])), float(norms(m[j, 3:]))],
                       "velocity_step": float(np.abs(v[j] - v[j - 1] - a[j - 1] * dt).max()),
                       "acceleration_change": _change(a, np.array([j])),
                       "measured_change": _change(m, np.array([j]))} for j in joins],
            "acceleration_change": _change(a, others), "measured_change": _change(m, others),
            "curves": {"t": times[every].tolist(), "speed": norms(v[every, :3]).tolist(),
                       "angular_speed": norms(v[every, 3:]).tolist(),
                       "measured_speed": norms(m[every, :3]).tolist(),
                       "measured_angular_speed": norms(m[every, 3:]).tolist(),
                       # the bottle's tilt about the world's x axis (the demonstration's only rotation)
                       "tilt": (2 * arctan2(c.quaternion[every, 1], c.quaternion[every, 0])).tolist()}}


def run_sequence(spec: SequenceSpec) -> dict[str, Any]:
    """Runs one execution (:func:`~dmprs.experiments.arm_sequence.pour`); plain data."""
    return result_of(seq.pour(spec.execution, liquid_seed=spec.liquid_seed), spec)


def held(run: dict[str, Any]) -> bool:
    """Whether ``run`` (a :func:`result_of`) met the sequence's truths: at every join the
    commanded and the measured mouth move (faster than :data:`~dmprs.experiments.arm_sequence.STILL`
    linearly or angularly), the velocity goes on by one Euler step (to rounding), the commanded
    acceleration and the measured velocity change no more into the join's step than into any
    other, and the pour is within the tolerance.
    """
    def moving(speeds: list[float]) -> bool:
        return speeds[0] > seq.STILL[0] or speeds[1] > seq.STILL[1]

    def smooth(change: list[float], elsewhere: list[float]) -> bool:
        return all(c <= e for c, e in zip(change, elsewhere, strict=True))

    return run["within"] and all(
        moving(j["commanded"]) and moving(j["measured"]) and j["velocity_step"] < 1e-9
        and smooth(j["acceleration_change"], run["acceleration_change"])
        and smooth(j["measured_change"], run["measured_change"]) for j in run["joins"])


def _spread(values: list[float], fmt: str) -> str:
    if len(values) == 1 or min(values) == max(values):
        return format(values[0], fmt)
    return f"{format(float(np.median(values)), fmt)} [{format(min(values), fmt)}-{format(max(values), fmt)}]"


def summarize_sequence(results: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """One row per execution over its liquids: when it ends, what it pours (median and range,
    how many within the tolerance), the speeds at its joins (the slowest over the liquids, and
    the joins' times), how smooth its joins are (the largest over the liquids), how long the
    commanded mouth was still, and for the sequence whether it met its truths (:func:`held`)
    with every liquid.
    """
    rows = []
    for execution in seq.EXECUTIONS:
        runs = [r for r in results if r.get("kind") == KIND and r["execution"] == execution]
        if not runs:
            continue
        joins = [[j for r in runs for j in r["joins"] if j["t"] == t] for t in (j["t"] for j in runs[0]["joins"])]

        def low(js: list[dict[str, Any]], key: str, i: int) -> float:
            return min(j[key][i] for j in js)

        def high(key: str, i: int, inside: bool = False, runs: list[dict[str, Any]] = runs) -> float:
            return max(r[key][i] if inside else max(j[key][i] for j in r["joins"]) for r in runs)

        rows.append({
            "part": KIND, "execution": execution, "setting": SETTINGS[execution], "liquids": len(runs),
            "end_time": _spread([r["end_time"] for r in runs], ".2f"),
            "poured_ml": _spread([r["poured_ml"] for r in runs], ".0f"),
            "within": sum(r["within"] for r in runs), "tolerance_ml": runs[0]["tolerance_ml"],
            "joins": [{"t": js[0]["t"], "commanded": [low(js, "commanded", 0), low(js, "commanded", 1)],
                       "measured": [low(js, "measured", 0), low(js, "measured", 1)]} for js in joins],
            "velocity_step": max(j["velocity_step"] for r in runs for j in r["joins"]),
            "acceleration_change": [high("acceleration_change", i) for i in (0, 1)],
            "acceleration_change_inside": [high("acceleration_change", i, True) for i in (0, 1)],
            "measured_change": [high("measured_change", i) for i in (0, 1)],
            "measured_change_inside": [high("measured_change", i, True) for i in (0, 1)],
            "still": _spread([r["still"] for r in runs], ".3f"),
            "met": all(held(r) for r in runs) if execution == "sequence" else None})
    return rows


def markdown_sequence(rows: list[dict[str, Any]]) -> str:
    """The table of the report (and of docs/arm.md)."""
    head = ("| execution | ends at (s) | poured (ml), within the tolerance | at the joins: commanded / measured "
            "speed (m/s, rad/s) | into a join's step: velocity - one Euler step; change of the acceleration "
            "(m/s², rad/s²) and of the measured velocity (m/s, rad/s), largest into any other step | still (s) "
            "| truths met |")
    lines = [head, "|---|---:|---|---|---|---:|---|"]
    for r in rows:
        at = "; ".join(f"t = {j['t']:.3f} s: {j['commanded'][0]:.3g}, {j['commanded'][1]:.3g} / "
                       f"{j['measured'][0]:.3g}, {j['measured'][1]:.3g}" for j in r["joins"])
        smooth = (f"{r['velocity_step']:.1e}; {r['acceleration_change'][0]:.3g}, {r['acceleration_change'][1]:.3g} "
                  f"({r['acceleration_change_inside'][0]:.3g}, {r['acceleration_change_inside'][1]:.3g}) and "
                  f"{r['measured_change'][0]:.2g}, {r['measured_change'][1]:.2g} "
                  f"({r['measured_change_inside'][0]:.2g}, {r['measured_change_inside'][1]:.2g})")
        met = "-" if r["met"] is None else ("yes" if r["met"] else "no")
        lines.append(f"| {r['setting']} | {r['end_time']} | {r['poured_ml']}, {r['within']}/{r['liquids']} within "
                     f"{r['tolerance_ml']:g} ml | {at} "
                     f"| {smooth} | {r['still']} | {met} |")
    return "\n".join(lines) + "\n"


def figure_sequence(results: list[dict[str, Any]], out: str | Path) -> Path | None:
    """Three panels, ``out/arm_sequence.png``, liquid 0: the mouth's commanded and measured
    speed, its angular speed, and the bottle's tilt, for the sequence and the stops, the joins
    marked.
    """
    runs = [r for r in results if r.get("kind") == KIND and r["liquid_seed"] == 0]
    if not runs:
        return None
    plt = pyplot()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    fig, ax = plt.subplots(1, 3, figsize=(13, 3.8), sharex=True)
    panels = (("speed", "mouth speed (m/s)"), ("angular_speed", "angular speed (rad/s)"), ("tilt", "tilt (rad)"))
    for r in runs:
        c, name = ("C0", "sequence") if r["execution"] == "sequence" else ("C3", "one after another, at rest")
        curves = r["curves"]
        for axis, (key, label) in zip(ax, panels, strict=True):
            axis.plot(curves["t"], curves[key], color=c, lw=1.5, label=f"{name}, commanded")
            if f"measured_{key}" in curves:
                axis.plot(curves["t"], curves[f"measured_{key}"], color=c, lw=0.8, ls="--", label=f"{name}, measured")
            for j in r["joins"]:
                axis.axvline(j["t"], color=c, lw=0.6, ls=":")
            axis.set(xlabel="t (s)", ylabel=label)
        for k in (0, 1):  # the commanded speed on each join's sample
            ax[k].plot([j["t"] for j in r["joins"]], [j["commanded"][k] for j in r["joins"]], "o", color=c, ms=4)
    ax[0].set_title("Reach, pour, return: joins dotted, o on the join's sample")
    ax[0].legend(fontsize=7)
    fig.tight_layout()
    return save_figure(fig, out / "arm_sequence.png")


PART = Part(
    KIND, "Reach, pour and return as one sequence on the arm (docs/arm.md)",
    plan=plan_sequence, run=run_sequence, summarize=summarize_sequence, markdown_of=markdown_sequence,
    figure=figure_sequence, needs="mujoco",
)
