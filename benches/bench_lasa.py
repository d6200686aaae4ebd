"""LASA benchmark: dmprs against movement_primitives on the 210 human demonstrations of the LASA
handwriting data set (30 shapes x 7, 1000 samples each, positions in mm).

Per library, in one process: the time to fit all 210 demonstrations (50 kernels per DOF), the
time to roll all 210 out at each demonstration's own sample period (~2.5 ms), and each library's
own reproduction error (RMS of the Euclidean distance, its rollout interpolated onto the
demonstration's times; median and worst over the 210). Medians of REPEATS runs.

    pip install ".[bench]" && python benches/bench_lasa.py
"""

from __future__ import annotations

import os
import platform
import warnings

import numpy as np

import dmprs
from _timing import timed
from dmprs.io.lasa import lasa_demos

N_BASIS = 50
REPEATS = 5


def rms_mm(traj, t_roll, y_roll) -> float:
    y = np.stack([np.interp(traj.t, t_roll, y_roll[:, k]) for k in range(traj.n_dof)], axis=1)
    return float(np.sqrt(np.mean(np.sum((y - traj.y) ** 2, axis=1))))


def dt_of(traj) -> float:
    return float(np.median(np.diff(traj.t)))


def bench_dmprs(demos):
    fit, dmps = timed(lambda: [dmprs.DMP.fit(d.t, d.y, N_BASIS) for d in demos], REPEATS)
    roll, outs = timed(lambda: [m.rollout(dt=dt_of(d), duration=d.duration) for m, d in zip(dmps, demos, strict=True)],
                       REPEATS)
    errors = [rms_mm(d, o.t, o.y) for d, o in zip(demos, outs, strict=True)]
    return fit, roll, errors, "Euler (Rust)"


def bench_movement_primitives(demos):
    from movement_primitives.dmp import DMP

    def fit_all():
        out = []
        for d in demos:
            # int_dt = dt: it integrates at the same step as dmprs (its default is 1 ms)
            m = DMP(n_dims=2, execution_time=d.duration, dt=dt_of(d), n_weights_per_dim=N_BASIS, int_dt=dt_of(d))
            m.imitate(d.t, d.y)
            out.append(m)
        return out

    fit, dmps = timed(fit_all, REPEATS)
    roll, outs = timed(lambda: [m.open_loop(step_function="euler-cython") for m in dmps], REPEATS)
    errors = [rms_mm(d, np.asarray(T), np.asarray(Y)) for d, (T, Y) in zip(demos, outs, strict=True)]
    return fit, roll, errors, "euler-cython"


def main() -> None:
    demos = [d.trajectory for d in lasa_demos()]
    rows = [("dmprs", *bench_dmprs(demos))]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rows.append(("movement_primitives 0.9.1", *bench_movement_primitives(demos)))
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"Python {platform.python_version()}, numpy {np.__version__}; {len(demos)} demonstrations, "
          f"{N_BASIS} kernels per DOF, medians of {REPEATS} runs\n")
    print("| library | fit all 210 (ms) | roll out all 210 (ms) | RMS median (mm) | RMS worst (mm) | step function "
          "| fit vs dmprs | rollout vs dmprs |")
    print("|---|---:|---:|---:|---:|---|---:|---:|")
    ours = rows[0]
    for name, fit, roll, errors, step in rows:
        print(f"| {name} | {fit * 1e3:.1f} | {roll * 1e3:.1f} | {np.median(errors):.3f} | {np.max(errors):.2f} | "
              f"{step} | {fit / ours[1]:.0f}x | {roll / ours[2]:.0f}x |")


if __name__ == "__main__":
    main()
