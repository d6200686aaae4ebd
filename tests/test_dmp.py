"""The DMP API against independent truth: closed-form solutions, numpy, symmetries."""

import json
import pickle

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

import dmprs


def spring(y0: float, g: float, tau: float, t: np.ndarray, alpha_z: float = 48.0) -> np.ndarray:
    """Eqs. 1-2 with w = 0 and beta_z = alpha_z/4: a critically damped spring from rest."""
    omega = alpha_z / (2 * tau)
    return g + (y0 - g) * (1 + omega * t) * np.exp(-omega * t)


def test_zero_weights_give_the_closed_form_spring_and_euler_error_shrinks_with_dt():
    dmp = dmprs.DMP(np.zeros((1, 25)), [2.0], [-1.0], 1.5)
    errors = []
    for dt in (1e-3, 1e-4):
        tr = dmp.rollout(dt=dt)
        errors.append(np.abs(tr.y[:, 0] - spring(-1.0, 2.0, 1.5, tr.t)).max())
    assert errors[0] < 0.02
    assert 7 < errors[0] / errors[1] < 13  # explicit Euler: first order


def test_fit_then_rollout_reproduces_the_demo_within_one_percent(demo):
    t, y = demo
    dmp = dmprs.DMP.fit(t, y, n_basis=25)
    tr = dmp.rollout(dt=0.001)
    assert tr.y.shape == y.shape
    np.testing.assert_array_equal(tr.t, np.arange(1001) * 0.001)
    err = np.abs(tr.y - y).max(axis=0) / np.ptp(y, axis=0)
    assert (err < 0.01).all(), err
    assert dmp.tau == 1.0
    np.testing.assert_array_equal(dmp.goal, y[-1])
    np.testing.assert_array_equal(dmp.start, y[0])


def test_fit_without_derivatives_equals_fit_with_numpy_gradient(demo):
    # The documented scheme is numpy.gradient(..., edge_order=2) applied twice: an independent check.
    t = np.sort(np.random.default_rng(0).uniform(0, 1, 400))
    y = np.stack([np.sin(3 * t), t**3], axis=1)
    yd = np.gradient(y, t, axis=0, edge_order=2)
    ydd = np.gradient(yd, t, axis=0, edge_order=2)
    a = dmprs.DMP.fit(t, y, 20)
    b = dmprs.DMP.fit(t, y, 20, yd=yd, ydd=ydd)
    np.testing.assert_allclose(a.weights, b.weights, rtol=1e-9, atol=1e-9 * np.abs(b.weights).max())


def test_one_dimensional_y_is_one_dof(demo):
    t, y = demo
    dmp = dmprs.DMP.fit(t, y[:, 0])
    assert dmp.n_dof == 1 and dmp.weights.shape == (1, 25)
    assert dmp.rollout().y.shape == (1001, 1)


def test_weights_are_independent_of_the_demonstration_speed(demo):
    # docs/method.md §2.3: with tau = duration, a time-scaled copy of a demo has identical weights.
    t, y = demo
    a = dmprs.DMP.fit(t, y)
    b = dmprs.DMP.fit(2.5 * t, y)
    assert b.tau == 2.5
    np.testing.assert_allclose(a.weights, b.weights, rtol=1e-9, atol=1e-9)


def test_new_goal_start_and_tau(demo):
    t, y = demo
    dmp = dmprs.DMP.fit(t, y)
    goal = np.array([3.0, -2.0, 1.0])
    tr = dmp.with_goal(goal).rollout(dt=0.001, until_rest=True, rest_tol=1e-6)
    np.testing.assert_allclose(tr.y[-1], goal, atol=1e-6)
    assert tr.duration > dmp.tau
    c = 0.75
    shifted = dmp.with_goal(dmp.goal + c).with_start(dmp.start + c).rollout()
    np.testing.assert_allclose(shifted.y, dmp.rollout().y + c, atol=1e-12)
    slow = dmp.with_tau(2.0).rollout(dt=0.002)
    np.testing.assert_allclose(slow.y, dmp.rollout(dt=0.001).y, atol=1e-10)
    np.testing.assert_allclose(slow.t, 2 * dmp.rollout(dt=0.001).t, atol=1e-12)
    assert dmp.tau == 1.0  # the original is unchanged


def test_rollout_duration_rounds_up_to_a_whole_step(demo):
    t, y = demo
    dmp = dmprs.DMP.fit(t, y)
    assert dmp.rollout(dt=0.01, duration=0.5).n_samples == 51
    assert dmp.rollout(dt=0.01, duration=0.505).t[-1] == pytest.approx(0.51)


def test_repeat_runs_are_bit_identical(demo):
    t, y = demo
    a = dmprs.DMP.fit(t, y, 30)
    b = dmprs.DMP.fit(t.copy(), y.copy(), 30)
    np.testing.assert_array_equal(a.weights, b.weights)
    assert a.rollout() == b.rollout()


def test_rollout_batch_equals_one_by_one(demo):
    t, y = demo
    base = dmprs.DMP.fit(t, y)
    dmps = [base.with_tau(0.5 + 0.01 * k).with_goal(base.goal + 0.01 * k) for k in range(100)]
    batch = dmprs.rollout_batch(dmps, dt=0.002)
    assert len(batch) == 100
    for d, tr in zip(dmps, batch, strict=True):
        assert tr == d.rollout(dt=0.002)


def test_dict_round_trip_is_exact_through_json_and_pickle(demo):
    t, y = demo
    dmp = dmprs.DMP.fit(t, y, 17, alpha_z=30.0, alpha_x=3.0, width_factor=1.0)
    again = dmprs.DMP.from_dict(json.loads(json.dumps(dmp.to_dict())))
    assert again == dmp
    np.testing.assert_array_equal(again.weights, dmp.weights)
    assert again.rollout() == dmp.rollout()
    assert pickle.loads(pickle.dumps(dmp)) == dmp


@settings(max_examples=40, deadline=None)
@given(
    w=arrays(np.float64, (2, 6), elements=st.floats(-1e6, 1e6)),
    g=arrays(np.float64, 2, elements=st.floats(-1e3, 1e3)),
    tau=st.floats(1e-3, 1e3),
)
def test_dict_round_trip_property(w, g, tau):
    dmp = dmprs.DMP(w, g, -g, tau)
    assert dmprs.DMP.from_dict(json.loads(json.dumps(dmp.to_dict()))) == dmp


def test_trajectory_arrays_are_read_only_copies():
    t = np.linspace(0, 1, 5)
    y = np.zeros(5)
    tr = dmprs.Trajectory(t, y)
    t[0] = -1.0
    assert tr.t[0] == 0.0
    with pytest.raises(ValueError):
        tr.y[0, 0] = 1.0
    assert tr.n_dof == 1 and tr.duration == 1.0 and len(tr) == 5


def test_dmp_is_immutable(demo):
    dmp = dmprs.DMP.fit(*demo)
    with pytest.raises(AttributeError):
        dmp.tau = 3.0  # type: ignore[misc]


def test_integer_inputs_are_converted(demo):
    t = np.arange(0, 101)  # integers
    y = (t**2).astype(np.int32)
    dmp = dmprs.DMP.fit(t, y, 10)
    assert dmp.tau == 100.0 and dmp.goal[0] == 10000.0


# --- via-points ----------------------------------------------------------------------------------

def _least_norm_via_points(dmp, times, positions, dt):
    """The least-norm weight change by numpy, from rollouts through the public API: the rollout
    is linear in the weights, so each weight's impulse response is a rollout of that weight alone.
    """
    k = np.rint(np.asarray(times) / dt).astype(int)
    duration = k.max() * dt
    base = dmp.rollout(dt, duration).y[k]
    jac = np.empty((len(k), dmp.n_basis))
    for i in range(dmp.n_basis):
        unit = dmprs.DMP(np.eye(dmp.n_basis)[i : i + 1], [0.0], [0.0], dmp.tau)
        jac[:, i] = unit.rollout(dt, duration).y[k, 0]
    dw, *_ = np.linalg.lstsq(jac, np.asarray(positions) - base, rcond=None)  # least norm
    return dmp.weights + dw.T


def test_via_points_are_met_with_the_least_change_of_the_weights(demo):
    t, y = demo
    dmp = dmprs.DMP.fit(t, y, n_basis=25)
    times = [0.25, 0.6]
    positions = dmp.rollout(0.001).y[[250, 600]] + np.array([[0.05, -0.1, 0.0, 0.2, 0.1, 0.0, -0.05][: dmp.n_dof],
                                                                [-0.1, 0.0, 0.1, 0.0, 0.05, 0.1, 0.0][: dmp.n_dof]])
    moved = dmp.with_via_points(times, positions)
    tr = moved.rollout(0.001)
    np.testing.assert_allclose(tr.y[[250, 600]], positions, atol=1e-9)
    np.testing.assert_allclose(moved.weights, _least_norm_via_points(dmp, times, positions, 0.001),
                               rtol=1e-8, atol=1e-8 * np.abs(moved.weights).max())
    # at a finer step the via-points are met to the integrator's order
    fine = moved.rollout(0.0001)
    assert np.abs(fine.y[[2500, 6000]] - positions).max() < 0.01 * np.ptp(y)
    # a via-point on the rollout itself leaves the weights as they are, bit for bit
    assert dmp.with_via_points([0.4], dmp.rollout(0.001).y[[400]]) == dmp


def test_via_points_that_cannot_be_met_are_refused_by_name():
    dmp = dmprs.DMP(np.ones((1, 10)), [1.0], [0.0], 1.0)
    with pytest.raises(dmprs.InvalidInputError, match="times"):
        dmp.with_via_points([0.0], [0.5])
    with pytest.raises(dmprs.InvalidInputError, match="times"):
        dmp.with_via_points([0.5, 0.5001], [0.5, 0.6])
    with pytest.raises(dmprs.InvalidInputError, match="positions"):
        dmp.with_via_points([0.5], [[0.5, 0.6]])
    with pytest.raises(dmprs.InvalidInputError, match="positions"):
        dmp.with_via_points([0.5], [np.nan])
