"""dmprs.stepper against independent truth: the offline rollout (sample for sample, bit for bit),
the rollout at a finer step (sub-steps), the limits it must meet, a goal change, a sphere on the
path, and the invariants of the online clock.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

import dmprs
from dmprs.stepper import CartesianStepper, JointStepper
from tests.conftest import min_jerk


def reach(n_dof: int = 3, tau: float = 1.0) -> dmprs.DMP:
    t = np.linspace(0.0, tau, 500)
    s = min_jerk(t / tau)
    y = np.stack([(1.0 + 0.5 * d) * s + 0.3 * np.sin(np.pi * t / tau) ** 2 for d in range(n_dof)], axis=1)
    return dmprs.DMP.fit(t, y, 30)


def pose_reach() -> dmprs.CartesianDMP:
    t = np.linspace(0.0, 1.0, 500)
    a = min_jerk(t)
    q = Rotation.from_rotvec(np.outer(0.2 + 1.2 * a, [0.3, 0.5, 0.8])).as_quat(scalar_first=True)
    p = np.stack([0.4 * a, 0.1 * np.sin(np.pi * a), 0.05 * a], axis=1)
    return dmprs.CartesianDMP.fit(t, np.hstack([p, q]), 30)


def run(stepper, samples: int) -> list[np.ndarray]:
    out: list[list[np.ndarray]] = [[], [], []]
    for _ in range(samples):
        for k, a in enumerate(stepper.step()):
            out[k].append(a.copy())
    return [np.array(o) for o in out]


def test_a_joint_stepper_is_the_rollout() -> None:
    dmp = reach()
    tr = dmp.rollout(0.001)
    y, yd, ydd = run(dmp.stepper(0.001), tr.n_samples)
    np.testing.assert_array_equal(y, tr.y)
    np.testing.assert_array_equal(yd, tr.yd)
    np.testing.assert_array_equal(ydd, tr.ydd)


def test_a_cartesian_stepper_is_the_rollout() -> None:
    dmp = pose_reach()
    tr = dmp.rollout(0.002)
    pose, v, a = run(dmp.stepper(0.002), tr.n_samples)
    np.testing.assert_array_equal(pose, tr.pose)
    np.testing.assert_array_equal(v, np.hstack([tr.velocity, tr.angular_velocity]))
    np.testing.assert_array_equal(a, np.hstack([tr.acceleration, tr.angular_acceleration]))


@settings(max_examples=25, deadline=None)
@given(
    w=st.lists(st.floats(-300, 300), min_size=40, max_size=40),
    goal=st.lists(st.floats(-2, 2), min_size=2, max_size=2),
    tau=st.floats(0.05, 2.0),
    dt=st.sampled_from([0.001, 0.004, 0.01]),
)
def test_random_dmps_step_as_they_roll_out_also_when_sub_stepped(w, goal, tau, dt) -> None:
    dmp = dmprs.DMP(np.reshape(w, (2, 20)), goal, [0.2, -0.3], tau)
    tr = dmp.rollout(dt)
    stepper = dmp.stepper(dt)
    y, yd, ydd = run(stepper, tr.n_samples)
    np.testing.assert_array_equal(y, tr.y)
    np.testing.assert_array_equal(yd, tr.yd)
    np.testing.assert_array_equal(ydd, tr.ydd)


@settings(max_examples=15, deadline=None)
@given(k=st.integers(2, 5), tau=st.floats(0.3, 2.0), turn=st.floats(-2.5, 2.5))
def test_cartesian_sub_steps_are_the_rollout_at_a_finer_step(k, tau, turn) -> None:
    dmp = pose_reach().with_tau(tau)
    goal = dmp.goal.copy()
    goal[3:] = Rotation.from_rotvec([0.0, 0.0, turn]).as_quat(scalar_first=True)
    dmp = dmp.with_goal(goal)
    fine = dmp.rollout(0.004 / k)
    stepper = dmp.stepper(0.004, substeps=k)
    pose, v, _ = run(stepper, (fine.n_samples - 1) // k + 1)
    np.testing.assert_allclose(pose, fine.pose[::k], rtol=0, atol=1e-12)
    np.testing.assert_allclose(v[:, 3:], fine.angular_velocity[::k], rtol=0, atol=1e-12)


def test_a_perfectly_tracking_robot_does_not_slow_the_clock() -> None:
    dmp = reach()
    tr = dmp.rollout(0.001)
    stepper = dmp.stepper(0.001)
    measured = dmp.start.copy()
    ys = []
    for _ in range(tr.n_samples):
        y, _, _ = stepper.step(measured)
        measured = y.copy()
        ys.append(measured)
    np.testing.assert_array_equal(np.array(ys), run(dmp.stepper(0.001), tr.n_samples)[0])


def test_velocity_limits_are_never_exceeded_and_the_path_is_kept() -> None:
    dmp = reach(2)
    free = dmp.rollout(0.001, until_rest=True)
    v_max = np.abs(free.yd).max(axis=0) / 1.5
    stepper = dmp.stepper(0.001, velocity_max=v_max)
    ys, phases, yds = [], [], []
    while not stepper.done():
        y, yd, _ = stepper.step()
        ys.append(y.copy())
        yds.append(yd.copy())
        phases.append(stepper.phase)
        assert stepper.steps < 20_000
    yds = np.array(yds)
    assert (np.abs(yds) <= v_max * (1 + 1e-12)).all()
    # Slower: the phase that the free movement reaches at t = tau comes more than 20 % later.
    assert np.argmax(np.array(phases) <= np.exp(-dmp.alpha_x)) * 0.001 > 1.2 * dmp.tau
    # The path as a function of the phase: the rollout's positions at the stepper's phases.
    free_phase = np.exp(-dmp.alpha_x * free.t / dmp.tau)
    ys = np.array(ys)
    for d in range(2):
        along = np.interp(np.array(phases)[::-1], free_phase[::-1], free.y[::-1, d])[::-1]
        assert np.abs(along - ys[:, d]).max() < 2e-3


def test_acceleration_limits_are_met() -> None:
    dmp = reach(2)
    free = dmp.rollout(0.001)
    a_max = np.abs(free.ydd).max(axis=0) / 1.5
    stepper = dmp.stepper(0.001, acceleration_max=a_max)
    worst = 0.0
    while not stepper.done():
        _, _, ydd = stepper.step()
        worst = max(worst, float((np.abs(ydd) / a_max).max()))
    assert worst <= 1 + 1e-9


def test_a_new_goal_is_reached() -> None:
    dmp = reach(2)
    stepper = dmp.stepper(0.001)
    for _ in range(300):
        stepper.step()
    stepper.set_goal([0.5, 2.5])
    while not stepper.done():
        y, _, _ = stepper.step()
        assert stepper.steps < 20_000
    np.testing.assert_allclose(y, [0.5, 2.5], atol=1e-4)
    np.testing.assert_array_equal(stepper.goal, [0.5, 2.5])


def test_a_new_goal_pose_is_reached_along_the_geodesic() -> None:
    dmp = pose_reach()
    stepper = dmp.stepper(0.001)
    for _ in range(300):
        stepper.step()
    goal = np.array([0.2, -0.1, 0.3, *Rotation.from_rotvec([0.0, 1.0, 0.5]).as_quat(scalar_first=True)])
    flipped = goal.copy()
    flipped[3:] *= -1  # the same rotation: must not turn the long way round
    stepper.set_goal(flipped)
    turned = 0.0
    last = None
    while not stepper.done():
        pose, _, _ = stepper.step()
        q = Rotation.from_quat(np.array(pose[3:]), scalar_first=True)
        turned += 0.0 if last is None else (q * last.inv()).magnitude()
        last = q
        assert stepper.steps < 20_000
    np.testing.assert_allclose(pose[:3], goal[:3], atol=1e-4)
    assert turned < np.pi
    angle = (Rotation.from_quat(np.array(pose[3:]), scalar_first=True) * Rotation.from_quat(goal[3:], scalar_first=True).inv()).magnitude()
    assert angle < 1e-4


def test_a_sphere_on_the_path_keeps_its_clearance() -> None:
    dmp = pose_reach()
    free = dmp.rollout(0.001)
    center = free.position[free.n_samples // 3]
    stepper = dmp.stepper(0.001, obstacles=[[*center, 0.04]])
    clearance = np.inf
    while not stepper.done():
        pose, _, _ = stepper.step()
        clearance = min(clearance, np.linalg.norm(pose[:3] - center) - 0.04)
        assert stepper.steps < 20_000
    assert clearance > 0
    np.testing.assert_allclose(pose[:3], dmp.goal[:3], atol=1e-4)
    np.testing.assert_array_equal(stepper.obstacles, [[*center, 0.04]])


def test_position_limits_keep_a_crossing_path_inside() -> None:
    dmp = reach(1)
    free = dmp.rollout(0.001)
    limit = float(dmp.goal[0] + 0.5 * (free.y.max() - dmp.goal[0]))
    stepper = dmp.stepper(0.001, position_min=-1.0, position_max=limit, limit_margin=0.02)
    highest = -np.inf
    while not stepper.done():
        y, _, _ = stepper.step()
        highest = max(highest, float(y[0]))
        assert stepper.steps < 20_000
    assert free.y.max() > limit > highest


def test_the_outputs_are_read_only_and_overwritten() -> None:
    stepper = reach().stepper(0.001)
    y, _, _ = stepper.step()
    first = y.copy()
    with pytest.raises(ValueError):
        y[0] = 1.0
    stepper.step()
    stepper.step()
    assert not np.array_equal(y, first)
    assert stepper.output[0] is y


@pytest.mark.parametrize(
    ("options", "name"),
    [
        ({"dt": 0.0}, "dt"),
        ({"dt": "0.001"}, "dt"),
        ({"substeps": 0}, "substeps"),
        ({"alpha_e": -1.0}, "alpha_e"),
        ({"alpha_e": [1.0, 2.0]}, "alpha_e"),
        ({"goal_filter": 0.0}, "goal_filter"),
        ({"velocity_max": [1.0, -1.0, 1.0]}, "velocity_max"),
        ({"velocity_max": np.nan}, "velocity_max"),
        ({"acceleration_max": [1.0, 1.0]}, "acceleration_max"),
        ({"position_min": [0.0, 0.0, 0.0], "position_max": [1.0, -1.0, 1.0]}, "position_min"),
        ({"position_min": -5.0, "position_max": 5.0, "limit_margin": 6.0}, "limit_margin"),
        ({"position_min": 0.5, "position_max": 5.0}, "start"),
        ({"rest_tol": -1.0}, "rest_tol"),
    ],
)
def test_bad_options_name_the_argument(options, name) -> None:
    dmp = reach()
    dt = options.pop("dt", 0.001)
    with pytest.raises(dmprs.InvalidInputError, match=name):
        JointStepper(dmp, dt, **options)


def test_bad_step_inputs_name_the_argument() -> None:
    stepper = reach().stepper(0.001)
    with pytest.raises(dmprs.InvalidInputError, match="measured"):
        stepper.step([0.0, 0.0])
    with pytest.raises(dmprs.InvalidInputError, match="measured"):
        stepper.step(np.array([0.0, np.nan, 0.0]))
    with pytest.raises(dmprs.InvalidInputError, match="coupling"):
        stepper.step(None, "abc")
    with pytest.raises(dmprs.InvalidInputError, match="goal"):
        stepper.set_goal([1.0])
    with pytest.raises(dmprs.InvalidInputError, match="tau"):
        stepper.set_tau(-1.0)
    with pytest.raises(dmprs.InvalidInputError, match="dmp"):
        JointStepper(pose_reach(), 0.001)
    cartesian = pose_reach().stepper(0.001)
    with pytest.raises(dmprs.InvalidInputError, match="measured"):
        cartesian.step([0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0])
    with pytest.raises(dmprs.InvalidInputError, match="obstacles"):
        CartesianStepper(pose_reach(), 0.001, obstacles=[[0.0, 0.0, 0.0]])
    with pytest.raises(dmprs.InvalidInputError, match="obstacles"):
        cartesian.set_obstacles([[0.0, 0.0, 0.0, -1.0]])


@settings(max_examples=20, deadline=None)
@given(
    held=st.integers(0, 400),
    offset=st.floats(-0.5, 0.5),
    v_scale=st.floats(1.1, 3.0),
)
def test_the_clock_only_ever_slows(held, offset, v_scale) -> None:
    """Invariants under any measurement and limit: the phase decreases and stays in (0, 1], the
    time scale never drops below the nominal tau, and velocities stay within their limits.
    """
    dmp = reach(2)
    v_max = np.abs(dmp.rollout(0.001).yd).max(axis=0) / v_scale
    stepper = dmp.stepper(0.001, velocity_max=v_max)
    last_phase = 1.0
    for k in range(800):
        measured = stepper.output[0] + (offset if held <= k < held + 200 else 0.0)
        _, yd, _ = stepper.step(measured)
        assert 0.0 < stepper.phase <= last_phase
        assert stepper.tau >= dmp.tau
        assert (np.abs(yd) <= v_max * (1 + 1e-12)).all()
        last_phase = stepper.phase


def test_a_constant_coupling_term_shifts_the_rest_point_by_c_over_the_spring() -> None:
    """At rest eq. 1 with a coupling C reads alpha_z beta_z (g - y) + C = 0: y = g + C / (alpha_z
    beta_z), for a joint DMP and the position and orientation of a Cartesian one.
    """
    dmp = reach(2)
    stepper = dmp.stepper(0.001)
    c = np.array([5.76, -2.88])
    for _ in range(8000):
        y, _, _ = stepper.step(None, c)
    np.testing.assert_allclose(y, dmp.goal + c / (dmp.alpha_z * dmp.beta_z), atol=1e-6)
    cartesian = pose_reach().stepper(0.001)
    c6 = np.array([0.576, 0.0, -0.288, 0.0, 0.0, 0.576])
    for _ in range(8000):
        pose, _, _ = cartesian.step(None, c6)
    goal = cartesian.goal
    np.testing.assert_allclose(pose[:3], goal[:3] + c6[:3] / 576.0, atol=1e-6)
    turn = Rotation.from_quat(np.array(pose[3:]), scalar_first=True) * Rotation.from_quat(goal[3:], scalar_first=True).inv()
    np.testing.assert_allclose(turn.as_rotvec(), c6[3:] / 576.0, atol=1e-6)


# --- options and measurements the integration cannot take: refused where they are given ------


def test_a_goal_filter_whose_euler_step_would_overshoot_is_refused_at_construction() -> None:
    dmp = reach(tau=0.5)
    # alpha_g dt / (substeps tau): 150 x 0.004 / 0.5 = 1.2 > 1 overshoots (beyond 2 it diverges)
    with pytest.raises(dmprs.errors.InvalidInputError, match="goal_filter") as err:
        dmp.stepper(0.004, goal_filter=150.0, substeps=1)
    assert "<= 1" in str(err.value)
    dmp.stepper(0.004, goal_filter=100.0, substeps=1)  # 0.8: taken
    dmp.stepper(0.004, goal_filter=150.0, substeps=2)  # 0.6 per sub-step: taken
    s = dmp.stepper(0.004, goal_filter=100.0, substeps=1)
    with pytest.raises(dmprs.errors.InvalidInputError, match="goal_filter"):
        s.set_tau(0.3)  # 100 x 0.004 / 0.3 = 1.33: the same bound at the new tau
    # at the bound itself (240 x 0.002 / 0.5 = 0.96) the goal change is followed and stays finite
    s = dmp.stepper(0.004, goal_filter=240.0, substeps=2)
    s.set_goal(dmp.goal + 1.0)
    y = np.array([s.step()[0].copy() for _ in range(1000)])
    assert np.isfinite(y).all()
    np.testing.assert_allclose(y[-1], dmp.goal + 1.0, atol=1e-3)


def test_gamma_a_zero_is_off_with_an_acceleration_limit() -> None:
    dmp = reach()
    s = dmp.stepper(0.001, acceleration_max=20.0, gamma_a=0.0)
    y, _, ydd = run(s, 6000)
    assert np.isfinite(y).all() and np.isfinite(ydd).all()
    np.testing.assert_allclose(y[-1], dmp.goal, atol=1e-3)


def test_a_measurement_the_stepper_cannot_use_is_refused_at_that_call_and_changes_nothing() -> None:
    dmp = reach()
    s, ref = dmp.stepper(0.001), dmp.stepper(0.001)
    for _ in range(10):
        s.step()
        ref.step()
    with pytest.raises(dmprs.errors.InvalidInputError, match="measured"):
        s.step(measured=[1e154, 0.0, 0.0])
    for bad in (np.array([0.1 + 1j, 0.0, 0.0]), np.array([True, False, True]), [[0.0, 0.0, 0.0]], "abc"):
        with pytest.raises(dmprs.errors.InvalidInputError, match="measured"):
            s.step(measured=bad)
    # the stepper is as it was: the next step is the undisturbed one's
    for a, b in zip(s.step(), ref.step(), strict=True):
        np.testing.assert_array_equal(a, b)


def test_a_one_element_limit_is_not_spread_over_the_coordinates() -> None:
    with pytest.raises(dmprs.errors.InvalidInputError, match=r"acceleration_max has shape \(1,\)"):
        reach(3).stepper(0.001, acceleration_max=[1.0])
    reach(3).stepper(0.001, acceleration_max=1.0)  # a scalar is every coordinate's
