"""A sequence of DMPs joined end to start: dmprs.Sequence.rollout against the rollouts of its
movements alone, in one process, for joint and for Cartesian DMPs.

Workload: three 7-DOF DMPs of 50 basis functions (taus 1.0, 0.8 and 1.2 s, fitted to
min-jerk reaches between four waypoints with a bump), rolled out at dt = 1 ms: the sequence
(`Sequence(dmps).rollout(dt)`, which steps the sequence's stepper and joins the movements with
continuous acceleration) against the three `DMP.rollout(dt)` calls alone, everything from Python.
The same number of samples either way (the movements hand over at their taus; each rollout alone
has one more sample, its t = tau). Likewise three Cartesian DMPs of 50 basis functions (same
taus, fitted to min-jerk moves between four poses, the orientation turning about a moving axis
with a wobble): `Sequence(cartesian_dmps).rollout(dt)` against the three `CartesianDMP.rollout(dt)`.

    python benches/bench_sequence.py

Prints markdown tables; medians of repeated runs, alternated. Floor: each sequence <= 1.2x the
time of its three rollouts alone.
"""

from __future__ import annotations

import os
import platform

import numpy as np
from scipy.spatial.transform import Rotation

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


def poses() -> list[dmprs.CartesianDMP]:
    rng = np.random.default_rng(11)
    positions = rng.uniform(-0.5, 0.5, (len(TAUS) + 1, 3))
    turns = Rotation.from_rotvec(rng.uniform(-1.0, 1.0, (len(TAUS) + 1, 3)))
    out = []
    for k, tau in enumerate(TAUS):
        t = np.linspace(0.0, tau, round(tau / DT) + 1)
        s = t / tau
        a = 10 * s**3 - 15 * s**4 + 6 * s**5
        bump = np.sin(np.pi * s) ** 2
        p = positions[k] + np.outer(a, positions[k + 1] - positions[k]) + np.outer(bump, rng.uniform(-0.1, 0.1, 3))
        turn = (turns[k + 1] * turns[k].inv()).as_rotvec()
        wobble = Rotation.from_rotvec(np.outer(0.3 * bump, rng.uniform(-1.0, 1.0, 3)))
        q = (wobble * Rotation.from_rotvec(np.outer(a, turn)) * turns[k]).as_quat(scalar_first=True)
        out.append(dmprs.CartesianDMP.fit(t, np.hstack([p, q]), N_BASIS))
    return out


def measure(dmps: list) -> tuple[float, float, int, int, list[float]]:
    """Medians (s) of the three rollouts alone and of the sequence, their samples, and the
    per-round ratios.
    """
    seq = dmprs.Sequence(dmps)
    alone, sequence = [], []
    for _ in range(ROUNDS):
        a, trs = timed(lambda: [d.rollout(DT) for d in dmps], REPEATS)
        s, tr = timed(lambda: seq.rollout(DT), REPEATS)
        alone.append(a)
        sequence.append(s)
    samples = sum(t.n_samples for t in trs)
    return (float(np.median(alone)), float(np.median(sequence)), samples, tr.n_samples,
            [x / y for x, y in zip(sequence, alone, strict=True)])


def table(header: str, kind: str, n: int, result: tuple[float, float, int, int, list[float]]) -> None:
    a, s, samples, n_samples, rounds = result
    print(f"| {header} | samples | time (ms) | ns / step / DOF | vs the three alone |")
    print("|---|---:|---:|---:|---:|")
    print(f"| the three {kind}.rollout alone | {samples} | {a * 1e3:.3f} | {a / samples / n * 1e9:.1f} | 1x |")
    print(f"| Sequence.rollout | {n_samples} | {s * 1e3:.3f} | {s / n_samples / n * 1e9:.1f} | {s / a:.2f}x |")
    print(f"\nper round (sequence / alone): {', '.join(f'{x:.2f}' for x in rounds)}\n")


def main() -> None:
    joint, cartesian = measure(movements()), measure(poses())
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"Python {platform.python_version()}, numpy {np.__version__}, load {os.getloadavg()[0]:.1f}\n")
    taus = ", ".join(map(str, TAUS))
    table(f"rollout ({N_DOF} DOF, {N_BASIS} kernels, taus {taus} s, dt = 1 ms)", "DMP", N_DOF, joint)
    table(f"rollout (Cartesian, {N_BASIS} kernels, taus {taus} s, dt = 1 ms)", "CartesianDMP", 6, cartesian)


if __name__ == "__main__":
    main()
