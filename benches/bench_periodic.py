"""Periodic DMP benchmark: dmprs's PeriodicDMP against pydmps' rhythmic DMP and against dmprs's
own discrete DMP of the same size, in one process.

Workload: 7 DOF, 50 kernels, a rhythm of period 2 pi s (tau = 1, pydmps' fixed run time)
rolled out at dt = 1 ms from Python; the batch fit of one period (6,283 samples); and the
online fit (one recursive-least-squares update per sample, from Python); one open-loop step() of
the periodic stepper against the discrete JointStepper's of the same size. Then the adaptive
oscillator (§12.5): its update and the whole rhythm learner's per sample, from Python, and after
how many periods it follows a 0.5-3 Hz sine with 5 % noise to within 1 % (no other library to
compare with: pydmps and movement_primitives have no frequency adaptation).

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


def bench_steps(t, y):
    """One open-loop ``step()`` from Python of the periodic stepper and of the discrete
    ``JointStepper`` of the same size (7 DOF, 50 kernels, 1 ms), both without phase stopping.
    """
    n = 5000
    periodic = dmprs.PeriodicDMP.fit(t, y, n_basis=N_BASIS)
    discrete = dmprs.DMP.fit(t, y, N_BASIS)

    def run(make):
        def go():
            stepper = make()
            step = stepper.step
            for _ in range(n):
                step()
        return timed(go, 7)[0] / n

    p = run(lambda: periodic.stepper(DT, ramp=0.0, alpha_e=0.0))
    d = run(lambda: discrete.stepper(DT, alpha_e=0.0, goal_filter=None))
    return p, d


def bench_oscillator(y):
    n = 2000

    def follow():
        osc = dmprs.AdaptiveOscillator(1 / TWO_PI, N_DOF)
        for j in range(n):
            osc.update(DT, y[j])

    def learn():
        learner = dmprs.RhythmLearner(1 / TWO_PI, N_DOF, N_BASIS)
        for j in range(n):
            learner.update(DT, y[j])

    return timed(follow, 5)[0] / n, timed(learn, 3)[0] / n


def periods_to_one_percent(guesses: tuple[float, ...]) -> tuple[float, float]:
    """Median and largest number of periods after which the followed frequency stays within 1 %,
    over 0.5, 1, 2 and 3 Hz sines with 5 % noise, six phases, and these guesses (times the
    truth): the floor (five periods) is to hold at the largest, every case.
    """
    periods = []
    for f in (0.5, 1.0, 2.0, 3.0):
        t = np.arange(int(12 / f / DT)) * DT
        for guess in guesses:
            for phase in range(6):
                noise = 0.05 * np.random.default_rng(phase).standard_normal(t.size)
                y = 0.4 + np.sin(TWO_PI * f * t + phase) + noise
                osc = dmprs.AdaptiveOscillator(guess * f)
                last_off = 0
                for k, v in enumerate(y):
                    osc.update(DT, [v])
                    if abs(osc.frequency / f - 1) > 0.01:
                        last_off = k + 1
                periods.append(last_off * DT * f)
    return float(np.median(periods)), max(periods)


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
    periodic_step, discrete_step = bench_steps(t, y)
    print(f"one step() from Python, 7 DOF, 50 kernels: PeriodicStepper {periodic_step * 1e6:.2f} µs, "
          f"JointStepper {discrete_step * 1e6:.2f} µs: periodic / discrete {periodic_step / discrete_step:.2f}x "
          f"(floor 1.2x)")
    follow, learn = bench_oscillator(y)
    print(f"AdaptiveOscillator.update from Python (7 DOF, 10 harmonics): {follow * 1e6:.1f} µs per sample; "
          f"RhythmLearner.update (oscillator + online fit): {learn * 1e6:.1f} µs per sample")
    for label, guesses in (("1-1.6x", (1.0, 1.3, 1.6)), ("0.7x", (0.7,)), ("2x", (2.0,))):
        median, worst = periods_to_one_percent(guesses)
        print(f"frequency within 1 % for good (0.5-3 Hz, 5 % noise, six phases, guess {label}): "
              f"after {median:.1f} periods (median), {worst:.1f} (worst); floor 5 at every case")


if __name__ == "__main__":
    main()
