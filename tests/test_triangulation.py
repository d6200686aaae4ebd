"""The triangulated "linear" generalizer (dmprs.triangulation) over more than n + 1 demos:
exact at every demo, continuous across simplices, equal to scipy's LinearNDInterpolator inside the
hull, affine extrapolation outside, repeats averaged.
"""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.interpolate import LinearNDInterpolator
from scipy.spatial import Delaunay

import dmprs
from dmprs import _core
from dmprs.errors import ExtrapolationError, InvalidInputError
from dmprs.triangulation import PiecewiseLinear
from tests.test_generalize import database, flat, trajectory

N_BASIS = 10
QUERIES_2D = np.random.default_rng(3).uniform(0.0, 1.0, (9, 2))


def fitted(q):
    """The demo's own DMP, fitted independently of any generalizer."""
    tr = trajectory(q)
    return flat(dmprs.DMP.fit(tr.t, tr.y, n_basis=N_BASIS))


@pytest.fixture(scope="module")
def gen2d():
    return dmprs.Generalizer(database(list(QUERIES_2D)), "linear", n_basis=N_BASIS)


def test_more_than_n_plus_1_demos_use_the_triangulation(gen2d):
    assert isinstance(gen2d._core, PiecewiseLinear) and gen2d.n_demos == 9
    few = dmprs.Generalizer(database(list(QUERIES_2D[:3])), "linear", n_basis=N_BASIS)
    assert isinstance(few._core, _core.Generalizer)  # <= n + 1 demos: the core, unchanged


@pytest.mark.parametrize("queries", [[0.0, 2.0, 0.5, 1.2, -0.4], list(QUERIES_2D)], ids=["1-D", "2-D"])
def test_reproduces_every_demo_exactly(queries):
    gen = dmprs.Generalizer(database(queries), "linear", n_basis=N_BASIS)
    for q in queries:
        np.testing.assert_allclose(gen.parameters(q), fitted(q), rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(flat(gen.predict(q)), fitted(q), rtol=1e-12, atol=1e-12)


def test_agrees_with_the_one_simplex_core_where_both_apply():
    for queries in ([0.0, 1.0], [[0.0, 0.0], [1.0, 0.2], [0.3, 1.0]]):
        core = dmprs.Generalizer(database(queries), "linear", n_basis=N_BASIS)
        tri = dmprs.Generalizer(database(queries), "linear", n_basis=N_BASIS, triangulate=True)
        assert isinstance(tri._core, PiecewiseLinear)
        for q in np.random.default_rng(0).uniform(-0.5, 1.5, (6, np.ndim(queries))):
            np.testing.assert_allclose(tri.parameters(q), core.parameters(q), rtol=1e-10, atol=1e-10)
            np.testing.assert_allclose(tri.jacobian(q), core.jacobian(q), rtol=1e-6, atol=1e-8)


def test_1d_is_linear_between_neighbours_and_extrapolates_from_the_end_intervals():
    qs = [0.0, 2.0, 0.5, 1.2]
    gen = dmprs.Generalizer(database(qs), "linear", n_basis=N_BASIS)
    t = {q: fitted(q) for q in qs}
    np.testing.assert_allclose(gen.parameters(0.78), 0.6 * t[0.5] + 0.4 * t[1.2], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(gen.parameters(-0.25), 1.5 * t[0.0] - 0.5 * t[0.5], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(gen.parameters(2.4), -0.5 * t[1.2] + 1.5 * t[2.0], rtol=1e-12, atol=1e-12)


def test_agrees_with_scipy_inside_the_hull(gen2d):
    truth = LinearNDInterpolator(QUERIES_2D, np.array([fitted(q) for q in QUERIES_2D]))
    pts = np.random.default_rng(1).uniform(0.0, 1.0, (200, 2))
    expected = truth(pts)
    inside = ~np.isnan(expected[:, 0])
    assert inside.sum() > 50
    for p, e in zip(pts[inside], expected[inside], strict=True):
        np.testing.assert_allclose(gen2d.parameters(p), e, rtol=1e-9, atol=1e-9)


def test_continuous_across_every_shared_edge(gen2d):
    tri = Delaunay(QUERIES_2D)
    theta_scale = np.abs(np.array([fitted(q) for q in QUERIES_2D])).max()
    shared = 0
    for s, nbrs in enumerate(tri.neighbors):
        for k, nb in enumerate(nbrs):
            if nb < 0 or nb < s:
                continue
            a, b = QUERIES_2D[np.delete(tri.simplices[s], k)]
            normal = np.array([-(b - a)[1], (b - a)[0]]) / np.linalg.norm(b - a)
            for u in (0.2, 0.5, 0.8):
                p = a + u * (b - a)
                jump = gen2d.parameters(p + 1e-9 * normal) - gen2d.parameters(p - 1e-9 * normal)
                assert np.abs(jump).max() < 1e-6 * theta_scale
            shared += 1
    assert shared >= 3


def test_extrapolation_is_affine_and_continuous_at_the_hull(gen2d):
    tri = Delaunay(QUERIES_2D)
    a, b = QUERIES_2D[tri.convex_hull[0]]
    p = 0.5 * (a + b)
    out = p - np.mean(QUERIES_2D, axis=0)
    out /= np.linalg.norm(out)
    near = gen2d.parameters(p + 1e-9 * out) - gen2d.parameters(p - 1e-9 * out)
    assert np.abs(near).max() < 1e-5
    # Outside, along a line, the parameters stay affine as long as one simplex is used.
    f = [gen2d.parameters(p + s * out) for s in (1e-3, 2e-3, 3e-3)]
    np.testing.assert_allclose(f[2] - f[1], f[1] - f[0], rtol=1e-6, atol=1e-9)


def test_jacobian_matches_scipys_slopes_inside_a_simplex(gen2d):
    truth = LinearNDInterpolator(QUERIES_2D, np.array([fitted(q) for q in QUERIES_2D]))
    tri = Delaunay(QUERIES_2D)
    h = 1e-6
    for simplex in tri.simplices[:4]:
        c = QUERIES_2D[simplex].mean(axis=0)  # the centroid: a central difference stays inside
        expected = np.stack([(truth(c + h * e)[0] - truth(c - h * e)[0]) / (2 * h) for e in np.eye(2)], axis=1)
        np.testing.assert_allclose(gen2d.jacobian(c), expected, rtol=1e-5, atol=1e-5)


def test_repeats_are_averaged():
    db = database([0.0, 1.0, 2.0])
    db.add(1.0, trajectory(1.3), on_duplicate="keep")
    gen = dmprs.Generalizer(db, "linear", n_basis=N_BASIS)
    assert gen.n_demos == 4
    np.testing.assert_allclose(gen.parameters(1.0), 0.5 * (fitted(1.0) + fitted(1.3)), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(gen.parameters(2.0), fitted(2.0), rtol=1e-12, atol=1e-12)
    # two distinct queries plus a repeat: one interval, as the core would give without the repeat
    two = database([0.0, 1.0])
    two.add(0.0, trajectory(0.0), on_duplicate="keep")
    core = dmprs.Generalizer(database([0.0, 1.0]), "linear", n_basis=N_BASIS)
    np.testing.assert_allclose(dmprs.Generalizer(two, "linear", n_basis=N_BASIS).parameters(1.7),
                               core.parameters(1.7), rtol=1e-12, atol=1e-12)


def test_each_repeated_query_gets_the_mean_of_its_demos_bit_for_bit():
    # three demos at one query, two at another, interleaved with single ones
    db = database([0.0, 1.0, 2.0, 3.0])
    for q, shape in [(3.0, 1.3), (1.0, 1.6), (2.0, 2.2), (1.0, 0.7)]:
        db.add(q, trajectory(shape), on_duplicate="keep")
    dmps = dmprs.Generalizer(db, "linear", n_basis=N_BASIS).demo_dmps
    thetas = np.array([flat(d) for d in dmps])
    lin = PiecewiseLinear(db.queries, dmps)
    for node, q in enumerate([0.0, 1.0, 2.0, 3.0]):
        assert np.array_equal(lin._theta[node], thetas[db.queries[:, 0] == q].mean(axis=0))


def test_degenerate_and_far_queries_are_clear_errors(gen2d):
    with pytest.raises(InvalidInputError, match="lower-dimensional"):
        dmprs.Generalizer(database([[0.0, 0.0], [1.0, 1.0], [2.0, 2.0], [3.0, 3.0]]), "linear", n_basis=N_BASIS)
    with pytest.raises(ExtrapolationError, match="tau"):
        gen2d.predict([-40.0, -40.0])
    with pytest.raises(InvalidInputError, match="shape"):
        gen2d.predict([0.5, 0.5, 0.5])


@settings(max_examples=15, deadline=None)
@given(st.lists(st.floats(-1.0, 3.0), min_size=3, max_size=6, unique=True))
def test_1d_passes_through_every_demo_in_any_order(xs):
    if np.min(np.diff(sorted(xs))) < 1e-3:
        return
    gen = dmprs.Generalizer(database(xs), "linear", n_basis=N_BASIS)
    for x in xs:
        np.testing.assert_allclose(gen.parameters(x), fitted(x), rtol=1e-11, atol=1e-11)


@pytest.mark.parametrize("scale", [1e-10, 1.0, 1e10])
def test_spanning_queries_are_taken_whatever_the_units_of_a_dimension(scale):
    # a 4 x 4 grid (triangulated) and a triangle (the core's affine map), the second dimension
    # in units 1e-10, 1 or 1e10 times the first's: the span test is on each dimension's own range
    grid = [np.array([i, scale * j]) for i in range(4) for j in range(4)]
    gen = dmprs.Generalizer(database(grid), "linear", n_basis=N_BASIS)
    np.testing.assert_array_equal(gen.parameters(grid[5]), fitted(grid[5]))
    triangle = [np.array([0.0, 0.0]), np.array([1.0, 0.0]), np.array([0.0, scale])]
    dmprs.Generalizer(database(triangle), "linear", n_basis=N_BASIS)
    with pytest.raises(InvalidInputError, match="lower-dimensional"):
        dmprs.Generalizer(database([np.array([0.0, 0.0]), np.array([1.0, scale]), np.array([2.0, 2 * scale])]),
                          "linear", n_basis=N_BASIS)
