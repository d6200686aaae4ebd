"""How the benchmarks measure: the median wall time of repeated calls, the CPU time of one call,
and the CPU time of a bare MuJoCo servo loop (what an arm adapter's execute costs at the least).

Imported by the scripts beside it (``python benches/bench_*.py`` puts this folder on the path).
"""

from __future__ import annotations

import statistics
import time
from typing import Any

import numpy as np


def timed(fn, repeats: int, *, warm_up: bool = True) -> tuple[float, Any]:
    """The median wall time (s) of ``repeats`` calls of ``fn`` and what the last call returned;
    with ``warm_up``, one untimed call first (caches, lazy imports, the allocator).
    """
    out = fn() if warm_up else None
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), out


def cpu(fn) -> tuple[float, Any]:
    """The CPU seconds (this process) of one call of ``fn``, and what it returned."""
    t0 = time.process_time()
    out = fn()
    return time.process_time() - t0, out


def servo_cpu(model, qpos, qvel, trajectory, n_steps: int, timestep: float) -> float:
    """CPU seconds of ``n_steps`` bare ``mj_step`` calls from the state (qpos, qvel), the 7 arm
    joints' controls set to ``trajectory`` (interpolated beforehand, outside the timing).
    """
    import mujoco  # only the arm benchmarks have MuJoCo installed

    data = mujoco.MjData(model)
    data.qpos[:] = qpos
    data.qvel[:] = qvel
    mujoco.mj_forward(model, data)
    times = np.arange(n_steps + 1) * timestep
    ref = np.stack([np.interp(times, trajectory.t, trajectory.y[:, j]) for j in range(7)], axis=1)
    t0 = time.process_time()
    for k in range(1, n_steps + 1):
        data.ctrl[:] = ref[k]
        mujoco.mj_step(model, data)
    return time.process_time() - t0
