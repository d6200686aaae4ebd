"""Periodic DMP benchmark: dmprs's PeriodicDMP against pydmps' rhythmic DMP and against dmprs's
own discrete DMP of the same size, in one process.

Workload: 7 DOF, 50 kernels, a rhythm of period 2 pi s (tau = 1, pydmps' fixed run time)
rolled out at dt = 1 ms from Python; the batch fit of one period (6,283 samples); and the
online fit (one recursive-least-squares update per sample, from Python).

    pip install ".[bench]" && python benches/bench_periodic.py

Prints a markdown table; medians of repeated runs.
"""

from __future__ import annotations

import os
import platform
import warnings

import numpy as np

import dmprs
from _timing import timed

N_DOF, N_BASIS, DT = 7, 50, 0.001
TWO_PI = 2 * np.pi


def demo() -> tuple[np.ndarray, np.ndarray]:
    """One period (2 pi s) of a 7-DOF rhythm with two harmonics per joint."""
    t = np.arange(int(TWO_PI / DT)) * DT
    k = np.arange(N_DOF)
    y = 0.3 * np.sin(t[:, None] + 0.4 * k) + 0.1 * np.cos(2 * t[:, None] + k) + 0.05 * k
    return t, y


def bench_dmprs(t, y):
    fit, _ = timed(lambda: dmprs.PeriodicDMP.fit(t, y, n_basis=N_BASIS), 20)
    dmp = dmprs.PeriodicDMP.fit(t, y, n_basis=N_BASIS)
    roll, tr = timed(lambda: dmp.rollout(dt=DT), 30)
    return fit, roll / tr.n_samples


def bench_discrete(t, y):
    dmp = dmprs.DMP.fit(t, y, N_BASIS)
    roll, tr = timed(lambda: dmp.rollout(dt=DT), 30)
    return roll / tr.n_samples


def bench_pydmps(y):
    import pydmps

    def make():
        d = pydmps.DMPs_rhythmic(n_dmps=N_DOF, n_bfs=N_BASIS, dt=DT)
        d.imitate_path(y_des=y.T.copy())
        return d

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fit, _ = timed(make, 5)
        d = make()
        roll, out = timed(lambda: d.rollout(), 3)
    return fit, roll / len(out[0])


def bench_online(t, y):
    tau = 1.0
    g, r = (y.max(0) + y.min(0)) / 2, (y.max(0) - y.min(0)) / 2
    yd = np.gradient(y, t, axis=0)
    ydd = np.gradient(yd, t, axis=0)
    n = 2000

    def run():
        fit = dmprs.PeriodicOnlineFit(N_DOF, N_BASIS)
        for j in range(n):
            fit.update(t[j] / tau, tau, y[j], yd[j], ydd[j], g, r)

    per, _ = timed(run, 5)
    return per / n


def main() -> None:
    t, y = demo()
    fit, roll = bench_dmprs(t, y)
    discrete = bench_discrete(t, y)
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"Python {platform.python_version()}, numpy {np.__version__}\n")
    print("| library | fit one period (ms) | rollout (µs / step, 7 DOF) | fit vs dmprs | rollout vs dmprs |")
    print("|---|---:|---:|---:|---:|")
    print(f"| dmprs PeriodicDMP | {fit * 1e3:.2f} | {roll * 1e6:.3f} | 1x | 1x |")
    try:
        pf, pr = bench_pydmps(y)
        print(f"| pydmps DMPs_rhythmic | {pf * 1e3:.2f} | {pr * 1e6:.3f} | {pf / fit:.0f}x | {pr / roll:.0f}x |")
    except ImportError as exc:
        print(f"pydmps not installed ({exc}); pip install '.[bench]'")
    print(f"| dmprs DMP (discrete, same size) | | {discrete * 1e6:.3f} | | {discrete / roll:.2f}x |")
    print(f"\nPeriodicOnlineFit.update from Python (7 DOF, 50 kernels): {bench_online(t, y) * 1e6:.1f} µs per sample")


if __name__ == "__main__":
    main()
