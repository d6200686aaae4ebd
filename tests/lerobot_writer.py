"""Small LeRobot datasets in the v2.1 and v3.0 on-disk layouts, written with pyarrow as LeRobot
writes them (float32 features and timestamps, int64 indices, one row per frame).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

FPS = 50
TASKS = ("pour into the glass", "pour into the bowl")
NAMES = ["shoulder", "elbow", "gripper"]


def episode_states(k: int, period: int | None = None, base_s: float = 1.0) -> np.ndarray:
    """Episode k: a min-jerk reach of amplitude 0.2 (k + 1), base_s + 0.2 j s long (j = k, or
    k % period to keep the lengths of many episodes bounded), float32 like LeRobot.
    """
    j = k if period is None else k % period
    n = round((base_s + 0.2 * j) * FPS) + 1
    s = np.linspace(0.0, 1.0, n)
    m = 10 * s**3 - 15 * s**4 + 6 * s**5
    a = 0.2 * (k + 1)
    return np.stack([a * m, -0.5 * a * m, 0.04 + 0 * m], axis=1).astype(np.float32)


def frames_table(episodes: list[int], start_index: int = 0, period: int | None = None,
                 base_s: float = 1.0) -> pa.Table:
    states = [episode_states(k, period, base_s) for k in episodes]
    lengths = [len(y) for y in states]
    y = np.concatenate(states) if states else np.zeros((0, 3), np.float32)
    frame = np.concatenate([np.arange(n) for n in lengths]) if states else np.zeros(0, int)
    ep = np.repeat(np.asarray(episodes, dtype=np.int64), lengths)
    vec = pa.list_(pa.float32())

    def lists(v: np.ndarray) -> pa.Array:
        return pa.ListArray.from_arrays(pa.array(np.arange(0, v.size + 1, 3, dtype=np.int32)),
                                        pa.array(v.ravel()), type=vec)

    return pa.table({
        "observation.state": lists(y),
        "action": lists(y + np.float32(0.01)),
        "timestamp": pa.array((frame / FPS).astype(np.float32)),
        "frame_index": pa.array(frame.astype(np.int64)),
        "episode_index": pa.array(ep),
        "index": pa.array(np.arange(start_index, start_index + len(y), dtype=np.int64)),
        "task_index": pa.array(ep % 2),
    })


def info(version: str, n_episodes: int, data_path: str) -> dict:
    vec = {"dtype": "float32", "shape": [3], "names": {"motors": NAMES}}
    scalar = {"dtype": "int64", "shape": [1], "names": None}
    return {
        "codebase_version": version, "robot_type": "so100", "total_episodes": n_episodes,
        "total_tasks": len(TASKS), "chunks_size": 1000, "fps": FPS, "data_path": data_path,
        "features": {"observation.state": vec, "action": vec,
                     "timestamp": {"dtype": "float32", "shape": [1], "names": None},
                     "frame_index": scalar, "episode_index": scalar, "index": scalar, "task_index": scalar},
    }


def volume(k: int) -> float:
    """An extra per-episode field, as users add: the bottle volume (l) of the episode."""
    return 0.3 + 0.2 * k


def write_v2(root: Path, n_episodes: int = 3) -> Path:
    (root / "meta").mkdir(parents=True)
    (root / "data" / "chunk-000").mkdir(parents=True)
    tmpl = "data/chunk-{episode_chunk:03d}/episode_{episode_index:06d}.parquet"
    (root / "meta" / "info.json").write_text(json.dumps(info("v2.1", n_episodes, tmpl)))
    lines, index = [], 0
    for k in range(n_episodes):
        table = frames_table([k], index)
        index += table.num_rows
        pq.write_table(table, root / tmpl.format(episode_chunk=0, episode_index=k))
        lines.append(json.dumps({"episode_index": k, "tasks": [TASKS[k % 2]], "length": table.num_rows,
                                 "bottle_volume": volume(k)}))
    (root / "meta" / "episodes.jsonl").write_text("\n".join(lines) + "\n")
    (root / "meta" / "tasks.jsonl").write_text(
        "\n".join(json.dumps({"task_index": i, "task": t}) for i, t in enumerate(TASKS)) + "\n")
    return root


def write_v3(root: Path, n_episodes: int = 3, per_file: int | None = None, period: int | None = None,
             base_s: float = 1.0) -> Path:
    """A v3.0 dataset: ``per_file`` episodes per data file (default: episodes 0-1 in the first
    file, the rest in the second), their metadata in one episodes parquet file per 1000 episodes.
    """
    for d in ("meta/episodes/chunk-000", "data/chunk-000"):
        (root / d).mkdir(parents=True)
    tmpl = "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"
    (root / "meta" / "info.json").write_text(json.dumps(info("v3.0", n_episodes, tmpl)))
    if per_file is None:
        split = [list(range(min(2, n_episodes))), list(range(2, n_episodes))]
    else:
        split = [list(range(a, min(a + per_file, n_episodes))) for a in range(0, n_episodes, per_file)]
    rows, index = [], 0
    for f, eps in enumerate(split):
        if not eps:
            continue
        table = frames_table(eps, index, period, base_s)
        pq.write_table(table, root / tmpl.format(chunk_index=0, file_index=f))
        for k in eps:
            y = episode_states(k, period, base_s)
            rows.append({"episode_index": k, "tasks": [TASKS[k % 2]], "length": len(y),
                         "data/chunk_index": 0, "data/file_index": f,
                         "dataset_from_index": index, "dataset_to_index": index + len(y),
                         "stats/observation.state/mean": y.mean(0).tolist(),
                         "bottle_volume": volume(k)})
            index += len(y)
    for m in range(0, len(rows), 1000):
        pq.write_table(pa.Table.from_pylist(rows[m:m + 1000]),
                       root / "meta" / "episodes" / "chunk-000" / f"file-{m // 1000:03d}.parquet")
    pq.write_table(pa.table({"task_index": pa.array(range(len(TASKS)), type=pa.int64()),
                             "task": list(TASKS)}), root / "meta" / "tasks.parquet")
    return root
