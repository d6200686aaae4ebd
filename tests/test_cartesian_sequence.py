"""dmprs.Sequence of Cartesian DMPs against independent truth: the CartesianDMP itself (a sequence
of one), the orientation DMP at a join (the acceleration an unaided start would jump to, from
the DMP's own rollout), the integrator's own relations across every join (Euler in position and
velocity, ``q <- exp(dt/2 omega) q``) and the order in dt of what is left, each DMP's own rollout
(where each movement ends), a rotation about one axis against the joint sequence on its angle,
the stepper against the rollout, and the refusals.
"""

from __future__ import annotations

import copy

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import dmprs
from dmprs.sequence import CartesianSequenceStepper, Sequence
from tests.conftest import min_jerk
from tests.test_cartesian import angle_between, rot
from tests.test_stepper import run

#: positions and rotation vectors of a reach, pour and return
POSITIONS = np.array([[0.0, 0.5, -0.2], [0.6, -0.3, 0.4], [0.2, 0.4, 0.6], [-0.3, 0.1, 0.3]])
ROTVECS = np.array([[0.0, 0.0, 0.2], [0.4, 0.2, 0.9], [-0.6, 0.8, 0.1], [0.0, 0.1, 0.4]])
TAUS = (0.6, 0.45, 0.8)
DT = 0.001


def leg(k: int, axis_only: bool = False) -> dmprs.CartesianDMP:
    """A Cartesian DMP fitted to a min-jerk move from pose ``k`` to ``k + 1`` with a bump in
    position and orientation (at rest at both ends); ``axis_only``: a rotation about z only.
    """
    tau = TAUS[k]
    t = np.linspace(0.0, tau, 600)
    s = t / tau
    bump = np.sin(np.pi * s) ** 2
    p = POSITIONS[k] + np.outer(min_jerk(s), POSITIONS[k + 1] - POSITIONS[k]) + 0.2 * np.outer(bump, [1.0, -1.0, 0.5])
    if axis_only:
        theta = ROTVECS[k, 2] + min_jerk(s) * (ROTVECS[k + 1, 2] - ROTVECS[k, 2]) + 0.3 * bump
        q = Rotation.from_rotvec(np.outer(theta, [0.0, 0.0, 1.0])).as_quat(scalar_first=True)
    else:
        a, b = Rotation.from_rotvec(ROTVECS[k]), Rotation.from_rotvec(ROTVECS[k + 1])
        turn = (b * a.inv()).as_rotvec()
        wobble = Rotation.from_rotvec(np.outer(0.3 * bump, [1.0, 0.0, 0.0]))
        q = (wobble * Rotation.from_rotvec(np.outer(min_jerk(s), turn)) * a).as_quat(scalar_first=True)
    return dmprs.CartesianDMP.fit(t, np.hstack([p, q]), 30)


def legs() -> list[dmprs.CartesianDMP]:
    return [leg(k) for k in range(3)]


def joins(dt: float) -> list[int]:
    """The samples at which movements 1 and 2 start: their taus in whole steps."""
    return list(np.cumsum([round(t / dt) for t in TAUS[:-1]]))


def test_a_sequence_of_one_is_its_dmp() -> None:
    dmp = leg(1)
    for opts in ({"dt": 0.001}, {"dt": 0.004, "until_rest": True}):
        assert Sequence([dmp]).rollout(**opts) == dmp.rollout(**opts)


def test_it_returns_a_cartesian_trajectory_and_stepper() -> None:
    seq = Sequence(legs())
    assert seq.cartesian and "cartesian=True" in repr(seq)
    tr = seq.rollout(DT)
    assert isinstance(tr, dmprs.CartesianTrajectory)
    assert tr.n_samples == 600 + 450 + 801
    assert type(seq.stepper(DT)) is CartesianSequenceStepper


def test_the_joins_continue_the_integrator() -> None:
    """Position, velocities and the quaternion at a join's first sample are the integrator's
    step from the last sample before it.
    """
    tr = Sequence(legs()).rollout(DT)
    for j in joins(DT):
        p = j - 1
        np.testing.assert_allclose(tr.position[j], tr.position[p] + tr.velocity[p] * DT, rtol=0, atol=1e-12)
        np.testing.assert_allclose(tr.velocity[j], tr.velocity[p] + tr.acceleration[p] * DT, rtol=0, atol=1e-10)
        omega = tr.angular_velocity[p] + tr.angular_acceleration[p] * DT
        np.testing.assert_allclose(tr.angular_velocity[j], omega, rtol=0, atol=1e-10)
        turned = Rotation.from_rotvec(tr.angular_velocity[p] * DT) * rot(tr.quaternion[p])
        assert (turned * rot(tr.quaternion[j]).inv()).magnitude() < 1e-10
        assert tr.quaternion[p] @ tr.quaternion[j] > 0  # no sign flip in the command


def test_the_joins_jumps_are_first_order_in_dt() -> None:
    jumps = []
    for dt in (0.002, 0.001, 0.0005):
        tr = Sequence(legs()).rollout(dt)
        jumps.append([np.abs(a[j] - a[j - 1]).max() for j in joins(dt)
                      for a in (tr.acceleration, tr.angular_acceleration)])
    ratios = np.array(jumps[:-1]) / np.array(jumps[1:])
    assert ((ratios > 1.7) & (ratios < 2.3)).all(), ratios


def test_an_unaided_start_would_jump_in_both_accelerations() -> None:
    """Started at the join without the term, a movement would command its DMP's first
    acceleration from rest at that pose minus the damping of the velocity it has:
    ``a_rest - alpha_z v / tau`` (eqs. 1 and the orientation's).
    """
    dmps = legs()
    tr = Sequence(dmps).rollout(DT)
    for k, j in enumerate(joins(DT), start=1):
        dmp = dmps[k]
        start = np.concatenate([tr.position[j], tr.quaternion[j]])
        rest = dmp.with_start(start).rollout(DT, 2 * DT)
        alpha_z = 48.0
        unaided = np.concatenate([rest.acceleration[0] - alpha_z * tr.velocity[j] / dmp.tau,
                                  rest.angular_acceleration[0] - alpha_z * tr.angular_velocity[j] / dmp.tau])
        before = np.concatenate([tr.acceleration[j - 1], tr.angular_acceleration[j - 1]])
        joined = np.concatenate([tr.acceleration[j], tr.angular_acceleration[j]])
        # The joined jump is of the order of the movement's own change over one step (first
        # order in dt, tested above); the unaided one is not.
        assert np.abs(unaided - before).max() > 5 * np.abs(joined - before).max()


def test_each_movement_ends_where_its_dmp_takes_it_and_the_last_at_its_goal() -> None:
    dmps = legs()
    tr = Sequence(dmps).rollout(DT, until_rest=True)
    at = joins(DT)
    ends = [at[1] - 1, 600 + 450 + 800]
    for k, (j0, end) in enumerate(zip(at, ends, strict=True), start=1):
        start = np.concatenate([tr.position[j0], tr.quaternion[j0]])
        own = dmps[k].with_start(start).rollout(DT)
        np.testing.assert_allclose(tr.position[end], own.position[end - j0], rtol=0, atol=1e-6)
        assert angle_between(tr.quaternion[end], own.quaternion[end - j0]) < 1e-6
    np.testing.assert_allclose(tr.position[-1], dmps[-1].goal[:3], rtol=0, atol=1e-4)
    assert angle_between(tr.quaternion[-1], dmps[-1].goal[3:]) < 1e-4
    np.testing.assert_allclose(np.linalg.norm(tr.quaternion, axis=1), 1.0, rtol=0, atol=1e-12)


def test_a_rotation_about_one_axis_is_the_joint_sequence_on_its_angle() -> None:
    """About z only, the orientation DMP is the discrete DMP of the angle (docs/cartesian.md):
    the Cartesian sequence's angle is the joint sequence's, joins and all.
    """
    cart = [leg(k, axis_only=True) for k in range(3)]
    joint = [dmprs.DMP(d.weights[[0, 1, 2, 5]], np.append(d.goal[:3], 2 * np.arctan2(d.goal[6], d.goal[3])),
                       np.append(d.start[:3], 2 * np.arctan2(d.start[6], d.start[3])), d.tau) for d in cart]
    np.testing.assert_array_equal(np.array([d.weights[3:5] for d in cart]), 0.0)
    c, j = Sequence(cart).rollout(DT), Sequence(joint).rollout(DT)
    theta = 2 * np.arctan2(c.quaternion[:, 3], c.quaternion[:, 0])
    np.testing.assert_allclose(theta, j.y[:, 3], rtol=0, atol=1e-9)
    np.testing.assert_allclose(c.angular_velocity[:, 2], j.yd[:, 3], rtol=0, atol=1e-7)
    np.testing.assert_allclose(c.angular_acceleration[:, 2], j.ydd[:, 3], rtol=1e-6, atol=1e-5)
    np.testing.assert_allclose(c.position, j.y[:, :3], rtol=0, atol=1e-12)


# --- the stepper ----------------------------------------------------------------------------------

def test_the_stepper_is_the_rollout_bit_for_bit() -> None:
    seq = Sequence(legs())
    tr = seq.rollout(DT)
    pose, v, a = run(seq.stepper(DT), tr.n_samples)
    assert np.array_equal(pose[:, :3], tr.position) and np.array_equal(pose[:, 3:], tr.quaternion)
    assert np.array_equal(v[:, :3], tr.velocity) and np.array_equal(v[:, 3:], tr.angular_velocity)
    assert np.array_equal(a[:, :3], tr.acceleration) and np.array_equal(a[:, 3:], tr.angular_acceleration)


def test_a_copy_steps_on_as_the_original_across_a_join_and_reset_repeats() -> None:
    stepper = Sequence(legs()).stepper(DT)
    run(stepper, 500)
    twin = copy.deepcopy(stepper)
    assert type(twin) is CartesianSequenceStepper
    a, b = run(stepper, 400), run(twin, 400)
    assert all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))
    assert stepper.active == twin.active == 1
    stepper.reset()
    first = run(stepper, 1200)
    stepper.reset()
    assert all(np.array_equal(x, y) for x, y in zip(first, run(stepper, 1200), strict=True))


def test_a_held_robot_delays_the_hand_over() -> None:
    stepper = Sequence(legs()).stepper(DT)
    held = None
    for k in range(20_000):
        if k == 300:
            held = stepper.output[0].copy()
        before = stepper.active
        stepper.step(held if 300 <= k < 700 else None)
        if stepper.active != before and before == 0:
            assert k > 700
        if stepper.done():
            break
    assert stepper.done() and stepper.active == 2
    np.testing.assert_allclose(stepper.output[0][:3], POSITIONS[-1], atol=1e-3)


def test_it_has_the_cartesian_steppers_surface() -> None:
    public = {name for name in dir(dmprs.CartesianStepper) if not name.startswith("_")}
    assert public - {"set_obstacles"} <= set(dir(CartesianSequenceStepper))
    assert "active" in dir(CartesianSequenceStepper)


def test_determinism() -> None:
    assert Sequence(legs()).rollout(DT) == Sequence(legs()).rollout(DT)


# --- refusals -------------------------------------------------------------------------------------

def test_bad_input_is_refused_by_name() -> None:
    dmps = legs()
    joint = dmprs.DMP.fit(np.linspace(0, 1, 50), np.linspace(0, 1, 50), 10)
    cases = [
        (lambda: Sequence([dmps[0], joint]), "dmps[1]"),
        (lambda: Sequence([joint, dmps[0]]), "dmps[1]"),
        (lambda: Sequence([dmps[0], "dmp"]), "dmps[1]"),
        (lambda: Sequence(dmps[0]), "dmps"),
        (lambda: Sequence(dmps).rollout(0.0), "dt"),
        (lambda: Sequence(dmps).stepper(DT, velocity_max=1.0), "velocity_max"),
        (lambda: Sequence(dmps).stepper(DT, acceleration_max=[1.0] * 6), "acceleration_max"),
        (lambda: Sequence(dmps).stepper(DT).step(np.zeros(6)), "measured"),
        (lambda: Sequence(dmps).stepper(DT).step(np.array([0, 0, 0, 2.0, 0, 0, 0])), "measured"),
        (lambda: Sequence(dmps).stepper(DT).step(coupling=[np.nan] * 6), "coupling"),
        (lambda: Sequence(dmps).stepper(DT, obstacle_beta=0.5), "obstacle_beta"),
        (lambda: CartesianSequenceStepper(Sequence([joint]), DT), "sequence"),
        (lambda: dmprs.SequenceStepper(Sequence(dmps), DT), "sequence"),  # type: ignore[arg-type]
    ]
    for call, name in cases:
        with pytest.raises(dmprs.InvalidInputError, match=name.replace("[", r"\[")) as info:
            call()
        assert isinstance(info.value, ValueError)


def test_a_sequence_ending_at_a_final_velocity_never_rests_and_one_moving_in_the_middle_hands_over_moving() -> None:
    moving = legs()[0].with_final_velocity([0.2, 0.0, 0.0, 0.0, 0.0, 0.5])
    with pytest.raises(dmprs.InvalidInputError, match="until_rest"):
        Sequence([legs()[1], moving]).rollout(0.001, until_rest=True)
    tr = Sequence([moving, legs()[1]]).rollout(0.001, until_rest=True)
    k = joins(0.001)[0]
    # at the hand-over the first movement's final velocity is the second's starting velocity
    np.testing.assert_allclose(tr.velocity[k], [0.2, 0.0, 0.0], atol=0.02)
    np.testing.assert_allclose(tr.angular_velocity[k], [0.0, 0.0, 0.5], atol=0.03)
