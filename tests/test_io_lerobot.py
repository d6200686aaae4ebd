"""Demonstrations from LeRobot v2.1 and v3.0 datasets written by the test in LeRobot's layouts."""

from __future__ import annotations

import numpy as np
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
