"""Demonstrations from real ROS 1 and ROS 2 (sqlite3, mcap) bags written by rosbags' own writers."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import dmprs
import dmprs.io
from dmprs.errors import InvalidInputError
from dmprs.io import (
    bag_topics,
    motion_ranges,
    read_joint_states,
    read_poses,
    read_tf,
    resample,
    resample_poses,
    split_at_rest,
)
from tests.bag_writers import FORMATS, BagWriter, bag_path
from tests.conftest import min_jerk

T0 = 1_700_000_000 * 10**9  # a wall-clock start, as real bags have
JOINTS = ("shoulder", "elbow", "wrist")


def recording(rate: float = 100.0) -> tuple[np.ndarray, np.ndarray, list[tuple[float, float]]]:
    """Two movements separated by rests: 0.5 s rest, 1 s move, 1 s rest, 1.2 s move back, 0.5 s
    rest. Returns times (s, slightly jittered as a real clock), positions (T, 3) and the true
    movement ranges.
    """
    t = np.arange(0.0, 4.2, 1.0 / rate)
    t = t + np.random.default_rng(0).uniform(-1e-4, 1e-4, t.shape)
    t[0] = 0.0
    a = min_jerk(np.clip((t - 0.5) / 1.0, 0, 1))
    b = min_jerk(np.clip((t - 2.5) / 1.2, 0, 1))
    s = a - b
    y = np.stack([0.8 * s, -0.4 * s + 0.1, 0.3 * np.sin(np.pi * s)], axis=1)
    return t, y, [(0.5, 1.5), (2.5, 3.7)]


def write_joint_bag(tmp_path, fmt, t, y):
    path = bag_path(tmp_path, fmt)
    with BagWriter(path, fmt) as w:
        for k, (tk, yk) in enumerate(zip(t, y, strict=True)):
            ns = T0 + round(tk * 1e9)
            # the arm's publisher sends its joints in its own order, with an extra one
            w.write("/joint_states", w.joint_state(ns, ["wrist", "finger", "elbow", "shoulder"],
                                                   [yk[2], 0.01, yk[1], yk[0]], [0.0] * 4), ns + 2_000_000)
            if k % 10 == 0:  # a gripper node publishes on the same topic with other joints
                w.write("/joint_states", w.joint_state(ns + 1, ["gripper"], [0.04]), ns + 3_000_000)
            if k % 25 == 0:
                w.write("/rosout_like", w.joint_state(ns, ["x"], [0.0]), ns)
    return path


@pytest.mark.parametrize("fmt", FORMATS)
def test_joint_states_round_trip_exactly_and_segment(tmp_path, fmt):
    t, y, truth = recording()
    path = write_joint_bag(tmp_path, fmt, t, y)
    assert bag_topics(path)["/joint_states"] == "sensor_msgs/msg/JointState"
    rec = read_joint_states(path, "/joint_states", joints=JOINTS)
    assert rec.names == JOINTS
    # header stamps, in s since the bag's first message (received at T0, as the first stamp)
    np.testing.assert_allclose(rec.trajectory.t, t, atol=2e-9)
    np.testing.assert_array_equal(rec.trajectory.y, y)  # float64 round trip, reordered by name
    ranges = motion_ranges(rec.trajectory.t, rec.trajectory.y, speed_tol=0.02)
    assert len(ranges) == 2
    for (a, b), (ta, tb) in zip(ranges, truth, strict=True):
        assert abs(a - ta) < 0.05 and abs(b - tb) < 0.05
    demos = split_at_rest(rec.trajectory, speed_tol=0.02)
    assert [d.t[0] for d in demos] == [0.0, 0.0]
    # each movement, fitted and rolled out, reproduces the recording
    for demo in demos:
        uniform = resample(demo, 200.0)
        np.testing.assert_allclose(np.diff(uniform.t), 1 / 200.0, rtol=1e-9)
        dmp = dmprs.DMP.fit(uniform.t, uniform.y, n_basis=30)
        out = dmp.rollout(dt=1 / 200.0, duration=uniform.duration)
        n = min(len(out), len(uniform))
        assert np.sqrt(np.mean((out.y[:n] - uniform.y[:n]) ** 2)) < 5e-3


def test_velocities_and_defaults(tmp_path):
    fmt = "ros2-sqlite3"
    t, y, _ = recording()
    path = write_joint_bag(tmp_path, fmt, t, y)
    rec = read_joint_states(path)  # the joints of the first message, in its order
    assert rec.names == ("wrist", "finger", "elbow", "shoulder")
    assert rec.trajectory.yd is None
    with_v = read_joint_states(path, joints=["elbow"], velocities=True)
    np.testing.assert_array_equal(with_v.trajectory.yd, np.zeros((len(t), 1)))


def test_missing_topic_and_joint_name_what_exists(tmp_path):
    t, y, _ = recording()
    path = write_joint_bag(tmp_path, "ros2-mcap", t, y)
    topics = r"no topic '/joints'.*/joint_states \(sensor_msgs/msg/JointState\)"
    with pytest.raises(InvalidInputError, match=topics):
        read_joint_states(path, "/joints")
    with pytest.raises(InvalidInputError, match=r"no joint 'knee'.*shoulder.*gripper"):
        read_joint_states(path, joints=["shoulder", "knee"])
    with pytest.raises(InvalidInputError, match="no such bag"):
        read_joint_states(tmp_path / "nothing")
    (tmp_path / "junk.bag").write_bytes(b"not a bag at all")
    with pytest.raises(InvalidInputError, match=r"junk\.bag: not a ROS 1 bag \(it does not start with .#ROSBAG V2\.0.\)"):
        read_joint_states(tmp_path / "junk.bag")
    with pytest.raises(InvalidInputError, match="carries sensor_msgs/msg/JointState, expected geometry_msgs"):
        read_poses(path, "/joint_states")


def true_chain(t):
    """world -> base (static: 1 m along x, 90 deg about z) -> tool (moving)."""
    base = np.array([1.0, 0.0, 0.0, *Rotation.from_euler("z", 90, degrees=True).as_quat(scalar_first=True)])
    rot = Rotation.from_euler("x", 0.8 * t[:, None]).as_quat(scalar_first=True)
    tool = np.hstack([np.stack([t, 0.0 * t, 0.1 * t], axis=1), rot])
    return base, tool


@pytest.mark.parametrize("fmt", FORMATS)
def test_tf_chain_and_pose_topic(tmp_path, fmt):
    t = np.linspace(0.0, 2.0, 41)
    base, tool = true_chain(t)
    path = bag_path(tmp_path, fmt)
    with BagWriter(path, fmt) as w:
        w.write("/tf_static", w.tf_message(T0, [("world", "base", base)]), T0)
        for tk, pk in zip(t, tool, strict=True):
            ns = T0 + round(tk * 1e9)
            w.write("/tf", w.tf_message(ns, [("base", "tool", pk)]), ns)
            w.write("/tool_pose", w.pose_stamped(ns, "world", pk), ns)
    got = read_tf(path, "world", "tool")
    np.testing.assert_allclose(got.t, t, atol=2e-9)
    r_base = Rotation.from_quat(base[3:], scalar_first=True)
    r_tool = Rotation.from_quat(tool[:, 3:], scalar_first=True)
    want_pos = base[:3] + r_base.apply(tool[:, :3])
    want_rot = r_base * r_tool
    np.testing.assert_allclose(got.position, want_pos, atol=1e-12)
    # same rotation (q and -q are equal), and the stored signs are continuous
    assert np.all(np.abs(np.sum(got.quaternion * want_rot.as_quat(scalar_first=True), axis=1)) > 1 - 1e-12)
    assert np.all(np.sum(got.quaternion[1:] * got.quaternion[:-1], axis=1) > 0)
    back = read_tf(path, "tool", "world")  # the inverse chain
    inv = want_rot.inv()
    np.testing.assert_allclose(back.position, -inv.apply(want_pos), atol=1e-12)
    poses = read_poses(path, "/tool_pose")
    np.testing.assert_allclose(poses.pose, tool * np.sign(tool[:, 3:4]), atol=1e-15)
    half = resample_poses(poses, 40.0)  # interpolates between samples (every 50 ms) at 25 ms
    mid = Rotation.from_euler("x", 0.8 * half.t[:, None])
    assert np.all(np.abs(np.sum(half.quaternion * mid.as_quat(scalar_first=True), axis=1)) > 1 - 1e-12)
    with pytest.raises(InvalidInputError, match=r"no frame 'hand'.*base, tool, world"):
        read_tf(path, "world", "hand")


def test_receive_times_when_stamps_are_unset_and_cut_by_ranges(tmp_path):
    path = bag_path(tmp_path, "ros2-sqlite3")
    t = np.linspace(0.0, 2.0, 201)
    with BagWriter(path, "ros2-sqlite3") as w:
        for tk in t:
            msg = w.joint_state(0, ["a"], [np.sin(tk)])  # a driver that leaves the stamp at zero
            w.write("/joint_states", msg, T0 + round(tk * 1e9))
    rec = read_joint_states(path)
    np.testing.assert_allclose(rec.trajectory.t, t, atol=2e-9)
    (first, second) = dmprs.io.cut(rec.trajectory, [(0.0, 0.5), (1.0, 2.0)])
    assert first.t[0] == 0.0 and len(first) == 51 and len(second) == 101
    np.testing.assert_array_equal(second.y[:, 0], np.sin(t[100:]))
    with pytest.raises(InvalidInputError, match="holds 0 samples"):
        dmprs.io.cut(rec.trajectory, [(5.0, 6.0)])


def test_a_tf_recording_fitted_by_a_cartesian_dmp(tmp_path):
    """Poses read from TF are what CartesianDMP fits: it reproduces them and moves its goal."""
    t = np.linspace(0.0, 2.0, 201)
    s = min_jerk(t / 2.0)
    base, _ = true_chain(t)
    rot = Rotation.from_rotvec(np.outer(s, [0.3, -0.6, 0.9]))
    tool = np.hstack([np.stack([0.2 * s, 0.1 * s, -0.05 * s], axis=1), rot.as_quat(scalar_first=True)])
    path = bag_path(tmp_path, "ros2-mcap")
    with BagWriter(path, "ros2-mcap") as w:
        w.write("/tf_static", w.tf_message(T0, [("world", "base", base)]), T0)
        for tk, pk in zip(t, tool, strict=True):
            ns = T0 + round(tk * 1e9)
            w.write("/tf", w.tf_message(ns, [("base", "tool", pk)]), ns)
    demo = read_tf(path, "world", "tool")
    assert isinstance(demo, dmprs.CartesianTrajectory)
    dmp = dmprs.CartesianDMP.fit(demo.t, demo.pose, n_basis=30)
    out = dmp.rollout(dt=0.001, duration=demo.duration)
    idx = np.searchsorted(out.t, demo.t - 1e-9).clip(0, len(out.t) - 1)
    assert np.sqrt(np.mean(np.sum((out.position[idx] - demo.position) ** 2, axis=1))) < 2e-3  # m
    angle = 2 * np.arccos(np.abs(np.sum(out.quaternion[idx] * demo.quaternion, axis=1)).clip(0, 1))
    assert angle.max() < 0.02  # rad
    goal = demo.pose[-1].copy()
    goal[:3] += [0.05, 0.0, 0.02]
    moved = dmp.with_goal(goal).rollout(dt=0.001, until_rest=True)
    np.testing.assert_allclose(moved.position[-1], goal[:3], atol=1e-3)


def write_stamped(tmp_path, fmt, stamps_ns, positions, names=("a",), name="odd"):
    tmp_path.mkdir(parents=True, exist_ok=True)
    path = bag_path(tmp_path, fmt, name)
    with BagWriter(path, fmt) as w:
        for k, (ns, p) in enumerate(zip(stamps_ns, positions, strict=True)):
            w.write("/joint_states", w.joint_state(ns, names, p), T0 + k * 10_000_000)
    return path


@pytest.mark.parametrize("fmt", FORMATS)
def test_recordings_that_cannot_be_meant_are_refused_naming_bag_topic_and_message(tmp_path, fmt):
    n = 20
    stamps = [T0 + k * 10_000_000 for k in range(n)]
    good = [[float(np.sin(k / 5))] for k in range(n)]
    zero = stamps.copy()
    zero[5] = 0  # a publisher that does not stamp, among one that does
    with pytest.raises(InvalidInputError, match=r"odd.*, topic '/joint_states', message 5: its header stamp is zero "
                                                r"while message 0 is stamped 1700000000 s"):
        read_joint_states(write_stamped(tmp_path / "zero", fmt, zero, good))
    years = stamps.copy()
    years[-1] = T0 + 3 * 365 * 86400 * 10**9
    with pytest.raises(InvalidInputError, match=r"the stamps jump by 9.46\d+e\+07 s between message 18 .* and message 19"):
        read_joint_states(write_stamped(tmp_path / "years", fmt, years, good))
    nan = [row.copy() for row in good]
    nan[7] = [float("nan")]
    with pytest.raises(InvalidInputError, match=r"topic '/joint_states', message 7: the position of 'a' is nan"):
        read_joint_states(write_stamped(tmp_path / "nan", fmt, stamps, nan))
    with pytest.raises(InvalidInputError, match=r"message 0: joint 'a' is named twice in one message"):
        read_joint_states(write_stamped(tmp_path / "dup", fmt, stamps, [[1.0, 2.0]] * n, names=("a", "a")))
    with pytest.raises(InvalidInputError, match=r"has 2 distinct samples of \('a',\); a demonstration needs at least 3"):
        read_joint_states(write_stamped(tmp_path / "two", fmt, stamps[:2], good[:2]))
    with pytest.raises(InvalidInputError, match=r"joints = \['a', 'a'\]: give distinct joint names"):
        read_joint_states(write_stamped(tmp_path / "ok", fmt, stamps, good), joints=["a", "a"])


def test_out_of_order_and_repeated_stamps_are_sorted_and_deduplicated(tmp_path):
    """Repaired, not refused: two publishers interleave, so bag order is not stamp order, and a
    repeated stamp keeps its first message.
    """
    stamps = [T0 + k * 10_000_000 for k in (0, 2, 1, 3, 3, 4)]
    rec = read_joint_states(write_stamped(tmp_path, "ros2-mcap", stamps, [[float(k)] for k in range(6)]))
    np.testing.assert_allclose(rec.trajectory.t, [0.0, 0.01, 0.02, 0.03, 0.04], atol=1e-12)
    np.testing.assert_array_equal(rec.trajectory.y[:, 0], [0.0, 2.0, 1.0, 3.0, 5.0])


def test_a_pose_topic_with_a_nan_or_a_zero_quaternion_names_the_message(tmp_path):
    path = bag_path(tmp_path, "ros2-sqlite3")
    with BagWriter(path, "ros2-sqlite3") as w:
        for k in range(10):
            pose = [0.1 * k, 0, 0, 1, 0, 0, 0] if k != 4 else [0.0, 0, 0, 0, 0, 0, 0]
            w.write("/pose", w.pose_stamped(T0 + k * 10**7, "world", pose), T0 + k * 10**7)
            w.write("/tf", w.tf_message(T0 + k * 10**7, [("world", "tool", [float("nan") if k == 6 else 0.0,
                                                                          0, 0, 1, 0, 0, 0])]), T0 + k * 10**7)
    with pytest.raises(InvalidInputError, match=r"topic '/pose', message 4: its quaternion is zero"):
        read_poses(path, "/pose")
    with pytest.raises(InvalidInputError, match=r"TF message 6, transform 'world' -> 'tool': x is nan"):
        read_tf(path, "world", "tool")
