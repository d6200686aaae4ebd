"""Latency of dmprs.Generalizer.predict(q) -> DMP, the call a learner makes once per trial.

Workload of the issue: 20 demonstrations, 7 DOF, 50 basis functions ("lwr-gp": LWR over all
20 demos' stacked data for the weights, 15 GPs for tau, goal and start). Also "linear" with the
paper's 2 demos, and a 2-D query. Demos are 2 s at 500 Hz, with a goal, amplitude and duration
that depend on the query.

Run:  python benches/bench_generalizer.py      (floor: lwr-gp predict <= 200 us)
Reported: median over 7 rounds of the mean per-call time of 2000 calls (rounds, not single
calls, so the timer's resolution does not matter), and the 1st and 99th percentile of 2000
individually timed calls. Not part of the test suite.
"""

from __future__ import annotations

import os
import platform
import statistics
import time

import numpy as np

import dmprs


def trajectory(q: np.ndarray, n_dof: int = 7) -> dmprs.Trajectory:
    tau = 2.0 * (1.0 + 0.2 * np.tanh(q.sum()))
    t = np.linspace(0.0, tau, int(500 * tau))
    s = t / tau
    mj = 10 * s**3 - 15 * s**4 + 6 * s**5
    y = np.stack(
        [(0.5 + 0.1 * d + q.sum()) * mj + 0.05 * np.sin((d + 1) * np.pi * s) * q[0] for d in range(n_dof)],
        axis=1,
    )
    return dmprs.Trajectory(t, y)


def database(queries) -> dmprs.Database:
    n = np.atleast_1d(queries[0]).size
    db = dmprs.Database(tuple(f"q{i}" for i in range(n)))
    for q in queries:
        q = np.atleast_1d(np.asarray(q, dtype=float))
        db.add(q, trajectory(q))
    return db


def latency(gen: dmprs.Generalizer, queries: np.ndarray) -> tuple[float, float, float]:
    for q in queries[:50]:
        gen.predict(q)  # warm up
    rounds = []
    for _ in range(7):
        t0 = time.perf_counter()
        for q in queries:
            gen.predict(q)
        rounds.append((time.perf_counter() - t0) / len(queries))
    single = []
    for q in queries:
        t0 = time.perf_counter()
        gen.predict(q)
        single.append(time.perf_counter() - t0)
    p1, p99 = np.percentile(single, [1, 99])
    return statistics.median(rounds), p1, p99


def main() -> None:
    print(f"# {platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, "
          f"numpy {np.__version__}, dmprs {dmprs.__version__}")
    rng = np.random.default_rng(0)
    cases = [
        ("lwr-gp", "20 demos, 1-D query", list(np.linspace(0.0, 2.0, 20)), rng.uniform(-0.2, 2.2, (2000, 1))),
        ("lwr-gp", "20 demos, 2-D query", list(rng.uniform(0, 1, (20, 2))), rng.uniform(0, 1, (2000, 2))),
        ("linear", "2 demos, 1-D query", [0.0, 1.0], rng.uniform(-0.2, 1.2, (2000, 1))),
        # a database grown large (floors: build <= 2 s, predict <= 1 ms at 10,000 demos)
        ("linear", "10,000 demos, 2-D query", list(rng.uniform(0, 1, (10_000, 2))), rng.uniform(0.05, 0.95, (2000, 2))),
    ]
    print("| method | demos | 7 DOF, 50 basis: build | predict (median) | p1 | p99 |")
    print("|---|---|---|---|---|---|")
    for method, label, qs, test in cases:
        db = database(qs)
        t0 = time.perf_counter()
        gen = dmprs.Generalizer(db, method, n_basis=50)
        build = time.perf_counter() - t0
        med, p1, p99 = latency(gen, test)
        print(f"| {method} | {label} | {build * 1e3:.0f} ms | {med * 1e6:.1f} us | {p1 * 1e6:.1f} us "
              f"| {p99 * 1e6:.1f} us |", flush=True)


if __name__ == "__main__":
    main()
