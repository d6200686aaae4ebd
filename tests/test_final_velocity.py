"""A DMP that reaches its goal with a final velocity (docs/method.md §2.8), against independent
truth: the request itself at t = tau (met to rounding by the spring alone, to the integrator's
first order, shown by halving dt, by a fitted shape), a
demonstration ending in motion known in closed form, today's DMP bit for bit at zero, the
rollout for the stepper, and movement_primitives' DMPWithFinalVelocity on the same demonstration.
"""

from __future__ import annotations

import pickle

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import dmprs
from dmprs.errors import InvalidInputError

T_DEMO, V_END = 1.2, 0.9


def moving_demo(n: int = 1201) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Min-jerk from rest at 0 to 1 plus ``v T (s^5 - s^4)``, ``s = t / T``: still ending at 1,
    now at velocity ``v`` (closed form). Returns t, y (T, 2) and the end velocity per DOF.
    """
    t = np.linspace(0.0, T_DEMO, n)
    s = t / T_DEMO
    v = np.array([V_END, 0.4])
    base, moving = 10 * s**3 - 15 * s**4 + 6 * s**5, T_DEMO * (s**5 - s**4)
    y = np.stack([base + v[0] * moving, 0.3 - base + v[1] * moving], axis=1)
    return t, y, v


def spring_only(final_velocity, tau: float = 0.8) -> dmprs.DMP:
    """No forcing term: the spring alone tracks the moving goal (its transient from rest,
    (1 + a) e^-a with a = alpha_z / 2 = 24, is below 1e-9 at tau).
    """
    v = np.atleast_1d(final_velocity)
    return dmprs.DMP(np.zeros((v.size, 25)), np.linspace(1.0, -0.5, v.size), np.zeros(v.size), tau,
                     final_velocity=v)


def final_errors(dmp: dmprs.DMP, dt: float) -> tuple[float, float]:
    tr = dmp.rollout(dt)
    return (float(np.max(np.abs(tr.y[-1] - dmp.goal))),
            float(np.max(np.abs(tr.yd[-1] - dmp.final_velocity))))


def test_the_spring_alone_meets_the_request_at_any_dt():
    """Euler tracks a ramp whose velocity is fed forward exactly, and the moving goal's time is
    the integrator's own (from its phase), so the request is met to rounding.
    """
    dmp = spring_only([0.8, -1.5])
    for dt in (0.001, 0.004, 0.02):  # 0.02 s takes the rollout's sub-steps
        position, velocity = final_errors(dmp, dt)
        assert position < 1e-8 and velocity < 1e-7


def test_a_fitted_demonstration_ending_in_motion_is_reproduced():
    t, y, v = moving_demo()
    dmp = dmprs.DMP.fit(t, y, 40, final_velocity=v)
    np.testing.assert_array_equal(dmp.final_velocity, v)
    tr = dmp.rollout(0.001)
    assert np.max(np.abs(tr.y - y)) < 2e-3
    assert np.max(np.abs(tr.y[-1] - y[-1])) < 2e-3
    assert np.max(np.abs(tr.yd[-1] - v)) < 2e-2
    # what is left is the integrator's: halving dt halves it
    coarse, fine = final_errors(dmp, 0.002), final_errors(dmp, 0.001)
    for c, f in zip(coarse, fine, strict=True):
        assert 1.7 < c / f < 2.3
    # "demo": the demonstration's last velocity (its finite difference, second order)
    from_demo = dmprs.DMP.fit(t, y, 40, final_velocity="demo")
    np.testing.assert_allclose(from_demo.final_velocity, v, atol=1e-4)


def test_a_new_final_velocity_is_met_with_the_demonstrated_shape():
    """Eqs. 1-2 are linear in the final velocity and the spring's transient from rest has died
    out by tau, so changing it on a fitted DMP adds the spring's tracking of the new ramp: the
    new velocity and the goal are met to the same accuracy as the demonstrated ones.
    """
    t, y, v = moving_demo()
    fitted = dmprs.DMP.fit(t, y, 40, final_velocity=v)
    reference = final_errors(fitted, 0.001)
    for new in ([2.0, -1.0], [0.0, 0.1], [-0.9, 0.4]):
        moved = fitted.with_final_velocity(new)
        position, speed = final_errors(moved, 0.001)
        assert position < reference[0] + 2e-3 and speed < reference[1] + 2e-3


def test_zero_final_velocity_is_todays_dmp_bit_for_bit():
    t, y, _ = moving_demo()
    today = dmprs.DMP.fit(t, y, 40)
    for zero in (dmprs.DMP.fit(t, y, 40, final_velocity=[0.0, 0.0]), today.with_final_velocity(np.zeros(2))):
        assert zero == today
        assert zero.to_dict() == today.to_dict()
        assert "final_velocity" not in zero.to_dict()
        np.testing.assert_array_equal(zero.weights, today.weights)
        a, b = zero.rollout(0.001), today.rollout(0.001)
        for name in ("t", "y", "yd", "ydd"):
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    np.testing.assert_array_equal(today.final_velocity, np.zeros(2))


def test_it_is_kept_by_the_dict_form_pickle_equality_and_with():
    t, y, v = moving_demo()
    dmp = dmprs.DMP.fit(t, y, 40, final_velocity=v)
    assert dmprs.DMP.from_dict(dmp.to_dict()) == dmp
    assert pickle.loads(pickle.dumps(dmp)) == dmp
    assert dmp != dmp.with_final_velocity(np.zeros(2))
    for changed in (dmp.with_goal([1.5, 0.0]), dmp.with_start([0.1, 0.2])):
        np.testing.assert_array_equal(changed.final_velocity, v)
    again = dmprs.DMP(dmp.weights, dmp.goal, dmp.start, dmp.tau, final_velocity=v)
    assert again == dmp


def test_rollout_batch_and_the_stepper_integrate_it_as_the_rollout():
    t, y, v = moving_demo()
    dmp = dmprs.DMP.fit(t, y, 40, final_velocity=v)
    for dt in (0.001, 0.03):  # 0.03 s needs the rollout's sub-steps
        tr = dmp.rollout(dt, duration=1.5 * dmp.tau)
        [batch] = dmprs.rollout_batch([dmp], dt, duration=1.5 * dmp.tau)
        np.testing.assert_array_equal(batch.y, tr.y)
        stepper = dmp.stepper(dt)
        got = np.array([stepper.step()[0].copy() for _ in range(tr.n_samples)])  # step() reuses its arrays
        np.testing.assert_allclose(got, tr.y, rtol=0, atol=1e-12)


def test_past_tau_it_moves_on_at_the_final_velocity():
    dmp = spring_only([0.5])
    tr = dmp.rollout(0.001, duration=2.0 * dmp.tau)
    late = tr.t > 1.5 * dmp.tau
    np.testing.assert_allclose(tr.yd[late, 0], 0.5, atol=2e-3)


def test_bad_input_is_refused_by_name():
    t, y, _ = moving_demo()
    dmp = dmprs.DMP.fit(t, y, 40)
    for bad in ([1.0], [1.0, np.nan], [[1.0, 2.0]]):
        with pytest.raises(InvalidInputError, match="final_velocity"):
            dmp.with_final_velocity(bad)
        with pytest.raises(InvalidInputError, match="final_velocity"):
            dmprs.DMP.fit(t, y, 40, final_velocity=bad)
    with pytest.raises(InvalidInputError, match="final_velocity"):
        dmprs.DMP.fit(t, y, 40, final_velocity="last")
    with pytest.raises(InvalidInputError, match="until_rest"):
        dmp.with_final_velocity([1.0, 0.0]).rollout(0.001, until_rest=True)


@settings(max_examples=30, deadline=None)
@given(st.lists(st.floats(-3.0, 3.0), min_size=1, max_size=4), st.floats(0.3, 3.0), st.sampled_from([1e-3, 5e-3]))
def test_any_final_velocity_is_met_at_tau(velocity, tau, dt):
    dmp = spring_only(velocity, tau)
    # on a sample at tau: the rollout rounds a duration that is not a whole number of steps up
    dmp = dmp.with_tau(round(tau / dt) * dt)
    position, speed = final_errors(dmp, dt)
    scale = 1.0 + max(abs(v) for v in velocity)
    assert position <= 1e-7 * scale and speed <= 1e-6 * scale


@pytest.mark.parametrize("dt", [0.002, 0.001, 0.0005])
def test_the_final_velocity_is_met_as_well_as_movement_primitives_does(dt):
    """Same demonstration, same spring constants (alpha_z = 48, beta_z = 12), same Euler step
    for both, the demonstration's own sampling step (1 ms), where movement_primitives' backward
    differences match its integrator, among them (benches/bench_final_velocity.py reports why).
    """
    mp = pytest.importorskip("movement_primitives.dmp")
    t, y, v = moving_demo()
    ours = final_errors(dmprs.DMP.fit(t, y, 40, final_velocity=v), dt)
    theirs = mp.DMPWithFinalVelocity(n_dims=2, execution_time=T_DEMO, dt=dt, n_weights_per_dim=40,
                                     int_dt=dt, alpha_y=48.0, beta_y=12.0)
    theirs.imitate(t, y)
    theirs.configure(start_y=y[0], goal_y=y[-1], goal_yd=v)
    yy, yd = y[0].copy(), np.zeros(2)
    for _ in range(round(T_DEMO / dt)):
        yy, yd = theirs.step(yy, yd)
    assert ours[1] <= np.max(np.abs(yd - v))
    assert ours[0] <= np.max(np.abs(yy - y[-1]))


def throws(end_velocities) -> dmprs.Database:
    """Demonstrations ending in motion, one per end velocity (the query), as moving_demo's first DOF."""
    db = dmprs.Database(("v",))
    t = np.linspace(0.0, T_DEMO, 601)
    s = t / T_DEMO
    for v in end_velocities:
        db.add([v], dmprs.Trajectory(t, 10 * s**3 - 15 * s**4 + 6 * s**5 + v * T_DEMO * (s**5 - s**4)))
    return db


@pytest.mark.parametrize(("method", "velocities", "options"),
                         [("linear", [0.5, 1.5], {}), ("lwr-gp", [0.5, 1.0, 1.5], {"trend": "affine"})])
def test_the_final_velocity_is_generalized_with_the_other_parameters(method, velocities, options):
    db = throws(velocities)
    gen = dmprs.Generalizer(db, method, 30, final_velocity=True, **options)
    assert gen.n_parameters == 30 + 1 + 3
    for demo in db:
        tr = demo.trajectory
        own = dmprs.DMP.fit(tr.t, tr.y, 30, final_velocity="demo")
        at_demo = gen.predict(demo.query)
        np.testing.assert_allclose(at_demo.final_velocity, own.final_velocity, rtol=1e-6)
        np.testing.assert_allclose(gen.parameters(demo.query)[-1], own.final_velocity[0], rtol=1e-6)
    # between the demos: the demonstrations' end velocity is affine in the query, and so is the
    # generalized final velocity, which the rollout meets to the integrator's order
    between = gen.predict([1.25])
    np.testing.assert_allclose(between.final_velocity, [1.25], atol=1e-3)
    assert abs(between.rollout(0.001).yd[-1, 0] - 1.25) < 2e-2


def test_without_final_velocities_the_generalizer_is_todays():
    db = throws([0.5, 1.0, 1.5])
    today = dmprs.Generalizer(db, "linear", 30)
    assert today.n_parameters == 30 + 1 + 2
    np.testing.assert_array_equal(today.predict([1.25]).final_velocity, [0.0])
    with pytest.raises(InvalidInputError, match="final_velocity"):
        dmprs.Generalizer(db, "linear", 30, final_velocity=1)


def test_the_triangulation_generalizes_final_velocities_as_the_core():
    """Piecewise-linear (more than n + 1 demos, or triangulate=True) blends the final velocity
    with the other parameters: on two demos it is the core's "linear", to rounding; on three it
    reproduces each demo's and is affine between them.
    """
    two = throws([0.5, 1.5])
    core = dmprs.Generalizer(two, "linear", 30, final_velocity=True)
    tri = dmprs.Generalizer(two, "linear", 30, final_velocity=True, triangulate=True)
    assert tri.n_parameters == core.n_parameters == 30 + 1 + 3
    for q in ([0.5], [1.0], [1.7]):
        np.testing.assert_allclose(tri.parameters(q), core.parameters(q), rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(tri.predict(q).final_velocity, core.predict(q).final_velocity, rtol=1e-12)
    three = throws([0.5, 1.0, 1.5])
    gen = dmprs.Generalizer(three, "linear", 30, final_velocity=True)
    for demo in three:
        own = dmprs.DMP.fit(demo.trajectory.t, demo.trajectory.y, 30, final_velocity="demo")
        np.testing.assert_array_equal(gen.predict(demo.query).final_velocity, own.final_velocity)
    np.testing.assert_allclose(gen.predict([1.25]).final_velocity, [1.25], atol=1e-3)
    np.testing.assert_array_equal(dmprs.Generalizer(three, "linear", 30).predict([1.25]).final_velocity, [0.0])


def test_via_points_keep_the_final_velocity():
    """The moving goal adds a term independent of the weights, so the rollout stays linear in
    them and the via-point is met, the final velocity kept.
    """
    t, y, v = moving_demo()
    dmp = dmprs.DMP.fit(t, y, 40, final_velocity=v)
    via = dmp.with_via_points([0.5], [[0.6, -0.1]])
    np.testing.assert_array_equal(via.final_velocity, v)
    tr = via.rollout(0.001)
    np.testing.assert_allclose(tr.y[500], [0.6, -0.1], atol=1e-9)


def test_with_tau_keeps_the_path_and_scales_the_final_velocity():
    """Tau only scales time: twice the tau at twice the dt is the same integration of the same
    path (to rounding), at half the velocity, the final one included.
    """
    t, y, v = moving_demo()
    dmp = dmprs.DMP.fit(t, y, 40, final_velocity=v)
    slow = dmp.with_tau(2.0 * dmp.tau)
    np.testing.assert_allclose(slow.final_velocity, v / 2.0, rtol=1e-15)
    a, b = dmp.rollout(0.001), slow.rollout(0.002)
    np.testing.assert_allclose(b.y, a.y, rtol=0, atol=1e-12)
    np.testing.assert_allclose(b.yd, a.yd / 2.0, rtol=0, atol=1e-11)


def test_a_held_stepper_holds_the_moving_goal():
    """Phase stopping slows the phase and the moving goal with it (both are functions of the
    phase): a stepper held at its start for a while still meets the goal and the final velocity
    once released, as its rollout does.
    """
    t, y, v = moving_demo()
    dmp = dmprs.DMP.fit(t, y, 40, final_velocity=v)
    stepper = dmp.stepper(0.001, alpha_e=1e4)
    for _ in range(200):
        stepper.step(y[0] - 0.05)  # held 5 cm behind
    while stepper.phase > np.exp(-dmp.alpha_x):
        pos, vel, _ = stepper.step()
    np.testing.assert_allclose(pos, y[-1], atol=5e-3)
    np.testing.assert_allclose(vel, v, atol=3e-2)
