"""Demonstrations from LeRobot datasets on disk (LeRobotDataset v2.x and v3.0), read with
``pyarrow`` without importing ``lerobot``.

Both layouts keep ``meta/info.json`` (``codebase_version``, ``fps``, ``features``) and the frames
in parquet files under ``data/``, one row per frame with ``timestamp`` (s from the episode's
start), ``episode_index``, ``frame_index``, ``task_index`` and the feature columns (a vector
feature such as ``observation.state`` is a list column). They differ in the rest:

* v2: one parquet file per episode (``data/chunk-000/episode_000000.parquet``), episodes in
  ``meta/episodes.jsonl``, tasks in ``meta/tasks.jsonl``;
* v3: many episodes per file (``data/chunk-000/file-000.parquet``), episodes in
  ``meta/episodes/chunk-*/file-*.parquet``, tasks in ``meta/tasks.parquet``.

Each episode becomes an :class:`Episode`: its trajectory (the chosen column at the recorded
timestamps) and labels (``episode_index``, ``task_index``, ``task`` and the scalar fields of
the episode's metadata) that can serve as its query.

The data files are read one at a time (memory: one file's columns, not the dataset's), each
after its footer's row count and size are checked. Every file is checked to be a regular file
before pyarrow opens it; whatever pyarrow or the JSON metadata gets wrong is an
:class:`~dmprs.errors.InvalidInputError` naming the file (and episode, frame or line). An episode
with fewer than :data:`~dmprs.io.segment.MIN_SAMPLES` frames, non-finite values, repeated or
non-increasing frames, or rows in two files is refused.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from dmprs._io import MiB, check_directory, check_regular, parse_json, read_json, read_text
from dmprs.errors import InvalidInputError
from dmprs.io.segment import MIN_SAMPLES
from dmprs.trajectory import Trajectory

__all__ = ["METADATA_MAX_BYTES", "PARQUET_MAX_BYTES", "PARQUET_MAX_ROWS", "Episode", "read_lerobot"]

#: meta/info.json, episodes.jsonl, tasks.jsonl may be at most this large.
METADATA_MAX_BYTES = 64 * MiB
#: A parquet file (data or metadata) may declare at most this many rows and this many bytes of
#: uncompressed data in its footer; it is read whole, so this bounds the memory of the import.
PARQUET_MAX_ROWS = 50_000_000
PARQUET_MAX_BYTES = 2048 * MiB

#: Called as ``progress(frames_read, frames_total)`` after each data file.
Progress = Callable[[int, int], None]


@dataclass(frozen=True)
class Episode:
    """One episode: its ``index``, ``trajectory`` (times from 0 s) and ``labels``."""

    index: int
    trajectory: Trajectory
    labels: dict[str, Any] = field(default_factory=dict)
    names: tuple[str, ...] = ()


def _arrow_errors() -> tuple[type[BaseException], ...]:
    """What pyarrow raises for a file it cannot read: its own classes (ArrowInvalid, ...,
    all ArrowException) and OSError (a thrift footer it cannot decode, an I/O error).
    """
    import pyarrow as pa

    return (pa.ArrowException, OSError)


def _parquet(path: Path, what: str) -> Any:
    """The opened ParquetFile, after checking it is a regular file and what its footer declares."""
    import pyarrow.parquet as pq

    check_regular(path, what=what)
    try:
        f = pq.ParquetFile(path)
        meta = f.metadata
        rows = meta.num_rows
        size = sum(meta.row_group(i).total_byte_size for i in range(meta.num_row_groups))
    except _arrow_errors() as exc:
        raise InvalidInputError(f"{path}: not a readable parquet file ({type(exc).__name__}: {str(exc)[:200]})") from None
    if not 0 <= rows <= PARQUET_MAX_ROWS or not 0 <= size <= PARQUET_MAX_BYTES:
        raise InvalidInputError(
            f"{path}: its footer declares {rows} rows and {size} bytes; a {what} may have at most "
            f"{PARQUET_MAX_ROWS} rows and {PARQUET_MAX_BYTES} bytes")
    return f


def _read(f: Any, path: Path, columns: Sequence[str]) -> Any:
    try:
        return f.read(columns=list(columns))
    except _arrow_errors() as exc:
        raise InvalidInputError(f"{path}: cannot read columns {', '.join(columns)} ({type(exc).__name__}: "
                                f"{str(exc)[:200]})") from None


def _files(directory: Path) -> list[Path]:
    """The parquet files under ``directory``, sorted; links to directories are not followed (a
    loop of them would never end).
    """
    out = []
    for d, dirs, names in os.walk(directory, followlinks=False):
        dirs.sort()
        # a directory (or a link to one) named like a data file would otherwise be skipped, and its
        # episodes silently missing from the import
        posing = [n for n in dirs if n.endswith(".parquet")]
        if posing:
            raise InvalidInputError(f"{Path(d) / posing[0]}: is a directory; a parquet file must be a regular file")
        out += [Path(d) / n for n in names if n.endswith(".parquet")]
    return sorted(out)


def _exists(path: Path) -> bool:
    return os.path.lexists(path)


def _jsonl(path: Path, what: str) -> list[dict[str, Any]]:
    """The records of a JSON-lines metadata file, or none if there is no such file (a directory,
    a FIFO or a bad line is an error naming the file and line).
    """
    if not _exists(path):
        return []
    text = read_text(path, limit=METADATA_MAX_BYTES, what=what)
    out = []
    for i, line in enumerate(text.split("\n")):
        if line.strip():
            value = parse_json(line, f"{path}, line {i + 1}")
            if not isinstance(value, dict):
                raise InvalidInputError(f"{path}, line {i + 1}: not a JSON object")
            out.append(value)
    return out


def _index(value: Any, where: str, name: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise InvalidInputError(f"{where}: {name} = {str(value)[:40]!r}; expected an integer")
    return value


def _feature_names(info: dict[str, Any], column: str) -> tuple[str, ...]:
    """The names LeRobot gives the components of a vector feature (a list, or a dict of lists)."""
    features = info.get("features")
    feature = features.get(column) if isinstance(features, dict) else None
    names = feature.get("names") if isinstance(feature, dict) else None
    if isinstance(names, dict):
        names = [n for group in names.values() if isinstance(group, list) for n in group]
    return tuple(str(n) for n in names) if isinstance(names, list) else ()


_SCALAR_KINDS = ("is_integer", "is_floating", "is_string", "is_large_string")


def _episode_records(root: Path) -> Iterator[tuple[Path, dict[str, Any]]]:
    """v3's episode metadata rows (their scalar columns and tasks), file by file."""
    import pyarrow as pa

    for p in _files(root / "meta" / "episodes"):
        f = _parquet(p, "episode metadata file")
        keep = [fld.name for fld in f.schema_arrow
                if fld.name == "tasks" or ("/" not in fld.name and any(getattr(pa.types, k)(fld.type)
                                                                       for k in _SCALAR_KINDS))]
        for row in _read(f, p, keep).to_pylist():
            yield p, row


def _metadata(root: Path, version: str) -> tuple[dict[int, dict[str, Any]], dict[int, str]]:
    """Episode records by index and task strings by task index."""
    meta = root / "meta"
    episodes: dict[int, dict[str, Any]] = {}
    tasks: dict[int, str] = {}
    if version.startswith("v2"):
        path = meta / "episodes.jsonl"
        for k, r in enumerate(_jsonl(path, "episode metadata file")):
            episodes[_index(r.get("episode_index"), f"{path}, record {k}", "episode_index")] = r
        path = meta / "tasks.jsonl"
        for k, r in enumerate(_jsonl(path, "task metadata file")):
            tasks[_index(r.get("task_index"), f"{path}, record {k}", "task_index")] = str(r.get("task", ""))[:10_000]
        return episodes, tasks
    for p, r in _episode_records(root):
        episodes[_index(r.get("episode_index"), str(p), "episode_index")] = r
    task_file = meta / "tasks.parquet"
    if _exists(task_file):
        f = _parquet(task_file, "task metadata file")
        names = f.schema_arrow.names
        text = "task" if "task" in names else "__index_level_0__"  # pandas writes it as the index
        if "task_index" not in names or text not in names:
            raise InvalidInputError(f"{task_file}: expected columns task_index and task; it has {', '.join(names)}")
        for r in _read(f, task_file, ["task_index", text]).to_pylist():
            tasks[_index(r["task_index"], str(task_file), "task_index")] = str(r[text])[:10_000]
    return episodes, tasks


def _matrix(col: Any, path: Path, column: str) -> np.ndarray:
    """A frame column as (frames, components) float64: a list column of equal-length lists, or a
    numeric scalar column.
    """
    import pyarrow as pa
    import pyarrow.compute as pc

    col = col.combine_chunks()
    kind = col.type
    if pa.types.is_list(kind) or pa.types.is_fixed_size_list(kind) or pa.types.is_large_list(kind):
        if col.null_count:
            raise InvalidInputError(f"{path}: column {column!r} has {col.null_count} empty (null) rows")
        if not (pa.types.is_floating(kind.value_type) or pa.types.is_integer(kind.value_type)):
            raise InvalidInputError(f"{path}: column {column!r} holds lists of {kind.value_type}, not numbers")
        lengths = np.unique(pc.list_value_length(col).to_numpy(zero_copy_only=False))
        if len(lengths) > 1 or (len(lengths) == 1 and lengths[0] == 0):
            raise InvalidInputError(f"{path}: column {column!r} has rows of lengths {lengths.tolist()[:10]}; "
                                    "expected one length of at least 1")
        flat = pc.list_flatten(col)
        if flat.null_count:
            raise InvalidInputError(f"{path}: column {column!r} has null components")
        width = int(lengths[0]) if len(lengths) else 1
        return flat.to_numpy(zero_copy_only=False).astype(np.float64).reshape(len(col), width)
    if not (pa.types.is_floating(kind) or pa.types.is_integer(kind)):
        raise InvalidInputError(f"{path}: column {column!r} holds {kind}, not numbers")
    if col.null_count:
        raise InvalidInputError(f"{path}: column {column!r} has {col.null_count} null rows")
    return col.to_numpy(zero_copy_only=False).astype(np.float64).reshape(-1, 1)


def _integers(col: Any, path: Path, column: str) -> np.ndarray:
    import pyarrow as pa

    col = col.combine_chunks()
    if not pa.types.is_integer(col.type) or col.null_count:
        raise InvalidInputError(f"{path}: column {column!r} holds {col.type}{' with nulls' if col.null_count else ''}; "
                                "expected integers")
    return col.to_numpy(zero_copy_only=False).astype(np.int64)


def _scalar_labels(record: dict[str, Any]) -> dict[str, Any]:
    """The JSON-safe scalar fields of an episode record (v3's per-file bookkeeping and
    statistics, "data/chunk_index", "stats/...", are left out; so are non-finite numbers).
    """
    out: dict[str, Any] = {}
    for k, v in record.items():
        if "/" in k or isinstance(v, bool):
            continue
        if isinstance(v, (int, str)) or (isinstance(v, float) and np.isfinite(v)):
            out[str(k)] = v
    return out


def _episodes_of(path: Path, f: Any, column: str, index: list[int] | None) -> Iterator[tuple[int, Trajectory, int]]:
    """(episode index, trajectory, task index or -1) of every episode in one data file."""
    names = f.schema_arrow.names
    wanted = [c for c in (column, "timestamp", "episode_index", "frame_index", "task_index") if c in names]
    table = _read(f, path, wanted)
    values = _matrix(table.column(column), path, column)
    if index is not None:
        if max(index) >= values.shape[1]:
            raise InvalidInputError(f"{path}: column {column!r} has {values.shape[1]} components; "
                                    f"meta/info.json names more")
        values = values[:, index]
    ep_of = _integers(table.column("episode_index"), path, "episode_index")
    frame_of = _integers(table.column("frame_index"), path, "frame_index") if "frame_index" in wanted \
        else np.arange(len(ep_of))
    times = _matrix(table.column("timestamp"), path, "timestamp")
    if times.shape[1] != 1:
        raise InvalidInputError(f"{path}: column 'timestamp' holds lists; expected one time per frame")
    task_of = _integers(table.column("task_index"), path, "task_index") if "task_index" in wanted \
        else np.full(len(ep_of), -1)
    del table
    order = np.lexsort((frame_of, ep_of))  # by episode, then frame
    ep_of, frame_of, values, times, task_of = ep_of[order], frame_of[order], values[order], times[order, 0], task_of[order]
    starts = np.flatnonzero(np.concatenate([[True], np.diff(ep_of) != 0])) if len(ep_of) else np.zeros(0, int)
    for a, b in zip(starts, [*starts[1:], len(ep_of)], strict=True):
        ep = int(ep_of[a])
        where = f"{path}, episode {ep}"
        if b - a < MIN_SAMPLES:
            raise InvalidInputError(f"{where}: {b - a} frames; a demonstration needs at least {MIN_SAMPLES} "
                                    "(DMP.fit differentiates twice)")
        frames = frame_of[a:b]
        repeated = np.flatnonzero(np.diff(frames) == 0)
        if len(repeated):
            raise InvalidInputError(f"{where}: frame {frames[repeated[0]]} appears twice")
        y, t = values[a:b], times[a:b]
        bad = ~np.isfinite(y)
        if bad.any():
            j, d = (int(i) for i in np.argwhere(bad)[0])
            raise InvalidInputError(f"{where}, frame {frames[j]}: {column}[{d}] is {float(y[j, d])}; every value must be "
                                    "finite")
        back = np.flatnonzero(~(np.diff(t) > 0))
        if not np.isfinite(t).all() or len(back):
            j = int(np.argmin(np.isfinite(t))) if not np.isfinite(t).all() else int(back[0]) + 1
            after = f" after {float(t[j - 1])!r}" if j else ""
            raise InvalidInputError(f"{where}, frame {frames[j]}: timestamp {float(t[j])!r}{after}; timestamps must be "
                                    "finite and increase with the frame index")
        yield ep, Trajectory(t - t[0], y), int(task_of[a])


def read_lerobot(root: str | Path, column: str = "observation.state", *,
                 dims: Sequence[str] | None = None, episodes: Sequence[int] | None = None,
                 progress: Progress | None = None) -> list[Episode]:
    """The episodes of the LeRobot dataset in ``root``, in episode order.

    ``column`` is the frame column to use as positions (``observation.state``, ``action``, ...);
    ``dims`` picks its components by the names ``meta/info.json`` gives them; ``episodes`` picks
    episodes by index. ``progress(frames_read, frames_total)`` is called after each data file.
    """
    base = check_directory(root, what="LeRobot dataset directory")
    info_path = base / "meta" / "info.json"
    if not _exists(info_path):
        raise InvalidInputError(f"{base}: not a LeRobot dataset (no meta/info.json)")
    info = read_json(info_path, what="LeRobot info file", limit=METADATA_MAX_BYTES)
    if not isinstance(info, dict):
        raise InvalidInputError(f"{info_path}: expected a JSON object")
    version = str(info.get("codebase_version", ""))[:40]
    if not version.startswith(("v2", "v3")):
        raise InvalidInputError(f"{info_path}: codebase_version {version!r}; dmprs reads LeRobot v2.x and v3.0")
    files = _files(base / "data")
    if not files:
        raise InvalidInputError(f"{base}: no parquet files under data/")
    opened = [(p, _parquet(p, "LeRobot data file")) for p in files]
    have = opened[0][1].schema_arrow.names
    if column not in have:
        raise InvalidInputError(f"{base}: no column {column!r}; the frames have {', '.join(have)}")
    names = _feature_names(info, column)
    index: list[int] | None = None
    if dims is not None:
        dims = [str(d) for d in dims]
        if not dims or len(set(dims)) != len(dims):
            raise InvalidInputError(f"dims = {dims}: give distinct component names of {column!r}, at least one")
        missing = [d for d in dims if d not in names]
        if missing:
            raise InvalidInputError(
                f"{base}: {column!r} has no component {', '.join(map(repr, missing))}; its components are "
                f"{', '.join(names) or '(unnamed in meta/info.json)'}")
        index = [names.index(d) for d in dims]
        names = tuple(dims)
    for p, f in opened:
        absent = [c for c in (column, "timestamp", "episode_index") if c not in f.schema_arrow.names]
        if absent:
            raise InvalidInputError(f"{p}: no {', '.join(map(repr, absent))} column; is this a LeRobot dataset?")
    records, tasks = _metadata(base, version)
    total = sum(f.metadata.num_rows for _, f in opened)
    wanted = None if episodes is None else {int(e) for e in episodes}
    found: dict[int, tuple[Trajectory, int]] = {}
    seen: dict[int, Path] = {}
    done = 0
    for p, f in opened:
        try:
            for ep, traj, task in _episodes_of(p, f, column, index):
                if ep in seen:
                    raise InvalidInputError(f"{base}: episode {ep} has frames in {seen[ep]} and in {p}")
                seen[ep] = p
                if wanted is None or ep in wanted:
                    found[ep] = (traj, task)
        except _arrow_errors() as exc:  # converting a column pyarrow read but cannot hand over
            raise InvalidInputError(f"{p}: cannot convert its columns ({type(exc).__name__}: {str(exc)[:200]})") from None
        done += f.metadata.num_rows
        if progress is not None:
            progress(done, total)
    if wanted is not None:
        lacking = sorted(wanted - set(found))
        if lacking:
            have = sorted(seen)
            shown = f"{have}" if len(have) <= 20 else f"{have[:10]} ... {have[-1]} ({len(have)} episodes)"
            raise InvalidInputError(f"{base}: no episode {lacking[0]}; the dataset has episodes {shown}")
    out = []
    for ep in sorted(found) if episodes is None else [int(e) for e in episodes]:
        traj, task = found[ep]
        labels = _scalar_labels(records.get(ep, {}))
        labels["episode_index"] = ep
        if task >= 0:
            labels["task_index"] = task
            if task in tasks:
                labels["task"] = tasks[task]
        listed = records.get(ep, {}).get("tasks")
        if "task" not in labels and isinstance(listed, list) and listed:
            labels["task"] = str(listed[0])[:10_000]
        out.append(Episode(ep, traj, labels, names))
    return out
