"""Pose demonstrations in the Database and the Generalizer: saved, loaded and checksummed like the
others; "linear" slerps (against scipy's Slerp) and both methods reproduce their demos.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.spatial.transform import Rotation, Slerp

import dmprs
from tests.conftest import min_jerk


def pose_demo(q: float, n: int = 300) -> dmprs.CartesianTrajectory:
    """The turn, reach and duration depend on the query; odd queries come with flipped signs."""
    tau = 1.0 + 0.3 * q
    t = np.linspace(0.0, tau, n)
    a = min_jerk(t / tau)
    turn = np.stack([0.3 * q * a, 0.1 + 0.0 * a, (1.0 + q) * a], axis=1)
    quat = Rotation.from_rotvec(turn).as_quat(scalar_first=True) * (-1.0 if q > 0.5 else 1.0)
    pos = np.stack([(1.0 + q) * a, 0.2 * q + 0.0 * a, 0.5 * a * np.sin(3 * t / tau)], axis=1)
    return dmprs.CartesianTrajectory(t, pos, quat)


def database(qs) -> dmprs.Database:
    db = dmprs.Database(("q",), ("",))
    for q in qs:
        db.add(q, pose_demo(q))
    return db


def angle(a: np.ndarray, b: np.ndarray) -> float:
    return float((Rotation.from_quat(np.array(a), scalar_first=True)
                  * Rotation.from_quat(np.array(b), scalar_first=True).inv()).magnitude())


def test_pose_demos_round_trip_bit_exact_and_are_checksummed(tmp_path) -> None:
    db = database([0.0, 1.0])
    db.add(2.0, dmprs.CartesianTrajectory(
        pose_demo(2.0).t, pose_demo(2.0).position, pose_demo(2.0).quaternion,
        angular_velocity=np.ones((300, 3)),
    ))
    db.save(tmp_path / "db")
    back = dmprs.Database.load(tmp_path / "db")
    assert back.is_cartesian and len(back) == 3
    for a, b in zip(db, back, strict=True):
        assert a.trajectory == b.trajectory and np.array_equal(a.query, b.query)
    manifest = json.loads((tmp_path / "db" / "manifest.json").read_text())
    assert manifest["schema_version"] == 2
    victim = tmp_path / "db" / manifest["demos"][1]["file"]
    data = bytearray(victim.read_bytes())
    data[-10] ^= 0xFF
    victim.write_bytes(bytes(data))
    with pytest.raises(dmprs.DatabaseError, match="checksum mismatch"):
        dmprs.Database.load(tmp_path / "db")


def test_joint_and_pose_demos_do_not_mix() -> None:
    db = database([0.0])
    with pytest.raises(dmprs.InvalidInputError, match="pose trajectories"):
        db.add(1.0, dmprs.Trajectory(np.linspace(0, 1, 10), np.zeros((10, 6))))


@pytest.mark.parametrize("q", [0.0, 1.0])
def test_linear_reproduces_each_demo(q) -> None:
    gen = dmprs.Generalizer(database([0.0, 1.0]), "linear", n_basis=20)
    assert gen.is_cartesian and gen.n_parameters == 6 * 20 + 13
    got = gen.predict(q)
    assert isinstance(got, dmprs.CartesianDMP)
    own = dmprs.CartesianDMP.fit_trajectory(pose_demo(q), 20)
    a, b = got.rollout(0.002), own.rollout(0.002)
    np.testing.assert_allclose(a.position, b.position, rtol=0, atol=1e-9)
    assert max(angle(x, y) for x, y in zip(a.quaternion, b.quaternion, strict=True)) < 1e-9


def test_linear_slerps_goal_and_start_between_two_demos() -> None:
    gen = dmprs.Generalizer(database([0.0, 1.0]), "linear", n_basis=20)
    goals = Rotation.from_quat(np.array([pose_demo(q).quaternion[-1] for q in (0.0, 1.0)]), scalar_first=True)
    slerp = Slerp([0.0, 1.0], goals)
    for a in (0.3, 0.5, 0.8):
        dmp = gen.predict(a)
        assert isinstance(dmp, dmprs.CartesianDMP)
        assert angle(dmp.goal[3:], slerp([a]).as_quat(scalar_first=True)[0]) < 1e-12
        np.testing.assert_allclose(dmp.goal[:3], (1 - a) * pose_demo(0.0).position[-1]
                                   + a * pose_demo(1.0).position[-1], rtol=0, atol=1e-12)


def test_lwr_gp_reproduces_each_demo_and_predicts_cartesian_dmps() -> None:
    qs = [0.0, 0.4, 1.0, 1.5]
    gen = dmprs.Generalizer(database(qs), "lwr-gp", n_basis=15)
    for dmp, q in zip(gen.demo_dmps, qs, strict=True):
        got = gen.predict(q)
        assert isinstance(got, dmprs.CartesianDMP) and isinstance(dmp, dmprs.CartesianDMP)
        assert angle(got.goal[3:], dmp.goal[3:]) < 1e-4 and angle(got.start[3:], dmp.start[3:]) < 1e-4
        np.testing.assert_allclose(got.weights, dmp.weights, rtol=0, atol=1e-5 * np.abs(dmp.weights).max())
    tr = gen.predict(0.7).rollout(0.01)
    assert np.abs(np.linalg.norm(tr.quaternion, axis=1) - 1).max() < 1e-12


def test_local_gps_serve_pose_demos_too() -> None:
    qs = list(np.linspace(0.0, 1.4, 8))
    db = database(qs)
    exact = dmprs.Generalizer(db, "lwr-gp", n_basis=10)
    assert np.array_equal(dmprs.Generalizer(db, "lwr-gp", n_basis=10, gp_neighbours=8).parameters(0.33),
                          exact.parameters(0.33))
    local = dmprs.Generalizer(db, "lwr-gp", n_basis=10, gp_neighbours=4)
    for dmp, q in zip(local.demo_dmps, qs, strict=True):
        got = local.predict(q)
        assert angle(got.goal[3:], dmp.goal[3:]) < 1e-4 and np.allclose(got.goal[:3], dmp.goal[:3], atol=1e-4)


def test_sparse_gps_serve_pose_demos_too() -> None:
    qs = list(np.linspace(0.0, 1.4, 12))
    db = database(qs)
    exact = dmprs.Generalizer(db, "lwr-gp", n_basis=10)
    sparse = dmprs.Generalizer(db, "lwr-gp", n_basis=10, gp_sparse=True)
    for q in (0.05, 0.33, 1.21):
        a, b = sparse.parameters(q), exact.parameters(q)
        assert np.allclose(a, b, rtol=0, atol=1e-6 * np.abs(b).max()), q


def test_the_numerical_jacobian_works_for_poses() -> None:
    gen = dmprs.Generalizer(database([0.0, 2.0]), "linear", n_basis=15)
    jac = gen.jacobian(0.7, rel_step=1e-3)
    assert jac.shape == (gen.n_parameters, 1)
    want = (gen.parameters(2.0) - gen.parameters(0.0)) / 2.0
    np.testing.assert_allclose(jac[:, 0], want, rtol=0, atol=1e-8)
    ude = dmprs.Generalizer(database([0.0, 0.5, 1.0, 2.0]), "lwr-gp", n_basis=15)
    j2 = ude.jacobian(0.7)
    h = 1e-4 * 2.0
    fd = (ude.parameters(0.7 + h) - ude.parameters(0.7 - h)) / (2 * h)
    np.testing.assert_allclose(j2[:, 0], fd, rtol=1e-12, atol=1e-9)
    assert np.isfinite(j2).all() and np.abs(j2[-6:]).max() > 0  # orientations do depend on q
