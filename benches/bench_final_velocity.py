"""A DMP with a final velocity: dmprs.DMP(final_velocity=...) against movement_primitives'
DMPWithFinalVelocity, in one process.

Workload: a 2-DOF, 1.2 s demonstration ending in motion (min-jerk plus ``v T (s^5 - s^4)``,
closed form, 1201 samples; end velocities 0.9 and 0.4), 40 basis functions, the same spring
constants for both (alpha_z = 48, beta_z = 12), fitted with the demonstrated final velocity and
rolled out at dt = 1 ms; then the final position and velocity errors at t = tau at dt = 2, 1 and
0.5 ms (movement_primitives integrates at int_dt = dt), everything called from Python; beside
dmprs's errors the same demonstration fitted without a final velocity, and the velocity error the
explicit-Euler phase's lag predicts (the forcing term is played alpha_x dt / 2 early at tau, so
the velocity is off by ydd(tau) alpha_x dt / 2; docs/method.md §2.3), and dmprs's steps emulated in
Python with the forcing term on time.

    pip install ".[bench]" && python benches/bench_final_velocity.py

Prints markdown tables; medians of repeated runs. Floors: rollout >= 30x faster than
movement_primitives, and a final velocity error no larger than its.
"""

from __future__ import annotations

import os
import platform
import sys

import numpy as np

import dmprs
from _timing import timed

T_DEMO, N_SAMPLES, N_BASIS, DT = 1.2, 1201, 40, 0.001
END_VELOCITY = np.array([0.9, 0.4])
#: the demonstration's acceleration at its end: v T (s^5 - s^4) gives v (20 - 12) / T, min-jerk 0
END_ACCELERATION = 8 * END_VELOCITY / T_DEMO
DTS = (0.002, 0.001, 0.0005)
#: the phase's rate, dmprs's default (the fits below leave it)
ALPHA_X = 2.0
REPEATS = 50


def moving_demo() -> tuple[np.ndarray, np.ndarray]:
    t = np.linspace(0.0, T_DEMO, N_SAMPLES)
    s = t / T_DEMO
    base, moving = 10 * s**3 - 15 * s**4 + 6 * s**5, T_DEMO * (s**5 - s**4)
    return t, np.stack([base + END_VELOCITY[0] * moving, 0.3 - base + END_VELOCITY[1] * moving], axis=1)


def final_errors(dmp, y):
    """The final position and velocity errors at t = tau for every dt of DTS."""
    errors = {}
    for dt in DTS:
        end = dmp.rollout(dt)
        errors[dt] = (np.max(np.abs(end.y[-1] - y[-1])), np.max(np.abs(end.yd[-1] - END_VELOCITY)))
    return errors


def ours(t, y):
    dmp = dmprs.DMP.fit(t, y, N_BASIS, final_velocity=END_VELOCITY)
    roll, tr = timed(lambda: dmp.rollout(DT), REPEATS)
    return roll / tr.n_samples, final_errors(dmp, y)


def todays(t, y):
    """The same demonstration fitted without a final velocity: what the moving goal costs, and
    its errors at tau (the same integrator's).
    """
    dmp = dmprs.DMP.fit(t, y, N_BASIS)
    roll, tr = timed(lambda: dmp.rollout(DT), REPEATS)
    return roll / tr.n_samples, final_errors(dmp, y)


def euler(dmp, dt, on_time):
    """dmprs's rollout of a final-velocity DMP to t = tau (docs/method.md §2.4, §2.8) in Python:
    the same explicit-Euler steps with the moving goal at the integrator's time t_k = k dt, the
    forcing term (``on_time``, dmprs's) at the phase of that time, exp(-alpha_x t_k / tau), or at
    the integrator's Euler phase, which runs ahead of it. Returns the final (y, yd).
    """
    w, c, h = np.asarray(dmp.weights), np.asarray(dmp.centers), np.asarray(dmp.widths)
    g, gd, tau = np.asarray(dmp.goal), np.asarray(dmp.final_velocity), dmp.tau
    y, z, x = np.asarray(dmp.start, dtype=float), np.zeros(dmp.n_dof), 1.0
    for k in range(round(tau / dt)):
        t = k * dt
        phase = np.exp(-dmp.alpha_x * t / tau) if on_time else x
        psi = np.exp(-h * (phase - c) ** 2)
        f = phase * (w @ psi) / psi.sum()
        dz = (dmp.alpha_z * (dmp.beta_z * (g - gd * (tau - t) - y) + tau * gd - z) + f) / tau
        y, z, x = y + z / tau * dt, z + dz * dt, x - dmp.alpha_x * x / tau * dt
    return y, z / tau


def at_the_euler_phase(t, y):
    """The final errors with the forcing term at the Euler phase (:func:`euler`), after checking
    that the emulation with it on time is dmprs's rollout.
    """
    dmp = dmprs.DMP.fit(t, y, N_BASIS, final_velocity=END_VELOCITY)
    errors = {}
    for dt in DTS:
        end = dmp.rollout(dt)
        timed_y, timed_yd = euler(dmp, dt, on_time=True)
        assert np.abs(timed_y - end.y[-1]).max() < 1e-9 and np.abs(timed_yd - end.yd[-1]).max() < 1e-9
        yy, yd = euler(dmp, dt, on_time=False)
        errors[dt] = (np.max(np.abs(yy - y[-1])), np.max(np.abs(yd - END_VELOCITY)))
    return errors


def theirs(t, y):
    from movement_primitives.dmp import DMPWithFinalVelocity

    def make(dt):
        d = DMPWithFinalVelocity(n_dims=2, execution_time=T_DEMO, dt=dt, n_weights_per_dim=N_BASIS,
                                 int_dt=dt, alpha_y=48.0, beta_y=12.0)
        d.imitate(t, y)
        d.configure(start_y=y[0], goal_y=y[-1], goal_yd=END_VELOCITY)
        return d

    d = make(DT)
    roll, (T, _) = timed(lambda: d.open_loop(), 5)
    errors = {}
    for dt in DTS:
        d = make(dt)
        yy, yd = y[0].copy(), np.zeros(2)
        for _ in range(round(T_DEMO / dt)):
            yy, yd = d.step(yy, yd)
        errors[dt] = (np.max(np.abs(yy - y[-1])), np.max(np.abs(yd - END_VELOCITY)))
    return roll / len(T), errors


def main() -> None:
    t, y = moving_demo()
    rows = [("dmprs", *ours(t, y))]
    try:
        rows.append(("movement_primitives 0.9.1", *theirs(t, y)))
    except ImportError as exc:
        print(f"movement_primitives not installed ({exc}); pip install '.[bench]'", file=sys.stderr)
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"Python {platform.python_version()}, numpy {np.__version__}, load {os.getloadavg()[0]:.1f}\n")
    base = rows[0]
    print("| library | rollout (ns / step, 2 DOF) | rollout vs dmprs |")
    print("|---|---:|---:|")
    for name, roll, _ in rows:
        print(f"| {name} | {roll * 1e9:.1f} | {roll / base[1]:.0f}x |")
    today = ("dmprs without a final velocity", *todays(t, y))
    early = at_the_euler_phase(t, y)
    print(f"| {today[0]} | {today[1] * 1e9:.1f} | {today[1] / base[1]:.2f}x |")
    print("\n| dt (ms) | library | final position error | final velocity error | velocity error vs dmprs |")
    print("|---:|---|---:|---:|---:|")
    for dt in DTS:
        for name, _, errors in [*rows, today]:
            ep, ev = errors[dt]
            print(f"| {dt * 1e3:g} | {name} | {ep:.2e} | {ev:.2e} | {ev / base[2][dt][1]:.2f}x |")
        lag = np.max(np.abs(END_ACCELERATION)) * ALPHA_X * dt / 2
        print(f"| {dt * 1e3:g} | the Euler phase's lag, ydd(tau) alpha_x dt / 2 | | {lag:.2e} | {lag / base[2][dt][1]:.2f}x |")
        ep, ev = early[dt]
        print(f"| {dt * 1e3:g} | dmprs's steps, the forcing term at the Euler phase (emulated) | {ep:.2e} | "
              f"{ev:.2e} | {ev / base[2][dt][1]:.2f}x |")


if __name__ == "__main__":
    main()
