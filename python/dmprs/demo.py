"""A quick look at the DMP core (``dmprs demo``): fit a 7-DOF reaching movement, reproduce it,
and adapt it to a new goal and speed.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from dmprs._core import __version__
from dmprs.batch import rollout_batch
from dmprs.dmp import DMP
from dmprs.errors import DmprsError
from dmprs.plots import pyplot
from dmprs.profiles import min_jerk


def reaching_demo(n_samples: int = 1000, duration: float = 1.0, n_dof: int = 7):
    """A smooth synthetic arm movement: minimum-jerk reaches with a mid-course bump per joint,
    starting and ending at rest.
    """
    t = np.linspace(0.0, duration, n_samples)
    s = t / duration
    mj = min_jerk(s)[0]
    k = np.arange(n_dof)
    start = 0.2 * np.sin(k)
    goal = start + 0.8 * np.cos(1.3 * k)
    bump = 0.15 * np.sin(np.pi * s)[:, None] ** 2 * np.cos(0.7 * k)
    return t, start + mj[:, None] * (goal - start) + bump


def run(out: Path | None) -> dict[str, float]:
    """Fits, reproduces and adapts a 7-DOF demonstration, printing the timings; writes a figure into ``out``."""
    t, y = reaching_demo()
    t0 = time.perf_counter()
    dmp = DMP.fit(t, y, n_basis=50)
    fit_ms = (time.perf_counter() - t0) * 1e3
    repro = dmp.rollout(dt=t[1] - t[0])
    rel = np.abs(repro.y - y).max(axis=0) / np.ptp(y, axis=0)
    new_goal = dmp.goal + 0.3
    adapted = dmp.with_goal(new_goal).with_tau(1.5).rollout(dt=0.001, until_rest=True)
    many = [dmp.with_goal(dmp.goal + 0.001 * i) for i in range(1000)]
    t0 = time.perf_counter()
    rollout_batch(many, dt=0.001)
    batch_ms = (time.perf_counter() - t0) * 1e3

    print(f"dmprs {__version__}: {dmp}")
    print(f"fit of a 7-DOF, 1000-sample demo with 50 kernels: {fit_ms:.3f} ms")
    print("reproduction error per DOF, % of its range: "
          + " ".join(f"{100 * e:.2f}" for e in rel))
    print(f"new goal (+0.3 rad on every joint) and tau 1.5 s: reached within "
          f"{np.abs(adapted.y[-1] - new_goal).max():.1e} after {adapted.duration:.2f} s")
    print(f"1000 rollouts in one rollout_batch call: {batch_ms:.1f} ms")
    if out is not None:
        _plot(out, t, y, repro, adapted)
    return {"fit_ms": fit_ms, "max_rel_error": float(rel.max()), "batch_ms": batch_ms}


def _plot(out: Path, t, y, repro, adapted) -> None:

    try:
        plt = pyplot()
    except DmprsError as exc:
        print(f"{exc}: no figure written")
        return
    out.mkdir(parents=True, exist_ok=True)
    fig, ax = plt.subplots(1, 2, figsize=(11, 4), sharey=True)
    for d in range(y.shape[1]):
        (line,) = ax[0].plot(t, y[:, d], lw=3, alpha=0.35)
        ax[0].plot(repro.t, repro.y[:, d], "--", color=line.get_color(), lw=1)
        ax[1].plot(adapted.t, adapted.y[:, d], color=line.get_color())
    ax[0].set(title="demonstration (thick) and DMP reproduction (dashed)", xlabel="t (s)",
              ylabel="joint position (rad)")
    ax[1].set(title="same DMP: goal + 0.3 rad, tau = 1.5 s", xlabel="t (s)")
    fig.tight_layout()
    path = out / "dmp_demo.png"
    fig.savefig(path, dpi=120)
    print(f"figure written to {path}")
