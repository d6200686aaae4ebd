"""Demonstrations from ROS 1 and ROS 2 bags, read with the pure-Python ``rosbags`` package (no ROS
installation needed). ROS 2 bags may be sqlite3 or mcap; ROS 1 bags are ``.bag`` files.

* ``sensor_msgs/JointState`` topics -> :class:`JointRecording` (a :class:`~dmprs.Trajectory` of
  the chosen joints, in the order asked for),
* ``geometry_msgs/PoseStamped`` topics and TF (``/tf``, ``/tf_static``) between two frames ->
  :class:`~dmprs.CartesianTrajectory` (what :class:`~dmprs.CartesianDMP` fits).

Times are in seconds since the bag's first message (so they keep nanosecond precision and match
the offsets ``ros2 bag info`` shows). Header stamps are used when the messages have them, the
bag's receive times otherwise. Messages are put in time order; a message whose time does not
exceed the previous one's is dropped (duplicates happen when two nodes publish).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dmprs.errors import InvalidInputError
from dmprs.io.poses import interpolate_poses, pose_trajectory, quat_conjugate, quat_multiply, quat_rotate
from dmprs.trajectory import CartesianTrajectory, Trajectory

__all__ = ["JointRecording", "bag_topics", "read_joint_states", "read_poses", "read_tf"]

JOINT_STATE = "sensor_msgs/msg/JointState"
POSE_STAMPED = "geometry_msgs/msg/PoseStamped"
TF_MESSAGE = "tf2_msgs/msg/TFMessage"


@dataclass(frozen=True)
class JointRecording:
    """Joint positions read from a bag: ``trajectory.y[:, k]`` is joint ``names[k]``; times in s
    since the bag's start."""

    names: tuple[str, ...]
    trajectory: Trajectory
    topic: str = ""


@contextmanager
def _reader(path: str | Path) -> Iterator[Any]:
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    p = Path(path)
    if not p.exists():
        raise InvalidInputError(f"{p}: no such bag (a ROS 2 bag is a directory, a ROS 1 bag a .bag file)")
    reader = AnyReader([p], default_typestore=get_typestore(Stores.LATEST))
    try:
        reader.open()
    except Exception as exc:  # noqa: BLE001 - rosbags raises its own classes for each kind of bad file
        raise InvalidInputError(f"{p}: not a readable ROS bag ({type(exc).__name__}: {exc})") from None
    try:
        yield reader
    finally:
        reader.close()


def bag_topics(path: str | Path) -> dict[str, str]:
    """The topics of a bag and their message types."""
    with _reader(path) as reader:
        return {c.topic: c.msgtype for c in reader.connections}


def _connections(reader: Any, path: str | Path, topic: str, msgtypes: Sequence[str]) -> list[Any]:
    conns = [c for c in reader.connections if c.topic == topic]
    if not conns:
        have = ", ".join(f"{c.topic} ({c.msgtype})" for c in reader.connections) or "none"
        raise InvalidInputError(f"{path}: no topic {topic!r}; the bag has: {have}")
    bad = [c.msgtype for c in conns if c.msgtype not in msgtypes]
    if bad:
        raise InvalidInputError(f"{path}: topic {topic!r} carries {bad[0]}, expected {' or '.join(msgtypes)}")
    return conns


def _stamp_ns(msg: Any) -> int:
    s = msg.header.stamp
    return int(s.sec) * 1_000_000_000 + int(s.nanosec)


def _messages(reader: Any, conns: list[Any]) -> list[tuple[int, Any]]:
    """(receive time in ns, message) in bag order."""
    return [(ts, reader.deserialize(raw, c.msgtype)) for c, ts, raw in reader.messages(connections=conns)]


def _times(reader: Any, msgs: list[tuple[int, Any]]) -> NDArray[np.float64]:
    """Header stamps if any is set, else receive times, in s since the bag's start."""
    stamps = np.array([_stamp_ns(m) for _, m in msgs], dtype=np.int64)
    if not stamps.any():
        stamps = np.array([ts for ts, _ in msgs], dtype=np.int64)
    return (stamps - int(reader.start_time)).astype(np.float64) * 1e-9


def _increasing(t: NDArray[np.float64]) -> NDArray[np.intp]:
    """Indices that sort ``t`` and drop samples not later than the one kept before them."""
    order = np.argsort(t, kind="stable")
    ts = t[order]
    keep = np.concatenate([[True], np.diff(ts) > 0])
    return order[keep]


def read_joint_states(path: str | Path, topic: str = "/joint_states", joints: Sequence[str] | None = None,
                      *, velocities: bool = False) -> JointRecording:
    """The joint positions of a ``sensor_msgs/JointState`` topic.

    ``joints`` picks joints by name, in that order (default: those of the first message).
    Messages that lack one of them (another publisher on the same topic) are skipped. With
    ``velocities=True`` the recorded velocities become the trajectory's ``yd`` (every kept
    message must have them); by default the fit differentiates the positions instead.
    """
    with _reader(path) as reader:
        conns = _connections(reader, path, topic, (JOINT_STATE,))
        msgs = _messages(reader, conns)
        if not msgs:
            raise InvalidInputError(f"{path}: topic {topic!r} has no messages")
        seen: dict[str, None] = {}
        for _, m in msgs:
            seen.update(dict.fromkeys(m.name))
        names = tuple(msgs[0][1].name) if joints is None else tuple(joints)
        missing = [j for j in names if j not in seen]
        if missing:
            raise InvalidInputError(
                f"{path}: topic {topic!r} has no joint {', '.join(map(repr, missing))}; its joints are "
                f"{', '.join(seen)}")
        kept = [(ts, m) for ts, m in msgs if all(j in m.name for j in names)]
        t = _times(reader, kept)
    rows, vel = [], []
    for _, m in kept:
        index = [list(m.name).index(j) for j in names]
        if len(m.position) != len(m.name):
            raise InvalidInputError(
                f"{path}: a message on {topic!r} has {len(m.name)} names but {len(m.position)} positions")
        rows.append(np.asarray(m.position, dtype=np.float64)[index])
        if velocities:
            if len(m.velocity) != len(m.name):
                raise InvalidInputError(
                    f"{path}: velocities=True but a message on {topic!r} has {len(m.velocity)} velocities "
                    f"for {len(m.name)} joints")
            vel.append(np.asarray(m.velocity, dtype=np.float64)[index])
    order = _increasing(t)
    if len(order) < 3:
        raise InvalidInputError(
            f"{path}: topic {topic!r} has {len(order)} distinct samples of {names}; at least 3 are needed")
    y = np.asarray(rows)[order]
    yd = np.asarray(vel)[order] if velocities else None
    return JointRecording(names, Trajectory(t[order], y, yd), topic)


def _pose_row(position: Any, orientation: Any) -> list[float]:
    return [position.x, position.y, position.z, orientation.w, orientation.x, orientation.y, orientation.z]


def read_poses(path: str | Path, topic: str) -> CartesianTrajectory:
    """The poses of a ``geometry_msgs/PoseStamped`` topic (in the messages' ``header.frame_id``)."""
    with _reader(path) as reader:
        conns = _connections(reader, path, topic, (POSE_STAMPED,))
        msgs = _messages(reader, conns)
        if len(msgs) < 2:
            raise InvalidInputError(
                f"{path}: topic {topic!r} has {len(msgs)} messages; at least 2 are needed")
        t = _times(reader, msgs)
    poses = np.array([_pose_row(m.pose.position, m.pose.orientation) for _, m in msgs], dtype=np.float64)
    order = _increasing(t)
    return pose_trajectory(t[order], poses[order])


# --- TF ----------------------------------------------------------------------------------------

def _compose(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """Pose b expressed in the frame of pose a, both (M, 7): T_a * T_b."""
    return np.hstack([a[:, :3] + quat_rotate(a[:, 3:], b[:, :3]), quat_multiply(a[:, 3:], b[:, 3:])])


def _invert(a: NDArray[np.float64]) -> NDArray[np.float64]:
    qi = quat_conjugate(a[:, 3:])
    return np.hstack([-quat_rotate(qi, a[:, :3]), qi])


def _frame_path(edges: dict[tuple[str, str], Any], frame: str, child: str,
                path: str | Path) -> list[tuple[str, str, bool]]:
    """The TF edges from ``frame`` to ``child`` as (parent, child, forward) by breadth-first search."""
    graph: dict[str, list[tuple[str, tuple[str, str, bool]]]] = {}
    for p, c in edges:
        graph.setdefault(p, []).append((c, (p, c, True)))
        graph.setdefault(c, []).append((p, (p, c, False)))
    for name in (frame, child):
        if name not in graph:
            raise InvalidInputError(
                f"{path}: TF has no frame {name!r}; its frames are {', '.join(sorted(graph))}")
    prev: dict[str, tuple[str, tuple[str, str, bool]] | None] = {frame: None}
    queue = deque([frame])
    while queue:
        node = queue.popleft()
        for nxt, edge in graph[node]:
            if nxt not in prev:
                prev[nxt] = (node, edge)
                queue.append(nxt)
    if child not in prev:
        raise InvalidInputError(
            f"{path}: TF does not connect {frame!r} and {child!r} (they are in separate trees)")
    steps = []
    node = child
    while (link := prev[node]) is not None:
        node, edge = link
        steps.append(edge)
    return steps[::-1]


def read_tf(path: str | Path, frame: str, child_frame: str,
            topics: Sequence[str] = ("/tf", "/tf_static")) -> CartesianTrajectory:
    """The pose of ``child_frame`` in ``frame`` over time, from TF messages, through any chain of
    transforms between them (each one interpolated: translations linearly, rotations by slerp).

    Samples are at the times of the moving transforms on the chain, within the interval all of
    them cover; static transforms (``/tf_static``, or any published once) hold for all times.
    """
    with _reader(path) as reader:
        present = [t for t in topics if any(c.topic == t for c in reader.connections)]
        if not present:
            have = ", ".join(f"{c.topic} ({c.msgtype})" for c in reader.connections) or "none"
            raise InvalidInputError(f"{path}: no TF topic ({', '.join(topics)}); the bag has: {have}")
        conns = [c for t in present for c in _connections(reader, path, t, (TF_MESSAGE,))]
        start = int(reader.start_time)
        edges: dict[tuple[str, str], list[tuple[float, list[float]]]] = {}
        for _, m in _messages(reader, conns):
            for tf in m.transforms:
                key = (tf.header.frame_id.lstrip("/"), tf.child_frame_id.lstrip("/"))
                tr = tf.transform
                edges.setdefault(key, []).append(
                    ((_stamp_ns(tf) - start) * 1e-9, _pose_row(tr.translation, tr.rotation)))
    steps = _frame_path(edges, frame.lstrip("/"), child_frame.lstrip("/"), path)
    series = []
    for p, c, forward in steps:
        samples = sorted(edges[(p, c)], key=lambda s: s[0])
        t = np.array([s[0] for s in samples])
        keep = _increasing(t)
        series.append((t[keep], np.array([s[1] for s in samples])[keep], forward))
    moving = [s for s in series if len(s[0]) > 1]
    if moving:
        lo, hi = max(s[0][0] for s in moving), min(s[0][-1] for s in moving)
        if lo > hi:
            raise InvalidInputError(
                f"{path}: the transforms between {frame!r} and {child_frame!r} never overlap in time")
        times = np.unique(np.concatenate([s[0] for s in moving]))
        times = times[(times >= lo) & (times <= hi)]
    else:
        times = np.array([max(s[0][-1] for s in series)])
    pose = np.tile(np.array([0.0, 0, 0, 1, 0, 0, 0]), (len(times), 1))
    for t, poses, forward in series:
        edge = interpolate_poses(t, poses, times) if len(t) > 1 else np.tile(poses[-1], (len(times), 1))
        norm = np.linalg.norm(edge[:, 3:], axis=1, keepdims=True)
        edge = np.hstack([edge[:, :3], edge[:, 3:] / norm])
        pose = _compose(pose, edge if forward else _invert(edge))
    return pose_trajectory(times, pose)
