"""Arm-pouring benchmark (MuJoCo): CPU seconds (time.process_time) of one pour trial, and the
share of it spent outside the physics in the IK and the servo loop; with ``--solvers``, the
contact-solver comparison behind the model's choice (docs/arm.md).

A trial is one ``ArmPouringAdapter.execute`` of the scripted demonstration (reach 0.5 s, tilt up
1.5 s, hold 0.7 s, tilt back 1.5 s: 4.2 s) plus the 0.5 s hold before counting: 4.7 s of simulated
time, 4700 steps of 1 ms. It is split into

* IK + checks: ``adapter.check`` (the dry pass: IK at 500 Hz, limits, collision checks),
* physics: the same 4700 ``mj_step`` calls from the same state with the same controls, alone,
* servo: the rest of ``execute`` (interpolating the reference, writing the controls, recording
  the joints, counting the spheres every 20 ms).

The liquid's settling runs once per (volume, seed) and process and is reported apart.

    python benches/bench_arm.py [--repeats 3] [--solvers]
"""

from __future__ import annotations

import argparse
import platform
import statistics
import time

import mujoco
import numpy as np

from _timing import cpu, servo_cpu
from dmprs.sim import arm_model as am
from dmprs.sim import arm_scene, granular
from dmprs.tasks.arm_pouring import ArmPouringAdapter, pour_poses

VOLUMES = (0.3, 0.5, 1.0)
PEAK = 2.0  # rad


def physics_only(adapter: ArmPouringAdapter, trajectory) -> float:
    """CPU of the bare mj_step loop that execute() runs, with its controls precomputed."""
    joints = adapter.plan(trajectory)[0]
    liquid = arm_scene.settled_liquid(adapter.n_particles, 0)
    n_steps = round(joints.duration / am.TIMESTEP) + round(adapter.liquid.hold / am.TIMESTEP)
    return servo_cpu(liquid.model, liquid.qpos, liquid.qvel, joints, n_steps, am.TIMESTEP)


def trial_table(repeats: int) -> None:
    print("| bottle | spheres | settling (once) | CPU per trial (median) | IK + checks | servo | physics | poured |")
    print("|---:|---:|---:|---:|---:|---:|---:|---:|")
    trajectory = pour_poses(PEAK)
    for v in VOLUMES:
        adapter = ArmPouringAdapter(v)
        settle, _ = cpu(lambda adapter=adapter: arm_scene.settled_liquid(adapter.n_particles, 0))
        totals, checks, physics = [], [], []
        poured = None
        with adapter:
            for _ in range(repeats):
                adapter._planned = None  # time the IK every time, not its cache
                adapter.reset(seed=0)
                total, out = cpu(lambda adapter=adapter: adapter.execute(trajectory))
                assert out.ok, out.message
                poured = out.signals["poured_volume"]
                adapter._planned = None
                check, problems = cpu(lambda adapter=adapter: adapter.check(trajectory))
                assert not problems
                totals.append(total)
                checks.append(check)
                physics.append(physics_only(adapter, trajectory))
        total, check, phys = (statistics.median(x) for x in (totals, checks, physics))
        servo = max(total - check - phys, 0.0)
        print(f"| {v:.1f} l | {adapter.n_particles} | {settle:.2f} s | {total:.2f} s | "
              f"{check:.2f} s ({100 * check / total:.1f} %) | {servo:.2f} s ({100 * servo / total:.1f} %) | "
              f"{phys:.2f} s | {poured * 1000:.0f} ml |")


def solver_table(n: int = 300) -> None:
    """CPU per simulated second of a 2.5 s tilt of A7 by 1.8 rad with n spheres, per solver."""
    print(f"\n| solver | iterations | condim | CPU per simulated s ({n} spheres) | bottle / glass / spilled | "
          "deepest penetration |")
    print("|---|---:|---:|---:|---|---:|")
    q0 = arm_scene.home_configuration()
    configs = [("CG", 10, 1), ("CG", 30, 1), ("PGS", 10, 1), ("PGS", 30, 1), ("Newton", 10, 1), ("CG", 10, 3)]
    for solver, iterations, condim in configs:
        liquid = arm_scene.settled_liquid(n, 0, (solver, iterations, condim))
        m, d = liquid.model, mujoco.MjData(liquid.model)
        d.qpos[:] = liquid.qpos
        d.qvel[:] = liquid.qvel
        deepest = 0.0
        t0 = time.process_time()
        for k in range(2500):
            s = min(k / 1000, 1.0)
            d.ctrl[:] = q0
            d.ctrl[6] = q0[6] + 1.8 * (10 * s**3 - 15 * s**4 + 6 * s**5)
            mujoco.mj_step(m, d)
            if k % 10 == 0 and d.ncon:
                deepest = max(deepest, -float(d.contact.dist[: d.ncon].min()))
        per_s = (time.process_time() - t0) / 2.5
        positions = d.qpos[7:].reshape(n, 7)[:, :3]
        b = m.body("bottle").id
        region = granular.classify(positions, d.xpos[b], d.xmat[b].reshape(3, 3))
        counts = np.bincount(region, minlength=3).tolist()
        print(f"| {solver} | {iterations} | {condim} | {per_s:.2f} s | {counts} | {deepest * 1000:.1f} mm |")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--solvers", action="store_true")
    args = ap.parse_args()
    print(f"mujoco {mujoco.__version__}, {platform.processor() or platform.machine()}, "
          f"{am.SOLVER} {am.ITERATIONS} iterations, condim {am.CONDIM}\n")
    trial_table(args.repeats)
    if args.solvers:
        solver_table()


if __name__ == "__main__":
    main()
