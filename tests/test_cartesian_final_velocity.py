"""A Cartesian DMP that reaches its goal pose with a final linear and angular velocity
(docs/cartesian.md, "A final velocity"), against independent truth: the request itself at
t = tau (met to rounding by the springs alone, to the integrator's first order by a fitted
shape, shown by halving dt), a demonstration ending in motion known in closed form, the 1-D
final-velocity DMP of the angle of a fixed-axis rotation, today's Cartesian DMP bit for bit at
zero, and the rollout for the stepper.
"""

from __future__ import annotations

import pickle

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import dmprs
from dmprs.errors import InvalidInputError

T_DEMO = 1.2
TWIST = np.array([0.4, -0.3, 0.25, 0.6, -0.2, 0.5])
GOAL_P = np.array([0.5, -0.2, 0.3])


def rot(q: np.ndarray) -> Rotation:
    return Rotation.from_quat(np.array(q), scalar_first=True)  # scipy refuses read-only arrays


def moving_demo(twist: np.ndarray = TWIST, n: int = 1201) -> tuple[np.ndarray, np.ndarray]:
    """Starts at rest, ends at the last pose moving at ``twist`` (closed form). Position:
    min-jerk to ``GOAL_P`` plus ``v T k(s)``; orientation: ``exp(k(s) T / 2 omega) * h(s)``, with
    ``k = s^5 - s^4`` (``k(1) = 0``, ``k'(1) = 1``, ``k'(0) = 0``) and ``h`` a turn about a slowly
    moving axis at rest at both ends: its angular velocity is ``k'(s) omega + R(k) omega_h``,
    ``omega`` at the end.
    """
    t = np.linspace(0.0, T_DEMO, n)
    s = t / T_DEMO
    min_jerk, k = 10 * s**3 - 15 * s**4 + 6 * s**5, s**5 - s**4
    p = GOAL_P * min_jerk[:, None] + T_DEMO * np.outer(k, twist[:3])
    u = (1 - s) ** 2
    axis = np.stack([np.ones_like(s), 0.5 * u, 1 + u], axis=1)
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    h = Rotation.from_rotvec(axis * (1.2 * min_jerk)[:, None])
    q = (Rotation.from_rotvec(np.outer(k * T_DEMO, twist[3:])) * h).as_quat(scalar_first=True)
    return t, np.hstack([p, q])


def final_errors(dmp: dmprs.CartesianDMP, dt: float) -> np.ndarray:
    """Position (m), linear velocity, orientation (rad), angular velocity at the last sample."""
    tr = dmp.rollout(dt)
    v = dmp.final_velocity
    return np.array([
        np.linalg.norm(tr.position[-1] - dmp.goal[:3]),
        np.linalg.norm(tr.velocity[-1] - v[:3]),
        (rot(tr.quaternion[-1]) * rot(dmp.goal[3:]).inv()).magnitude(),
        np.linalg.norm(tr.angular_velocity[-1] - v[3:]),
    ])


def shaped(**kwargs) -> dmprs.CartesianDMP:
    w = 30 * np.sin(0.7 * np.arange(25)[None, :] + 1.1 * np.arange(6)[:, None])
    goal = np.r_[GOAL_P, Rotation.from_rotvec([0.3, 0.8, -0.2]).as_quat(scalar_first=True)]
    start = np.r_[0.0, 0.1, 0.0, Rotation.from_rotvec([-0.1, 0.4, 0.1]).as_quat(scalar_first=True)]
    return dmprs.CartesianDMP(w, goal, start, 0.9, **kwargs)


def test_the_springs_alone_meet_the_request_at_any_dt():
    """Euler tracks goals whose velocities are fed forward exactly, at the integrator's own time
    (from its phase): only the transient from rest is left at tau.
    """
    base = shaped()
    dmp = dmprs.CartesianDMP(np.zeros((6, 25)), base.goal, base.start, 0.9, final_velocity=TWIST)
    for dt in (0.001, 0.004, 0.01):
        e = final_errors(dmp, dt)
        assert e[0] < 1e-8 and e[2] < 1e-8
        assert e[1] < 1e-7 and e[3] < 1e-7


def test_a_demonstration_ending_in_motion_meets_the_request_to_first_order():
    t, pose = moving_demo()
    dmp = dmprs.CartesianDMP.fit(t, pose, 40, final_velocity=TWIST)
    np.testing.assert_array_equal(dmp.final_velocity, TWIST)
    errors = np.array([final_errors(dmp, dt) for dt in (0.002, 0.001, 0.0005)])
    ratios = errors[:-1] / errors[1:]
    assert np.all((1.6 < ratios) & (ratios < 2.4)), errors
    assert errors[1, 0] < 1e-3 and errors[1, 2] < 1e-3
    assert errors[1, 1] < 2e-2 and errors[1, 3] < 2e-2
    tr = dmp.rollout(0.001)
    assert np.max(np.abs(tr.position - pose[:, :3])) < 1e-2
    assert np.max((rot(tr.quaternion) * rot(pose[:, 3:]).inv()).magnitude()) < 1e-2
    np.testing.assert_allclose(np.linalg.norm(tr.quaternion, axis=1), 1.0, rtol=0, atol=1e-12)
    # "demo": the demonstration's last linear and angular velocity (finite differences)
    from_demo = dmprs.CartesianDMP.fit(t, pose, 40, final_velocity="demo")
    np.testing.assert_allclose(from_demo.final_velocity, TWIST, atol=1e-4)


def test_a_new_final_velocity_is_met_with_the_demonstrated_shape():
    """The position's spring is linear in the final velocity and its transient from rest has died
    out by tau: another final velocity on the fitted shape is met as accurately as the
    demonstrated one. The orientation's is linear only to first order in the turn between the
    moving goal and q, so it is met to a few mrad (rad/s: a few times the demonstrated one's).
    """
    t, pose = moving_demo()
    new = np.array([-0.2, 0.5, 0.1, -0.4, 0.7, 0.2])
    dmp = dmprs.CartesianDMP.fit(t, pose, 40, final_velocity=TWIST).with_final_velocity(new)
    e = final_errors(dmp, 0.001)
    assert e[0] < 2e-4 and e[1] < 5e-3, e
    assert e[2] < 5e-3 and e[3] < 5e-2, e


def test_a_fixed_axis_rotation_is_the_joint_final_velocity_dmp_of_its_angle():
    axis = np.array([0.3, -1.0, 0.6]) / np.linalg.norm([0.3, -1.0, 0.6])
    w_theta = 50 * np.sin(0.9 * np.arange(25))
    theta0, theta_g, omega, tau = 0.3, 1.4, -0.7, 1.1
    w = np.vstack([np.zeros((3, 25)), np.outer(axis, w_theta)])
    q = lambda a: Rotation.from_rotvec(a * axis).as_quat(scalar_first=True)
    cart = dmprs.CartesianDMP(w, np.r_[0.0, 0.0, 0.0, q(theta_g)], np.r_[0.0, 0.0, 0.0, q(theta0)], tau,
                              final_velocity=np.r_[0.0, 0.0, 0.0, omega * axis])
    angle = dmprs.DMP(w_theta[None, :], [theta_g], [theta0], tau, final_velocity=[omega])
    a, b = cart.rollout(0.002, 1.3 * tau), angle.rollout(0.002, 1.3 * tau)
    turned = (rot(a.quaternion) * rot(a.quaternion[0]).inv()).as_rotvec()
    np.testing.assert_allclose(theta0 + turned @ axis, b.y[:, 0], rtol=0, atol=1e-10)
    np.testing.assert_allclose(a.angular_velocity, np.outer(b.yd[:, 0], axis), rtol=0, atol=1e-9)


def test_zero_is_todays_cartesian_dmp_bit_for_bit():
    dmp = shaped()
    zero = shaped(final_velocity=np.zeros(6))
    assert zero == dmp and "final_velocity" not in zero.to_dict()
    np.testing.assert_array_equal(zero.final_velocity, np.zeros(6))
    a, b = zero.rollout(0.001), dmp.rollout(0.001)
    for name in ("position", "quaternion", "velocity", "angular_velocity", "acceleration"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    t, pose = moving_demo(np.zeros(6))
    fitted = dmprs.CartesianDMP.fit(t, pose, 30, final_velocity=np.zeros(6))
    assert fitted == dmprs.CartesianDMP.fit(t, pose, 30)


def test_it_survives_dict_pickle_and_the_derived_movements():
    dmp = shaped(final_velocity=TWIST)
    assert dmp.to_dict()["final_velocity"] == TWIST.tolist()
    for copy in (dmprs.CartesianDMP.from_dict(dmp.to_dict()), pickle.loads(pickle.dumps(dmp))):
        assert copy == dmp
        np.testing.assert_array_equal(copy.rollout(0.001).pose, dmp.rollout(0.001).pose)
    assert dmp != shaped()
    np.testing.assert_array_equal(dmp.with_goal(shaped().start).final_velocity, TWIST)
    np.testing.assert_array_equal(dmp.with_start(shaped().goal).final_velocity, TWIST)
    np.testing.assert_allclose(dmp.with_tau(1.8).final_velocity, TWIST * 0.5, rtol=1e-15)
    np.testing.assert_array_equal(shaped().with_final_velocity(TWIST).final_velocity, TWIST)


def test_rollouts_are_deterministic_one_by_one_or_in_a_batch():
    dmp = shaped(final_velocity=TWIST)
    a, b = dmp.rollout(0.001, 2.0), dmp.rollout(0.001, 2.0)
    (c,) = dmprs.rollout_batch([dmp], 0.001, 2.0)
    for other in (b, c):
        np.testing.assert_array_equal(a.pose, other.pose)
        np.testing.assert_array_equal(a.angular_velocity, other.angular_velocity)


@pytest.mark.parametrize("bad", [np.zeros(5), np.r_[0.0, np.nan, 0, 0, 0, 0], np.zeros((2, 3)), "stop"])
def test_a_bad_final_velocity_is_refused_by_name(bad):
    t, pose = moving_demo()
    for build in (lambda: shaped(final_velocity=bad), lambda: shaped().with_final_velocity(bad),
                  lambda: dmprs.CartesianDMP.fit(t, pose, 25, final_velocity=bad)):
        with pytest.raises((dmprs.DmprsError, ValueError), match="final_velocity"):
            build()


def turning_demo(angle) -> tuple[np.ndarray, np.ndarray]:
    """Still at the origin, turned about z by ``angle(t)`` rad over 1 s (1001 samples)."""
    t = np.linspace(0.0, 1.0, 1001)
    a = angle(t)
    q = np.stack([np.cos(a / 2), 0 * t, 0 * t, np.sin(a / 2)], axis=1)
    return t, np.hstack([np.zeros((len(t), 3)), q])


def test_a_goal_a_full_turn_from_the_demonstration_is_refused_by_name():
    """The moving goal is the goal turned back by ``(tau - t) omega_g``. With the demo at rest it
    is a full turn away where ``(tau - t) |omega_g| = 2 pi``, and the quaternion logarithm's
    targets would jump there (the rollout's angular velocity to 35-115 rad/s): refused. Just
    inside a full turn the fit is taken and reproduces the still demonstration. A generalizer's
    demo that comes back to where it started but ends turning at 6.4 rad/s is refused the same
    way, by its index.
    """
    t, still = turning_demo(lambda t: 0 * t)
    with pytest.raises(InvalidInputError, match=r"final_velocity = .*6\.4.* full turn .* t = 0\.01"):
        dmprs.CartesianDMP.fit(t, still, 50, final_velocity=[0, 0, 0, 0, 0, 6.4])
    ok = dmprs.CartesianDMP.fit(t, still, 50, final_velocity=[0, 0, 0, 0, 0, 6.2]).rollout(0.001, 1.0)
    assert np.abs(ok.angular_velocity).max() < 0.05
    db = dmprs.Database(("k",))
    for k, angle in enumerate((lambda t: 0 * t, lambda t: 6.4 * t**2 * (t - 1))):
        t, pose = turning_demo(angle)
        db.add([k], dmprs.CartesianTrajectory(t, pose[:, :3], pose[:, 3:]))
    with pytest.raises(InvalidInputError, match=r"demonstration 1: final_velocity = .* full turn"):
        dmprs.Generalizer(db, "linear", 30, final_velocity=True)


def test_a_demonstration_turning_with_its_goal_may_turn_more_than_a_full_turn():
    """Spun up to 7 rad/s over a 1 s demo (7 rad of turn, and its goal's 7): the goal turns with
    the demonstration and stays near it, so the fit is taken, and the rollout ends turning at the
    final velocity along the demonstrated turn.
    """
    spin = lambda t: 7.0 * t**2 * (2 - t)
    t, spinning = turning_demo(spin)
    dmp = dmprs.CartesianDMP.fit(t, spinning, 50, final_velocity="demo")
    np.testing.assert_allclose(dmp.final_velocity, [0, 0, 0, 0, 0, 7.0], atol=1e-4)  # finite differences
    tr = dmp.rollout(0.001, 1.0)
    np.testing.assert_allclose(tr.angular_velocity[-1], [0, 0, 7.0], atol=0.05)
    turned = rot(tr.quaternion) * Rotation.from_rotvec(np.outer(spin(tr.t), [0, 0, 1])).inv()
    assert turned.magnitude().max() < 0.01


def test_until_rest_is_refused_by_name():
    with pytest.raises(InvalidInputError, match="until_rest"):
        shaped(final_velocity=TWIST).rollout(0.001, until_rest=True)


def test_the_stepper_is_the_rollout_and_never_done():
    dmp = shaped(final_velocity=TWIST)
    tr = dmp.rollout(0.001, 1.5 * dmp.tau)
    stepper = dmp.stepper(0.001)
    for j in range(len(tr.t)):
        pose, velocity, _ = stepper.step()
        np.testing.assert_allclose(pose, tr.pose[j], rtol=0, atol=1e-11)
        np.testing.assert_allclose(velocity, np.r_[tr.velocity[j], tr.angular_velocity[j]], rtol=0, atol=1e-11)
        assert not stepper.done()


def poses_ending_in_motion(scales) -> dmprs.Database:
    """Pose demonstrations labelled by ``scale``, each ``moving_demo`` ending at ``scale x TWIST``."""
    db = dmprs.Database(("scale",))
    for scale in scales:
        t, pose = moving_demo(scale * TWIST, n=601)
        db.add([scale], dmprs.CartesianTrajectory(t, pose[:, :3], pose[:, 3:]))
    return db


@pytest.mark.parametrize(("method", "scales", "options"),
                         [("linear", [0.5, 1.5], {}), ("lwr-gp", [0.5, 1.0, 1.5], {"trend": "affine"})])
def test_pose_final_velocities_are_generalized_with_the_other_parameters(method, scales, options):
    """Each demo's own fit (its last twist as its final velocity) at its query; between them the
    demonstrated end twist is linear in the query, and the rollout meets the generalized twist
    to the integrator's first order (halving dt halves the error).
    """
    db = poses_ending_in_motion(scales)
    gen = dmprs.Generalizer(db, method, 30, final_velocity=True, **options)
    assert gen.n_parameters == 6 * 30 + 1 + 18
    for demo in db:
        tr = demo.trajectory
        own = dmprs.CartesianDMP.fit(tr.t, tr.pose, 30, final_velocity="demo")
        at_demo = gen.predict(demo.query)
        np.testing.assert_allclose(at_demo.final_velocity, own.final_velocity, rtol=1e-6, atol=1e-9)
        np.testing.assert_allclose(gen.parameters(demo.query)[-6:], own.final_velocity, rtol=1e-6, atol=1e-9)
        np.testing.assert_allclose(at_demo.weights, own.weights, rtol=1e-5, atol=1e-6 * np.abs(own.weights).max())
    between = gen.predict([1.25])
    np.testing.assert_allclose(between.final_velocity, 1.25 * TWIST, atol=2e-3)
    coarse, fine = final_errors(between, 0.002), final_errors(between, 0.001)
    assert coarse[1] < 0.05 and coarse[3] < 0.05
    np.testing.assert_allclose(fine[[1, 3]] / coarse[[1, 3]], 0.5, atol=0.08)


def test_pose_generalizers_without_final_velocities_are_todays():
    db = poses_ending_in_motion([0.5, 1.5])
    today, moving = dmprs.Generalizer(db, "linear", 30), dmprs.Generalizer(db, "linear", 30, final_velocity=True)
    assert today.n_parameters == 6 * 30 + 1 + 12
    # tau, goal and start are the demos' own either way; only the shape and the twist differ
    np.testing.assert_array_equal(today.parameters([1.0])[6 * 30:], moving.parameters([1.0])[6 * 30:-6])
    assert not np.any(today.predict([1.0]).final_velocity)
    with pytest.raises(InvalidInputError, match="final_velocity"):
        dmprs.Generalizer(db, "linear", 30, final_velocity=True, periodic=True)
