"""Demonstrations from ROS 1 and ROS 2 bags, read with the pure-Python ``rosbags`` package (no ROS
installation needed). ROS 2 bags may be sqlite3 or mcap; ROS 1 bags are ``.bag`` files.

* ``sensor_msgs/JointState`` topics -> :class:`JointRecording` (a :class:`~dmprs.Trajectory` of
  the chosen joints, in the order asked for),
* ``geometry_msgs/PoseStamped`` topics and TF (``/tf``, ``/tf_static``) between two frames ->
  :class:`~dmprs.CartesianTrajectory` (what :class:`~dmprs.CartesianDMP` fits).

Times are in seconds since the bag's first message (so they keep nanosecond precision and match
the offsets ``ros2 bag info`` shows). Header stamps are used when the messages have them, the
bag's receive times when a topic's stamps are all zero; a zero stamp among set ones is refused.
Messages are put in time order; a message whose time does not exceed the previous one's is
dropped (duplicates happen when two nodes publish). A gap longer than :data:`MAX_STAMP_GAP_S`
between consecutive samples, a non-finite value, a message with a joint named twice and fewer
than :data:`~dmprs.io.segment.MIN_SAMPLES` samples are refused, naming the bag, topic and message.

Before rosbags opens a bag, :func:`dmprs.io.bagcheck.check_bag` makes sure every file it will
open is a regular file and nothing it will inflate is a compression bomb; whatever rosbags
raises on a damaged bag becomes an :class:`~dmprs.errors.InvalidInputError` naming the bag.
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

from dmprs import quaternion
from dmprs.errors import DmprsError, InvalidInputError
from dmprs.io.bagcheck import check_bag
from dmprs.io.poses import interpolate_poses, pose_trajectory
from dmprs.io.segment import MIN_SAMPLES
from dmprs.trajectory import CartesianTrajectory, Trajectory

__all__ = ["MAX_STAMP_GAP_S", "JointRecording", "bag_topics", "read_joint_states", "read_poses", "read_tf"]

JOINT_STATE = "sensor_msgs/msg/JointState"
POSE_STAMPED = "geometry_msgs/msg/PoseStamped"
TF_MESSAGE = "tf2_msgs/msg/TFMessage"
#: Consecutive samples of one recording further apart than this (s) are refused: a clock that
#: jumped (a stamp of another epoch), not a pause in a demonstration.
MAX_STAMP_GAP_S = 3600.0
# Bag times are int64 ns; a start time within +-2**62 keeps every stamp minus it within int64.
_MAX_START_NS = 2**62


@dataclass(frozen=True)
class JointRecording:
    """Joint positions read from a bag: ``trajectory.y[:, k]`` is joint ``names[k]``; times in s
    since the bag's start.
    """

    names: tuple[str, ...]
    trajectory: Trajectory
    topic: str = ""


def _rosbags_errors() -> tuple[type[BaseException], ...]:
    """What rosbags and the libraries under it raise for a bag they cannot read."""
    import apsw
    from rosbags.highlevel import AnyReaderError
    from rosbags.rosbag1 import ReaderError as ReaderError1
    from rosbags.rosbag2 import ReaderError as ReaderError2
    from rosbags.serde import SerdeError
    from rosbags.typesys import TypesysError

    return (AnyReaderError, ReaderError1, ReaderError2, SerdeError, TypesysError, apsw.Error, OSError,
            UnicodeDecodeError, OverflowError)


@contextmanager
def _reader(path: str | Path) -> Iterator[Any]:
    """An open AnyReader; whatever rosbags raises in the ``with`` block (opening, listing,
    iterating, deserializing) becomes an InvalidInputError naming the bag.
    """
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    p = Path(path)
    if not p.exists():
        raise InvalidInputError(f"{p}: no such bag (a ROS 2 bag is a directory, a ROS 1 bag a .bag file)")
    check_bag(p)
    known = _rosbags_errors()
    reader = None
    try:
        reader = AnyReader([p], default_typestore=get_typestore(Stores.LATEST))
        reader.open()
        yield reader
    except DmprsError:
        raise
    except known as exc:
        raise InvalidInputError(f"{p}: not a readable ROS bag ({type(exc).__name__}: {str(exc)[:300]})") from None
    # The boundary with rosbags: it parses hostile bytes with asserts, struct.unpack, ord(),
    # dict and list lookups, so a damaged bag can raise anything (AssertionError, KeyError,
    # IndexError, struct.error, TypeError, ...). The block holds only rosbags calls and field
    # reads; the arrays are built after it.
    except Exception as exc:  # noqa: BLE001
        raise InvalidInputError(f"{p}: not a readable ROS bag (rosbags failed: {type(exc).__name__}: "
                                f"{str(exc)[:300]})") from None
    finally:
        if reader is not None and reader.stack is not None:
            try:
                reader.close()
            except known:
                pass


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


def _start_ns(reader: Any, path: str | Path) -> int:
    start = int(reader.start_time)
    if not -_MAX_START_NS <= start <= _MAX_START_NS:
        raise InvalidInputError(f"{path}: the bag's start time {start} ns is out of range (a damaged index or "
                                "metadata.yaml)")
    return start


def _stamp_ns(stamp: Any) -> int:
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def _messages(reader: Any, conns: list[Any]) -> Iterator[tuple[int, int, Any]]:
    """(index on the topics, receive time in ns, message) in bag order."""
    for k, (c, ts, raw) in enumerate(reader.messages(connections=conns)):
        yield k, int(ts), reader.deserialize(raw, c.msgtype)


class _Samples:
    """What a reader keeps of each message: its header stamp, receive time, index and values."""

    def __init__(self) -> None:
        self.stamps: list[int] = []
        self.received: list[int] = []
        self.index: list[int] = []
        self.rows: list[NDArray[np.float64]] = []

    def add(self, stamp: int, received: int, k: int, row: NDArray[np.float64]) -> None:
        self.stamps.append(stamp)
        self.received.append(received)
        self.index.append(k)
        self.rows.append(row)

    def __len__(self) -> int:
        return len(self.rows)


def _times(samples: _Samples, start: int, where: str) -> NDArray[np.float64]:
    """Header stamps if any is set, else receive times, in s since the bag's start. A zero stamp
    among set ones is refused (a publisher that does not stamp, mixed with one that does).
    """
    stamps = np.array(samples.stamps, dtype=np.int64)
    if not stamps.any():
        stamps = np.array(samples.received, dtype=np.int64)
    elif not stamps.all():
        j, set_ = int(np.argmin(stamps != 0)), int(np.argmax(stamps != 0))
        raise InvalidInputError(
            f"{where}, message {samples.index[j]}: its header stamp is zero while message "
            f"{samples.index[set_]} is stamped {stamps[set_] * 1e-9:.12g} s; a publisher that does not "
            "stamp its messages shares the topic (drop its messages or stamp them)")
    return (stamps - start).astype(np.float64) * 1e-9


def _increasing(t: NDArray[np.float64], index: Sequence[int], where: str) -> NDArray[np.intp]:
    """Indices that sort ``t`` and drop samples not later than the one kept before them; a gap
    longer than MAX_STAMP_GAP_S between kept samples is refused.
    """
    order = np.argsort(t, kind="stable")
    ts = t[order]
    keep = np.concatenate([[True], np.diff(ts) > 0])
    order = order[keep]
    gaps = np.diff(t[order])
    if len(gaps) and gaps.max() > MAX_STAMP_GAP_S:
        j = int(np.argmax(gaps))
        a, b = int(order[j]), int(order[j + 1])
        raise InvalidInputError(
            f"{where}: the stamps jump by {gaps[j]:.6g} s between message {index[a]} ({t[a]:.9g} s) and "
            f"message {index[b]} ({t[b]:.9g} s), more than the {MAX_STAMP_GAP_S:g} s a recording may pause; "
            "a clock that jumped (a stamp of another epoch)")
    return order


def _enough(n: int, where: str, what: str) -> None:
    if n < MIN_SAMPLES:
        raise InvalidInputError(
            f"{where} has {n} distinct samples of {what}; a demonstration needs at least {MIN_SAMPLES} "
            "(DMP.fit differentiates twice)")


def _finite(row: NDArray[np.float64], where: str, names: Sequence[str]) -> None:
    bad = ~np.isfinite(row)
    if bad.any():
        j = int(np.argmax(bad))
        raise InvalidInputError(f"{where}: {names[j]} is {row[j]}; every value must be finite")


def _joint_names(m: Any, where: str) -> list[str]:
    names = [str(n) for n in m.name]
    if len(set(names)) != len(names):
        dup = next(n for n in names if names.count(n) > 1)
        raise InvalidInputError(f"{where}: joint {dup!r} is named twice in one message")
    return names


def read_joint_states(path: str | Path, topic: str = "/joint_states", joints: Sequence[str] | None = None,
                      *, velocities: bool = False) -> JointRecording:
    """The joint positions of a ``sensor_msgs/JointState`` topic.

    ``joints`` picks joints by name, in that order (default: those of the first message).
    Messages that lack one of them (another publisher on the same topic) are skipped. With
    ``velocities=True`` the recorded velocities become the trajectory's ``yd`` (every kept
    message must have them); by default the fit differentiates the positions instead.
    """
    names: tuple[str, ...] | None = None
    if joints is not None:
        names = tuple(str(j) for j in joints)
        if not names or len(set(names)) != len(names):
            raise InvalidInputError(f"joints = {list(names)}: give distinct joint names, at least one")
    where = f"{path}, topic {topic!r}"
    samples, vel = _Samples(), []
    seen: dict[str, None] = {}
    with _reader(path) as reader:
        conns = _connections(reader, path, topic, (JOINT_STATE,))
        start = _start_ns(reader, path)
        for k, ts, m in _messages(reader, conns):
            here = f"{where}, message {k}"
            have = _joint_names(m, here)
            seen.update(dict.fromkeys(have))
            if names is None:
                if not have:
                    raise InvalidInputError(f"{here}: the first message names no joint; give the joints")
                names = tuple(have)
            pos = {n: i for i, n in enumerate(have)}
            if not all(j in pos for j in names):
                continue
            index = [pos[j] for j in names]
            position = np.asarray(m.position, dtype=np.float64)
            if len(position) != len(have):
                raise InvalidInputError(f"{here}: {len(have)} joint names but {len(position)} positions")
            _finite(position[index], here, [f"the position of {j!r}" for j in names])
            if velocities:
                velocity = np.asarray(m.velocity, dtype=np.float64)
                if len(velocity) != len(have):
                    raise InvalidInputError(
                        f"{here}: velocities=True but it has {len(velocity)} velocities for {len(have)} joints")
                _finite(velocity[index], here, [f"the velocity of {j!r}" for j in names])
                vel.append(velocity[index])
            samples.add(_stamp_ns(m.header.stamp), ts, k, position[index])
    if not seen and names is None:
        raise InvalidInputError(f"{where}: no messages")
    assert names is not None
    missing = [j for j in names if j not in seen]
    if missing:
        raise InvalidInputError(
            f"{where}: no joint {', '.join(map(repr, missing))}; its joints are {', '.join(seen) or 'none'}")
    _enough(len(samples), where, f"{names}")
    t = _times(samples, start, where)
    order = _increasing(t, samples.index, where)
    _enough(len(order), where, f"{names}")
    y = np.asarray(samples.rows)[order]
    yd = np.asarray(vel)[order] if velocities else None
    return JointRecording(names, Trajectory(t[order], y, yd), topic)


def _pose_row(position: Any, orientation: Any) -> NDArray[np.float64]:
    return np.array([position.x, position.y, position.z, orientation.w, orientation.x, orientation.y,
                     orientation.z], dtype=np.float64)


_POSE_FIELDS = ("x", "y", "z", "qw", "qx", "qy", "qz")


def _check_pose(row: NDArray[np.float64], where: str) -> None:
    _finite(row, where, _POSE_FIELDS)
    if np.linalg.norm(row[3:]) < 1e-9:
        raise InvalidInputError(f"{where}: its quaternion is zero; an orientation must be a rotation")


def read_poses(path: str | Path, topic: str) -> CartesianTrajectory:
    """The poses of a ``geometry_msgs/PoseStamped`` topic (in the messages' ``header.frame_id``)."""
    where = f"{path}, topic {topic!r}"
    samples = _Samples()
    with _reader(path) as reader:
        conns = _connections(reader, path, topic, (POSE_STAMPED,))
        start = _start_ns(reader, path)
        for k, ts, m in _messages(reader, conns):
            row = _pose_row(m.pose.position, m.pose.orientation)
            _check_pose(row, f"{where}, message {k}")
            samples.add(_stamp_ns(m.header.stamp), ts, k, row)
    _enough(len(samples), where, "poses")
    t = _times(samples, start, where)
    order = _increasing(t, samples.index, where)
    _enough(len(order), where, "poses")
    return pose_trajectory(t[order], np.asarray(samples.rows)[order])


# --- TF ----------------------------------------------------------------------------------------

def _compose(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """Pose b expressed in the frame of pose a, both (M, 7): T_a * T_b."""
    return np.hstack([a[:, :3] + quaternion.rotate(a[:, 3:], b[:, :3]), quaternion.product(a[:, 3:], b[:, 3:])])


def _invert(a: NDArray[np.float64]) -> NDArray[np.float64]:
    qi = quaternion.conjugate(a[:, 3:])
    return np.hstack([-quaternion.rotate(qi, a[:, :3]), qi])


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
    edges: dict[tuple[str, str], _Samples] = {}
    with _reader(path) as reader:
        present = [t for t in topics if any(c.topic == t for c in reader.connections)]
        if not present:
            have = ", ".join(f"{c.topic} ({c.msgtype})" for c in reader.connections) or "none"
            raise InvalidInputError(f"{path}: no TF topic ({', '.join(topics)}); the bag has: {have}")
        conns = [c for t in present for c in _connections(reader, path, t, (TF_MESSAGE,))]
        start = _start_ns(reader, path)
        for k, ts, m in _messages(reader, conns):
            for tf in m.transforms:
                key = (str(tf.header.frame_id).lstrip("/"), str(tf.child_frame_id).lstrip("/"))
                tr = tf.transform
                row = _pose_row(tr.translation, tr.rotation)
                _check_pose(row, f"{path}, TF message {k}, transform {key[0]!r} -> {key[1]!r}")
                edges.setdefault(key, _Samples()).add(_stamp_ns(tf.header.stamp), ts, k, row)
    steps = _frame_path(edges, frame.lstrip("/"), child_frame.lstrip("/"), path)
    series = []
    for p, c, forward in steps:
        recorded = edges[(p, c)]
        where = f"{path}, TF {p!r} -> {c!r}"
        t = _times(recorded, start, where)
        keep = _increasing(t, recorded.index, where)
        series.append((t[keep], np.asarray(recorded.rows)[keep], forward))
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
    _enough(len(times), f"{path}, TF {frame!r} -> {child_frame!r}", "poses (a chain of static transforms is one pose)")
    pose = np.tile(np.array([0.0, 0, 0, 1, 0, 0, 0]), (len(times), 1))
    for t, poses, forward in series:
        edge = interpolate_poses(t, poses, times) if len(t) > 1 else np.tile(poses[-1], (len(times), 1))
        norm = np.linalg.norm(edge[:, 3:], axis=1, keepdims=True)
        edge = np.hstack([edge[:, :3], edge[:, 3:] / norm])
        pose = _compose(pose, edge if forward else _invert(edge))
    return pose_trajectory(times, pose)
