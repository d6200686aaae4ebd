"""From your own demonstrations in a ROS bag to a learned skill, and back to the robot.

    pip install "dmprs[io]"
    python examples/bag_to_skill.py --bag my_recording --joints shoulder,elbow,wrist --out out/
    python examples/bag_to_skill.py --out out/          # records a demonstration bag first

1. read the joint states of the arm from the bag (ROS 1 or ROS 2; no ROS installation needed),
2. cut the recording where the arm rests into single movements and resample them at 100 Hz,
3. fit a DMP to the first movement, and move its goal,
4. write the adapted movement as a trajectory_msgs/JointTrajectory bag and a CSV for the robot.

Without ``--bag`` it first writes a bag like the one a robot records (/joint_states at 100 Hz,
two reaching movements separated by pauses), so the example runs anywhere.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

import dmprs
from dmprs.io import (
    read_joint_states,
    resample,
    split_at_rest,
    write_joint_trajectory_bag,
    write_trajectory_csv,
)

JOINTS = ("shoulder", "elbow", "wrist")


def record_demo_bag(path: Path) -> Path:
    """A 5 s recording of a 3-joint arm: rest, reach, rest, return, rest; stamps at 100 Hz."""
    from rosbags.rosbag2 import Writer
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS2_HUMBLE)
    T = ts.types
    t = np.arange(0.0, 5.0, 0.01)

    def min_jerk(s: np.ndarray) -> np.ndarray:
        s = np.clip(s, 0.0, 1.0)
        return 10 * s**3 - 15 * s**4 + 6 * s**5

    s = min_jerk((t - 0.5) / 1.5) - min_jerk((t - 3.0) / 1.5)
    q = np.stack([0.9 * s, 0.2 - 0.6 * s, 0.4 * np.sin(np.pi * s)], axis=1)
    with Writer(path, version=9) as w:
        conn = w.add_connection("/joint_states", "sensor_msgs/msg/JointState", typestore=ts)
        for tk, qk in zip(t, q, strict=True):
            ns = 1_700_000_000 * 10**9 + round(tk * 1e9)
            msg = T["sensor_msgs/msg/JointState"](
                header=T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](
                    sec=ns // 10**9, nanosec=ns % 10**9), frame_id=""),
                name=list(JOINTS), position=qk, velocity=np.zeros(0), effort=np.zeros(0))
            w.write(conn, ns, ts.serialize_cdr(msg, "sensor_msgs/msg/JointState"))
    return path


def main(out: Path, bag: Path | None = None, topic: str = "/joint_states", joints: tuple[str, ...] = JOINTS,
         rest_speed: float = 0.02, goal_shift: float = 0.1) -> dict:
    out.mkdir(parents=True, exist_ok=True)
    if bag is None:
        bag = out / "recording"
        if not bag.exists():
            record_demo_bag(bag)
    rec = read_joint_states(bag, topic, joints)
    moves = split_at_rest(rec.trajectory, speed_tol=rest_speed)
    print(f"{bag}: {rec.trajectory.duration:.2f} s of {', '.join(rec.names)}; {len(moves)} movements")
    demo = resample(moves[0], 100.0)
    dmp = dmprs.DMP.fit(demo.t, demo.y, n_basis=30)
    again = dmp.rollout(dt=0.01, duration=demo.duration)
    n = min(len(again), len(demo))
    rms = float(np.sqrt(np.mean((again.y[:n] - demo.y[:n]) ** 2)))
    print(f"movement 1: {demo.duration:.2f} s, DMP reproduces it within {rms * 1e3:.2f} mrad RMS")
    # the same movement to a goal shifted by goal_shift rad on every joint, until it is at rest
    adapted = dmp.with_goal(dmp.goal + goal_shift).rollout(dt=0.01, until_rest=True, rest_tol=1e-3)
    target = out / "adapted_bag"
    if target.exists():
        import shutil

        shutil.rmtree(target)
    write_joint_trajectory_bag(target, adapted, rec.names)
    write_trajectory_csv(out / "adapted.csv", adapted, rec.names)
    print(f"adapted movement ({adapted.duration:.2f} s, ends at {np.round(adapted.y[-1], 3)}) written to "
          f"{target} (trajectory_msgs/JointTrajectory on /joint_trajectory) and {out / 'adapted.csv'}")
    return {"movements": len(moves), "rms": rms, "end": adapted.y[-1], "goal": dmp.goal + goal_shift,
            "bag": target, "csv": out / "adapted.csv"}


if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--bag", type=Path, default=None, help="your bag (default: record one first)")
    p.add_argument("--topic", default="/joint_states")
    p.add_argument("--joints", default=",".join(JOINTS))
    p.add_argument("--rest-speed", type=float, default=0.02, help="rad/s below which the arm rests")
    p.add_argument("--out", type=Path, default=Path("out/bag_to_skill"))
    a = p.parse_args()
    main(a.out, a.bag, a.topic, tuple(a.joints.split(",")), a.rest_speed)
