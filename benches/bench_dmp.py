"""DMP benchmark: dmprs against movement_primitives and pydmps on one workload.

Workload (issue 2): a 7-DOF, 1000-sample, 1 s demonstration, 50 basis functions. Measured in
one process: fit time, rollout time per step per DOF (called from Python, at dt = 1 ms), and
each library's own reproduction RMS error (its rollout interpolated onto the demo's times; the
libraries use different constants, see benches/README.md). Then rollout_batch of 1000 DMPs
against a Python loop over the same DMPs, to show both cores at work.

    pip install ".[bench]" && python benches/bench_dmp.py

Prints a markdown table; medians of repeated runs.
"""

from __future__ import annotations

import os
import platform
import sys
import warnings

import numpy as np

import dmprs
from _timing import timed
from dmprs.demo import reaching_demo

N_DOF, N_SAMPLES, N_BASIS, DT = 7, 1000, 50, 0.001
REPEATS = 30


def rms(t_demo, y_demo, t_roll, y_roll) -> float:
    y_i = np.stack([np.interp(t_demo, t_roll, y_roll[:, d]) for d in range(y_demo.shape[1])], 1)
    return float(np.sqrt(np.mean((y_i - y_demo) ** 2)))


def bench_dmprs(t, y):
    fit, _ = timed(lambda: dmprs.DMP.fit(t, y, N_BASIS), REPEATS)
    dmp = dmprs.DMP.fit(t, y, N_BASIS)
    roll, _ = timed(lambda: dmp.rollout(dt=DT), REPEATS)
    tr = dmp.rollout(dt=DT)
    return fit, roll / (tr.n_samples * N_DOF), rms(t, y, tr.t, tr.y)


def bench_movement_primitives(t, y):
    from movement_primitives.dmp import DMP

    def make():
        d = DMP(n_dims=N_DOF, execution_time=1.0, dt=DT, n_weights_per_dim=N_BASIS, int_dt=DT)
        d.imitate(t, y)
        return d

    fit, _ = timed(make, REPEATS)
    d = make()
    best = None
    for step in ("euler-cython", "rk4-cython", "euler"):
        try:
            d.open_loop(step_function=step)
        except Exception:  # noqa: BLE001, S112 - a step function this build lacks
            continue
        roll, _ = timed(lambda: d.open_loop(step_function=step), 10)
        if best is None or roll < best[0]:
            best = (roll, step)
    T, Y = d.open_loop(step_function=best[1])
    return fit, best[0] / (len(T) * N_DOF), rms(t, y, np.asarray(T), np.asarray(Y)), best[1]


def bench_pydmps(t, y):
    import pydmps.dmp_discrete

    def make():
        d = pydmps.dmp_discrete.DMPs_discrete(n_dmps=N_DOF, n_bfs=N_BASIS, dt=DT)
        d.imitate_path(y_des=y.T.copy())
        return d

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fit, _ = timed(make, 10)
        d = make()
        roll, _ = timed(lambda: (d.reset_state(), d.rollout()), 5)
        d.reset_state()
        Y, _, _ = d.rollout()
    T = np.arange(len(Y)) * DT
    return fit, roll / (len(T) * N_DOF), rms(t, y, T, Y)


def bench_batch(t, y, n=1000):
    base = dmprs.DMP.fit(t, y, N_BASIS)
    dmps = [base.with_goal(base.goal + 1e-4 * i) for i in range(n)]
    loop, _ = timed(lambda: [d.rollout(dt=DT) for d in dmps], 5)
    batch, _ = timed(lambda: dmprs.rollout_batch(dmps, dt=DT), 5)
    return loop, batch


def bench_memory_limit(t, y):
    """The rollout against what writing its output costs: the bytes one ``DMP.rollout`` returns
    per step (t, then y, yd and ydd for every DOF), and the time per step of a plain copy of the
    same four arrays into fresh ones (numpy's ``copy``, one read and one write of every byte,
    what the rollout's output costs at the least), both in this process, minutes apart at most.
    """
    dmp = dmprs.DMP.fit(t, y, N_BASIS)
    tr = dmp.rollout(dt=DT)
    arrays = (np.asarray(tr.t), np.asarray(tr.y), np.asarray(tr.yd), np.asarray(tr.ydd))
    steps = tr.n_samples
    copy, _ = timed(lambda: [a.copy() for a in arrays], REPEATS * 10)
    roll, _ = timed(lambda: dmp.rollout(dt=DT), REPEATS)
    written = sum(a.nbytes for a in arrays)
    # and main memory's bandwidth, for a copy far larger than the caches
    big = np.ones(2**23)
    dram, _ = timed(big.copy, 10)
    return written / steps, copy / steps, roll / steps, 2 * written / copy, 2 * big.nbytes / dram


def main() -> None:
    t, y = reaching_demo(N_SAMPLES, 1.0, N_DOF)
    rows = [("dmprs", *bench_dmprs(t, y), "Euler (Rust)")]
    try:
        f, r, e, step = bench_movement_primitives(t, y)
        rows.append(("movement_primitives 0.9.1", f, r, e, step))
    except ImportError as exc:
        print(f"movement_primitives not installed ({exc}); pip install '.[bench]'", file=sys.stderr)
    try:
        rows.append(("pydmps", *bench_pydmps(t, y), "Euler (Python)"))
    except ImportError as exc:
        print(f"pydmps not installed ({exc})", file=sys.stderr)

    ours = rows[0]
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"Python {platform.python_version()}, numpy {np.__version__}\n")
    print("| library | fit (ms) | rollout (ns / step / DOF) | reproduction RMS (rad) | step function | fit vs dmprs | rollout vs dmprs |")
    print("|---|---:|---:|---:|---|---:|---:|")
    for name, fit, roll, err, step in rows:
        print(f"| {name} | {fit * 1e3:.3f} | {roll * 1e9:.1f} | {err:.2e} | {step} | "
              f"{fit / ours[1]:.0f}x | {roll / ours[2]:.0f}x |")
    per_step, copy, roll, bandwidth, dram = bench_memory_limit(t, y)
    print(f"\nmemory limit: a rollout returns {per_step:.0f} bytes per step; a plain copy of its four "
          f"arrays takes {copy * 1e9:.1f} ns per step ({bandwidth / 1e9:.1f} GB/s read + write; "
          f"{dram / 1e9:.1f} GB/s for a 64 MB copy, main memory's), "
          f"{copy / N_DOF * 1e9:.2f} ns per step per DOF; DMP.rollout {roll * 1e9:.1f} ns per step: "
          f"{roll / copy:.1f}x the copy")
    loop, batch = bench_batch(t, y)
    print(f"\nrollout_batch of 1000 DMPs (7 DOF, 1 s at 1 ms): {batch * 1e3:.1f} ms; "
          f"a Python loop of DMP.rollout: {loop * 1e3:.1f} ms; speed-up {loop / batch:.2f}x "
          f"on {os.cpu_count()} cores")


if __name__ == "__main__":
    main()
