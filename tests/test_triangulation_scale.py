"""Piecewise-linear generalization over many demonstrations: locating the query and comparing only
the simplices around it picks exactly what comparing all of them picks, ties included.
"""

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from dmprs import portable, triangulation
from dmprs.dmp import DMP
from dmprs.triangulation import PiecewiseLinear

T = np.linspace(0.0, 1.0, 30)


def generalizer(nodes: np.ndarray) -> PiecewiseLinear:
    # tiny DMPs: what is compared here is the simplex choice, not the fit
    dmps = [DMP.fit(T, np.outer(T, [1.0 + q[0], 2.0 - q[1]]), 4) for q in nodes]
    return PiecewiseLinear(nodes, dmps)


@pytest.fixture(scope="module")
def grid() -> PiecewiseLinear:
    # a jittered 24 x 24 grid (several hundred simplices) with exact grid rows left in, so that
    # cocircular points and queries on shared edges and nodes are common
    rng = np.random.default_rng(7)
    x, y = np.meshgrid(np.arange(24.0), np.arange(24.0))
    nodes = np.stack([x.ravel(), y.ravel()], axis=1)
    nodes[::3] += rng.uniform(-0.3, 0.3, (len(nodes[::3]), 2))
    gen = generalizer(nodes)
    assert len(gen._simplices) >= triangulation.LOCAL_SEARCH_FROM
    return gen


def full_scan(gen: PiecewiseLinear, q: np.ndarray) -> tuple:
    with pytest.MonkeyPatch.context() as m:
        m.setattr(triangulation, "LOCAL_SEARCH_FROM", 10**9)
        return gen._coordinates(q)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.data())
def test_the_local_search_picks_what_the_full_scan_picks(grid, data):
    nodes = grid._nodes
    kind = data.draw(st.sampled_from(["node", "edge", "inside", "outside"]))
    i, j = data.draw(st.integers(0, len(nodes) - 1)), data.draw(st.integers(0, len(nodes) - 1))
    if kind == "node":
        q = nodes[i].copy()
    elif kind == "edge":
        s = grid._simplices[i % len(grid._simplices)]
        q = 0.5 * (nodes[s[0]] + nodes[s[1]])
    elif kind == "inside":
        q = nodes[i] + data.draw(st.floats(0.0, 1.0)) * (nodes[j] - nodes[i])
    else:
        q = np.array([data.draw(st.floats(-30.0, 60.0)), data.draw(st.floats(-30.0, 60.0))])
    idx, b = grid._coordinates(q)
    idx0, b0 = full_scan(grid, q)
    assert idx.tolist() == idx0.tolist()
    assert b.tobytes() == b0.tobytes()  # bit for bit
    assert grid.parameters(q).tobytes() == portable.combine(b0, grid._theta[idx0]).tobytes()


def test_demos_are_reproduced_exactly_through_the_local_search(grid):
    for k in range(0, len(grid._nodes), 37):
        theta = grid.parameters(grid._nodes[k])
        np.testing.assert_allclose(theta, grid._theta[k], rtol=1e-12, atol=1e-12)
