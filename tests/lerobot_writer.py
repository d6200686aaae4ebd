"""Small LeRobot datasets in the v2.1 and v3.0 on-disk layouts, written with pyarrow as LeRobot
writes them (float32 features and timestamps, int64 indices, one row per frame)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

FPS = 50
TASKS = ("pour into the glass", "pour into the bowl")
NAMES = ["shoulder", "elbow", "gripper"]


def episode_states(k: int) -> np.ndarray:
    """Episode k: a min-jerk reach of amplitude 0.2 (k + 1), 1 + 0.2 k s long, float32 like LeRobot."""
    n = round((1.0 + 0.2 * k) * FPS) + 1
    s = np.linspace(0.0, 1.0, n)
    m = 10 * s**3 - 15 * s**4 + 6 * s**5
    a = 0.2 * (k + 1)
    return np.stack([a * m, -0.5 * a * m, 0.04 + 0 * m], axis=1).astype(np.float32)


def frames_table(episodes: list[int], start_index: int = 0) -> pa.Table:
    cols: dict[str, list] = {k: [] for k in ("observation.state", "action", "timestamp", "frame_index",
                                              "episode_index", "index", "task_index")}
    index = start_index
    for k in episodes:
        y = episode_states(k)
        for j, row in enumerate(y):
            cols["observation.state"].append(row.tolist())
            cols["action"].append((row + 0.01).tolist())
            cols["timestamp"].append(j / FPS)
            cols["frame_index"].append(j)
            cols["episode_index"].append(k)
            cols["index"].append(index)
            cols["task_index"].append(k % 2)
            index += 1
    vec = pa.list_(pa.float32())
    return pa.table({
        "observation.state": pa.array(cols["observation.state"], type=vec),
        "action": pa.array(cols["action"], type=vec),
        "timestamp": pa.array(cols["timestamp"], type=pa.float32()),
        "frame_index": pa.array(cols["frame_index"], type=pa.int64()),
        "episode_index": pa.array(cols["episode_index"], type=pa.int64()),
        "index": pa.array(cols["index"], type=pa.int64()),
        "task_index": pa.array(cols["task_index"], type=pa.int64()),
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


def write_v3(root: Path, n_episodes: int = 3) -> Path:
    for d in ("meta/episodes/chunk-000", "data/chunk-000"):
        (root / d).mkdir(parents=True)
    tmpl = "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"
    (root / "meta" / "info.json").write_text(json.dumps(info("v3.0", n_episodes, tmpl)))
    # two data files: episodes 0-1 in the first, the rest in the second
    split = [list(range(min(2, n_episodes))), list(range(2, n_episodes))]
    rows, index = [], 0
    for f, eps in enumerate(split):
        if not eps:
            continue
        table = frames_table(eps, index)
        pq.write_table(table, root / tmpl.format(chunk_index=0, file_index=f))
        for k in eps:
            n = len(episode_states(k))
            rows.append({"episode_index": k, "tasks": [TASKS[k % 2]], "length": n,
                         "data/chunk_index": 0, "data/file_index": f,
                         "dataset_from_index": index, "dataset_to_index": index + n,
                         "stats/observation.state/mean": episode_states(k).mean(0).tolist(),
                         "bottle_volume": volume(k)})
            index += n
    pq.write_table(pa.Table.from_pylist(rows), root / "meta" / "episodes" / "chunk-000" / "file-000.parquet")
    pq.write_table(pa.table({"task_index": pa.array(range(len(TASKS)), type=pa.int64()),
                             "task": list(TASKS)}), root / "meta" / "tasks.parquet")
    return root
