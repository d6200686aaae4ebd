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
    import pyarrow.parquet as pq  # type: ignore[import-untyped]

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
    import pyarrow.parquet as pq  # type: ignore[import-untyped]

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
    frames: dict[int, list[dict[str, Any]]] = {}
    for p in files:
        for row in pq.read_table(p, columns=wanted).to_pylist():
            frames.setdefault(int(row["episode_index"]), []).append(row)
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
        absent = [e for e in episodes if e not in frames]
        if absent:
            raise InvalidInputError(
                f"{base}: no episode {absent[0]}; the dataset has episodes {sorted(frames)}")
    records, tasks = _metadata(base, version)
    out = []
    for ep in sorted(frames) if episodes is None else list(episodes):
        rows = sorted(frames[ep], key=lambda r: r.get("frame_index", 0))
        y = np.asarray([np.atleast_1d(np.asarray(r[column], dtype=np.float64)) for r in rows])
        if index is not None:
            y = y[:, index]
        t = np.asarray([r["timestamp"] for r in rows], dtype=np.float64)
        try:
            traj = Trajectory(t - t[0], y)
        except DmprsError as exc:
            raise InvalidInputError(f"{base}: episode {ep}: {exc}") from None
        labels = _scalar_labels(records.get(ep, {}))
        labels["episode_index"] = ep
        if "task_index" in rows[0]:
            labels["task_index"] = int(rows[0]["task_index"])
            if labels["task_index"] in tasks:
                labels["task"] = tasks[labels["task_index"]]
        if "task" not in labels and records.get(ep, {}).get("tasks"):
            labels["task"] = str(records[ep]["tasks"][0])
        out.append(Episode(ep, traj, labels, names))
    return out
