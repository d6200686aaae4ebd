"""Goals near the start: three formulations of the DMP side by side (docs/method.md §2.7).

    python examples/goals_near_start.py [out_dir]

One demonstration (a reach from 0 to 1 with a bump of 0.3 on the way) and one whose goal equals
its start to rounding (the bump alone, a movement that returns, ending 1.5e-33 from where it
began), each fitted by three formulations with the
same kernels, spring constants and Euler step, then run to new goals: the demonstrated one, one
near the start and one behind it.

* Ijspeert et al. (2013): the forcing term scaled by ``(g - y0) / (g_demo - y0_demo)``. It squashes
  the bump towards a goal near the start and mirrors it behind the start; fitted to a movement
  that returns to its start, it does not move at all to that start and explodes to any other
  goal (the factor is ``1 / 1.5e-33``).
* Hoffmann, Pastor, Park and Schaal (2009): the scaling moved into the spring,
  ``tau v' = K (g - y) - D v - K (g - y0) x + K f(x)``; no mirroring, the bump keeps its size.
* dmprs (eqs. 1-4 of the paper, no scaling): the weights are in the units of ``y``; a new goal adds
  the spring's step response to the demonstrated shape. Nothing mirrors or explodes and a goal
  equal to the start keeps the shape, but a goal far from the demonstrated one is reached by the
  spring, fast, while the shape still unfolds at its own pace: the movement overshoots the way it
  is going (to -1.27 for the goal at -0.5), which is what generalizing over demonstrated goals
  (the paper's eq. 6) is for.

Both scaled formulations are written out here, in numpy, for the comparison; dmprs offers its own.
The figure is ``goals_near_start.png`` in ``out_dir`` (docs/figures/ keeps a copy).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

import dmprs

DT, N_BASIS = 0.001, 30
GOALS = (1.0, 0.05, -0.5)
# a rollout beyond this is drawn as a note, not a curve
LIMIT = 5.0


def demonstration(end: float) -> tuple[np.ndarray, np.ndarray]:
    """A one-second movement from 0 to ``end`` with a bump of 0.3 on the way."""
    t = np.arange(0.0, 1.0 + DT / 2, DT)
    s = t / t[-1]
    return t, end * (10 * s**3 - 15 * s**4 + 6 * s**5) + 0.3 * np.sin(np.pi * s) ** 2


class Scaled:
    """Ijspeert's (``"ijspeert"``) or Hoffmann's (``"hoffmann"``) formulation of one DOF, with
    dmprs's kernels, phase, spring constants and explicit Euler step, so that only the forcing
    term's scaling differs.
    """

    def __init__(self, kind: str, t: np.ndarray, y: np.ndarray, like: dmprs.DMP) -> None:
        self.kind, self.tau = kind, float(t[-1] - t[0])
        self.alpha_z, self.beta_z, self.alpha_x = like.alpha_z, like.beta_z, like.alpha_x
        self.centers, self.widths = np.asarray(like.centers), np.asarray(like.widths)
        self.y0, self.g_demo = float(y[0]), float(y[-1])
        yd = np.gradient(y, t)
        ydd = np.gradient(yd, t)
        x = np.exp(-self.alpha_x * (t - t[0]) / self.tau)
        k, tau = self.alpha_z * self.beta_z, self.tau
        if kind == "ijspeert":
            # tau^2 ydd = alpha_z (beta_z (g - y) - tau yd) + (g - y0) f(x)
            scale = self.g_demo - self.y0
            target = (tau**2 * ydd - self.alpha_z * (self.beta_z * (self.g_demo - y) - tau * yd)) / scale
        else:
            # tau^2 ydd = K (g - y) - D tau yd - K (g - y0) x + K f(x)
            target = (
                (tau**2 * ydd + self.alpha_z * tau * yd) / k - (self.g_demo - y) + (self.g_demo - self.y0) * x
            )
        basis = self.basis(x)
        self.weights = np.linalg.lstsq(basis, target, rcond=None)[0]

    def basis(self, x: np.ndarray) -> np.ndarray:
        """The normalized kernels times the phase, one row per phase value."""
        psi = np.exp(-self.widths * (np.asarray(x)[:, None] - self.centers) ** 2)
        return psi * np.asarray(x)[:, None] / psi.sum(axis=1, keepdims=True)

    def rollout(self, goal: float, duration: float) -> np.ndarray:
        """Positions at every ``DT`` from the start at rest, to the new goal."""
        n = round(duration / DT) + 1
        y, z, x, out = self.y0, 0.0, 1.0, np.empty(n)
        k = self.alpha_z * self.beta_z
        for j in range(n):
            out[j] = y
            f = float(self.basis(np.array([x]))[0] @ self.weights)
            if self.kind == "ijspeert":
                dz = self.alpha_z * (self.beta_z * (goal - y) - z) + (goal - self.y0) * f
            else:
                dz = k * (goal - y) - self.alpha_z * z - k * (goal - self.y0) * x + k * f
            y, z, x = y + DT * z / self.tau, z + DT * dz / self.tau, x - DT * self.alpha_x * x / self.tau
        return out


def compare(
    end: float, goals: tuple[float, ...], duration: float = 1.5
) -> dict[str, dict[float, np.ndarray]]:
    """Every formulation's rollout to every goal, for the demonstration ending at ``end``."""
    t, y = demonstration(end)
    dmp = dmprs.DMP.fit(t, y, N_BASIS)
    runs: dict[str, dict[float, np.ndarray]] = {"dmprs": {}}
    for kind in ("ijspeert", "hoffmann"):
        scaled = Scaled(kind, t, y, dmp)
        runs[kind] = {g: scaled.rollout(g, duration) for g in goals}
    for g in goals:
        runs["dmprs"][g] = dmp.with_goal([g]).rollout(DT, duration=duration).y[:, 0]
    return runs


def main(out_dir: Path | None = None) -> dict:
    out_dir = Path(out_dir) if out_dir is not None else Path(".")
    reach = compare(1.0, GOALS)
    loop = compare(0.0, (0.0, 0.3))
    path = plot(reach, loop, out_dir / "goals_near_start.png")
    return {"reach": reach, "loop": loop, "figure": path}


def plot(reach: dict, loop: dict, path: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    titles = {
        "ijspeert": "Ijspeert et al. 2013: f scaled by (g - y0)",
        "hoffmann": "Hoffmann et al. 2009: scaling in the spring",
        "dmprs": "dmprs: no scaling (eqs. 1-4)",
    }
    fig, axes = plt.subplots(2, 3, figsize=(13, 6.5), sharex=True, sharey="row")
    for row, (runs, end, label) in enumerate(((reach, 1.0, "demo 0 → 1"), (loop, 0.0, "demo 0 → 0"))):
        t_demo, y_demo = demonstration(end)
        for col, kind in enumerate(("ijspeert", "hoffmann", "dmprs")):
            ax = axes[row, col]
            ax.plot(t_demo, y_demo, "k--", lw=1, label=label)
            for g, y in runs[kind].items():
                t = np.arange(len(y)) * DT
                peak = float(np.max(np.abs(y)))
                if peak <= LIMIT:
                    ax.plot(t, y, label=f"g = {g:g}")
                else:
                    ax.text(
                        0.5,
                        0.15,
                        f"g = {g:g}: explodes, |y| up to {peak:.0e}",
                        transform=ax.transAxes,
                        ha="center",
                        fontsize=8,
                        color="C3",
                    )
            ax.axhline(0.0, color="0.8", lw=0.5)
            if row == 0:
                ax.set_title(titles[kind], fontsize=10)
            if row == 1:
                ax.set_xlabel("t (s)")
            if col == 0:
                ax.set_ylabel("y")
            ax.legend(fontsize=7, loc="upper right")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


if __name__ == "__main__":
    print(main(Path(sys.argv[1]) if len(sys.argv) > 1 else None)["figure"])
