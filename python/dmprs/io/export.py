"""Rolled-out trajectories for a robot stack: a ``trajectory_msgs/JointTrajectory`` message in a
ROS 2 bag (replay it with ``ros2 bag play`` into a joint trajectory controller), or a CSV file.
"""

from __future__ import annotations

import csv
import io
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from dmprs._io import write_atomic
from dmprs.errors import InvalidInputError
from dmprs.trajectory import Trajectory

__all__ = ["write_joint_trajectory_bag", "write_trajectory_csv"]

JOINT_TRAJECTORY = "trajectory_msgs/msg/JointTrajectory"


def _names(trajectory: Trajectory, joint_names: Sequence[str]) -> list[str]:
    if not isinstance(trajectory, Trajectory):
        raise InvalidInputError(f"trajectory is a {type(trajectory).__name__}; expected a dmprs.Trajectory")
    names = [str(n) for n in joint_names]
    if len(names) != trajectory.n_dof or len(set(names)) != len(names):
        raise InvalidInputError(
            f"joint_names must be {trajectory.n_dof} distinct names, one per DOF; got {names}")
    return names


def write_joint_trajectory_bag(path: str | Path, trajectory: Trajectory, joint_names: Sequence[str], *,
                               topic: str = "/joint_trajectory", storage: str = "sqlite3",
                               stamp_ns: int = 0, frame_id: str = "") -> Path:
    """Writes ``trajectory`` as one ``JointTrajectory`` message (every sample a point with its
    ``time_from_start``, positions, and velocities and accelerations when the trajectory has
    them) into a new ROS 2 bag directory ``path`` (``storage``: ``"sqlite3"`` or ``"mcap"``).
    """
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    names = _names(trajectory, joint_names)
    plugins = {"sqlite3": StoragePlugin.SQLITE3, "mcap": StoragePlugin.MCAP}
    if storage not in plugins:
        raise InvalidInputError(f"storage = {storage!r}; use 'sqlite3' or 'mcap'")
    out = Path(path)
    if out.exists():
        raise InvalidInputError(f"{out} exists; a bag is written to a new directory")
    ts = get_typestore(Stores.LATEST)
    T = ts.types
    stamp = T["builtin_interfaces/msg/Time"](sec=stamp_ns // 10**9, nanosec=stamp_ns % 10**9)
    empty = np.zeros(0)
    points = []
    t0 = trajectory.t[0]
    for j, tj in enumerate(trajectory.t):
        ns = round((tj - t0) * 1e9)
        points.append(T["trajectory_msgs/msg/JointTrajectoryPoint"](
            positions=trajectory.y[j].copy(),
            velocities=empty if trajectory.yd is None else trajectory.yd[j].copy(),
            accelerations=empty if trajectory.ydd is None else trajectory.ydd[j].copy(),
            effort=empty,
            time_from_start=T["builtin_interfaces/msg/Duration"](sec=ns // 10**9, nanosec=ns % 10**9)))
    msg = T[JOINT_TRAJECTORY](header=T["std_msgs/msg/Header"](stamp=stamp, frame_id=frame_id),
                              joint_names=names, points=points)
    with Writer(out, version=9, storage_plugin=plugins[storage]) as writer:
        conn = writer.add_connection(topic, JOINT_TRAJECTORY, typestore=ts)
        writer.write(conn, stamp_ns, ts.serialize_cdr(msg, JOINT_TRAJECTORY))
    return out


def write_trajectory_csv(path: str | Path, trajectory: Trajectory, joint_names: Sequence[str]) -> Path:
    """Writes ``time`` (s) and one column per joint, then ``<joint>.velocity`` and
    ``<joint>.acceleration`` columns when known; values with 17 significant digits (they read
    back exactly). The file is replaced atomically.
    """
    names = _names(trajectory, joint_names)
    header = ["time", *names]
    cols = [trajectory.t[:, None], trajectory.y]
    for suffix, arr in (("velocity", trajectory.yd), ("acceleration", trajectory.ydd)):
        if arr is not None:
            header += [f"{n}.{suffix}" for n in names]
            cols.append(arr)
    data = np.hstack(cols)
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(header)
    w.writerows([[repr(float(v)) for v in row] for row in data])
    out = Path(path)
    write_atomic(out, buf.getvalue().encode("utf-8"))
    return out
