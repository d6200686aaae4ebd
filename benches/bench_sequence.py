"""A sequence of DMPs joined end to start: dmprs.Sequence.rollout against the rollouts of its
movements alone, in one process.

Workload: three 7-DOF DMPs of 50 basis functions (taus 1.0, 0.8 and 1.2 s, fitted to
min-jerk reaches between four waypoints with a bump), rolled out at dt = 1 ms: the sequence
(`Sequence(dmps).rollout(dt)`, which steps the sequence's stepper and joins the movements with
continuous acceleration) against the three `DMP.rollout(dt)` calls alone, everything from Python.
The same number of samples either way (the movements hand over at their taus; each rollout alone
has one more sample, its t = tau).

    python benches/bench_sequence.py

Prints a markdown table; medians of repeated runs, alternated. Floor: the sequence <= 1.2x the
time of the three rollouts alone.
"""

from __future__ import annotations

import os
import platform

import numpy as np

import dmprs
from _timing import timed

N_DOF, N_BASIS, DT = 7, 50, 0.001
TAUS = (1.0, 0.8, 1.2)
REPEATS, ROUNDS = 40, 5


def movements() -> list[dmprs.DMP]:
    rng = np.random.default_rng(7)
    waypoints = rng.uniform(-1.0, 1.0, (len(TAUS) + 1, N_DOF))
    out = []
    for k, tau in enumerate(TAUS):
        t = np.linspace(0.0, tau, round(tau / DT) + 1)
        s = t / tau
        bump = np.outer(np.sin(np.pi * s) ** 2, rng.uniform(-0.3, 0.3, N_DOF))
        y = waypoints[k] + np.outer(10 * s**3 - 15 * s**4 + 6 * s**5, waypoints[k + 1] - waypoints[k]) + bump
        out.append(dmprs.DMP.fit(t, y, N_BASIS))
    return out


def main() -> None:
    dmps = movements()
    seq = dmprs.Sequence(dmps)
    alone, sequence = [], []
    for _ in range(ROUNDS):
        a, trs = timed(lambda: [d.rollout(DT) for d in dmps], REPEATS)
        s, tr = timed(lambda: seq.rollout(DT), REPEATS)
        alone.append(a)
        sequence.append(s)
    a, s = float(np.median(alone)), float(np.median(sequence))
    samples = sum(t.n_samples for t in trs)
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"Python {platform.python_version()}, numpy {np.__version__}, load {os.getloadavg()[0]:.1f}\n")
    print(f"| rollout ({N_DOF} DOF, {N_BASIS} kernels, taus {', '.join(map(str, TAUS))} s, dt = 1 ms) | samples "
          "| time (ms) | ns / step / DOF | vs the three alone |")
    print("|---|---:|---:|---:|---:|")
    print(f"| the three DMP.rollout alone | {samples} | {a * 1e3:.3f} | {a / samples / N_DOF * 1e9:.1f} | 1x |")
    print(f"| Sequence.rollout | {tr.n_samples} | {s * 1e3:.3f} | {s / tr.n_samples / N_DOF * 1e9:.1f} "
          f"| {s / a:.2f}x |")
    print(f"\nper round (sequence / alone): {', '.join(f'{x / y:.2f}' for x, y in zip(sequence, alone, strict=True))}")


if __name__ == "__main__":
    main()
