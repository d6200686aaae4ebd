"""Building a movement :class:`~dmprs.Database` from recordings: what ``dmprs demos import`` runs.

Every source becomes one or more named demonstrations (:class:`ImportedDemo`):

* a ROS bag (a ROS 2 bag directory or a ROS 1 ``.bag``) -> its joint-state topic, or poses (a
  ``PoseStamped`` topic, or TF between two frames) for a database of pose demonstrations, named
  by the bag's file name; cut by time ranges or at rests, the pieces are ``<name>#0``,
  ``<name>#1``...
* a LeRobot dataset directory -> one demonstration per episode, named by the episode index;
* a CSV or npz file -> one demonstration named by the file name without its suffix.

The query of each comes from a query table (by name) or from label fields (LeRobot episode
fields such as ``task_index``, scalar arrays of an npz file).
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from dmprs.database import Database
from dmprs.errors import DmprsError, InvalidInputError
from dmprs.io.lerobot import read_lerobot
from dmprs.io.poses import poses_between, resample_poses, split_poses_at_rest
from dmprs.io.rosbag import read_joint_states, read_poses, read_tf
from dmprs.io.segment import MIN_SAMPLES, cut, from_zero, resample, split_at_rest
from dmprs.io.tables import QueryTable, read_csv_trajectory, read_npz_trajectory, read_query_table
from dmprs.trajectory import CartesianTrajectory, Trajectory

__all__ = ["FORMATS", "ImportedDemo", "Progress", "build_database", "detect_format", "load_demos"]

#: Called as ``progress(source, done, total)``: LeRobot datasets after each data file (in
#: frames), other sources once they are read (1 of 1).
Progress = Callable[[Path, int, int], None]

FORMATS = ("rosbag", "lerobot", "csv", "npz")
POSE_NAMES = ("x", "y", "z", "qw", "qx", "qy", "qz")


@dataclass(frozen=True)
class ImportedDemo:
    """A demonstration read from a file: its name, trajectory (times from 0), labels that can
    serve as its query, and where it came from (JSON-safe, kept as the database's metadata).
    """

    name: str
    trajectory: Trajectory | CartesianTrajectory
    labels: Mapping[str, Any] = field(default_factory=dict)
    metadata: Mapping[str, Any] = field(default_factory=dict)


def detect_format(path: str | Path) -> str:
    """``rosbag``, ``lerobot``, ``csv`` or ``npz``, from what ``path`` is."""
    p = Path(path)
    if p.is_dir():  # what is inside is checked by the reader (a FIFO metadata.yaml is refused there)
        if os.path.lexists(p / "meta" / "info.json"):
            return "lerobot"
        if os.path.lexists(p / "metadata.yaml"):
            return "rosbag"
        raise InvalidInputError(
            f"{p}: a directory that is neither a ROS 2 bag (metadata.yaml) nor a LeRobot dataset (meta/info.json)")
    suffix = p.suffix.lower()
    formats = {".bag": "rosbag", ".csv": "csv", ".npz": "npz"}
    if suffix not in formats:
        if not p.exists():
            raise InvalidInputError(f"{p}: no such file or directory")
        raise InvalidInputError(f"{p}: unknown kind of file; expected a ROS bag, a LeRobot dataset, .csv or .npz")
    return formats[suffix]


def load_demos(
    sources: Sequence[str | Path],
    *,
    format: str = "auto",
    topic: str = "/joint_states",
    joints: Sequence[str] | None = None,
    column: str = "observation.state",
    dims: Sequence[str] | None = None,
    time_column: str = "t",
    columns: Sequence[str] | None = None,
    ranges: Sequence[tuple[float, float]] | None = None,
    rest_speed: float | None = None,
    rest_angular_speed: float = 0.05,
    rate: float | None = None,
    pose_topic: str | None = None,
    tf: tuple[str, str] | None = None,
    progress: Progress | None = None,
) -> list[ImportedDemo]:
    """The demonstrations in ``sources``.

    ``topic``/``joints`` select joint states in bags, ``column``/``dims`` the LeRobot feature,
    ``time_column``/``columns`` the CSV columns. From bags, ``pose_topic`` (a
    ``geometry_msgs/PoseStamped`` topic) or ``tf=(frame, child_frame)`` read pose trajectories
    instead of joint states; they rest when their linear speed is below ``rest_speed`` (m/s) and
    their angular speed below ``rest_angular_speed`` (rad/s). A recording is cut into pieces by ``ranges``
    (``(start, stop)`` in s of the recording's own clock; bags: since the bag's start) or where it
    rests (speed below ``rest_speed``, in units of y per s). ``rate`` (Hz) resamples every
    demonstration onto a uniform grid (its size is checked before it is allocated); by default
    the recorded times are kept. Every demonstration has at least
    :data:`~dmprs.io.segment.MIN_SAMPLES` samples. ``progress`` is told how far the reading is.
    """
    if format != "auto" and format not in FORMATS:
        raise InvalidInputError(f"format = {format!r}; use auto or one of {', '.join(FORMATS)}")
    if ranges is not None and rest_speed is not None:
        raise InvalidInputError("give time ranges or a rest speed to cut recordings, not both")
    out: list[ImportedDemo] = []
    for src in sources:
        p = Path(src)
        kind = detect_format(p) if format == "auto" else format
        meta: dict[str, Any] = {"source": str(p), "format": kind}
        if kind == "lerobot":
            if ranges is not None or rest_speed is not None:
                raise InvalidInputError(f"{p}: LeRobot episodes are already cut; drop the ranges / rest speed")
            report = None if progress is None else (lambda done, total, p=p: progress(p, done, total))
            for ep in read_lerobot(p, column, dims=dims, progress=report):
                out.append(ImportedDemo(str(ep.index), _resampled(ep.trajectory, rate, f"{p}, episode {ep.index}"),
                                        dict(ep.labels), {**meta, "column": column, "names": list(ep.names),
                                                          "labels": dict(ep.labels)}))
            continue
        labels: dict[str, Any] = {}
        traj: Trajectory | CartesianTrajectory
        names: tuple[str, ...]
        if kind == "rosbag" and pose_topic is not None and tf is not None:
            raise InvalidInputError("read poses from a pose topic or from TF, not both")
        if kind == "rosbag" and pose_topic is not None:
            traj, names = read_poses(p, pose_topic), POSE_NAMES
            meta.update(pose_topic=pose_topic)
        elif kind == "rosbag" and tf is not None:
            traj, names = read_tf(p, *tf), POSE_NAMES
            meta.update(tf=list(tf))
        elif kind == "rosbag":
            rec = read_joint_states(p, topic, joints)
            traj, names = rec.trajectory, rec.names
            meta.update(topic=topic)
        elif kind == "csv":
            traj, names = read_csv_trajectory(p, time_column, columns)
        else:
            traj, labels = read_npz_trajectory(p)
            names = ()
        meta["names"] = list(names)
        stem = p.name[: -len(p.suffix)] if p.suffix else p.name
        try:
            pieces = _pieces(traj, ranges, rest_speed, rest_angular_speed)
        except DmprsError as exc:
            raise InvalidInputError(f"{p}: {exc}") from None
        for k, piece in enumerate(pieces):
            name = stem if len(pieces) == 1 and ranges is None and rest_speed is None else f"{stem}#{k}"
            out.append(ImportedDemo(name, _resampled(piece, rate, str(p) if name == stem else f"{p} ({name})"), labels, {**meta, "labels": labels}))
        if progress is not None:
            progress(p, 1, 1)
    names_seen: dict[str, str] = {}
    for d in out:
        if d.name in names_seen:
            raise InvalidInputError(
                f"two demonstrations are named {d.name!r} ({names_seen[d.name]} and {d.metadata['source']}); "
                "rename one of the files")
        names_seen[d.name] = str(d.metadata["source"])
    return out


def _pieces(traj: Trajectory | CartesianTrajectory, ranges: Sequence[tuple[float, float]] | None,
            rest_speed: float | None, rest_angular_speed: float) -> list[Any]:
    """The demonstrations in one recording: all of it, its time ranges, or its movements between rests."""
    if isinstance(traj, CartesianTrajectory):
        if rest_speed is not None:
            return split_poses_at_rest(traj, speed_tol=rest_speed, angular_speed_tol=rest_angular_speed)
        if ranges is None:  # all of it, from t = 0 (a single pose is refused by the caller)
            return [traj if traj.n_samples < 2 else poses_between(traj, traj.t[0], traj.t[-1])]
        return [poses_between(traj, a, b) for a, b in ranges]
    if rest_speed is not None:
        return split_at_rest(traj, speed_tol=rest_speed)
    return [from_zero(traj)] if ranges is None else cut(traj, ranges)


def _resampled(traj: Any, rate: float | None, where: str) -> Any:
    """The demonstration, resampled at ``rate`` if given; one of fewer than MIN_SAMPLES samples
    is refused (DMP.fit differentiates twice).
    """
    try:
        if rate is not None:
            traj = resample_poses(traj, rate) if isinstance(traj, CartesianTrajectory) else resample(traj, rate)
    except DmprsError as exc:
        raise InvalidInputError(f"{where}: {exc}") from None
    if traj.n_samples < MIN_SAMPLES:
        raise InvalidInputError(f"{where}: {traj.n_samples} samples; a demonstration needs at least {MIN_SAMPLES} "
                                "(DMP.fit differentiates twice)")
    return traj


def build_database(
    demos: Sequence[ImportedDemo],
    *,
    queries: QueryTable | str | Path | None = None,
    query_fields: Sequence[str] | None = None,
    query_units: Sequence[str] | None = None,
) -> Database:
    """A database of ``demos`` whose queries come from the table ``queries`` (by demonstration
    name) or from the label fields ``query_fields``. ``query_units`` overrides the table's units.
    """
    if (queries is None) == (query_fields is None):
        raise InvalidInputError("give the queries as a table or as label fields (exactly one of them)")
    if not demos:
        raise InvalidInputError("no demonstrations to import")
    if queries is not None:
        table = queries if isinstance(queries, QueryTable) else read_query_table(queries)
        missing = [d.name for d in demos if d.name not in table.queries]
        if missing:
            raise InvalidInputError(
                f"the query table has no row for {', '.join(map(repr, missing))}; it has "
                f"{', '.join(map(repr, table.queries))}")
        names, units = table.names, table.units
        values = [table.queries[d.name] for d in demos]
    else:
        names = tuple(query_fields or ())
        units = ("",) * len(names)
        values = []
        for d in demos:
            absent = [f for f in names if f not in d.labels]
            if absent:
                raise InvalidInputError(
                    f"demonstration {d.name!r} has no field {', '.join(map(repr, absent))}; its fields are "
                    f"{', '.join(d.labels) or 'none'}")
            row = []
            for f in names:
                v = d.labels[f]
                if isinstance(v, bool) or not isinstance(v, (int, float)):
                    raise InvalidInputError(f"demonstration {d.name!r}: field {f!r} = {v!r} is not a number")
                row.append(float(v))
            values.append(tuple(row))
    if query_units is not None:
        units = tuple(query_units)
    db = Database(names, units)
    for d, q in zip(demos, values, strict=True):
        try:
            db.add(q, d.trajectory, label=d.name, metadata=dict(d.metadata))
        except DmprsError as exc:
            raise InvalidInputError(f"demonstration {d.name!r} ({d.metadata.get('source')}): {exc}") from None
    return db
