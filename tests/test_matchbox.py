"""The matchbox flip-up task: the Rapier simulation behind the adapter interface."""

import math

import numpy as np
import pytest

import dmprs
from dmprs.adapters import Status, check_adapter
from dmprs.tasks.matchbox import MatchboxAdapter, MatchboxFlip, simulate_batch, strike


@pytest.fixture(scope="module")
def adapter():
    return MatchboxAdapter()


def run(adapter, traj):
    with adapter:
        adapter.reset(seed=0)
        return adapter.execute(traj)


def test_the_adapter_conforms(adapter):
    check_adapter(adapter, strike(0.1))


def test_regimes_follow_strike_speed():
    durations = np.linspace(0.15, 0.06, 19)  # slow to fast
    regimes = [s["regime"] for s in simulate_batch(durations)]
    assert regimes[0] == "flipped_back" and regimes[-1] == "flipped_over"
    assert "upright" in regimes
    first, last = regimes.index("upright"), len(regimes) - 1 - regimes[::-1].index("upright")
    assert set(regimes[:first]) == {"flipped_back"}
    assert set(regimes[last + 1:]) == {"flipped_over"}


def test_measures_are_consistent(adapter):
    for d in (0.14, 0.1, 0.07):
        s = run(adapter, strike(d)).signals
        phi = np.asarray(s["phi"])
        assert phi.min() >= 0 and phi.max() <= math.pi
        assert s["phi_max"] == pytest.approx(phi.max())
        assert s["eps18"] == pytest.approx(s["outcome_angle"] - math.pi / 2)
        if s["regime"] == "flipped_back":
            assert math.isnan(s["t0"]) and s["outcome_angle"] == s["phi_max"] < math.pi / 2
        else:
            i = np.searchsorted(s["phi_t"], s["t0"] + 0.05)
            assert s["phi_after"] == pytest.approx(phi[i], abs=0.05)


def test_error_uses_eq13_sign():
    task = MatchboxFlip()
    back = run(task.adapter, strike(0.14))
    over = run(task.adapter, strike(0.07))
    assert task.error(math.pi / 2, back)[0] > 0  # flipped back: hit harder, raise the query
    assert task.error(math.pi / 2, over)[0] < 0
    assert task.error(math.pi / 2, back)[0] == pytest.approx(-back.signals["eps18"])


def test_repeat_episodes_are_bit_identical(adapter):
    a, b = run(adapter, strike(0.1)), run(adapter, strike(0.1))
    assert np.array_equal(a.signals["phi"], b.signals["phi"])
    assert a.signals["regime"] == b.signals["regime"]


def bad(adapter, traj):
    o = run(adapter, traj)
    assert o.status is Status.REJECTED
    return o.message


def test_nan_is_rejected(adapter):
    tr = strike(0.1)
    y = tr.y.copy()
    y[20, 1] = np.nan
    assert "y[20, 1] (finger_z) is not finite" in bad(adapter, dmprs.Trajectory._trusted(tr.t.copy(), y, None, None))


def test_wrong_dof_count_is_rejected(adapter):
    tr = strike(0.1)
    assert "3 DOFs" in bad(adapter, dmprs.Trajectory(tr.t, np.hstack([tr.y, tr.y[:, :1]])))


def test_too_short_is_rejected(adapter):
    tr = strike(0.1)
    assert "at least 3" in bad(adapter, dmprs.Trajectory(tr.t[:2], tr.y[:2]))


def test_through_the_table_is_rejected(adapter):
    tr = strike(0.1)
    y = tr.y.copy()
    y[:, 0] = np.linspace(y[0, 0], -0.03, len(y))  # sweeps sideways into the table slab
    assert "passes through the table" in bad(adapter, dmprs.Trajectory(tr.t, y))


def test_outside_the_workspace_is_rejected(adapter):
    tr = strike(0.1)
    y = tr.y.copy()
    y[:, 1] += np.linspace(0, 0.2, len(y))
    assert "above the maximum" in bad(adapter, dmprs.Trajectory(tr.t, y))


def test_bad_configuration_is_a_clear_error():
    with pytest.raises(dmprs.InvalidInputError, match="overhang"):
        MatchboxAdapter(overhang=0.05)
    with pytest.raises(dmprs.InvalidInputError, match="friction"):
        MatchboxAdapter(friction=-1.0)
    with pytest.raises(dmprs.InvalidInputError, match=r"paths\[1\]"):
        from dmprs import _core

        good = strike(0.1)
        cols = (good.t, np.ascontiguousarray(good.y[:, 0]), np.ascontiguousarray(good.y[:, 1]))
        _core.matchbox_simulate_batch([cols, (good.t, cols[1] - 0.05, cols[2])], _core.MatchboxConfig())


def test_learning_stands_the_box_up_as_in_the_paper():
    from dmprs import experiments

    # Fig. 4: eq. 16 with K = I, one demo flipped back and one over: within 5 trials (paper: 4).
    r = experiments.run("matchbox", demos="default", learner="error")
    assert r.converged and r.n_trials <= 5
    assert r.trials[-1].signals["regime"] == "upright"
    assert r.trials[0].query[0] == pytest.approx(math.pi / 2)  # the first trial is Ĝ(pi/2)
    # Fig. 7: both demos flipped back, pi/2 outside them (extrapolation), eq. 17: within 8.
    r = experiments.run("matchbox", demos="both_flipped_back", learner="weighted")
    assert r.converged and r.n_trials <= 8
    s = experiments.make("matchbox", demos="both_flipped_back")
    assert (s.database.queries < math.pi / 2).all()
