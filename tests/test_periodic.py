"""The periodic DMP against independent truth: the closed-form spring, the exact forcing term of a
sine, linearity in the amplitude, time scaling, pydmps' rhythmic DMP, and numpy's least squares.
"""

import copy
import json
import pickle
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

import dmprs
from dmprs.errors import InvalidInputError, NumericalError

TWO_PI = 2 * np.pi


def sine_demo(tau: float, amplitude: float, baseline: float, periods: int = 1, dt: float = 1e-3):
    """``y = g + A sin(t / tau)`` over whole periods, with its exact derivatives."""
    n = round(periods * TWO_PI * tau / dt)
    t = np.linspace(0.0, periods * TWO_PI * tau, n + 1)
    y = baseline + amplitude * np.sin(t / tau)
    yd = amplitude / tau * np.cos(t / tau)
    ydd = -amplitude / tau**2 * np.sin(t / tau)
    return t, y, yd, ydd


def test_zero_weights_give_the_critically_damped_spring_and_the_error_shrinks_with_dt():
    # f = 0: y(t) = g + (A + B t) exp(-alpha_z t / (2 tau)) from rest, A = y0 - g, B = A alpha_z / (2 tau)
    tau, g, y0 = 0.3, 0.5, -1.0
    dmp = dmprs.PeriodicDMP(np.zeros((1, 20)), [g], [y0], tau)
    omega = dmp.alpha_z / (2 * tau)
    errors = []
    for dt in (1e-4, 1e-5):
        tr = dmp.rollout(dt=dt, duration=0.2)
        exact = g + (y0 - g) * (1 + omega * tr.t) * np.exp(-omega * tr.t)
        errors.append(np.abs(tr.y[:, 0] - exact).max())
    assert errors[0] < 0.02
    assert 7 < errors[0] / errors[1] < 13  # semi-implicit Euler: first order


@pytest.mark.parametrize(("tau", "amplitude", "baseline"), [(0.25, 0.1, 0.3), (1 / TWO_PI, 2.0, -1.0)])
def test_a_sine_is_fitted_and_its_steady_rollout_reproduces_it(tau, amplitude, baseline):
    t, y, yd, ydd = sine_demo(tau, amplitude, baseline)
    dmp = dmprs.PeriodicDMP.fit(t, y, yd=yd, ydd=ydd, n_basis=50, period=TWO_PI * tau)
    assert dmp.goal[0] == pytest.approx(baseline, abs=1e-6)
    assert dmp.amplitude[0] == pytest.approx(amplitude, rel=1e-6)
    # the weights are the forcing term per unit amplitude; at the kernels' centres the
    # normalized sum is close to the target f_d(phi) = A ((alpha_z beta_z - 1) sin phi + alpha_z cos phi)
    c = dmp.centers
    target = (dmp.alpha_z * dmp.beta_z - 1) * np.sin(c) + dmp.alpha_z * np.cos(c)
    psi = np.exp(dmp.h * (np.cos(c[:, None] - c[None, :]) - 1))
    f = psi @ dmp.weights[0] / psi.sum(axis=1)
    np.testing.assert_allclose(f, target, atol=1e-3 * np.abs(target).max())
    # started at rest on the baseline, the spring settles within a period; the third matches
    tr = dmp.rollout(dt=1e-4, duration=3 * dmp.period, phase=0.0)
    steady = tr.t >= 2 * dmp.period
    exact = baseline + amplitude * np.sin(tr.t[steady] / tau)
    assert np.abs(tr.y[steady, 0] - exact).max() < 2e-3 * amplitude


def test_scaling_the_amplitude_scales_the_oscillation_about_the_baseline_exactly():
    t, y, _, _ = sine_demo(0.2, 0.3, 1.0)
    y2 = np.column_stack([y, 0.5 * y**2])
    dmp = dmprs.PeriodicDMP.fit(t, y2, n_basis=30)
    k = np.array([2.5, 0.4])
    g = dmp.goal
    scaled = dmp.with_amplitude(dmp.amplitude * k).with_start(g + k * (dmp.start - g))
    a, b = dmp.rollout(dt=1e-3, duration=2.0), scaled.rollout(dt=1e-3, duration=2.0)
    np.testing.assert_allclose(b.y - g, k * (a.y - g), rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(b.yd, k * a.yd, rtol=1e-10, atol=1e-10)


def test_changing_tau_changes_only_the_period():
    t, y, _, _ = sine_demo(0.2, 0.3, 1.0, periods=2)
    dmp = dmprs.PeriodicDMP.fit(t, y, period=TWO_PI * 0.2, n_basis=25)
    slow = dmp.with_tau(2 * dmp.tau)
    assert slow.period == pytest.approx(2 * dmp.period, rel=1e-15)
    a = dmp.rollout(dt=1e-3, duration=1.0)
    b = slow.rollout(dt=2e-3, duration=2.0)
    # the same steps in phase: the same positions bit for bit, velocities halved
    np.testing.assert_array_equal(a.y, b.y)
    np.testing.assert_allclose(b.yd, a.yd / 2, rtol=1e-14, atol=1e-14)


def test_the_rollout_equals_pydmps_rhythmic_dmp_where_the_equations_agree():
    pydmps = pytest.importorskip("pydmps")
    n, dt = 20, 1e-3
    rng = np.random.default_rng(5)
    w = rng.normal(0, 200, (3, n))
    goal, y0 = np.array([0.5, -1.0, 2.0]), np.array([0.0, -0.5, 2.5])
    ref = pydmps.DMPs_rhythmic(n_dmps=3, n_bfs=n, dt=dt, w=w.copy(), goal=goal.copy(), y0=y0.copy())
    y_ref, dy_ref, _ = ref.rollout()
    # pydmps: alpha_z = 25, beta_z = alpha_z / 4, h = N (our width_factor N (1 - cos(2 pi / N))),
    # tau = 1, its phase starts at 1 and is advanced before the first step
    ours = dmprs.PeriodicDMP(w, goal, y0, 1.0, alpha_z=25.0, width_factor=n * (1 - np.cos(TWO_PI / n)))
    assert ours.h == pytest.approx(n, rel=1e-12)
    tr = ours.rollout(dt=dt, duration=len(y_ref) * dt, phase=1.0 + dt)
    np.testing.assert_allclose(tr.y[1 : len(y_ref) + 1], y_ref, rtol=0, atol=1e-9)
    np.testing.assert_allclose(tr.yd[1 : len(y_ref) + 1], dy_ref, rtol=0, atol=1e-9)


def _dense_design(dmp: dmprs.PeriodicDMP, phi: np.ndarray) -> np.ndarray:
    psi = np.exp(dmp.h * (np.cos(phi[:, None] - dmp.centers[None, :]) - 1))
    return psi / psi.sum(axis=1, keepdims=True)


def test_the_batch_fit_is_numpys_least_squares():
    t, y, yd, ydd = sine_demo(0.15, 0.4, 0.2, periods=3)
    y = y + 0.05 * np.sin(3 * t / 0.15)
    yd = yd + 0.05 * 3 / 0.15 * np.cos(3 * t / 0.15)
    ydd = ydd - 0.05 * 9 / 0.15**2 * np.sin(3 * t / 0.15)
    dmp = dmprs.PeriodicDMP.fit(t, y, yd=yd, ydd=ydd, period=TWO_PI * 0.15, n_basis=30)
    tau, g, r = dmp.tau, dmp.goal[0], dmp.amplitude[0]
    a = _dense_design(dmp, (t / tau) % TWO_PI)
    f = (tau**2 * ydd - dmp.alpha_z * (dmp.beta_z * (g - y) - tau * yd)) / r
    w, *_ = np.linalg.lstsq(a, f, rcond=None)
    np.testing.assert_allclose(dmp.weights[0], w, rtol=1e-7, atol=1e-7 * np.abs(w).max())


def test_recursive_least_squares_without_forgetting_is_the_ridge_solution():
    t, y, yd, ydd = sine_demo(0.15, 0.4, 0.2, periods=2, dt=2e-3)
    tau, g, r, delta = 0.15, 0.2, 0.4, 1e-3
    fit = dmprs.PeriodicOnlineFit(1, 20, forgetting=1.0, delta=delta)
    for j in range(len(t)):
        fit.update((t[j] / tau) % TWO_PI, tau, [y[j]], [yd[j]], [ydd[j]], [g], [r])
    assert fit.samples == len(t)
    dmp = fit.dmp([g], [y[0]], tau, amplitude=[r])
    a = _dense_design(dmp, (t / tau) % TWO_PI)
    f = (tau**2 * ydd - dmp.alpha_z * (dmp.beta_z * (g - y) - tau * yd)) / r
    w = np.linalg.solve(a.T @ a + delta * np.eye(20), a.T @ f)
    np.testing.assert_allclose(fit.weights[0], w, rtol=1e-6, atol=1e-6 * np.abs(w).max())


def test_forgetting_follows_a_rhythm_that_changes():
    tau, dt = 0.1, 2e-3
    fit = dmprs.PeriodicOnlineFit(1, 20, forgetting=0.99)
    for amplitude in (1.0, 3.0):  # the demonstrator's rhythm triples halfway
        t, y, yd, ydd = sine_demo(tau, amplitude, 0.0, periods=4, dt=dt)
        for j in range(len(t)):
            fit.update((t[j] / tau) % TWO_PI, tau, [y[j]], [yd[j]], [ydd[j]], [0.0], [1.0])
    dmp = fit.dmp([0.0], [0.0], tau)
    tr = dmp.rollout(dt=1e-4, duration=4 * dmp.period)
    steady = tr.y[tr.t >= 3 * dmp.period, 0]
    assert np.ptp(steady) / 2 == pytest.approx(3.0, rel=0.02)


def test_rollout_batch_takes_periodic_dmps_with_the_same_bits():
    t, y, _, _ = sine_demo(0.2, 0.3, 1.0)
    rhythm = dmprs.PeriodicDMP.fit(t, np.column_stack([y, -y]), n_basis=15)
    discrete = dmprs.DMP.fit(t, y, n_basis=10)
    out = dmprs.rollout_batch([rhythm, discrete, rhythm.with_tau(0.3)], dt=2e-3, phase=0.5)
    for got, want in zip(out, [rhythm.rollout(2e-3, phase=0.5), discrete.rollout(2e-3),
                               rhythm.with_tau(0.3).rollout(2e-3, phase=0.5)], strict=True):
        np.testing.assert_array_equal(got.y, want.y)
        np.testing.assert_array_equal(got.ydd, want.ydd)
    with pytest.raises(InvalidInputError, match="until_rest"):
        dmprs.rollout_batch([discrete, rhythm], until_rest=True)


def test_dict_pickle_copy_and_equality_round_trip_exactly():
    t, y, _, _ = sine_demo(0.2, 0.3, 1.0)
    dmp = dmprs.PeriodicDMP.fit(t, y, n_basis=12, beta_z=10.0).with_amplitude([0.7])
    data = json.loads(json.dumps(dmp.to_dict()))
    assert data["type"] == "dmprs.PeriodicDMP"
    back = dmprs.PeriodicDMP.from_dict(data)
    assert back == dmp and pickle.loads(pickle.dumps(dmp)) == dmp and copy.deepcopy(dmp) == dmp
    np.testing.assert_array_equal(back.rollout().y, dmp.rollout().y)
    assert dmp != dmp.with_goal([2.0])
    assert dmp != dmprs.DMP.fit(t, y, n_basis=12)
    with pytest.raises(InvalidInputError, match="not a PeriodicDMP dict"):
        dmprs.PeriodicDMP.from_dict(dmprs.DMP.fit(t, y).to_dict())
    with pytest.raises(InvalidInputError, match="missing amplitude"):
        dmprs.PeriodicDMP.from_dict({k: v for k, v in data.items() if k != "amplitude"})
    with pytest.raises(AttributeError, match="immutable"):
        dmp.tau = 1.0  # type: ignore[misc]


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda t, y: dmprs.PeriodicDMP.fit(t, y, period=2 * t[-1]), "period"),
        (lambda t, y: dmprs.PeriodicDMP.fit(t, y, n_basis=2), "n_basis"),
        (lambda t, y: dmprs.PeriodicDMP.fit(t, y, period=-1.0), "period"),
        (lambda t, y: dmprs.PeriodicDMP.fit(t, np.where(t > 0.5, np.nan, y)), "y"),
        (lambda t, y: dmprs.PeriodicDMP(np.zeros((2, 5)), [0.0], [0.0, 0.0], 1.0), "goal"),
        (lambda t, y: dmprs.PeriodicDMP(np.zeros((1, 5)), [0.0], [0.0], 1.0, amplitude=[np.inf]), "amplitude"),
        (lambda t, y: dmprs.PeriodicDMP(np.zeros((1, 5)), [0.0], [0.0], 0.0), "tau"),
        (lambda t, y: dmprs.PeriodicDMP.fit(t, y).rollout(dt=0.0), "dt"),
        (lambda t, y: dmprs.PeriodicDMP.fit(t, y).rollout(phase=np.nan), "phase"),
        (lambda t, y: dmprs.PeriodicDMP.fit(t, y).with_amplitude([1.0, 2.0]), "amplitude"),
        (lambda t, y: dmprs.PeriodicOnlineFit(1, 5, forgetting=0.2), "forgetting"),
        (lambda t, y: dmprs.PeriodicOnlineFit(1, 5).update(0.0, 1.0, [np.nan], [0.0], [0.0], [0.0], [1.0]), "y"),
    ],
)
def test_bad_input_is_refused_by_name(call, match):
    t, y, _, _ = sine_demo(0.2, 0.3, 1.0)
    with pytest.raises(InvalidInputError, match=match):
        call(t, y)


def test_a_refused_sample_leaves_the_online_fit_unchanged():
    fit = dmprs.PeriodicOnlineFit(2, 8)
    fit.update(0.3, 0.2, [1.0, 2.0], [0.1, 0.0], [0.0, 1.0], [0.0, 0.0], [1.0, 1.0])
    before = fit.weights.copy()
    with pytest.raises(NumericalError, match="not taken"):  # its forcing target overflows
        fit.update(0.4, 0.2, [1e308, 2.0], [0.1, 0.0], [0.0, 1.0], [0.0, 0.0], [1.0, 1.0])
    with pytest.raises(InvalidInputError, match="amplitude"):
        fit.update(0.4, 0.2, [1.0, 2.0], [0.1, 0.0], [0.0, 1.0], [0.0, 0.0], [1.0, 0.0])
    np.testing.assert_array_equal(fit.weights, before)
    assert fit.samples == 1


@settings(max_examples=25, deadline=None)
@given(
    w=arrays(np.float64, (2, 9), elements=st.floats(-500, 500)),
    tau=st.floats(0.05, 2.0),
    r=st.floats(0.01, 10.0),
    phase=st.floats(0.0, TWO_PI),
)
def test_every_rollout_is_finite_and_settles_into_a_rhythm_of_one_period(w, tau, r, phase):
    dmp = dmprs.PeriodicDMP(w, [0.0, 1.0], [0.5, 0.5], tau, amplitude=[r, r])
    steps = 400
    dt = dmp.period / steps
    tr = dmp.rollout(dt=dt, duration=6 * dmp.period, phase=phase)
    assert np.isfinite(tr.y).all() and np.isfinite(tr.yd).all() and np.isfinite(tr.ydd).all()
    # after the transient (it decays as exp(-alpha_z t / (2 tau))), one period later is the same state
    last, before = tr.y[-steps - 1 :], tr.y[-2 * steps - 1 : -steps]
    scale = max(1.0, np.abs(tr.y).max())
    assert np.abs(last - before).max() < 1e-6 * scale


def test_the_readmes_periodic_example_runs_and_does_what_it_says():
    readme = (Path(__file__).resolve().parents[1] / "README.md").read_text()
    block = readme.split("Rhythms (wiping", 1)[1].split("```python\n", 1)[1].split("```", 1)[0]
    scope: dict = {"np": np, "dmprs": dmprs}
    exec(block, scope)  # noqa: S102 - the README's own code
    dmp, tr = scope["dmp"], scope["tr"]
    assert dmp.period == pytest.approx(1.0)
    np.testing.assert_allclose(dmp.amplitude, [0.2, 0.05], rtol=1e-3)
    # twice the amplitude at 1.5 times the frequency: the last period swings 0.8 peak to peak
    last = tr.y[tr.t >= 4.0 - 1 / 1.5, 0]
    assert np.ptp(last) == pytest.approx(0.8, rel=0.02)


# --- the periodic pose ---------------------------------------------------------------------------

def _rotation_about(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Unit quaternions (w, x, y, z) turning by ``angle`` about the unit ``axis``."""
    return np.column_stack([np.cos(angle / 2), np.outer(np.sin(angle / 2), axis)])


def _angle_between(q: np.ndarray, p: np.ndarray) -> np.ndarray:
    return 2 * np.arccos(np.clip(np.abs(np.sum(q * p, axis=1)), 0.0, 1.0))


def test_a_rotation_about_one_axis_is_the_periodic_dmp_of_its_angle_and_stays_unit():
    tau = 0.2
    t = np.linspace(0.0, TWO_PI * tau, 2001)
    theta = 0.3 + 0.4 * np.sin(t / tau) + 0.1 * np.cos(2 * t / tau)
    axis = np.array([2.0, -1.0, 0.5]) / np.linalg.norm([2.0, -1.0, 0.5])
    pose = np.column_stack([np.outer(0.1 * theta, [1.0, 0.0, 0.0]), _rotation_about(axis, theta)])
    dmp = dmprs.PeriodicCartesianDMP.fit(t, pose, n_basis=30)
    angle = dmprs.PeriodicDMP.fit(t, theta, n_basis=30)
    a = dmp.rollout(dt=1e-3, duration=1.0)
    b = angle.rollout(dt=1e-3, duration=1.0)
    np.testing.assert_allclose(np.linalg.norm(a.quaternion, axis=1), 1.0, rtol=0, atol=4e-16)
    assert _angle_between(a.quaternion, _rotation_about(axis, b.y[:, 0])).max() < 1e-7
    np.testing.assert_allclose(a.angular_velocity, np.outer(b.yd[:, 0], axis), atol=1e-8)
    # the baseline orientation is the middle of the range; the amplitude per axis |axis| r
    assert _angle_between(dmp.goal[None, 3:], _rotation_about(axis, angle.goal))[0] < 1e-12
    np.testing.assert_allclose(dmp.amplitude[3:], np.abs(axis) * angle.amplitude[0], rtol=1e-9)


def test_a_swing_of_a_full_turn_from_the_baseline_is_refused_and_one_just_under_is_kept():
    """About one axis the orientation's coordinates are the angle from the baseline while it is
    within a full turn (the quaternion logarithm's range); past it they would jump by 2 pi and
    the rollout with them (it turned at 120 rad/s). A swing of 6.2 rad each way is fitted and
    follows the angle's own periodic DMP; one of 6.4 is refused, naming the time.
    """
    tau = 1.0
    t = np.linspace(0.0, TWO_PI * tau, 800, endpoint=False)
    axis = np.array([0.0, 0.0, 1.0])
    for amplitude in (6.2, 6.4):
        theta = amplitude * np.sin(t / tau)
        pose = np.column_stack([0 * np.outer(t, axis), _rotation_about(axis, theta)])
        if amplitude > TWO_PI:
            with pytest.raises(InvalidInputError, match=r"at t = 1\.38.* s is a full turn or more"):
                dmprs.PeriodicCartesianDMP.fit(t, pose, n_basis=25)
            continue
        a = dmprs.PeriodicCartesianDMP.fit(t, pose, n_basis=25).rollout(dt=1e-3, duration=2.0)
        b = dmprs.PeriodicDMP.fit(t, theta, n_basis=25).rollout(dt=1e-3, duration=2.0)
        np.testing.assert_allclose(a.angular_velocity, np.outer(b.yd[:, 0], axis), atol=1e-7)


def test_a_wobbling_wipe_is_reproduced_once_the_start_transient_has_gone():
    tau = 0.15
    t = np.linspace(0.0, 2 * TWO_PI * tau, 3001)
    rotvec = np.column_stack([0.3 * np.sin(t / tau), 0.2 * np.cos(t / tau), 0.1 * np.sin(2 * t / tau)])
    angle = np.linalg.norm(rotvec, axis=1)
    axis = rotvec / angle[:, None]
    q = np.column_stack([np.cos(angle / 2), axis * np.sin(angle / 2)[:, None]])
    position = np.column_stack([0.2 * np.sin(t / tau), 0.05 * np.sin(2 * t / tau), 0.3 + 0 * t])
    dmp = dmprs.PeriodicCartesianDMP.fit(t, np.column_stack([position, q]), period=TWO_PI * tau, n_basis=40)
    tr = dmp.rollout(dt=5e-4, duration=3 * dmp.period)
    late = tr.t >= 2 * dmp.period
    rv = np.column_stack([0.3 * np.sin(tr.t / tau), 0.2 * np.cos(tr.t / tau), 0.1 * np.sin(2 * tr.t / tau)])
    ang = np.linalg.norm(rv, axis=1)
    want = np.column_stack([np.cos(ang / 2), rv / ang[:, None] * np.sin(ang / 2)[:, None]])
    assert _angle_between(tr.quaternion[late], want[late]).max() < 5e-3
    assert np.abs(tr.position[late, 0] - 0.2 * np.sin(tr.t[late] / tau)).max() < 2e-3
    assert np.abs(tr.position[late, 2] - 0.3).max() < 1e-9


def test_the_periodic_pose_round_trips_and_batches_with_the_same_bits():
    tau = 0.2
    t = np.linspace(0.0, TWO_PI * tau, 801)
    theta = 0.5 * np.sin(t / tau)
    pose = np.column_stack([np.outer(theta, [0.1, 0.2, 0.0]), _rotation_about(np.array([0.0, 0.0, 1.0]), theta)])
    dmp = dmprs.PeriodicCartesianDMP.fit(t, pose, n_basis=15).with_amplitude(np.full(6, 0.5))
    back = dmprs.PeriodicCartesianDMP.from_dict(json.loads(json.dumps(dmp.to_dict())))
    assert back == dmp and pickle.loads(pickle.dumps(dmp)) == dmp
    a, b = dmprs.rollout_batch([dmp, dmp.with_tau(0.3)], dt=2e-3, phase=1.0)
    np.testing.assert_array_equal(a.quaternion, dmp.rollout(2e-3, phase=1.0).quaternion)
    np.testing.assert_array_equal(b.position, dmp.with_tau(0.3).rollout(2e-3, phase=1.0).position)
    with pytest.raises(InvalidInputError, match="amplitude"):
        dmp.with_amplitude(np.ones(3))
    with pytest.raises(InvalidInputError, match="weights"):
        dmprs.PeriodicCartesianDMP(np.zeros((3, 10)), pose[0], pose[0], 1.0)
    with pytest.raises(InvalidInputError, match="goal"):
        dmp.with_goal([0, 0, 0, 2.0, 0, 0, 0])
