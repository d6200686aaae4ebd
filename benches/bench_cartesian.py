"""Cartesian DMP benchmark: dmprs.CartesianDMP against movement_primitives' CartesianDMP.

Workload (issue 14): a 1000-sample, 1 s pose demonstration (position along a curve, orientation
turning 1.7 rad about a moving axis), 50 basis functions; fit, then rollout at dt = 1 ms, all
called from Python, in one process. Each library's own reproduction error of the demo is
reported (its rollout interpolated onto the demo's times: linearly for positions, by slerp for
orientations); the libraries use different constants (benches/README.md).

    pip install ".[bench]" && python benches/bench_cartesian.py

Prints a markdown table; medians of repeated runs. Floors (issue 14): rollout >= 30x faster
than movement_primitives' fastest step functions and <= 100 ns per step for the whole pose;
fit <= 0.5 ms.
"""

from __future__ import annotations

import os
import platform
import sys

import numpy as np
from scipy.spatial.transform import Rotation, Slerp

import dmprs
from _timing import timed

N_SAMPLES, N_BASIS, DT = 1000, 50, 0.001
REPEATS = 50


def pose_demo(n: int = N_SAMPLES) -> tuple[np.ndarray, np.ndarray]:
    t = np.linspace(0.0, 1.0, n)
    a = 10 * t**3 - 15 * t**4 + 6 * t**5
    axis = np.stack([np.ones_like(t), 0.5 * t, 2.0 - t], axis=1)
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    q = Rotation.from_rotvec(axis * (0.2 + 1.7 * a)[:, None]).as_quat(scalar_first=True)
    p = np.stack([0.3 + 0.4 * a, -0.2 * a + 0.05 * np.sin(2 * t), 0.5 - 0.1 * a], axis=1)
    return t, np.hstack([p, q])


def errors(t, pose, t_roll, pose_roll) -> tuple[float, float]:
    """Position RMS (m) and orientation RMS angle (rad) of a rollout against the demo."""
    keep = t_roll <= t[-1] + 1e-12
    t_roll, pose_roll = t_roll[keep], pose_roll[keep]
    p = np.stack([np.interp(t, t_roll, pose_roll[:, d]) for d in range(3)], axis=1)
    slerp = Slerp(t_roll, Rotation.from_quat(np.array(pose_roll[:, 3:]), scalar_first=True))
    q = slerp(np.clip(t, t_roll[0], t_roll[-1]))
    angle = (q * Rotation.from_quat(pose[:, 3:], scalar_first=True).inv()).magnitude()
    return float(np.sqrt(np.mean(np.sum((p - pose[:, :3]) ** 2, axis=1)))), float(np.sqrt(np.mean(angle**2)))


def bench_dmprs(t, pose):
    fit, _ = timed(lambda: dmprs.CartesianDMP.fit(t, pose, N_BASIS), REPEATS)
    dmp = dmprs.CartesianDMP.fit(t, pose, N_BASIS)
    roll, _ = timed(lambda: dmp.rollout(dt=DT), REPEATS)
    tr = dmp.rollout(dt=DT)
    return (fit, roll / tr.n_samples, *errors(t, pose, tr.t, tr.pose), "Euler, exp map (Rust)")


def bench_movement_primitives(t, pose):
    from movement_primitives.dmp import CartesianDMP

    def make():
        d = CartesianDMP(execution_time=1.0, dt=DT, n_weights_per_dim=N_BASIS, int_dt=DT)
        d.imitate(t, pose)
        return d

    fit, _ = timed(make, 10)
    d = make()
    best = None
    # The compiled step functions this build has (and plain Euler), for position and orientation.
    from movement_primitives.dmp._cartesian_dmp import CARTESIAN_DMP_STEP_FUNCTIONS
    from movement_primitives.dmp._dmp import DMP_STEP_FUNCTIONS

    steps = [s for s in ("euler-cython", "rk4-cython", "euler") if s in DMP_STEP_FUNCTIONS]
    quat_steps = [s for s in ("cython", "python") if s in CARTESIAN_DMP_STEP_FUNCTIONS]
    for step in steps:
        for quat_step in quat_steps:
            roll, _ = timed(
                lambda s=step, qs=quat_step: d.open_loop(step_function=s, quaternion_step_function=qs), 5
            )
            if best is None or roll < best[0]:
                best = (roll, step, quat_step)
    assert best is not None
    T, Y = d.open_loop(step_function=best[1], quaternion_step_function=best[2])
    T, Y = np.asarray(T), np.asarray(Y)
    return (fit, best[0] / len(T), *errors(t, pose, T, Y), f"{best[1]} + {best[2]} (quaternion)")


def main() -> None:
    t, pose = pose_demo()
    rows = [("dmprs", *bench_dmprs(t, pose))]
    try:
        rows.append(("movement_primitives 0.9.1", *bench_movement_primitives(t, pose)))
    except ImportError as exc:
        print(f"movement_primitives not installed ({exc}); pip install '.[bench]'", file=sys.stderr)
    ours = rows[0]
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"Python {platform.python_version()}, numpy {np.__version__}, load {os.getloadavg()[0]:.1f}\n")
    print("| library | fit (ms) | rollout (ns / step, whole pose) | position RMS (m) | orientation RMS (rad) "
          "| step functions | fit vs dmprs | rollout vs dmprs |")
    print("|---|---:|---:|---:|---:|---|---:|---:|")
    for name, fit, roll, ep, eo, step in rows:
        print(f"| {name} | {fit * 1e3:.3f} | {roll * 1e9:.1f} | {ep:.2e} | {eo:.2e} | {step} | "
              f"{fit / ours[1]:.0f}x | {roll / ours[2]:.0f}x |")


if __name__ == "__main__":
    main()
