"""Periodic demonstrations generalized over a task query (Ude et al. 2010; docs/method.md §12.7):
against each demonstration's own fit, the paper's interpolation formula, rhythms whose period,
baseline and amplitude are known functions of the query (their closed form), a database saved and
loaded, and demonstrations imported from ROS 2 bags written by rosbags.
"""

import numpy as np
import pytest

import dmprs
from dmprs.errors import ExtrapolationError, InvalidInputError
from dmprs.io.importer import load_demos
from tests.bag_writers import BagWriter

TWO_PI = 2 * np.pi


def truth(q: float) -> tuple[float, float, float]:
    """The rhythm at query q: its period (s), baseline and amplitude, each affine in q."""
    return 0.8 + 0.4 * q, 0.1 - 0.3 * q, 0.5 + 0.5 * q


def rhythm(q: float, periods: int = 2, dt: float = 2e-3) -> dmprs.Trajectory:
    """``periods`` periods of a 2-DOF rhythm with its exact derivatives: DOF 0 a sine about the
    baseline, DOF 1 the same sine's phase-shifted waveform with a second harmonic, fixed in q.
    """
    period, g, a = truth(q)
    w = TWO_PI / period
    t = np.arange(round(periods * period / dt)) * dt
    phi = w * t
    y = np.stack([g + a * np.sin(phi), 0.2 * np.cos(phi) + 0.05 * np.sin(2 * phi)], axis=1)
    yd = np.stack([a * w * np.cos(phi), w * (-0.2 * np.sin(phi) + 0.1 * np.cos(2 * phi))], axis=1)
    ydd = np.stack([-a * w * w * np.sin(phi), w * w * (-0.2 * np.cos(phi) - 0.2 * np.sin(2 * phi))], axis=1)
    return dmprs.Trajectory(t, y, yd, ydd)


def database(queries, with_period: bool = True) -> dmprs.Database:
    db = dmprs.Database(("height",), ("m",))
    for q in queries:
        db.add(q, rhythm(q), metadata={"period": truth(q)[0]} if with_period else {})
    return db


def test_each_demonstration_is_returned_at_its_own_query():
    db = database([0.0, 1.0])
    gen = dmprs.Generalizer(db, "linear", n_basis=30, periodic=True)
    assert gen.is_periodic and gen.n_parameters == 2 * 30 + 1 + 3 * 2
    for demo in db:
        tr = demo.trajectory
        own = dmprs.PeriodicDMP.fit(tr.t, tr.y, demo.metadata["period"], 30, tr.yd, tr.ydd)
        assert gen.predict(demo.query) == own  # bit for bit
    many = database([0.0, 0.4, 0.7, 1.0])
    ude = dmprs.Generalizer(many, "lwr-gp", n_basis=30, periodic=True)
    for demo, own in zip(many, ude.demo_dmps, strict=True):
        got = ude.predict(demo.query)
        np.testing.assert_array_equal(got.weights, own.weights)  # the LWR's interpolating kernel
        # the GPs to their noise (1e-4 of the outputs' spread)
        assert got.tau == pytest.approx(own.tau, rel=1e-5)
        np.testing.assert_allclose(got.amplitude, own.amplitude, rtol=1e-5)
        np.testing.assert_allclose(got.goal, own.goal, atol=1e-5)


def test_linear_is_the_papers_interpolation_formula():
    db = database([0.0, 1.0])
    gen = dmprs.Generalizer(db, "linear", n_basis=20, periodic=True)

    def flat(d):
        return np.concatenate([d.weights.ravel(), [d.tau], d.goal, d.amplitude, d.start])

    th1, th2 = (flat(d) for d in gen.demo_dmps)
    for a in (0.25, 0.6, 1.5):
        np.testing.assert_allclose(gen.parameters(a), (1 - a) * th1 + a * th2, rtol=1e-13, atol=1e-13)
    np.testing.assert_allclose(gen.jacobian(0.3)[:, 0], th2 - th1, rtol=1e-7, atol=1e-9)


@pytest.mark.parametrize(("method", "demos", "tol"), [("linear", (0.0, 1.0), 2e-3), ("linear", (0.0, 0.5, 1.0), 2e-3),
                                                      ("lwr-gp", (0.0, 0.25, 0.5, 0.75, 1.0), 1e-2)])
def test_an_unseen_query_gives_the_rhythm_of_its_closed_form(method, demos, tol):
    # Period, baseline and amplitude are affine in q and the normalized waveform does not change,
    # so the generalized DMP at a query between the demos must roll out that query's own rhythm.
    gen = dmprs.Generalizer(database(demos), method, n_basis=40, periodic=True)
    for q in (0.3, 0.85):
        period, g, a = truth(q)
        dmp = gen.predict(q)
        assert dmp.period == pytest.approx(period, rel=tol / 10)
        tr = dmp.rollout(dt=1e-3, duration=4 * dmp.period)
        steady = tr.t >= 3 * dmp.period
        phi = TWO_PI * tr.t[steady] / dmp.period
        exact = np.stack([g + a * np.sin(phi), 0.2 * np.cos(phi) + 0.05 * np.sin(2 * phi)], axis=1)
        assert np.abs(tr.y[steady] - exact).max() < tol * 10 * (a + 0.25)


def test_without_a_period_the_demonstration_is_one_period():
    one = dmprs.Database(("q",))
    for q in (0.0, 1.0):
        tr = rhythm(q, periods=1)
        one.add(q, tr)
    gen = dmprs.Generalizer(one, "linear", n_basis=25, periodic=True)
    for demo, dmp in zip(one, gen.demo_dmps, strict=True):
        assert dmp.period == pytest.approx(demo.trajectory.t[-1] - demo.trajectory.t[0])


@pytest.mark.parametrize(("kwargs", "metadata", "match"), [
    ({"alpha_x": 2.0}, {}, "alpha_x"),
    ({"periodic": 1}, {}, "periodic"),
    ({"n_basis": 2}, {}, "n_basis"),
    ({}, {"period": -1.0}, r"metadata\['period'\] of demonstration 1"),
    ({}, {"period": 100.0}, "period"),
])
def test_bad_options_and_periods_are_refused_by_name(kwargs, metadata, match):
    db = dmprs.Database(("q",))
    db.add(0.0, rhythm(0.0), metadata={"period": truth(0.0)[0]})
    db.add(1.0, rhythm(1.0), metadata=metadata or {"period": truth(1.0)[0]})
    with pytest.raises(InvalidInputError, match=match):
        dmprs.Generalizer(db, "linear", **{"periodic": True, **kwargs})


def test_a_query_whose_amplitude_would_vanish_is_refused():
    gen = dmprs.Generalizer(database([0.0, 1.0]), "linear", n_basis=20, periodic=True)
    with pytest.raises(ExtrapolationError, match=r"amplitude\[0\]"):
        gen.predict(-1.2)  # a = 0.5 + 0.5 q < 0
    tri = dmprs.Generalizer(database([0.0, 0.5, 1.0]), "linear", n_basis=20, periodic=True)
    with pytest.raises(ExtrapolationError, match=r"amplitude\[0\]"):
        tri.predict(-1.2)


def test_pose_demonstrations_are_refused_with_the_reason():
    db = dmprs.Database(("q",))
    for q in (0.0, 1.0):
        t = np.linspace(0, 1, 50)
        position = np.zeros((50, 3))
        position[:, 0] = np.sin(TWO_PI * t) * (1 + q)
        db.add(q, dmprs.CartesianTrajectory(t, position, np.tile([1.0, 0.0, 0.0, 0.0], (50, 1))))
    with pytest.raises(InvalidInputError, match="pose trajectories"):
        dmprs.Generalizer(db, "lwr-gp", periodic=True)


def test_a_saved_and_loaded_database_generalizes_to_the_same_bits(tmp_path):
    db = database([0.0, 0.4, 1.0])
    db.save(tmp_path / "db")
    loaded = dmprs.Database.load(tmp_path / "db")
    for method in ("linear", "lwr-gp"):
        a = dmprs.Generalizer(db, method, n_basis=20, periodic=True)
        b = dmprs.Generalizer(loaded, method, n_basis=20, periodic=True)
        np.testing.assert_array_equal(a.parameters(0.55), b.parameters(0.55))


def test_rhythms_imported_from_ros2_bags_are_generalized(tmp_path):
    # Each bag, written by rosbags, holds three periods of /joint_states at 250 Hz; the importer
    # reads them back, the period goes into the demonstration's metadata.
    names = ("wrist", "elbow")
    demos = {}
    for q in (0.0, 1.0):
        tr = rhythm(q, periods=3, dt=4e-3)
        path = tmp_path / f"rhythm_{q:g}"
        with BagWriter(path, "ros2-sqlite3") as w:
            for t, y, yd in zip(tr.t, tr.y, tr.yd, strict=True):
                t_ns = 1_700_000_000 * 10**9 + round(t * 1e9)
                w.write("/joint_states", w.joint_state(t_ns, names, y, yd), t_ns)
        (imported,) = load_demos([path], joints=names)
        demos[q] = imported
    db = dmprs.Database(("height",), ("m",))
    for q, imported in demos.items():
        db.add(q, imported.trajectory, metadata={**imported.metadata, "period": truth(q)[0]})
    gen = dmprs.Generalizer(db, "linear", n_basis=30, periodic=True)
    period, g, a = truth(0.5)
    dmp = gen.predict(0.5)
    assert dmp.period == pytest.approx(period, rel=1e-12)
    tr = dmp.rollout(dt=1e-3, duration=4 * period)
    steady = tr.t >= 3 * period
    phi = TWO_PI * tr.t[steady] / period
    assert np.abs(tr.y[steady, 0] - (g + a * np.sin(phi))).max() < 0.02 * a
