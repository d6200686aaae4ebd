"""Pouring-simulation benchmark: CPU seconds per trial (time.process_time) for bottles of 0.3,
0.5 and 1.0 l (150, 250, 500 discs), and the scripted demonstrations' calibration.

A trial is one ``PouringAdapter.execute`` of the demonstration profile (min-jerk up 1 s, hold
1 s, down 1 s) peaking at 95 deg, plus the 1 s hold before counting: 4 s of simulated time,
2400 physics steps. The liquid's 0.5 s settling runs once per (volume, seed) and process and is
reported apart. With ``--calibration`` it also calibrates the 0.3 l and 1.0 l demonstrations
(peak tilt pouring 0.2 l) and measures the poured volume's sensitivity at +-2 deg around them.

    python benches/bench_pouring.py [--repeats 3] [--calibration]

Prints markdown tables (medians over repeats).
"""

from __future__ import annotations

import argparse
import math
import platform
import statistics

import numpy as np
import pymunk

from _timing import cpu
from dmprs.sim import pouring_scene as scene
from dmprs.tasks.pouring import PouringAdapter, calibrate_peak_tilt, demonstration_dmp, tilt_profile

VOLUMES = (0.3, 0.5, 1.0)
PEAK = math.radians(95.0)


def trial_table(repeats: int) -> None:
    print("| bottle | discs | settling (once) | CPU per trial (median) | min / max | poured at 95 deg |")
    print("|---|---|---|---|---|---|")
    traj = tilt_profile(PEAK)
    for v in VOLUMES:
        adapter = PouringAdapter(v)
        scene.settled_liquid.cache_clear()
        settle, _ = cpu(lambda: scene.settled_liquid(adapter.n_particles, 0))
        times, poured = [], None
        with adapter:
            for _ in range(repeats):
                adapter.reset(seed=0)
                dt, o = cpu(lambda: adapter.execute(traj))
                assert o.ok, o.message
                times.append(dt)
                poured = o.signals["poured_volume"]
        print(f"| {v:.1f} l | {adapter.n_particles} | {settle:.2f} s | {statistics.median(times):.2f} s "
              f"| {min(times):.2f} / {max(times):.2f} s | {poured * 1000:.0f} ml |")


def calibration_table() -> None:
    print("\n| demo bottle | peak tilt | poured (profile) | poured (N=40 DMP) | pours to calibrate | calibration CPU | ml/deg at the peak (+-2 deg) |")
    print("|---|---|---|---|---|---|---|")
    for v in (0.3, 1.0):
        dt, cal = cpu(lambda: calibrate_peak_tilt(v))
        adapter = PouringAdapter(v)
        with adapter:
            dmp_traj = demonstration_dmp(v).rollout(dt=adapter.spec.control_period)
            p_dmp = adapter.execute(dmp_traj).signals["poured_volume"]
            lo = adapter.execute(tilt_profile(cal.peak_tilt - math.radians(2))).signals["poured_volume"]
            hi = adapter.execute(tilt_profile(cal.peak_tilt + math.radians(2))).signals["poured_volume"]
        print(f"| {v:.1f} l | {math.degrees(cal.peak_tilt):.2f} deg | {cal.poured_volume * 1000:.0f} ml "
              f"| {p_dmp * 1000:.0f} ml | {len(cal.evaluations)} | {dt:.1f} s | {(hi - lo) * 1000 / 4:.0f} |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--calibration", action="store_true")
    args = ap.parse_args()
    print(f"pymunk {pymunk.version}, Python {platform.python_version()}, {platform.machine()}, "
          f"dt = 1/{round(1 / scene.DT)} s, {scene.ITERATIONS} iterations\n")
    trial_table(args.repeats)
    if args.calibration:
        calibration_table()


if __name__ == "__main__":
    np.seterr(all="raise")
    main()
