"""The movement database at the size of the datasets users have: N demonstrations of 7 DOF x 200
samples with a 2-D query. Times adding them all, the first save, a load, one more add + save
(the append a growing database makes after every learned trial), and ``nearest(k)``.

Run:  python benches/bench_database.py [N ...]      (default 10000)
Floors at 10,000 demos: add all <= 2 s, save <= 10 s, load <= 10 s, one more add + save
<= 50 ms. No other library keeps DMP demonstrations on disk, so there is no peer to compare
with; the per-demo columns show whether a step scales linearly (constant per demo).
Not part of the test suite.
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import dmprs

SAMPLES, DOF = 200, 7


def trajectories(n: int, seed: int = 0) -> tuple[np.ndarray, list[dmprs.Trajectory]]:
    """``n`` distinct 2-D queries and a smooth 7-DOF demonstration for each."""
    rng = np.random.default_rng(seed)
    queries = rng.uniform(0.0, 1.0, (n, 2))
    t = np.linspace(0.0, 2.0, SAMPLES)
    s = t / 2.0
    mj = 10 * s**3 - 15 * s**4 + 6 * s**5
    out = []
    for q in queries:
        y = np.outer(mj, 0.5 + q[0] + 0.1 * np.arange(DOF)) + 0.05 * np.sin(np.pi * s)[:, None] * q[1]
        out.append(dmprs.Trajectory(t, y))
    return queries, out


def measure(n: int) -> dict[str, float]:
    queries, trajs = trajectories(n + 1)
    db = dmprs.Database(("x", "y"), ("m", "m"))
    t0 = time.perf_counter()
    for q, traj in zip(queries[:n], trajs[:n], strict=True):
        db.add(q, traj)
    add = time.perf_counter() - t0
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp) / "db"
        t0 = time.perf_counter()
        db.save(root)
        save = time.perf_counter() - t0
        t0 = time.perf_counter()
        loaded = dmprs.Database.load(root)
        load = time.perf_counter() - t0
        assert len(loaded) == n
        t0 = time.perf_counter()
        loaded.add(queries[n], trajs[n])
        loaded.save(root)
        append = time.perf_counter() - t0
        assert len(dmprs.Database.load(root)) == n + 1
    probes = np.random.default_rng(1).uniform(0.0, 1.0, (200, 2))
    loaded.nearest(probes[0], 3)  # builds the index
    t0 = time.perf_counter()
    for p in probes:
        loaded.nearest(p, 3)
    nearest = (time.perf_counter() - t0) / len(probes)
    return {"add": add, "save": save, "load": load, "append": append, "nearest": nearest}


def main() -> None:
    sizes = [int(a) for a in sys.argv[1:]] or [10_000]
    print("| demos | add all (s) | save (s) | load (s) | one more add + save (ms) | nearest(3) (us) "
          "| add / demo (us) | save / demo (us) | load / demo (us) |")
    print("|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for n in sizes:
        r = measure(n)
        print(f"| {n} | {r['add']:.2f} | {r['save']:.2f} | {r['load']:.2f} | {1e3 * r['append']:.1f} "
              f"| {1e6 * r['nearest']:.0f} | {1e6 * r['add'] / n:.0f} | {1e6 * r['save'] / n:.0f} "
              f"| {1e6 * r['load'] / n:.0f} |")


if __name__ == "__main__":
    main()
