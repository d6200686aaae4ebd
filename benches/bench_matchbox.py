"""Matchbox simulation speed: CPU time of one 2 s episode, and the batch call on all cores.

    python benches/bench_matchbox.py

Issue 6's floor: one episode (strike + 2 s of settling, 1 ms steps, Rapier 3-D) in <= 20 ms of
CPU. The batch call is what the baselines' thousands of rollouts use.
"""

from __future__ import annotations

import os
import statistics
import time

import numpy as np

from dmprs.adapters import Status
from dmprs.tasks.matchbox import MatchboxAdapter, simulate_batch, strike


def main() -> None:
    adapter = MatchboxAdapter()
    adapter.connect()
    rows = []
    for duration in (0.14, 0.105, 0.07):
        traj = strike(duration)
        cpu = []
        for _ in range(20):
            c0 = time.process_time()
            o = adapter.execute(traj)
            cpu.append(time.process_time() - c0)
            assert o.status is Status.OK
        rows.append((duration, o.signals["regime"], statistics.median(cpu) * 1e3, min(cpu) * 1e3))
    print("| strike (s) | regime | CPU per episode, median (ms) | min (ms) |")
    print("|---:|---|---:|---:|")
    for d, r, med, lo in rows:
        print(f"| {d:.3f} | {r} | {med:.1f} | {lo:.1f} |")

    durations = np.linspace(0.06, 0.15, 400)
    w0 = time.perf_counter()
    c0 = time.process_time()
    simulate_batch(durations)
    wall, cpu = time.perf_counter() - w0, time.process_time() - c0
    w1 = time.perf_counter()
    for d in durations[:100]:
        adapter.execute(strike(float(d)))
    serial = (time.perf_counter() - w1) * 4
    print(f"\nsimulate_batch of 400 episodes: {wall:.2f} s wall, {cpu:.2f} s CPU "
          f"({wall / 400 * 1e3:.1f} ms per episode on {os.cpu_count()} cores; "
          f"one by one through the adapter: {serial:.2f} s, {serial / wall:.2f}x slower)")


if __name__ == "__main__":
    main()
