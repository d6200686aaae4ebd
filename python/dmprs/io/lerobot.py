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
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from dmprs.errors import DmprsError, InvalidInputError
from dmprs.trajectory import Trajectory

__all__ = ["Episode", "read_lerobot"]


@dataclass(frozen=True)
class Episode:
    """One episode: its ``index``, ``trajectory`` (times from 0 s) and ``labels``."""

    index: int
    trajectory: Trajectory
    labels: dict[str, Any] = field(default_factory=dict)
    names: tuple[str, ...] = ()


def _read_json(path: Path) -> Any:
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise InvalidInputError(f"{path}: cannot read it as JSON ({exc})") from None


def _jsonl(path: Path) -> list[dict[str, Any]]:
    if not path.is_file():
        return []
    return [json.loads(line) for line in path.read_text(encoding="utf-8").splitlines() if line.strip()]


def _parquet_rows(paths: Sequence[Path]) -> list[dict[str, Any]]:
    import pyarrow.parquet as pq

    rows: list[dict[str, Any]] = []
    for p in paths:
        rows.extend(pq.read_table(p).to_pylist())
    return rows


def _feature_names(info: dict[str, Any], column: str) -> tuple[str, ...]:
    """The names LeRobot gives the components of a vector feature (a list, or a dict of lists)."""
    names = info.get("features", {}).get(column, {}).get("names")
    if isinstance(names, dict):
        names = [n for group in names.values() for n in group]
    return tuple(str(n) for n in names) if isinstance(names, list) else ()


def _metadata(root: Path, version: str) -> tuple[dict[int, dict[str, Any]], dict[int, str]]:
    """Episode records by index and task strings by task index."""
    if version.startswith("v2"):
        episodes = _jsonl(root / "meta" / "episodes.jsonl")
        tasks = {int(r["task_index"]): str(r["task"]) for r in _jsonl(root / "meta" / "tasks.jsonl")}
    else:
        episodes = _parquet_rows(sorted((root / "meta" / "episodes").glob("**/*.parquet")))
        task_file = root / "meta" / "tasks.parquet"
        tasks = {}
        for r in _parquet_rows([task_file] if task_file.is_file() else []):
            # pandas writes the task string as the table's index
            text = r.get("task", r.get("__index_level_0__"))
            tasks[int(r["task_index"])] = str(text)
    return {int(e["episode_index"]): e for e in episodes}, tasks


def _matrix(col: Any, base: Path, column: str) -> np.ndarray:
    """A frame column as (frames, components) float64: a list column of equal-length lists, or a
    numeric scalar column."""
    import pyarrow as pa
    import pyarrow.compute as pc

    col = col.combine_chunks()
    if pa.types.is_list(col.type) or pa.types.is_fixed_size_list(col.type) or pa.types.is_large_list(col.type):
        lengths = np.unique(pc.list_value_length(col).to_numpy(zero_copy_only=False))
        if len(lengths) != 1:
            raise InvalidInputError(f"{base}: column {column!r} has rows of lengths {lengths.tolist()}")
        flat = pc.list_flatten(col).to_numpy(zero_copy_only=False).astype(np.float64)
        return flat.reshape(len(col), int(lengths[0]))
    if not (pa.types.is_floating(col.type) or pa.types.is_integer(col.type)):
        raise InvalidInputError(f"{base}: column {column!r} holds {col.type}, not numbers")
    return col.to_numpy(zero_copy_only=False).astype(np.float64).reshape(-1, 1)


def _scalar_labels(record: dict[str, Any]) -> dict[str, Any]:
    """The JSON-safe scalar fields of an episode record (v3's per-file bookkeeping and
    statistics, "data/chunk_index", "stats/...", are left out)."""
    out: dict[str, Any] = {}
    for k, v in record.items():
        if "/" in k or isinstance(v, bool):
            continue
        if isinstance(v, (int, float, str)):
            out[k] = v
    return out


def read_lerobot(root: str | Path, column: str = "observation.state", *,
                 dims: Sequence[str] | None = None, episodes: Sequence[int] | None = None) -> list[Episode]:
    """The episodes of the LeRobot dataset in ``root``, in episode order.

    ``column`` is the frame column to use as positions (``observation.state``, ``action``, ...);
    ``dims`` picks its components by the names ``meta/info.json`` gives them; ``episodes`` picks
    episodes by index.
    """
    import pyarrow as pa
    import pyarrow.parquet as pq

    base = Path(root)
    info_path = base / "meta" / "info.json"
    if not info_path.is_file():
        raise InvalidInputError(f"{base}: not a LeRobot dataset (no meta/info.json)")
    info = _read_json(info_path)
    version = str(info.get("codebase_version", ""))
    if not version.startswith(("v2", "v3")):
        raise InvalidInputError(f"{info_path}: codebase_version {version!r}; dmprs reads LeRobot v2.x and v3.0")
    files = sorted((base / "data").glob("**/*.parquet"))
    if not files:
        raise InvalidInputError(f"{base}: no parquet files under data/")
    schema = pq.read_schema(files[0])
    if column not in schema.names:
        raise InvalidInputError(
            f"{base}: no column {column!r}; the frames have {', '.join(schema.names)}")
    for needed in ("timestamp", "episode_index"):
        if needed not in schema.names:
            raise InvalidInputError(f"{files[0]}: no {needed!r} column; is this a LeRobot dataset?")
    wanted = [c for c in (column, "timestamp", "episode_index", "frame_index", "task_index") if c in schema.names]
    table = pa.concat_tables([pq.read_table(p, columns=wanted) for p in files])
    values = _matrix(table.column(column), base, column)
    ep_of = table.column("episode_index").to_numpy()
    frame_of = table.column("frame_index").to_numpy() if "frame_index" in wanted else np.arange(len(ep_of))
    order = np.lexsort((frame_of, ep_of))  # by episode, then frame
    ep_of, values = ep_of[order], values[order]
    times = table.column("timestamp").to_numpy().astype(np.float64)[order]
    task_of = table.column("task_index").to_numpy()[order] if "task_index" in wanted else None
    starts = np.flatnonzero(np.concatenate([[True], np.diff(ep_of) != 0]))
    spans = {int(ep_of[a]): (int(a), int(b)) for a, b in zip(starts, [*starts[1:], len(ep_of)])}
    names = _feature_names(info, column)
    index: list[int] | None = None
    if dims is not None:
        missing = [d for d in dims if d not in names]
        if missing:
            raise InvalidInputError(
                f"{base}: {column!r} has no component {', '.join(map(repr, missing))}; its components are "
                f"{', '.join(names) or '(unnamed in meta/info.json)'}")
        index = [names.index(d) for d in dims]
        names = tuple(dims)
    if episodes is not None:
        absent = [e for e in episodes if e not in spans]
        if absent:
            raise InvalidInputError(
                f"{base}: no episode {absent[0]}; the dataset has episodes {sorted(spans)}")
    records, tasks = _metadata(base, version)
    out = []
    for ep in sorted(spans) if episodes is None else list(episodes):
        lo, hi = spans[ep]
        y = values[lo:hi] if index is None else values[lo:hi][:, index]
        t = times[lo:hi]
        try:
            traj = Trajectory(t - t[0], y)
        except DmprsError as exc:
            raise InvalidInputError(f"{base}: episode {ep}: {exc}") from None
        labels = _scalar_labels(records.get(ep, {}))
        labels["episode_index"] = ep
        if task_of is not None:
            labels["task_index"] = int(task_of[lo])
            if labels["task_index"] in tasks:
                labels["task"] = tasks[labels["task_index"]]
        if "task" not in labels and records.get(ep, {}).get("tasks"):
            labels["task"] = str(records[ep]["tasks"][0])
        out.append(Episode(ep, traj, labels, names))
    return out
