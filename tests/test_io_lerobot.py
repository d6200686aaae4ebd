"""Demonstrations from LeRobot v2.1 and v3.0 datasets written by the test in LeRobot's layouts."""

from __future__ import annotations

import numpy as np
import pyarrow as pa
import pyarrow.compute
import pyarrow.parquet as pq
import pytest

from dmprs.errors import InvalidInputError
from dmprs.io import read_lerobot
from tests.lerobot_writer import FPS, NAMES, TASKS, episode_states, volume, write_v2, write_v3

WRITERS = {"v2.1": write_v2, "v3.0": write_v3}


@pytest.mark.parametrize("version", WRITERS)
def test_episodes_trajectories_and_labels(tmp_path, version):
    root = WRITERS[version](tmp_path / "ds", n_episodes=3)
    episodes = read_lerobot(root)
    assert [e.index for e in episodes] == [0, 1, 2]
    for e in episodes:
        k = e.index
        want = episode_states(k).astype(np.float64)
        np.testing.assert_array_equal(e.trajectory.y, want)
        np.testing.assert_allclose(e.trajectory.t, np.float32(np.arange(len(want)) / FPS), rtol=0, atol=0)
        assert e.names == tuple(NAMES)
        assert e.labels["episode_index"] == k
        assert e.labels["task_index"] == k % 2 and e.labels["task"] == TASKS[k % 2]
        assert e.labels["bottle_volume"] == pytest.approx(volume(k))
        assert e.labels["length"] == len(want)
        assert not any("/" in key for key in e.labels)  # v3 bookkeeping stays out
    picked = read_lerobot(root, "action", dims=["elbow", "shoulder"], episodes=[2])
    assert len(picked) == 1 and picked[0].names == ("elbow", "shoulder")
    np.testing.assert_array_equal(picked[0].trajectory.y,
                                  (episode_states(2) + np.float32(0.01))[:, [1, 0]].astype(np.float64))


@pytest.mark.parametrize("version", WRITERS)
def test_missing_column_component_episode_name_what_exists(tmp_path, version):
    root = WRITERS[version](tmp_path / "ds", n_episodes=2)
    with pytest.raises(InvalidInputError, match=r"no column 'observation.joints'.*observation.state, action"):
        read_lerobot(root, "observation.joints")
    with pytest.raises(InvalidInputError, match=r"no component 'wrist'.*shoulder, elbow, gripper"):
        read_lerobot(root, dims=["wrist"])
    with pytest.raises(InvalidInputError, match=r"no episode 7.*\[0, 1\]"):
        read_lerobot(root, episodes=[7])
    with pytest.raises(InvalidInputError, match="not a LeRobot dataset"):
        read_lerobot(tmp_path)


def test_fifty_episodes_in_five_files_read_exactly_with_progress(tmp_path):
    root = write_v3(tmp_path / "ds", n_episodes=50, per_file=10, period=7)
    assert len(list((root / "data").glob("**/*.parquet"))) == 5
    calls = []
    episodes = read_lerobot(root, progress=lambda done, total: calls.append((done, total)))
    assert [e.index for e in episodes] == list(range(50))
    for e in episodes:
        np.testing.assert_array_equal(e.trajectory.y, episode_states(e.index, 7).astype(np.float64))
        assert e.labels["bottle_volume"] == pytest.approx(volume(e.index))
    frames = sum(len(episode_states(k, 7)) for k in range(50))
    assert len(calls) == 5 and calls[-1] == (frames, frames)
    assert [d for d, _ in calls] == sorted(d for d, _ in calls)


def _rewrite(path, **columns):
    """Replaces (or with None drops) columns of a parquet file."""
    table = pq.read_table(path)
    for name, value in columns.items():
        table = table.drop(name) if value is None else table.set_column(table.schema.get_field_index(name), name, value)
    pq.write_table(table, path)


def test_malformed_datasets_are_refused_naming_file_episode_and_frame(tmp_path):
    def fresh(name, version="v3.0"):
        return WRITERS[version](tmp_path / name, n_episodes=3)

    root = fresh("two")
    data = root / "data" / "chunk-000" / "file-000.parquet"
    table = pq.read_table(data)
    pq.write_table(table.filter(pa.compute.less(table.column("frame_index"), 2)), data)
    with pytest.raises(InvalidInputError, match=r"file-000\.parquet, episode 0: 2 frames; a demonstration needs at least 3"):
        read_lerobot(root)

    root = fresh("nan")
    data = root / "data" / "chunk-000" / "file-000.parquet"
    y = pq.read_table(data).column("observation.state").to_pylist()
    y[5][1] = float("nan")
    _rewrite(data, **{"observation.state": pa.array(y, type=pa.list_(pa.float32()))})
    with pytest.raises(InvalidInputError, match=r"episode 0, frame 5: observation.state\[1\] is nan"):
        read_lerobot(root)

    root = fresh("dtype")
    data = root / "data" / "chunk-000" / "file-001.parquet"
    n = pq.read_table(data).num_rows
    _rewrite(data, episode_index=pa.array(["x"] * n))
    with pytest.raises(InvalidInputError, match=r"file-001\.parquet: column 'episode_index' holds string"):
        read_lerobot(root)

    root = fresh("missing")
    _rewrite(root / "data" / "chunk-000" / "file-001.parquet", timestamp=None)
    with pytest.raises(InvalidInputError, match=r"file-001\.parquet: no 'timestamp' column"):
        read_lerobot(root)

    root = fresh("time")
    data = root / "data" / "chunk-000" / "file-000.parquet"
    t = pq.read_table(data).column("timestamp").to_numpy().copy()
    t[3] = t[1]
    _rewrite(data, timestamp=pa.array(t))
    with pytest.raises(InvalidInputError, match=r"episode 0, frame 3: timestamp .*must be finite and increase"):
        read_lerobot(root)

    root = fresh("dir", "v2.1")
    (root / "meta" / "tasks.jsonl").unlink()
    (root / "meta" / "tasks.jsonl").mkdir()
    with pytest.raises(InvalidInputError, match=r"tasks\.jsonl: is a directory; a task metadata file must be a regular file"):
        read_lerobot(root)

    root = fresh("jsonl", "v2.1")
    (root / "meta" / "episodes.jsonl").write_text('{"episode_index": 0}\n{"episode_index": \n')
    with pytest.raises(InvalidInputError, match=r"episodes\.jsonl, line 2: not valid JSON"):
        read_lerobot(root)

    root = fresh("info")
    for text, why in [("[1, 2]", "expected a JSON object"), ('{"codebase_version": "v9"}', "codebase_version 'v9'"),
                      ("{" * 1000, "nested too deeply|not valid JSON")]:
        (root / "meta" / "info.json").write_text(text)
        with pytest.raises(InvalidInputError, match=why):
            read_lerobot(root)

    root = fresh("split")  # an episode's frames in two files
    a, b = (root / "data" / "chunk-000" / f"file-00{k}.parquet" for k in (0, 1))
    first = pq.read_table(a)
    _rewrite(b, episode_index=pa.array([0] * pq.read_table(b).num_rows, type=pa.int64()))
    with pytest.raises(InvalidInputError, match=r"episode 0 has frames in .*file-000\.parquet and in .*file-001\.parquet"):
        read_lerobot(root)
    assert first.num_rows


def test_files_that_are_not_parquet_or_not_regular_are_refused(tmp_path, monkeypatch):
    import os

    from dmprs.io import lerobot

    root = write_v3(tmp_path / "ds", n_episodes=3)
    data = root / "data" / "chunk-000" / "file-001.parquet"
    good = data.read_bytes()
    data.write_bytes(good[: len(good) // 2])
    with pytest.raises(InvalidInputError, match=r"file-001\.parquet: not a readable parquet file"):
        read_lerobot(root)
    data.unlink()
    os.mkfifo(data)
    with pytest.raises(InvalidInputError, match=r"file-001\.parquet: is a FIFO"):
        read_lerobot(root)
    data.unlink()
    data.symlink_to("/dev/zero")
    with pytest.raises(InvalidInputError, match=r"file-001\.parquet: is a character device"):
        read_lerobot(root)
    data.unlink()
    data.write_bytes(good)
    monkeypatch.setattr(lerobot, "PARQUET_MAX_ROWS", 100)
    with pytest.raises(InvalidInputError, match=r"file-000\.parquet: its footer declares 112 rows and \d+ bytes; "
                                                r"a LeRobot data file may have at most 100 rows"):
        read_lerobot(root)


def test_a_directory_named_like_a_data_file_is_refused_not_skipped(tmp_path):
    root = write_v2(tmp_path / "ds")
    data = root / "data" / "chunk-000" / "episode_000002.parquet"
    data.unlink()
    data.mkdir()
    with pytest.raises(InvalidInputError, match=r"episode_000002\.parquet: is a directory"):
        read_lerobot(root, "observation.state")
