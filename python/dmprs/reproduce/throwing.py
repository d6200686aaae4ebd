"""Reproduction part "throwing into a basket" (the paper's example of a
query: "the relationship between the basket positions and the DMP parameters"): the 7-DOF arm
learns to hit unseen baskets on the floor from five demonstration throws, with each generalizer
and the n-D query learners, on an exact and on a noisy robot.

Baskets: ``inside`` ones drawn uniformly (seeded) from the bounding box of the demos' landing
points, at least 5 cm from every demo; ``outside`` ones up to 20 % of the box's extent beyond it
(10-20 % beyond one side, anywhere along it). Every run starts from the desired landing point
(the pure generalization) and stops at the first throw within 5 cm, or after :data:`MAX_TRIALS`.
The issue's floors: inside, at most 5 trials median; outside, at most 8.

Wiring as :mod:`dmprs.reproduce.growing`: :func:`plan_throwing` (picklable specs for
:func:`dmprs.parallel.pmap`), :func:`run_throwing`, :func:`summarize_throwing` (table rows),
:func:`figure_throwing` (landing points per trial on the floor plan, the paper's Fig. 2 way).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from dmprs.experiments import arm_throwing
from dmprs.experiments.arm_throwing import demonstrations
from dmprs.loop import learn
from dmprs.plots import pyplot, save_figure
from dmprs.portable import norm
from dmprs.reproduce.part import Part
from dmprs.reproduce.stats import trial_stats
from dmprs.tasks.noise import Noise

MAX_TRIALS = 15
#: the project's floors: median trials to success for baskets inside / up to 20 % outside the demos
FLOORS = {"inside": 5, "outside": 8}
#: the noisy robot: 3 mrad joint tracking noise, 1 cm on each measured landing coordinate
NOISE = (0.003, 0.01)
PAPER = "not in the paper (its example of a query, section 3); the project's floors: inside <= 5, outside <= 8 median"


@dataclass(frozen=True)
class ThrowingSpec:
    """One learning run: hit the basket at ``target`` (m)."""

    target: tuple[float, float]
    region: str  # "inside" | "outside"
    generalizer: str  # a key of dmprs.experiments.arm_throwing.GENERALIZERS
    learner: str
    noise_seed: int | None = None  # None: the exact robot
    tol: float = 0.05  # the basket's radius (m)
    max_trials: int = MAX_TRIALS
    kind: str = "throwing"

    @property
    def label(self) -> str:
        """The run's name in progress lines and errors."""
        noise = "" if self.noise_seed is None else f" / noise seed {self.noise_seed}"
        return f"{self.kind} {self.region} {self.target} / {self.generalizer} / {self.learner} / tol {self.tol}{noise}"


def baskets(n: int, seed: int = 0) -> dict[str, list[tuple[float, float]]]:
    """``n`` unseen baskets inside the demos' landing box and ``n`` up to 20 % outside it."""
    labels = np.array([label for label, _ in demonstrations()])
    lo, hi = labels.min(axis=0), labels.max(axis=0)
    size = hi - lo
    rng = np.random.default_rng(seed)
    inside: list[tuple[float, float]] = []
    while len(inside) < n:
        p = lo + rng.random(2) * size
        if np.linalg.norm(labels - p, axis=1).min() > 0.05:
            inside.append((round(float(p[0]), 3), round(float(p[1]), 3)))
    outside: list[tuple[float, float]] = []
    for _ in range(n):
        axis, side = int(rng.integers(2)), int(rng.integers(2))
        p = lo + rng.random(2) * size
        beyond = (0.1 + 0.1 * rng.random()) * size[axis]
        p[axis] = hi[axis] + beyond if side else lo[axis] - beyond
        outside.append((round(float(p[0]), 3), round(float(p[1]), 3)))
    return {"inside": inside, "outside": outside}


def plan_throwing(quick: bool = False) -> list[ThrowingSpec]:
    """Full: 10 inside and 10 outside baskets x the three generalizers x the secant (Broyden), fixed
    (J = I) and CMA-ES learners, and the noisy robot over 10 noise seeds at two baskets
    (linear, secant and error). Quick: two inside baskets and one outside, linear, secant.
    """
    if quick:
        b = baskets(2)
        return [ThrowingSpec(t, region, "linear", "secant") for region in ("inside", "outside")
                for t in b[region][: 2 if region == "inside" else 1]]
    b = baskets(10)
    specs = [ThrowingSpec(t, region, gen, lrn) for gen in ("linear", "lwr-gp", "lwr-gp-affine")
             for lrn in ("secant", "error", "cma")
             for region in ("inside", "outside") for t in b[region]]
    specs += [ThrowingSpec(b[region][0], region, "linear", lrn, seed) for lrn in ("secant", "error")
              for region in ("inside", "outside") for seed in range(10)]
    # a 2 cm basket, which the pure generalization mostly misses: the learners at work
    specs += [ThrowingSpec(t, region, "linear", lrn, tol=0.02) for lrn in ("secant", "error", "finite-difference", "broyden")
              for region in ("inside", "outside") for t in b[region]]
    return specs


def run_throwing(spec: ThrowingSpec, release: bool = False) -> dict[str, Any]:
    """Learns ``spec``; plain data (every trial's query, landing and error). ``release``: the
    final-velocity throw (``arm_throwing.setup(..., release=True)``, :mod:`dmprs.reproduce.release_throwing`).
    """
    noise = None if spec.noise_seed is None else Noise(execution=NOISE[0], measurement=NOISE[1])
    setup = arm_throwing.setup(spec.target, spec.generalizer, tol=spec.tol, noise=noise, release=release)
    r = learn(setup.task, setup.generalizer, setup.desired_query, setup.make_learner(spec.learner),
              max_trials=spec.max_trials, seed=0 if spec.noise_seed is None else 1000 * spec.noise_seed)
    trials = [{"query": t.query.tolist(), "status": t.status, "success": t.success,
               "landing": None if "landing_x" not in t.signals else [t.signals["landing_x"], t.signals["landing_y"]],
               "miss": None if t.eps is None else norm(t.eps)} for t in r.trials]
    return {"kind": spec.kind, "target": list(spec.target), "region": spec.region,
            "generalizer": spec.generalizer, "learner": spec.learner, "noise_seed": spec.noise_seed,
            "noise": None if noise is None else list(NOISE), "tol": spec.tol, "max_trials": spec.max_trials,
            "converged": r.converged, "trials_to_success": r.trials_to_success, "stop_reason": r.stop_reason,
            "demos": [label.tolist() for label, _ in arm_throwing.demonstrations(release=release)], "trials": trials}


def summarize_throwing(results: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Per region, generalizer, learner and robot (exact / noisy): trials to success (median,
    range, successes) against the issue's floor.
    """
    runs = [r for r in results if r.get("kind") == "throwing"]
    def key(r: dict[str, Any]) -> tuple[Any, ...]:
        return (-r["tol"], r["region"], r["generalizer"], r["learner"], r["noise"] is not None)

    rows = []
    for k in sorted({key(r) for r in runs}):
        group = [r for r in runs if key(r) == k]
        tol, region, gen, lrn, noisy = -k[0], *k[1:]
        floor = FLOORS[region] if tol == 0.05 else None
        stats = trial_stats([r["trials_to_success"] for r in group], group[0]["max_trials"])
        robot = f"noisy robot ({NOISE[0]:g} rad tracking, {NOISE[1]:g} m measurement), " \
                f"{len({r['noise_seed'] for r in group})} seeds" if noisy else "exact robot"
        failed = [r["stop_reason"] for r in group if not r["converged"]]
        rows.append({"part": "throwing", "region": region, "generalizer": gen, "tol": tol, "noisy": noisy,
                     "experiment": f"arm throwing, {len(group)} baskets of {100 * tol:g} cm "
                     f"{region} the demos' range, {gen}, {robot}", "learner": lrn, **stats, "paper": PAPER,
                     "floor": floor, "meets_floor": None if floor is None else
                     stats["median"] is not None and stats["median"] <= floor,
                     "stop_reason": failed[0] if failed and not stats["successes"] else None,
                     "failures": failed})
    return rows


def markdown_throwing(rows: list[dict[str, Any]]) -> str:
    """The throwing table of the report."""
    lines = ["| experiment | learner | succeeded | trials to success median [range] | floor (median) | met |",
             "|---|---|---|---|---|---|"]
    for r in rows:
        med = "-" if r["median"] is None else f"{r['median']:g} [{r['min']}-{r['max']}]"
        floor = "-" if r["floor"] is None else f"<= {r['floor']}"
        met = "-" if r["meets_floor"] is None else ("yes" if r["meets_floor"] else "no")
        lines.append(f"| {r['experiment']} | {r['learner']} | {r['successes']}/{r['runs']} | {med} | {floor} | {met} |")
    return "\n".join(lines) + "\n"


def figure_throwing(results: list[dict[str, Any]], out: str | Path) -> Path:
    """Landing points per trial on the floor plan (the paper's Fig. 2 way): the demos' landings,
    each basket (5 cm circle) and the trials' landings joined in order, one panel per generalizer
    (exact robot, the secant learner, or the first learner present); ``out/throwing.png``.
    """
    plt = pyplot()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    runs = [r for r in results if r.get("kind") == "throwing" and r["noise"] is None and r["tol"] == 0.05]
    gens = sorted({r["generalizer"] for r in runs}) or ["linear"]
    fig, axes = plt.subplots(1, len(gens), figsize=(5.2 * len(gens), 4.6), squeeze=False)
    for ax, gen in zip(axes[0], gens, strict=True):
        mine = [r for r in runs if r["generalizer"] == gen]
        learner = "secant" if any(r["learner"] == "secant" for r in mine) else (mine[0]["learner"] if mine else "")
        mine = [r for r in mine if r["learner"] == learner]
        for r in mine[:1]:
            demos = np.array(r["demos"])
            ax.plot(demos[:, 0], demos[:, 1], "k*", ms=11, label="demonstrations' landings")
        for i, r in enumerate(mine):
            color = "C0" if r["region"] == "inside" else "C3"
            tx, ty = r["target"]
            ax.add_patch(plt.Circle((tx, ty), 0.05, fill=False, color=color, lw=1.0))
            pts = np.array([t["landing"] for t in r["trials"] if t["landing"] is not None])
            if len(pts):
                ax.plot(pts[:, 0], pts[:, 1], "o-", color=color, ms=3, lw=0.7, alpha=0.8,
                        label=f"trials, basket {r['region']}" if i == 0 or r["region"] != mine[i - 1]["region"] else None)
                ax.plot(pts[-1, 0], pts[-1, 1], "o", color=color, ms=6, mfc="none")
        ax.set_aspect("equal")
        ax.set(xlabel="x (m)", ylabel="y (m)", title=f"{gen}, {learner}: landing per trial")
        ax.legend(fontsize=7, loc="upper left")
    return save_figure(fig, out / "throwing.png")


PART = Part(
    "throwing", "Throwing into a basket with the 7-DOF arm, a 2-D query (docs/throwing.md)",
    plan=plan_throwing, run=run_throwing, summarize=summarize_throwing, markdown_of=markdown_throwing, figure=figure_throwing, needs="mujoco",
)
