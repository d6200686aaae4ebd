"""What the steppers command a robot, whatever the options: copies that step as the original,
obstacles that cannot push a movement without bound or hold it silently, limits held or
reported, and returned samples consistent with each other (docs/method.md §2.5).
"""

from __future__ import annotations

import copy

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import dmprs
from dmprs import _core
from tests.conftest import min_jerk
from tests.test_stepper import pose_reach, reach


def line(length: float = 0.3) -> dmprs.CartesianDMP:
    """A straight reach along x with a constant orientation."""
    t = np.linspace(0.0, 1.0, 500)
    a = min_jerk(t)
    p = np.stack([length * a, 0.0 * a, 0.0 * a], axis=1)
    q = np.tile([1.0, 0.0, 0.0, 0.0], (len(t), 1))
    return dmprs.CartesianDMP.fit(t, np.hstack([p, q]), 30)


def bits(arrays) -> list[bytes]:
    return [np.asarray(a).tobytes() for a in arrays]


# --- copies ------------------------------------------------------------------------------------


def _busy_joint():
    s = reach().stepper(0.001, velocity_max=2.0, acceleration_max=30.0)
    for k in range(150):
        s.step(s.output[0] - (0.01 if 50 <= k < 80 else 0.0))
    s.set_goal(reach().goal + 0.2)
    return s


def _busy_cartesian():
    s = pose_reach().stepper(0.001, obstacles=[[0.2, 0.05, 0.03, 0.02]], position_min=-1.0, position_max=1.0)
    for _ in range(150):
        s.step(s.output[0])
    return s


@pytest.mark.parametrize("make", [_busy_joint, _busy_cartesian])
@pytest.mark.parametrize("how", [copy.copy, copy.deepcopy])
def test_a_copy_is_an_independent_stepper_that_steps_as_the_original(make, how) -> None:
    original = make()
    twin = how(original)
    assert type(twin) is type(original)
    assert twin is not original and twin.output[0] is not original.output[0]
    assert bits(twin.output) == bits(original.output)
    assert (twin.steps, twin.phase, twin.tau) == (original.steps, original.phase, original.tau)
    # The copy moves on alone: the original is untouched by it ...
    reference = make()
    for _ in range(300):
        twin.step()
    assert bits(original.output) == bits(reference.output)
    # ... and from equal states the two step bit for bit alike.
    twin = how(original)
    for k in range(500):
        measured = original.output[0].copy()
        assert bits(original.step(measured)) == bits(twin.step(measured)), k


def test_the_core_classes_and_containers_copy_too() -> None:
    core = _core.Stepper.__new__(_core.Stepper, _busy_joint())
    assert type(core) is _core.Stepper
    assert bits(copy.deepcopy(core).step()) == bits(core.step())
    held = {"stepper": _busy_cartesian()}
    twin = copy.deepcopy(held)
    assert type(twin["stepper"]) is dmprs.stepper.CartesianStepper
    assert bits(twin["stepper"].step()) == bits(held["stepper"].step())
    with pytest.raises(dmprs.InvalidInputError):
        _core.Stepper.__new__(_core.Stepper, _busy_joint(), 0.001)


# --- obstacles ---------------------------------------------------------------------------------


def test_a_start_or_goal_inside_an_obstacle_is_refused_naming_the_option() -> None:
    dmp = line()
    for sphere in ([0.0, 0.0, 0.0, 0.05], [0.3, 0.0, 0.0, 0.05], [0.3, 0.0, 0.0, 0.0]):
        with pytest.raises(dmprs.InvalidInputError, match=r"^obstacles = obstacles\[0\].*around the (start|goal)"):
            dmp.stepper(0.001, obstacles=[sphere])
    s = dmp.stepper(0.001, obstacles=[[0.15, 0.2, 0.0, 0.05]])
    for _ in range(100):
        s.step()
    with pytest.raises(dmprs.InvalidInputError, match=r"^goal = .*inside obstacles\[0\]"):
        s.set_goal([0.15, 0.21, 0.0, 1.0, 0.0, 0.0, 0.0])
    with pytest.raises(dmprs.InvalidInputError, match=r"^start = .*inside obstacles\[0\]"):
        s.reset([0.15, 0.18, 0.0, 1.0, 0.0, 0.0, 0.0])
    with pytest.raises(dmprs.InvalidInputError, match=r"^obstacles = .*around the current position"):
        s.set_obstacles([[*s.output[0][:3], 0.01]])
    np.testing.assert_array_equal(s.obstacles, [[0.15, 0.2, 0.0, 0.05]])


@settings(max_examples=12, deadline=None)
@given(gain_exp=st.floats(-2.0, 300.0), y_offset=st.floats(-0.02, 0.02), radius=st.floats(0.0, 0.06))
def test_any_obstacle_gain_keeps_the_command_bounded(gain_exp, y_offset, radius) -> None:
    """Any obstacle_gain leaves the command finite, slower than 3 m/s, outside the sphere."""
    # Measured before the bound: 18 m/s at a gain of 1e3, 490 m/s at 1e6, inf at 1e300.
    s = line().stepper(0.001, obstacles=[[0.15, y_offset, 0.0, radius]], obstacle_gain=10.0**gain_exp)
    for _ in range(3000):
        pose, v, a = s.step()
        assert np.isfinite(pose).all() and np.isfinite(v).all() and np.isfinite(a).all()
        assert np.linalg.norm(v[:3]) < 3.0
        assert np.linalg.norm(pose[:3] - [0.15, y_offset, 0.0]) > radius


def test_a_sphere_straight_ahead_is_passed_and_the_goal_reached() -> None:
    """A sphere centred on the straight path (a saddle of the field) is passed on a fixed side."""
    # Before, the movement stopped in front of it for good.
    s = line().stepper(0.001, obstacles=[[0.15, 0.0, 0.0, 0.03]])
    side = 0.0
    while not s.done():
        pose, _, _ = s.step()
        side = max(side, pose[1])
        assert not s.blocked()
        assert s.steps < 10_000, "stopped short"
    assert side > 0.01  # passed on +y, the fixed side
    np.testing.assert_allclose(s.output[0][:3], [0.3, 0.0, 0.0], atol=1e-4)


def test_a_movement_held_away_from_its_goal_says_blocked() -> None:
    s = line().stepper(0.001)
    hold = np.array([-28.8, 0.0, 0.0, 0.0, 0.0, 0.0])  # alpha_z beta_z x 5 cm short
    for _ in range(8000):
        s.step(None, hold)
    assert s.blocked() and not s.done()
    while not s.done():
        s.step()
        assert s.steps < 20_000
    assert not s.blocked()


def test_a_joint_movement_held_short_of_its_goal_says_blocked() -> None:
    dmp = reach()
    limited = dmp.stepper(0.001, position_min=-10.0, position_max=[dmp.goal[0] - 0.1, 10.0, 10.0])
    free = dmp.stepper(0.001)
    for _ in range(10_000):
        limited.step()
        if not free.done():
            free.step()
            assert not free.blocked()
    assert limited.blocked() and not limited.done()
    assert free.done() and not free.blocked()


# --- limits and consistency ----------------------------------------------------------------------


def _consistent(yd, ydd, dt) -> float:
    """The largest |yd[k+1] - yd[k] - ydd[k] dt| relative to max(1, |ydd[k] dt|)."""
    step = ydd[:-1] * dt
    return float((np.abs(yd[1:] - yd[:-1] - step) / np.maximum(1.0, np.abs(step))).max())


def test_phase_stopping_keeps_an_acceleration_limit() -> None:
    """A lag of 0.02 held 0.2 s, one sample 1.0 off: the clock slows within the limit."""
    # Measured before (the phase-stopped scale a floor that won over the limit): |ydd| reached
    # 597 and 1.8e6 times the limit.
    for lag, hold in ((0.02, range(300, 500)), (1.0, range(300, 301))):
        s = reach().stepper(0.001, acceleration_max=2.0)
        yds, ydds = [], []
        for k in range(4000):
            _, yd, ydd = s.step(s.output[0] - (lag if k in hold else 0.0))
            yds.append(yd.copy())
            ydds.append(ydd.copy())
        assert np.abs(ydds).max() <= 2.0 * (1 + 1e-12)
        assert _consistent(np.array(yds), np.array(ydds), 0.001) < 1e-12


@settings(max_examples=25, deadline=None)
@given(
    v_max=st.one_of(st.none(), st.floats(0.3, 5.0)),
    a_max=st.one_of(st.none(), st.floats(0.5, 50.0)),
    lag=st.floats(-0.2, 0.2),
    hold=st.integers(0, 800),
    spike=st.floats(-2.0, 2.0),
    tau=st.floats(0.3, 3.0),
    cartesian=st.booleans(),
)
def test_every_sample_is_finite_within_its_limits_or_reported_and_consistent(
    v_max, a_max, lag, hold, spike, tau, cartesian
) -> None:
    dmp = pose_reach() if cartesian else reach()
    s = dmp.stepper(0.001, velocity_max=v_max, acceleration_max=a_max)
    yds, ydds = [], []
    for k in range(2000):
        if k == 400:
            s.set_tau(tau)
        measured = s.output[0].copy()
        off = lag if hold <= k < hold + 150 else spike if k == 900 else 0.0
        measured[:3] -= off
        if cartesian:
            measured[3:] = s.output[0][3:]
        y, yd, ydd = s.step(measured)
        assert np.isfinite(y).all() and np.isfinite(yd).all() and np.isfinite(ydd).all()
        if v_max is not None:
            assert (np.abs(yd) <= v_max * (1 + 1e-12)).all()
        over = a_max is not None and bool((np.abs(ydd) > a_max * (1 + 1e-12)).any())
        assert s.over_limit() == over
        yds.append(yd.copy())
        ydds.append(ydd.copy())
    assert _consistent(np.array(yds), np.array(ydds), 0.001) < 1e-12
