"""Arm-throwing benchmark (MuJoCo): CPU seconds (time.process_time) of one throw trial, against
the bare physics it runs (issue 16's budget: at most 1 s of CPU per throw).

A throw is one ``ArmThrowingAdapter.execute`` of a generalized DMP's rollout (base turn 0.8 s,
swing 0.7 s, then the flight until the ball touches the floor: ~1.97 s of simulated time, ~1970
steps of 1 ms). It is split into

* generalize: ``Generalizer.predict`` at an unseen basket + the rollout at 2 ms (``linear``,
  piecewise linear on the five demos' Delaunay triangulation, and ``lwr-gp``),
* throw: ``adapter.execute`` (limit checks, the 1 kHz servo loop, contact bookkeeping, landing),
* physics: the same number of ``mj_step`` calls from the same state with the same controls, alone.

The ball's settling in the cup runs once per process and is reported apart.

    python benches/bench_throw.py [--repeats 5]
"""

from __future__ import annotations

import argparse
import platform
import statistics

import mujoco

from _timing import cpu, servo_cpu
from dmprs.experiments.arm_throwing import setup as arm_throwing_setup
from dmprs.sim import throw_scene as ts

TARGETS = ((1.05, 0.12), (0.85, -0.1), (1.27, -0.3))


def physics_only(trajectory, n_steps: int) -> float:
    m = ts.model()
    qpos, qvel = ts.settled_ball()
    return servo_cpu(m, qpos, qvel, trajectory, n_steps, 0.001)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    settle, _ = cpu(ts.settled_ball)
    print(f"# {platform.processor() or platform.machine()}, mujoco {mujoco.__version__}; "
          f"settling the ball once: {settle * 1000:.0f} ms CPU")
    print("| generalizer | target (m) | generalize + rollout (ms) | throw (ms) | physics alone (ms) | "
          "throw / physics | simulated (s) |")
    print("|---|---|---|---|---|---|---|")
    for gen in ("linear", "lwr-gp"):
        for target in TARGETS:
            setup = arm_throwing_setup(target, gen)
            task, adapter = setup.task, setup.task.adapter
            adapter.connect()
            g, th, ph = [], [], []
            for _ in range(args.repeats):
                c, traj = cpu(lambda: task.trajectory(setup.generalizer.predict(setup.desired_query)))
                g.append(c)
                adapter.reset(seed=0)
                c, outcome = cpu(lambda: adapter.execute(traj))
                th.append(c)
                assert outcome.ok, outcome.message
                n_steps = round(outcome.signals["landing_time"] / 0.001) + 1
                ph.append(physics_only(traj, n_steps))
            gm, tm, pm = (1000 * statistics.median(x) for x in (g, th, ph))
            print(f"| {gen} | {target} | {gm:.1f} | {tm:.1f} | {pm:.1f} | {tm / pm:.2f} | "
                  f"{outcome.signals['landing_time']:.3f} |")


if __name__ == "__main__":
    main()
