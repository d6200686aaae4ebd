"""dmprs.Generalizer: the paper's G(q; Z) -> DMP (eq. 6, docs/method.md §3)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import dmprs
from dmprs import _core, portable
from dmprs.errors import ExtrapolationError, InvalidInputError
from dmprs.generalize import MAX_GP_DEMOS

#: what dmprs.Generalizer hands the core, for the tests that call the core directly
CONSTANTS = {"alpha_z": 48.0, "beta_z": 12.0, "alpha_x": 2.0, "width_factor": 2.0}
OPTIONS = {"kernel": "tricube", "bandwidth": 1.5, "ridge": 1e-8, "interpolate": True, "gp_noise": 1e-3,
           "gp_optimize": None, "gp_restarts": 0, "gp_neighbours": None, "gp_sparse": False,
           "trend": "constant"}


def min_jerk(s):
    # products, not numpy's power, and dmprs.portable's sin below: the machine fingerprint
    # (tests/machine_fingerprint.py) builds its demos here, and numpy's AVX-512 power and sin
    # differ from its other loops in the last bit
    s3 = s * s * s
    return 10 * s3 - 15 * s3 * s + 6 * s3 * s * s


def trajectory(q, n_dof=2, samples=400, derivatives=False):
    """A demo whose goal, amplitude, shape and duration all depend on the (scalar or vector)
    query.
    """
    q = np.atleast_1d(np.asarray(q, dtype=float))
    tau = 1.0 + 0.3 * q[0] + (0.1 * q[1] if q.size > 1 else 0.0)
    t = np.linspace(0.0, tau, samples)
    s = t / tau
    cols = [(1.0 + q.sum() + 0.2 * d) * min_jerk(s) + 0.1 * d * q[0] * portable.sin(np.pi * s) ** 2
            for d in range(n_dof)]
    y = np.stack(cols, axis=1)
    if not derivatives:
        return dmprs.Trajectory(t, y)
    yd = np.gradient(y, t, axis=0, edge_order=2)
    return dmprs.Trajectory(t, y, yd, np.gradient(yd, t, axis=0, edge_order=2))


def database(queries, **kw):
    queries = [np.atleast_1d(q) for q in queries]
    n = queries[0].size
    db = dmprs.Database(tuple(f"q{i}" for i in range(n)), ("m",) * n)
    for q in queries:
        db.add(q, trajectory(q, **kw))
    return db


def flat(dmp):
    return np.concatenate([dmp.weights.ravel(), [dmp.tau], dmp.goal, dmp.start])


# --- linear (docs/method.md §3.3) -------------------------------------------------------------
def test_linear_reproduces_each_demo_exactly():
    db = database([0.0, 1.0])
    gen = dmprs.Generalizer(db, "linear", n_basis=20)
    for demo in db:
        tr = demo.trajectory
        assert gen.predict(demo.query) == dmprs.DMP.fit(tr.t, tr.y, 20)  # bit for bit


def test_linear_is_the_papers_interpolation_formula():
    db = database([0.5, 2.0])
    gen = dmprs.Generalizer(db, "linear", n_basis=15)
    th1, th2 = (flat(dmprs.DMP.fit(d.trajectory.t, d.trajectory.y, 15)) for d in db)
    for q in [0.8, 1.7, -0.3, 3.1]:  # inside and outside the demos (extrapolation, Fig. 7)
        a = (q - 0.5) / (2.0 - 0.5)
        np.testing.assert_allclose(flat(gen.predict(q)), (1 - a) * th1 + a * th2, rtol=1e-12, atol=1e-12)


def test_linear_uses_measured_derivatives():
    db = database([0.0, 1.0], derivatives=True)
    gen = dmprs.Generalizer(db, "linear", n_basis=10)
    tr = db[1].trajectory
    assert gen.demo_dmps[1] == dmprs.DMP.fit(tr.t, tr.y, 10, yd=tr.yd, ydd=tr.ydd)


def test_linear_on_a_triangle_of_2d_queries():
    queries = [np.array([0.0, 0.0]), np.array([1.0, 0.0]), np.array([0.0, 2.0])]
    gen = dmprs.Generalizer(database(queries), "linear", n_basis=10)
    for q, d in zip(queries, gen.demo_dmps, strict=True):
        assert gen.predict(q) == d
    # Barycentric coordinates of (0.25, 0.5): 0.5, 0.25, 0.25.
    want = 0.5 * flat(gen.demo_dmps[0]) + 0.25 * flat(gen.demo_dmps[1]) + 0.25 * flat(gen.demo_dmps[2])
    np.testing.assert_allclose(gen.parameters([0.25, 0.5]), want, rtol=1e-12, atol=1e-12)


def test_linear_with_two_demos_in_2d_projects_onto_their_line():
    gen = dmprs.Generalizer(database([[0.0, 0.0], [2.0, 0.0]]), "linear", n_basis=10)
    np.testing.assert_allclose(gen.parameters([1.0, 5.0]), gen.parameters([1.0, 0.0]), rtol=1e-13)


@settings(max_examples=25, deadline=None)
@given(a=st.floats(-1.0, 2.0), b=st.floats(-1.0, 2.0))
def test_linear_is_affine_in_q(a, b):
    gen = _LINEAR
    mid = gen.parameters(0.5 * (a + b))
    avg = 0.5 * (gen.parameters(a) + gen.parameters(b))
    np.testing.assert_allclose(mid, avg, rtol=1e-10, atol=1e-10)


_LINEAR = dmprs.Generalizer(database([0.0, 1.0]), "linear", n_basis=10)


def test_linear_jacobian_is_the_demo_difference():
    gen = dmprs.Generalizer(database([0.0, 2.0]), "linear", n_basis=10)
    jac = gen.jacobian(0.7)
    assert jac.shape == (gen.n_parameters, 1) == (2 * 10 + 1 + 2 * 2, 1)
    want = (flat(gen.demo_dmps[1]) - flat(gen.demo_dmps[0])) / 2.0
    np.testing.assert_allclose(jac[:, 0], want, rtol=1e-7, atol=1e-7)


# --- tau must stay valid ---------------------------------------------------------------------
def test_extrapolating_too_far_is_an_extrapolation_error():
    gen = dmprs.Generalizer(database([0.0, 1.0]), "linear", n_basis=10)
    lo, hi = gen.tau_bounds
    assert (lo, hi) == pytest.approx((0.2 * 1.0, 5 * 1.3))
    gen.predict(-2.0)  # tau = 0.4: still valid
    with pytest.raises(ExtrapolationError, match=r"query \[-3\].*tau = 0\.0999") as info:
        gen.predict(-3.0)  # tau = 0.1 < 0.2
    assert isinstance(info.value, InvalidInputError) and isinstance(info.value, ValueError)
    with pytest.raises(ExtrapolationError, match=r"tau = .* outside the valid range"):
        gen.predict(-10.0)  # tau < 0
    with pytest.raises(ExtrapolationError):
        gen.predict(20.0)  # tau = 7 > 6.5


# --- lwr-gp (Ude 2010, docs/method.md §3.2) --------------------------------------------------
@pytest.mark.parametrize("kernel", ["tricube", "gaussian"])
def test_lwr_gp_reproduces_its_demos_to_ridge_precision(kernel):
    queries = [0.0, 0.3, 0.9, 1.4, 2.0]  # 5 demos: ML-II for the GPs
    db = database(queries)
    gen = dmprs.Generalizer(db, "lwr-gp", n_basis=20, kernel=kernel)
    for demo, own in zip(db, gen.demo_dmps, strict=True):
        got, want = flat(gen.predict(demo.query)), flat(own)
        # Weights: the demo's own fit (same ridge), exactly. tau, g, y0: to GP-noise precision.
        assert np.array_equal(gen.predict(demo.query).weights, own.weights)
        assert np.abs(got - want).max() < 1e-5 * np.abs(want).max()
        # ... and so does the motion.
        a, b = gen.predict(demo.query).rollout(0.002, own.tau), own.rollout(0.002, own.tau)
        assert np.abs(a.y - b.y).max() < 1e-4 * np.ptp(b.y)


def test_lwr_gp_and_linear_agree_at_the_demo_queries():
    db = database([0.0, 1.0])
    lin = dmprs.Generalizer(db, "linear", n_basis=15)
    ude = dmprs.Generalizer(db, "lwr-gp", n_basis=15)
    for q in (0.0, 1.0):
        a, b = lin.parameters(q), ude.parameters(q)
        assert np.abs(a - b).max() < 1e-5 * np.abs(a).max()


def test_lwr_gp_of_identical_motions_is_that_motion_everywhere():
    db = dmprs.Database(("q",))
    tr = trajectory(0.4)
    for q in [0.0, 1.0, 2.5]:
        db.add(q, tr)
    gen = dmprs.Generalizer(db, "lwr-gp", n_basis=12)
    want = flat(gen.demo_dmps[0])
    for q in [-1.0, 0.5, 1.7, 4.0]:
        assert np.abs(gen.parameters(q) - want).max() < 1e-6 * np.abs(want).max()


def affine_trajectory(q, samples=300):
    """Data affine in the (scalar or vector) query on one time grid: its DMP parameters are too."""
    q = np.atleast_1d(np.asarray(q, dtype=float))
    t = np.linspace(0.0, 1.2, samples)
    s = t / 1.2
    y = np.stack([(1.0 + q.sum()) * min_jerk(s) + 0.1 * q[0] * np.sin(3 * s),
                  0.3 + (0.5 - q[-1]) * min_jerk(s)], axis=1)
    return dmprs.Trajectory(t, y)


@pytest.mark.parametrize("queries", [[[0.0], [0.5], [1.0], [1.5]],
                                     [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0], [0.4, 0.6]]])
def test_lwr_gp_with_an_affine_trend_extrapolates_like_linear_on_affine_data(queries):
    db = dmprs.Database(tuple(f"q{i}" for i in range(len(queries[0]))))
    for q in queries:
        db.add(q, affine_trajectory(q))
    lin = dmprs.Generalizer(db, "linear", n_basis=15)  # piecewise linear: exact on affine data
    aff = dmprs.Generalizer(db, "lwr-gp", n_basis=15, trend="affine")
    plain = dmprs.Generalizer(db, "lwr-gp", n_basis=15)
    n = len(queries[0])
    for q in ([0.7] * n, [-0.6] * n, [2.4] * n, [1.8, -0.5][:n]):
        want = lin.parameters(q)
        assert np.abs(aff.parameters(q) - want).max() < 1e-6 * np.abs(want).max(), q
    far = [2.4] * n  # the constant trend cannot get there
    assert np.abs(plain.parameters(far) - lin.parameters(far)).max() > 0.05 * np.abs(lin.parameters(far)).max()
    for demo, own in zip(db, plain.demo_dmps, strict=True):  # the demos as the default reproduces them
        assert np.array_equal(aff.predict(demo.query).weights, own.weights)


def test_the_affine_trend_is_refused_by_name_and_works_on_poses():
    with pytest.raises(InvalidInputError, match="trend = 'cubic' is invalid"):
        dmprs.Generalizer(database([0.0, 1.0]), "lwr-gp", trend="cubic")
    from dmprs.trajectory import CartesianTrajectory
    db = dmprs.Database(("q",))
    t = np.linspace(0.0, 1.0, 200)
    for q in (0.0, 0.5, 1.0):
        a = min_jerk(t)
        position = np.zeros((200, 3))
        position[:, 0] = (0.2 + q) * a
        quaternion = np.zeros((200, 4))
        quaternion[:, 0], quaternion[:, 3] = np.cos(0.5 * q * a), np.sin(0.5 * q * a)  # about z, angle q a
        db.add(q, CartesianTrajectory(t, position, quaternion))
    aff = dmprs.Generalizer(db, "lwr-gp", n_basis=15, trend="affine")
    goal = aff.predict(1.5).goal  # beyond the demos: x = 1.7, angle 1.5 about z
    assert goal[0] == pytest.approx(1.7, abs=1e-3)
    assert 2 * np.arctan2(goal[6], goal[3]) == pytest.approx(1.5, abs=1e-3)


def test_lwr_gp_in_2d_blends_between_demos():
    rng = np.random.default_rng(0)
    queries = [rng.uniform(0, 1, 2) for _ in range(7)]
    gen = dmprs.Generalizer(database(queries), "lwr-gp", n_basis=15)
    q = np.array([0.5, 0.5])
    dmp = gen.predict(q)
    taus = [d.tau for d in gen.demo_dmps]
    assert min(taus) * 0.9 < dmp.tau < max(taus) * 1.1
    # Weights stay within the range the demos span (a convex blend of similar design matrices).
    w = np.stack([d.weights for d in gen.demo_dmps])
    span = w.max(0) - w.min(0)
    assert np.all(dmp.weights >= w.min(0) - 0.1 * span - 1e-9)
    assert np.all(dmp.weights <= w.max(0) + 0.1 * span + 1e-9)
    jac = gen.jacobian(q)
    assert jac.shape == (gen.n_parameters, 2) and np.isfinite(jac).all()
    # The Jacobian predicts a small step.
    dq = np.array([1e-3, -2e-3])
    np.testing.assert_allclose(
        gen.parameters(q + dq) - gen.parameters(q), jac @ dq, atol=1e-4 * np.abs(jac).max()
    )


def test_predictions_are_bit_identical():
    db = database([0.0, 0.5, 1.0, 1.5])
    a = dmprs.Generalizer(db, "lwr-gp", n_basis=10)
    b = dmprs.Generalizer(db, "lwr-gp", n_basis=10)
    assert a.parameters(0.77).tobytes() == b.parameters(0.77).tobytes()


# --- bad input: one test per case, each a DmprsError that says what -----------------------------
def test_empty_database():
    with pytest.raises(InvalidInputError, match="database is empty"):
        dmprs.Generalizer(dmprs.Database(("q",)), "linear")


@pytest.mark.parametrize("method", ["linear", "lwr-gp"])
def test_too_few_demos(method):
    with pytest.raises(InvalidInputError, match="needs at least 2 demonstrations"):
        dmprs.Generalizer(database([0.0]), method)


def test_more_than_n_plus_1_demos_make_linear_piecewise():
    # tests/test_triangulation.py checks the triangulated path; here only that it is taken
    gen = dmprs.Generalizer(database([0.0, 1.0, 2.0]), "linear")
    assert gen.n_demos == 3 and type(gen._core).__name__ == "PiecewiseLinear"


def test_collinear_queries_for_linear():
    with pytest.raises(InvalidInputError, match="affinely independent"):
        dmprs.Generalizer(database([[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]]), "linear")


def test_duplicate_queries():
    db = database([0.0, 1.0])
    with pytest.raises(InvalidInputError, match=r"demonstration 0 already has the query \[0\.0\]"):
        db.add(0.0, trajectory(0.5))
    # The core checks too (for callers that bypass Database).
    tr = trajectory(0.0)
    demo = (tr.t, tr.y, None, None)
    with pytest.raises(InvalidInputError, match="demonstrations 0 and 1 have the same query"):
        _core.Generalizer(
            np.array([[0.0], [0.0]]), [demo, demo], "linear", 10, CONSTANTS, OPTIONS
        )


def test_query_of_the_wrong_dimension():
    db = database([0.0, 1.0])
    with pytest.raises(InvalidInputError, match=r"query has shape \(2,\), expected \(1,\)"):
        db.add([0.5, 0.5], trajectory(0.5))
    gen = dmprs.Generalizer(db, "linear", n_basis=10)
    with pytest.raises(InvalidInputError, match=r"q has shape \(2,\), expected \(1,\)"):
        gen.predict([0.5, 0.5])


def test_query_with_nan():
    db = database([0.0, 1.0])
    with pytest.raises(InvalidInputError, match=r"query\[0\] is nan"):
        db.add([np.nan], trajectory(0.5))
    gen = dmprs.Generalizer(db, "lwr-gp", n_basis=10)
    with pytest.raises(InvalidInputError, match=r"q\[0\] is nan"):
        gen.predict(np.nan)
    with pytest.raises(InvalidInputError, match=r"q\[0\] is inf"):
        gen.jacobian(np.inf)


def test_demos_with_different_dof_counts():
    db = database([0.0], n_dof=2)
    with pytest.raises(InvalidInputError, match="has 3 DOFs, but the demonstrations in this database have 2"):
        db.add(1.0, trajectory(1.0, n_dof=3))
    a, b = trajectory(0.0, n_dof=2), trajectory(1.0, n_dof=3)
    with pytest.raises(InvalidInputError, match="demonstration 1 has 3 degrees of freedom, but demonstration 0 has 2"):
        _core.Generalizer(
            np.array([[0.0], [1.0]]), [(a.t, a.y, None, None), (b.t, b.y, None, None)], "lwr-gp", 10,
            CONSTANTS, OPTIONS,
        )


def test_bad_options():
    db = database([0.0, 1.0])
    with pytest.raises(InvalidInputError, match="method = 'nearest' is invalid"):
        dmprs.Generalizer(db, "nearest")
    with pytest.raises(InvalidInputError, match="kernel = 'box' is invalid"):
        dmprs.Generalizer(db, "lwr-gp", kernel="box")
    with pytest.raises(InvalidInputError, match="bandwidth = 1 is invalid"):
        dmprs.Generalizer(db, "lwr-gp", bandwidth=1.0)
    with pytest.raises(InvalidInputError, match=r"expected a dmprs.Database"):
        dmprs.Generalizer([(0.0, trajectory(0.0))], "linear")


def test_a_bad_demo_is_named():
    t = np.array([0.0, 0.5, 0.5, 1.0])
    with pytest.raises(InvalidInputError, match=r"demonstration 1: t must be strictly increasing"):
        tr = trajectory(0.0)
        _core.Generalizer(
            np.array([[0.0], [1.0]]), [(tr.t, tr.y, None, None), (t, np.zeros((4, 2)), None, None)],
            "linear", 10, CONSTANTS, OPTIONS,
        )


def test_lwr_gp_refuses_more_demos_than_its_exact_gps_can_take_and_local_gps_take_them():
    t = np.linspace(0.0, 1.0, 10)
    db = dmprs.Database(("a", "b"))
    for k in range(MAX_GP_DEMOS + 1):
        db.add([k % 40, k // 40], dmprs.Trajectory(t, np.outer(t, [1.0 + k % 7])))
    refused = (rf"exact Gaussian processes over {MAX_GP_DEMOS + 1} demonstrations is refused.*gp_sparse=True"
               r".*gp_neighbours.*'linear'")
    with pytest.raises(InvalidInputError, match=refused):
        dmprs.Generalizer(db, "lwr-gp")
    with pytest.raises(InvalidInputError, match=refused):
        dmprs.Generalizer(db, "lwr-gp", gp_neighbours=5000)  # as many as the database: exact again
    local = dmprs.Generalizer(db, "lwr-gp", n_basis=5, gp_neighbours=12)
    assert local.n_demos == MAX_GP_DEMOS + 1
    for k in (0, 517, MAX_GP_DEMOS):  # each demo back, to the GP noise
        demo = db[k]
        want = flat(dmprs.DMP.fit(demo.trajectory.t, demo.trajectory.y, 5))
        assert np.allclose(flat(local.predict(demo.query)), want, rtol=1e-5, atol=1e-6)


def test_local_gps_over_every_demo_are_the_exact_generalizer_bit_for_bit():
    db = database([[a, b] for a in np.linspace(0.0, 1.0, 5) for b in np.linspace(0.0, 2.0, 4)])
    exact = dmprs.Generalizer(db, "lwr-gp", n_basis=10)
    for k in (len(db), 100):
        local = dmprs.Generalizer(db, "lwr-gp", n_basis=10, gp_neighbours=k)
        for q in ([0.0, 0.0], [0.37, 1.21], [0.9, 2.4]):
            assert np.array_equal(local.parameters(q), exact.parameters(q))


def test_local_gps_stay_close_to_the_exact_ones_between_the_demos():
    # the GPs of tau, goal and start over the 8 nearest of 20 demos, hyperparameters fitted on the 8
    # around the central one, against the GPs over all 20 with their own ML-II hyperparameters
    db = database([[a, b] for a in np.linspace(0.0, 1.0, 5) for b in np.linspace(0.0, 2.0, 4)])
    exact = dmprs.Generalizer(db, "lwr-gp", n_basis=10)
    local = dmprs.Generalizer(db, "lwr-gp", n_basis=10, gp_neighbours=8)
    nw = 10 * 2
    for q in ([0.1, 0.3], [0.37, 1.21], [0.62, 1.9]):
        a, b = local.parameters(q), exact.parameters(q)
        assert np.array_equal(a[:nw], b[:nw])  # the weights are the LWR's, the same in both
        assert np.allclose(a[nw:], b[nw:], rtol=1e-3, atol=0), (q, a[nw:] - b[nw:])


def smooth_database(n: int, seed: int) -> dmprs.Database:
    """``n`` demos whose duration, goals and start vary smoothly (not affinely) with a 2-D query
    drawn from the unit square.
    """
    rng = np.random.default_rng(seed)
    db = dmprs.Database(("x", "y"))
    for q in rng.uniform(0.0, 1.0, (n, 2)):
        tau = 1.5 + 0.5 * q[0] + 0.2 * np.sin(3 * q[1])
        s = np.linspace(0.0, 1.0, 30)
        amp = np.array([0.5 + q[0] + 0.3 * np.cos(2 * q[1]), 1.0 - 0.4 * q[1] ** 2])
        start = np.array([0.1 * np.sin(2 * q[0]), 0.0])
        db.add(q, dmprs.Trajectory(tau * s, start + np.outer(10 * s**3 - 15 * s**4 + 6 * s**5, amp)))
    return db


def test_sparse_gps_give_the_exact_gps_mean_to_a_millionth_of_each_parameters_range():
    # 200 demos: the sparse GPs fit the exact ones' hyperparameters on them, then condition on
    # a low-rank factor that leaves out a thousandth of the noise
    db = smooth_database(200, seed=3)
    exact = dmprs.Generalizer(db, "lwr-gp", n_basis=8)
    sparse = dmprs.Generalizer(db, "lwr-gp", n_basis=8, gp_sparse=True)
    nw = 8 * 2
    probes = np.random.default_rng(4).uniform(0.05, 0.95, (40, 2))
    want = np.array([exact.parameters(q) for q in probes])
    got = np.array([sparse.parameters(q) for q in probes])
    assert np.array_equal(got[:, :nw], want[:, :nw])  # the weights are the LWR's in both
    spread = np.ptp(np.array([exact.parameters(d.query)[nw:] for d in db]), axis=0)
    varies = spread > 0
    assert varies.sum() == 4  # tau, both goals, the first start
    err = np.abs(got[:, nw:] - want[:, nw:])[:, varies] / spread[varies]
    assert err.max() < 1e-6, err.max()


def test_sparse_gps_take_more_demos_than_the_exact_ones_and_give_each_back():
    db = smooth_database(MAX_GP_DEMOS + 200, seed=5)
    sparse = dmprs.Generalizer(db, "lwr-gp", n_basis=6, gp_sparse=True)
    for k in (0, 517, MAX_GP_DEMOS + 199):  # each demo back, to the GP noise
        demo = db[k]
        want = flat(dmprs.DMP.fit(demo.trajectory.t, demo.trajectory.y, 6))
        assert np.allclose(flat(sparse.predict(demo.query)), want, rtol=1e-5, atol=1e-6)


def test_sparse_gps_refuse_outputs_too_rough_for_their_factor_and_say_what_to_use():
    # goals that jump from demo to demo: ML-II finds short length scales, and the factor would
    # need every demo
    t = np.linspace(0.0, 1.0, 10)
    db = dmprs.Database(("a", "b"))
    for k in range(1200):
        db.add([k % 40, k // 40], dmprs.Trajectory(t, np.outer(t, [1.0 + k % 7])))
    # the method does not suit the data (nothing failed): a ValueError naming the output
    with pytest.raises(InvalidInputError,
                       match=r"^the GP of goal\[0\]: .*more than 1000 demos.*gp_neighbours"):
        dmprs.Generalizer(db, "lwr-gp", n_basis=5, gp_sparse=True)


def test_gp_sparse_and_gp_neighbours_are_refused_together():
    db = database([0.0, 1.0, 2.0, 3.0, 4.0])
    with pytest.raises(InvalidInputError, match="gp_sparse=True and gp_neighbours=4"):
        dmprs.Generalizer(db, "lwr-gp", gp_sparse=True, gp_neighbours=4)


@pytest.mark.parametrize("value", [3, 0, -1, 2.5, True, "8"])
def test_gp_neighbours_must_be_a_count_of_at_least_four(value):
    db = database([0.0, 1.0, 2.0])
    with pytest.raises(InvalidInputError, match="gp_neighbours"):
        dmprs.Generalizer(db, "lwr-gp", gp_neighbours=value)
