"""dmprs.CartesianDMP and dmprs.CartesianTrajectory against independent truth: the discrete DMP of
a fixed-axis rotation's angle, scipy's rotations, and the invariants of the quaternion DMP.
"""

from __future__ import annotations

import pickle

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

import dmprs
from tests.conftest import min_jerk


def rot(q: np.ndarray) -> Rotation:
    return Rotation.from_quat(np.array(q), scalar_first=True)  # scipy refuses read-only arrays


def pose_demo(n: int = 400, tau: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Position along a curve; orientation turning 1.7 rad about a moving axis."""
    t = np.linspace(0.0, tau, n)
    s = t / tau
    a = min_jerk(s)
    axis = np.stack([np.ones_like(s), 0.5 * s, 2.0 - s], axis=1)
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    q = Rotation.from_rotvec(axis * (0.2 + 1.7 * a)[:, None]).as_quat(scalar_first=True)
    p = np.stack([0.3 + 0.4 * a, -0.2 * a + 0.05 * np.sin(2 * s), 0.5 - 0.1 * a], axis=1)
    return t, np.hstack([p, q])


def angle_between(qa: np.ndarray, qb: np.ndarray) -> np.ndarray:
    return (rot(qa) * rot(qb).inv()).magnitude()


def test_a_fixed_axis_rotation_is_the_discrete_dmp_of_its_angle() -> None:
    t = np.linspace(0.0, 1.2, 600)
    theta = 0.4 + 2.0 * min_jerk(t / 1.2) + 0.2 * np.sin(np.pi * t / 1.2) ** 2
    axis = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    q = Rotation.from_rotvec(axis * theta[:, None]).as_quat(scalar_first=True)
    pose = np.hstack([np.zeros((600, 3)), q])
    cart = dmprs.CartesianDMP.fit(t, pose, 30)
    scalar = dmprs.DMP.fit(t, theta, 30)
    scale = np.abs(scalar.weights).max()
    np.testing.assert_allclose(cart.weights[3:], np.outer(axis, scalar.weights[0]), rtol=0, atol=1e-10 * scale)
    a, b = cart.rollout(0.001, 2.0), scalar.rollout(0.001, 2.0)
    turned = (rot(a.quaternion) * rot(a.quaternion[0]).inv()).as_rotvec() @ axis
    np.testing.assert_allclose(theta[0] + turned, b.y[:, 0], rtol=0, atol=1e-10)
    np.testing.assert_allclose(a.angular_velocity, np.outer(b.yd[:, 0], axis), rtol=0, atol=1e-9)


def test_a_turn_of_a_full_turn_or_more_is_refused_naming_the_time_and_one_just_under_is_kept() -> None:
    """The orientation coordinates are the rotation to the goal while it is under a full turn
    (the quaternion logarithm's range); past it they jump by 2 pi and the rollout with them (it
    turned at about 100 rad/s and ended the other way round). A 6.0 rad turn is still the
    discrete DMP of its angle; a 6.4 rad one is refused by the fit and, by its index, by a
    generalizer.
    """
    t = np.linspace(0.0, 1.0, 1001)
    axis = np.array([0.0, 0.6, 0.8])

    def turn(total: float) -> np.ndarray:
        q = Rotation.from_rotvec(np.outer(total * min_jerk(t), axis)).as_quat(scalar_first=True)
        return np.hstack([np.zeros((len(t), 3)), q])

    a = dmprs.CartesianDMP.fit(t, turn(6.0), 50).rollout(0.001, 1.0)
    b = dmprs.DMP.fit(t, 6.0 * min_jerk(t), 50).rollout(0.001, 1.0)
    # (to 1e-6 of the peak 11 rad/s; a wrap would be off by about 100 rad/s)
    np.testing.assert_allclose(a.angular_velocity, np.outer(b.yd[:, 0], axis), rtol=0, atol=1e-5)
    with pytest.raises(dmprs.errors.InvalidInputError, match=r"at t = 0\.131 s is a full turn or more from the goal"):
        dmprs.CartesianDMP.fit(t, turn(6.4), 50)
    db = dmprs.Database(("turn",))
    for total in (3.0, 6.4):
        pose = turn(total)
        db.add([total], dmprs.CartesianTrajectory(t, pose[:, :3], pose[:, 3:]))
    with pytest.raises(dmprs.errors.InvalidInputError, match=r"demonstration 1: .* full turn"):
        dmprs.Generalizer(db, "linear", 30)


@settings(max_examples=30, deadline=None)
@given(
    w=st.lists(st.floats(-300, 300), min_size=60, max_size=60),
    goal=st.lists(st.floats(-1, 1), min_size=4, max_size=4),
    start=st.lists(st.floats(-1, 1), min_size=4, max_size=4),
    tau=st.floats(0.2, 2.0),
)
def test_rollouts_stay_unit_and_come_to_rest_at_the_goal(w, goal, start, tau) -> None:
    g, s = np.array(goal), np.array(start)
    if np.linalg.norm(g) < 0.1 or np.linalg.norm(s) < 0.1:
        return
    g, s = g / np.linalg.norm(g), s / np.linalg.norm(s)
    dmp = dmprs.CartesianDMP(
        np.reshape(w, (6, 10)), np.r_[0.5, -0.2, 0.1, g], np.r_[0.0, 0.0, 0.0, s], tau
    )
    tr = dmp.rollout(0.002, until_rest=True, rest_tol=1e-8)
    assert np.abs(np.linalg.norm(tr.quaternion, axis=1) - 1.0).max() <= 1e-12
    assert angle_between(tr.quaternion[-1], g) <= 1e-6
    np.testing.assert_allclose(tr.position[-1], [0.5, -0.2, 0.1], rtol=0, atol=1e-6)


def test_a_rotated_demo_gives_the_rotated_rollout() -> None:
    t, pose = pose_demo()
    r = Rotation.from_rotvec([0.4, -1.1, 0.7])
    rotated = np.hstack([r.apply(pose[:, :3]), (r * rot(pose[:, 3:])).as_quat(scalar_first=True)])
    a = dmprs.CartesianDMP.fit(t, pose, 30).rollout(0.001, 2.0)
    b = dmprs.CartesianDMP.fit(t, rotated, 30).rollout(0.001, 2.0)
    np.testing.assert_allclose(r.apply(np.array(a.position)), b.position, rtol=0, atol=1e-9)
    assert angle_between((r * rot(a.quaternion)).as_quat(scalar_first=True), b.quaternion).max() < 1e-9
    np.testing.assert_allclose(r.apply(np.array(a.angular_velocity)), b.angular_velocity, rtol=0, atol=1e-8)


def test_alternating_signs_fit_as_if_continuous() -> None:
    t, pose = pose_demo()
    flipped = pose.copy()
    flipped[1::2, 3:] *= -1.0
    assert dmprs.CartesianDMP.fit(t, flipped, 25) == dmprs.CartesianDMP.fit(t, pose, 25)


@settings(max_examples=20, deadline=None)
@given(
    rotvec=st.lists(st.floats(-1.8, 1.8), min_size=3, max_size=3),
    position=st.lists(st.floats(-1, 1), min_size=3, max_size=3),
    flip=st.booleans(),
)
def test_with_a_new_goal_the_movement_ends_there(rotvec, position, flip) -> None:
    t, pose = pose_demo()
    dmp = dmprs.CartesianDMP.fit(t, pose, 25)
    q = Rotation.from_rotvec(rotvec).as_quat(scalar_first=True) * (-1.0 if flip else 1.0)
    tr = dmp.with_goal(np.r_[position, q]).rollout(0.001, until_rest=True, rest_tol=1e-8)
    assert angle_between(tr.quaternion[-1], q) <= 1e-6
    np.testing.assert_allclose(tr.position[-1], position, rtol=0, atol=1e-6)


def test_the_sign_of_a_new_goal_or_start_does_not_matter() -> None:
    t, pose = pose_demo()
    dmp = dmprs.CartesianDMP.fit(t, pose, 25)
    g = np.r_[0.1, 0.2, 0.3, Rotation.from_rotvec([0.5, 0.1, 2.0]).as_quat(scalar_first=True)]
    minus = g * np.r_[1, 1, 1, -1, -1, -1, -1]
    assert dmp.with_goal(g) == dmp.with_goal(minus)
    assert dmp.with_start(g) == dmp.with_start(minus)


def test_the_fit_reproduces_the_demo_and_its_ends() -> None:
    t, pose = pose_demo(n=1000)
    dmp = dmprs.CartesianDMP.fit(t, pose, 50)
    np.testing.assert_array_equal(dmp.start[:3], pose[0, :3])
    np.testing.assert_allclose(dmp.goal, pose[-1], rtol=0, atol=1e-15)
    tr = dmp.rollout(dt=t[1] - t[0])
    assert angle_between(tr.quaternion[: len(t)], pose[:, 3:]).max() < 2e-3
    assert np.abs(tr.position[: len(t)] - pose[:, :3]).max() < 2e-3
    np.testing.assert_array_equal(tr.pose, np.hstack([tr.position, tr.quaternion]))


def test_serialization_batch_and_tau() -> None:
    t, pose = pose_demo()
    dmp = dmprs.CartesianDMP.fit(t, pose, 20)
    assert dmprs.CartesianDMP.from_dict(dmp.to_dict()) == dmp
    assert pickle.loads(pickle.dumps(dmp)) == dmp
    slow = dmp.with_tau(2.0)
    a, b = dmp.rollout(0.001), slow.rollout(0.002)
    np.testing.assert_allclose(a.quaternion, b.quaternion, rtol=0, atol=1e-12)
    batch = dmprs.rollout_batch([dmp, dmprs.DMP.fit(t, pose[:, :3], 20), slow], 0.001)
    assert batch[0] == dmp.rollout(0.001) and batch[2] == slow.rollout(0.001)
    assert isinstance(batch[1], dmprs.Trajectory)
    for tr in (a, batch[2]):  # rollouts are immutable
        assert not any(getattr(tr, n).flags.writeable for n in ("t", "position", "quaternion", "angular_velocity"))
    with pytest.raises(AttributeError):
        dmp.tau = 3.0  # type: ignore[misc]


def test_measured_angular_velocities_are_used() -> None:
    t, pose = pose_demo()
    est = dmprs.CartesianDMP.fit(t, pose, 25)
    # The exact angular velocity of the demo, from scipy, is close to the estimate.
    dq = rot(pose[2:, 3:]) * rot(pose[:-2, 3:]).inv()
    omega = np.vstack([np.zeros(3), dq.as_rotvec() / (t[2:] - t[:-2])[:, None], np.zeros(3)])
    omega[0], omega[-1] = omega[1], omega[-2]
    given_ = dmprs.CartesianDMP.fit(t, pose, 25, angular_velocity=omega)
    assert not np.array_equal(given_.weights, est.weights)
    np.testing.assert_allclose(given_.weights, est.weights, rtol=0, atol=0.05 * np.abs(est.weights).max())


# --- bad input: each a clear InvalidInputError naming the sample ------------------------------------


def _fit(pose: np.ndarray, t: np.ndarray | None = None, **kw) -> None:
    dmprs.CartesianDMP.fit(pose_demo()[0] if t is None else t, pose, 10, **kw)


def _trajectory(pose: np.ndarray, t: np.ndarray | None = None, **kw) -> None:
    dmprs.CartesianTrajectory.from_pose(pose_demo()[0] if t is None else t, pose, **kw)


BUILDERS = pytest.mark.parametrize("build", [_fit, _trajectory], ids=["fit", "trajectory"])


@BUILDERS
def test_a_quaternion_off_unit_norm_is_refused_unless_normalize(build) -> None:
    _, pose = pose_demo()
    pose[17, 3:] *= 1.0 + 2e-6
    with pytest.raises(dmprs.InvalidInputError, match=r"pose\[17\].*norm"):
        build(pose)
    build(pose, normalize=True)
    pose[17, 3:] /= 1.0 + 2e-6
    pose[17, 3:] *= 1.0 + 5e-7  # within the tolerance
    build(pose)


@BUILDERS
def test_the_zero_quaternion_is_refused_even_with_normalize(build) -> None:
    _, pose = pose_demo()
    pose[5, 3:] = 0.0
    with pytest.raises(dmprs.InvalidInputError, match=r"pose\[5\].*zero quaternion"):
        build(pose, normalize=True)


@BUILDERS
def test_nan_is_refused(build) -> None:
    _, pose = pose_demo()
    pose[9, 4] = np.nan
    with pytest.raises(dmprs.InvalidInputError, match=r"(?i)pose\[9, 4\] is nan"):
        build(pose)


@BUILDERS
def test_a_pose_of_the_wrong_width_is_refused(build) -> None:
    _, pose = pose_demo()
    with pytest.raises(dmprs.InvalidInputError, match=r"pose has shape \(400, 6\), expected \(T, 7\)"):
        build(pose[:, :6])


@BUILDERS
def test_non_increasing_t_is_refused(build) -> None:
    t, pose = pose_demo()
    t[30] = t[29]
    with pytest.raises(dmprs.InvalidInputError, match=r"t\[30\] .* is not greater than t\[29\]"):
        build(pose, t=t)


def test_bad_goal_and_start_poses_are_refused() -> None:
    dmp = dmprs.CartesianDMP.fit(*pose_demo(), 10)
    with pytest.raises(dmprs.InvalidInputError, match=r"goal\[0\].*norm"):
        dmp.with_goal([0, 0, 0, 2.0, 0, 0, 0])
    with pytest.raises(dmprs.InvalidInputError, match=r"start has shape \(6,\)"):
        dmp.with_start([0, 0, 0, 1.0, 0, 0])
    with pytest.raises(dmprs.InvalidInputError, match=r"(?i)goal\[2\] is nan"):
        dmp.with_goal([0, 0, np.nan, 1.0, 0, 0, 0])


def test_a_coarse_dt_is_sub_stepped_as_the_stepper_does() -> None:
    dmp = dmprs.CartesianDMP.fit(*pose_demo(), 10)
    tr = dmp.rollout(dt=0.2, duration=500.0)
    assert np.isfinite(tr.position).all() and np.isfinite(tr.quaternion).all()
    np.testing.assert_allclose(tr.position[-1], dmp.goal[:3], atol=1e-9)
    stepper = dmp.stepper(0.2, alpha_e=0.0, goal_filter=None)
    assert stepper.substeps > 1
    for j in range(50):
        pose, _, _ = stepper.step()
        np.testing.assert_array_equal(pose, np.concatenate([tr.position[j], tr.quaternion[j]]))


def test_an_overflowing_rollout_is_an_error_not_a_nan_trajectory() -> None:
    dmp = dmprs.CartesianDMP.fit(*pose_demo(), 10)
    goal = dmp.goal.copy()
    goal[0] = 1.7e308
    with pytest.raises(dmprs.NumericalError, match="overflowed"):
        dmp.with_goal(goal).rollout(dt=0.001)
