"""Online stepper benchmark: one ``step()`` called from Python, dmprs against movement_primitives.

Workload: a 7-DOF, 1 s reaching DMP (``dmprs.demo.reaching_demo``) with N = 25 and 50 kernels,
and a 1 s pose DMP (position along a curve, orientation turning 1.7 rad about a moving axis,
N = 50), stepped at dt = 1 ms. dmprs: ``stepper.step()`` open loop, ``step(measured)`` (phase
stopping), and with velocity and acceleration limits. movement_primitives 0.9.1: ``DMP.step`` /
``CartesianDMP.step`` with its fastest step functions (``euler-cython``; Cython quaternion step),
fed back its own state as the measured one (what its closed loop does), for the same demo and
N. Both in one process; each timing is the median of ROUNDS rounds of CALLS calls (a round
restarts the movement).

    pip install ".[bench]" && python benches/bench_stepper.py

Prints a markdown table. Floors: <= 300 ns per joint step and <= 400 ns per Cartesian step from
Python, >= 20x faster than movement_primitives' step (benches/README.md).
"""

from __future__ import annotations

import os
import platform
import statistics
import sys
import time

import numpy as np

import dmprs
from bench_cartesian import pose_demo  # the Cartesian benchmark's demo (benches/ is on the path)
from dmprs.demo import reaching_demo

DT = 0.001
ROUNDS, CALLS = 41, 1000
MP_ROUNDS, MP_CALLS = 11, 300


def median_per_call(setup, call, rounds: int = ROUNDS, calls: int = CALLS) -> float:
    """Median over ``rounds`` of the time per call of ``call`` (``setup`` restarts between rounds)."""
    times = []
    for _ in range(rounds + 1):  # the first round warms up
        setup()
        t0 = time.perf_counter()
        for _ in range(calls):
            call()
        times.append((time.perf_counter() - t0) / calls)
    return statistics.median(times[1:])


def dmprs_joint(t, y, n_basis: int) -> dict[str, float]:
    dmp = dmprs.DMP.fit(t, y, n_basis)
    out = {}
    stepper = dmp.stepper(DT)
    step = stepper.step
    out["open loop"] = median_per_call(stepper.reset, step)
    measured = dmp.start.copy()
    out["measured"] = median_per_call(stepper.reset, lambda: step(measured))
    free = dmp.rollout(DT)
    limited = dmp.stepper(
        DT, velocity_max=np.abs(free.yd).max(axis=0) / 1.5, acceleration_max=np.abs(free.ydd).max(axis=0) / 1.5
    )
    out["limits"] = median_per_call(limited.reset, limited.step)
    return out


def mp_joint(t, y, n_basis: int) -> float:
    from movement_primitives.dmp import DMP

    d = DMP(n_dims=y.shape[1], execution_time=1.0, dt=DT, n_weights_per_dim=n_basis, int_dt=DT)
    d.imitate(t, y)
    state = {}

    def setup():
        d.reset()
        d.configure(start_y=y[0], goal_y=y[-1])
        state["y"], state["yd"] = y[0].copy(), np.zeros(y.shape[1])

    def call():
        state["y"], state["yd"] = d.step(state["y"], state["yd"], step_function="euler-cython")

    return median_per_call(setup, call, MP_ROUNDS, MP_CALLS)


def dmprs_cartesian(t, pose) -> float:
    stepper = dmprs.CartesianDMP.fit(t, pose, 50).stepper(DT)
    return median_per_call(stepper.reset, stepper.step)


def mp_cartesian(t, pose) -> float:
    from movement_primitives.dmp import CartesianDMP
    from movement_primitives.dmp._cartesian_dmp import CARTESIAN_DMP_STEP_FUNCTIONS
    from movement_primitives.dmp._dmp import DMP_STEP_FUNCTIONS

    d = CartesianDMP(execution_time=1.0, dt=DT, n_weights_per_dim=50, int_dt=DT)
    d.imitate(t, pose)
    step_fn = DMP_STEP_FUNCTIONS["euler-cython"]
    quat_fn = CARTESIAN_DMP_STEP_FUNCTIONS["cython"]
    state = {}

    def setup():
        d.reset()
        state["y"], state["yd"] = pose[0].copy(), np.zeros(6)

    def call():
        state["y"], state["yd"] = d.step(state["y"], state["yd"], step_function=step_fn, quaternion_step_function=quat_fn)

    return median_per_call(setup, call, MP_ROUNDS, MP_CALLS)


def main() -> None:
    t, y = reaching_demo()
    tp, pose = pose_demo()
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"Python {platform.python_version()}, numpy {np.__version__}, load {os.getloadavg()[0]:.1f}\n")
    rows = []
    for n_basis in (25, 50):
        ours = dmprs_joint(t, y, n_basis)
        try:
            theirs = mp_joint(t, y, n_basis)
        except ImportError as exc:
            print(f"movement_primitives not installed ({exc}); pip install '.[bench]'", file=sys.stderr)
            theirs = float("nan")
        rows.append((f"joint, 7 DOF, N = {n_basis}", ours, theirs))
    ours_c = dmprs_cartesian(tp, pose)
    try:
        theirs_c = mp_cartesian(tp, pose)
    except ImportError:
        theirs_c = float("nan")
    print("| DMP | dmprs step, open loop (ns) | dmprs step(measured) (ns) | dmprs step with limits (ns) "
          "| movement_primitives step (ns) | ratio (open loop) |")
    print("|---|---:|---:|---:|---:|---:|")
    for name, ours, theirs in rows:
        print(f"| {name} | {ours['open loop'] * 1e9:.0f} | {ours['measured'] * 1e9:.0f} | {ours['limits'] * 1e9:.0f} "
              f"| {theirs * 1e9:.0f} | {theirs / ours['open loop']:.0f}x |")
    print(f"| Cartesian, N = 50 | {ours_c * 1e9:.0f} | | | {theirs_c * 1e9:.0f} | {theirs_c / ours_c:.0f}x |")


if __name__ == "__main__":
    main()
