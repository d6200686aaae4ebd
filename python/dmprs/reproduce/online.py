"""Reproduction part "a stepper in the arm's servo loop" (docs/arm.md): the three scenarios of
:mod:`dmprs.experiments.online_arm`, each with its truth: the held pour ends within the task's
tolerance with phase stopping; the ball lands in the moved basket; the velocity-limited move keeps
its commanded and measured speeds within the limits on the DMP's path.

Wiring as :mod:`dmprs.reproduce.growing`: :func:`plan_online` (picklable specs),
:func:`run_online`, :func:`summarize_online` (table rows), :func:`figure_online`.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from dmprs.errors import InvalidInputError
from dmprs.experiments import online_arm as oa
from dmprs.plots import pyplot, save_figure
from dmprs.portable import norm
from dmprs.reproduce.part import LIQUID_SEEDS, Part
from dmprs.tasks.arm_pouring import SUCCESS_TOLERANCE as POUR_TOLERANCE
from dmprs.tasks.arm_pouring import TARGET_VOLUME
from dmprs.tasks.arm_throwing import SUCCESS_TOLERANCE as BASKET_TOLERANCE

#: s between the samples of the curves a result keeps for the figure
CURVE_PERIOD = 0.01
#: the wrist joint (A7), which tilts the bottle: the held pour's curves
WRIST = 6


@dataclass(frozen=True)
class OnlineSpec:
    """One scenario: ``"held-pour"`` (``value``: alpha_e, with the liquid of ``liquid_seed``),
    ``"moving-basket"`` (``value``: the time of the basket's move, s) or ``"velocity-limit"``
    (``value`` unused).
    """

    scenario: str
    value: float = 0.0
    liquid_seed: int = 0
    kind: str = "online"

    @property
    def label(self) -> str:
        """The run's name in progress lines and errors."""
        return f"online {self.scenario} {self.value:g} (liquid {self.liquid_seed})"


def plan_online(quick: bool = False) -> list[OnlineSpec]:
    """The held pour with and without phase stopping, each with every liquid of
    :data:`LIQUID_SEEDS`; the basket moved at several times; the velocity limit (``quick``: one
    liquid, one move).
    """
    moves = (oa.MOVE_TIME,) if quick else (oa.MOVE_TIME, 0.6, 0.9, 1.1)
    liquids = LIQUID_SEEDS[:1] if quick else LIQUID_SEEDS
    return [*(OnlineSpec("held-pour", alpha_e, seed) for alpha_e in (1e4, 0.0) for seed in liquids),
            *(OnlineSpec("moving-basket", t) for t in moves), OnlineSpec("velocity-limit")]


def _every(times: np.ndarray) -> slice:
    return slice(None, None, max(1, round(CURVE_PERIOD / float(times[1] - times[0]))))


def run_online(spec: OnlineSpec) -> dict[str, Any]:
    """Runs one scenario; plain data (numbers, and the curves of the figure)."""
    out: dict[str, Any] = {"scenario": spec.scenario, "value": spec.value}
    if spec.scenario == "held-pour":
        r = oa.held_pour(oa.pour_dmp(), alpha_e=spec.value, liquid_seed=spec.liquid_seed)
        run, every = r.run, _every(r.run.times)
        out.update(alpha_e=spec.value, liquid_seed=spec.liquid_seed, hold=[oa.HOLD_START, oa.HOLD],
                   poured_ml=1000 * r.poured_volume, error_ml=1000 * (r.poured_volume - TARGET_VOLUME),
                   tolerance_ml=1000 * POUR_TOLERANCE, tracking_error=run.tracking_error, hold_drift=r.hold_drift,
                   phase_kept=r.phase_kept, end_time=run.end_time,
                   met=bool(abs(r.poured_volume - TARGET_VOLUME) < POUR_TOLERANCE),
                   t=run.times[every].tolist(), command=run.command[every, WRIST].tolist(),
                   q=run.q[every, WRIST].tolist())
    elif spec.scenario == "moving-basket":
        b = oa.moving_basket_throw(move_time=spec.value)
        dist = {name: norm(getattr(b, name).landing - b.moved)
                for name in ("updated", "ignored", "planned")}
        out.update(move_time=spec.value, basket=b.basket.tolist(), moved=b.moved.tolist(),
                   landings={name: getattr(b, name).landing.tolist() for name in dist}, distances=dist,
                   tau=list(b.tau), tolerance=BASKET_TOLERANCE, met=bool(dist["updated"] < BASKET_TOLERANCE))
    elif spec.scenario == "velocity-limit":
        lim = oa.velocity_limited_move()
        runs = {"free": lim.free, "limited": lim.limited}
        out.update(
            speed={k: lim.speed_ratio(v) for k, v in runs.items()},
            measured_speed={k: lim.speed_ratio(v, measured=True) for k, v in runs.items()},
            duration={k: lim.duration(v) for k, v in runs.items()},
            deviation={k: lim.deviation(v) for k, v in runs.items()},
            measured_deviation={k: lim.deviation(v, measured=True) for k, v in runs.items()},
            met=bool(lim.speed_ratio(lim.limited, measured=True) <= 1.0 and lim.deviation(lim.limited) < 1e-6),
            curves={k: {"t": v.times[_every(v.times)].tolist(),
                        "ratio": (np.abs(v.qd) / lim.limits).max(axis=1)[_every(v.times)].tolist()}
                    for k, v in runs.items()})
    else:
        raise InvalidInputError(f"scenario = {spec.scenario!r}: expected held-pour, moving-basket or velocity-limit")
    return out


def summarize_online(results: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """One row per setting: the scenario, its setting, what was measured, its truth and whether it
    held. The held pour's liquids are one setting: medians and ranges over them, held when every
    liquid's pour is within the tolerance.
    """
    rows = []
    online = [r for r in results if r.get("kind") == "online"]
    held = [r for r in online if r["scenario"] == "held-pour"]
    for alpha_e in dict.fromkeys(r["alpha_e"] for r in held):
        runs = [r for r in held if r["alpha_e"] == alpha_e]
        r = runs[0]

        def spread(key: str, fmt: str, runs: list[dict[str, Any]] = runs) -> str:
            v = [x[key] for x in runs]
            if len(v) == 1:
                return format(v[0], fmt)
            return f"{format(float(np.median(v)), fmt)} [{format(min(v), fmt)}-{format(max(v), fmt)}]"

        met = sum(x["met"] for x in runs)
        rows.append({"part": "online", "scenario": "held-pour",
                     "setting": f"held {r['hold'][1]:g} s from {r['hold'][0]:g} s, alpha_e = {alpha_e:g}, "
                                f"{len(runs)} liquid(s)",
                     "measured": (f"poured {spread('poured_ml', '.0f')} ml, {met}/{len(runs)} within; tracking "
                                  f"error {spread('tracking_error', '.3f')} rad; phase kept {spread('phase_kept', '.3f')}; "
                                  f"ends at {spread('end_time', '.2f')} s"),
                     "truth": f"abs error < {r['tolerance_ml']:g} ml", "met": met == len(runs)})
    for r in online:
        if r["scenario"] == "held-pour":
            continue
        if r["scenario"] == "moving-basket":
            d = r["distances"]
            setting = f"basket moved {100 * norm(np.subtract(r['moved'], r['basket'])):.0f} cm at {r['move_time']:g} s"
            measured = (f"landed {100 * d['updated']:.1f} cm from it (ignoring the move {100 * d['ignored']:.1f} cm, "
                        f"its own DMP {100 * d['planned']:.1f} cm); tau {r['tau'][0]:g} -> {r['tau'][1]:g} s")
            truth = f"< {100 * r['tolerance']:g} cm"
        else:
            setting = f"A1, A7 at {oa.LIMIT_EXCESS:g} x their limits"
            measured = (f"peak speed / limit {r['speed']['free']:.3f} free, {r['speed']['limited']:.3f} commanded and "
                        f"{r['measured_speed']['limited']:.4f} measured limited; {r['duration']['free']:.3f} -> "
                        f"{r['duration']['limited']:.3f} s; off the path: command {r['deviation']['limited']:.1e} rad, "
                        f"arm {r['measured_deviation']['limited']:.4f} rad (free {r['measured_deviation']['free']:.4f})")
            truth = "measured speeds <= limit, command on the path (< 1e-6 rad)"
        rows.append({"part": "online", "scenario": r["scenario"], "setting": setting, "measured": measured,
                     "truth": truth, "met": r["met"]})
    return rows


def markdown_online(rows: list[dict[str, Any]]) -> str:
    """The table of the report."""
    lines = ["| scenario | setting | measured | truth | met |", "|---|---|---|---|---|"]
    lines += [f"| {r['scenario']} | {r['setting']} | {r['measured']} | {r['truth']} | {'yes' if r['met'] else 'no'} |"
              for r in rows]
    return "\n".join(lines) + "\n"


def figure_online(results: list[dict[str, Any]], out: str | Path) -> Path:
    """Three panels, ``out/online_arm.png``: the wrist's command and position through the held
    pour (with and without phase stopping); the baskets and the landings on the floor; the
    largest joint speed over its limit, free and limited.
    """
    plt = pyplot()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    fig, ax = plt.subplots(1, 3, figsize=(13, 3.8))
    runs = [r for r in results if r.get("kind") == "online"]
    # one liquid's curves (the first): every liquid's would hide the hold in clutter
    for r in (r for r in runs if r["scenario"] == "held-pour" and r.get("liquid_seed", 0) == 0):
        name = "phase stopping" if r["alpha_e"] > 0 else "no phase stopping"
        line, = ax[0].plot(r["t"], r["command"], "--", lw=1, label=f"command, {name}")
        ax[0].plot(r["t"], r["q"], color=line.get_color(), lw=1.5, label=f"arm, {name}")
        start, length = r["hold"]
        ax[0].axvspan(start, start + length, color="0.85")
    ax[0].set(xlabel="t (s)", ylabel="A7 (rad)", title="Held for 0.5 s during the pour")
    if ax[0].lines:
        ax[0].legend(fontsize=7)
    for k, r in enumerate(r for r in runs if r["scenario"] == "moving-basket"):
        if k == 0:
            for centre, colour in ((r["basket"], "0.6"), (r["moved"], "green")):
                ax[1].add_patch(plt.Circle(centre, r["tolerance"], fill=False, color=colour))
            ax[1].plot(*r["landings"]["ignored"], "x", color="0.4", label="move ignored")
            ax[1].plot(*r["landings"]["planned"], "+", color="k", label="new DMP from the start")
        ax[1].plot(*r["landings"]["updated"], "o", ms=4, label=f"set_goal at {r['move_time']:g} s")
    ax[1].set(xlabel="x (m)", ylabel="y (m)", title="The basket moves 10 cm", aspect="equal")
    if ax[1].lines:  # room on the right for the legend, off the baskets
        x0, x1 = ax[1].get_xlim()
        ax[1].set_xlim(x0, x1 + 1.5 * (x1 - x0))
    ax[1].legend(fontsize=7, loc="upper right")
    for r in (r for r in runs if r["scenario"] == "velocity-limit"):
        for name, curve in r["curves"].items():
            ax[2].plot(curve["t"], curve["ratio"], label=name)
    ax[2].axhline(1.0, color="red", ls="--", lw=0.8, label="limit")
    ax[2].set(xlabel="t (s)", ylabel="max over joints of |qd| / limit (measured)", title="Velocity limit")
    ax[2].legend(fontsize=7)
    fig.tight_layout()
    return save_figure(fig, out / "online_arm.png")


PART = Part(
    "online", "A stepper in the arm's servo loop (docs/arm.md)",
    plan=plan_online, run=run_online, summarize=summarize_online, markdown_of=markdown_online,
    figure=figure_online, needs="mujoco",
)
