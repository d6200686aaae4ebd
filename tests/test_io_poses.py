"""Pose trajectories: quaternion sign continuity, slerp and composition against scipy."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation, Slerp

from dmprs.errors import InvalidInputError
from dmprs.io.poses import pose_trajectory, resample_poses, split_poses_at_rest
from dmprs.quaternion import product as quat_multiply
from dmprs.quaternion import rotate as quat_rotate


def smooth_rotations(seed: int, n: int = 40) -> Rotation:
    rng = np.random.default_rng(seed)
    steps = Rotation.from_rotvec(rng.normal(0, 0.15, (n - 1, 3)))
    out = [Rotation.from_rotvec(rng.normal(0, 1.0, 3))]
    for s in steps:
        out.append(s * out[-1])
    return Rotation.concatenate(out)


@settings(max_examples=15, deadline=None)
@given(st.integers(0, 2**31), st.integers(0, 2**31))
def test_signs_are_made_continuous_and_rotations_kept(seed, flip_seed):
    rot = smooth_rotations(seed)
    q = rot.as_quat(scalar_first=True)
    flips = np.where(np.random.default_rng(flip_seed).random(len(q)) < 0.5, -1.0, 1.0)
    t = np.linspace(0, 1, len(q))
    pt = pose_trajectory(t, np.hstack([np.zeros((len(q), 3)), 3.0 * flips[:, None] * q]))  # not unit either
    assert np.all(np.sum(pt.quaternion[1:] * pt.quaternion[:-1], axis=1) > 0)
    np.testing.assert_allclose(np.linalg.norm(pt.quaternion, axis=1), 1.0, rtol=1e-12)
    np.testing.assert_allclose(np.abs(np.sum(pt.quaternion * q, axis=1)), 1.0, rtol=1e-12)


@settings(max_examples=10, deadline=None)
@given(st.integers(0, 2**31))
def test_resampling_is_slerp_and_composition_is_scipys(seed):
    rot = smooth_rotations(seed, 11)
    t = np.linspace(0, 1, 11)
    pos = np.random.default_rng(seed).normal(size=(11, 3))
    pt = pose_trajectory(t, np.hstack([pos, rot.as_quat(scalar_first=True)]))
    fine = resample_poses(pt, 40.0)
    want = Slerp(t, rot)(fine.t)
    np.testing.assert_allclose(np.abs(np.sum(fine.quaternion * want.as_quat(scalar_first=True), axis=1)), 1.0,
                               atol=1e-12)
    np.testing.assert_allclose(fine.position[:, 0], np.interp(fine.t, t, pos[:, 0]), atol=1e-12)
    a, b = rot[:5], rot[5:10]
    qa, qb = a.as_quat(scalar_first=True), b.as_quat(scalar_first=True)
    np.testing.assert_allclose(np.abs(np.sum(quat_multiply(qa, qb) * (a * b).as_quat(scalar_first=True), axis=1)),
                               1.0, atol=1e-12)
    np.testing.assert_allclose(quat_rotate(qa, pos[:5]), a.apply(pos[:5]), atol=1e-12)


def test_bad_poses_are_named():
    with pytest.raises(InvalidInputError, match=r"expected \(2, 7\)"):
        pose_trajectory([0, 1], np.zeros((2, 6)))
    with pytest.raises(InvalidInputError, match="zero quaternion"):
        pose_trajectory([0, 1], np.zeros((2, 7)))
    with pytest.raises(InvalidInputError, match="strictly increasing"):
        pose_trajectory([0, 0], np.tile([0, 0, 0, 1.0, 0, 0, 0], (2, 1)))


def test_pose_recordings_are_cut_at_rests_in_position_and_orientation():
    t = np.arange(0.0, 5.0, 0.01)
    s1 = np.clip((t - 0.5) / 1.0, 0, 1)
    s2 = np.clip((t - 2.5) / 1.5, 0, 1)
    m1, m2 = (10 * s**3 - 15 * s**4 + 6 * s**5 for s in (s1, s2))
    # first a translation, then a pure rotation (no translation at all)
    rot = Rotation.from_euler("z", 1.2 * m2[:, None]).as_quat(scalar_first=True)
    pt = pose_trajectory(t, np.hstack([np.stack([0.3 * m1, 0 * t, 0 * t], 1), rot]))
    pieces = split_poses_at_rest(pt, speed_tol=0.01, angular_speed_tol=0.02)
    assert len(pieces) == 2 and all(p.t[0] == 0.0 for p in pieces)
    assert abs(pieces[0].duration - 1.0) < 0.1 and abs(pieces[1].duration - 1.5) < 0.1
    np.testing.assert_allclose(np.ptp(pieces[1].position, axis=0), 0.0, atol=1e-15)
    with pytest.raises(InvalidInputError, match="no movement faster"):
        split_poses_at_rest(pt, speed_tol=10.0, angular_speed_tol=10.0)
