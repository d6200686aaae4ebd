"""Every kind of bad input gets a DmprsError (also a ValueError) that says what and where.
One test per case; none may reach Python as a panic.
"""

import numpy as np
import pytest

import dmprs
from dmprs.errors import InvalidInputError


@pytest.fixture
def t() -> np.ndarray:
    return np.linspace(0.0, 1.0, 50)


@pytest.fixture
def y(t) -> np.ndarray:
    return np.stack([t**2, np.sin(t)], axis=1)


@pytest.fixture
def dmp(t, y) -> dmprs.DMP:
    return dmprs.DMP.fit(t, y, 10)


def raises(match: str):
    return pytest.raises(InvalidInputError, match=match)


def test_errors_are_dmprs_errors_and_value_errors():
    assert issubclass(InvalidInputError, dmprs.DmprsError)
    assert issubclass(InvalidInputError, ValueError)
    assert issubclass(dmprs.NumericalError, dmprs.DmprsError)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_positions(t, y, bad):
    y = y.copy()
    y[7, 1] = bad
    with raises(r"y\[7, 1\] is (NaN|inf|-inf): all values must be finite"):
        dmprs.DMP.fit(t, y)


def test_non_finite_time(t, y):
    t = t.copy()
    t[3] = np.nan
    with raises(r"t\[3\] is NaN"):
        dmprs.DMP.fit(t, y)


@pytest.mark.parametrize("name", ["yd", "ydd"])
def test_non_finite_derivatives(t, y, name):
    d = np.zeros_like(y)
    d[4, 0] = np.inf
    with raises(rf"{name}\[4, 0\] is inf"):
        dmprs.DMP.fit(t, y, **{name: d})


def test_mismatched_lengths(t, y):
    with raises("y has shape"):
        dmprs.DMP.fit(t[:-1], y)


def test_mismatched_derivative_shape(t, y):
    with raises("yd has shape"):
        dmprs.DMP.fit(t, y, yd=np.zeros((50, 3)))


def test_too_few_samples(t, y):
    with raises("t has 2 samples, but 3 are needed"):
        dmprs.DMP.fit(t[:2], y[:2])


def test_repeated_time(t, y):
    t = t.copy()
    t[5] = t[4]
    with raises(r"t must be strictly increasing, but t\[5\]"):
        dmprs.DMP.fit(t, y)


def test_decreasing_time(t, y):
    with raises(r"strictly increasing, but t\[1\]"):
        dmprs.DMP.fit(t[::-1], y)


@pytest.mark.parametrize("n", [1, 0, -3])
def test_too_few_basis_functions(t, y, n):
    with raises("n_basis = .* must be at least 2"):
        dmprs.DMP.fit(t, y, n_basis=n)


def test_non_integer_basis_count(t, y):
    with raises("n_basis must be an integer"):
        dmprs.DMP.fit(t, y, n_basis=2.5)


@pytest.mark.parametrize("dt", [0.0, -0.001])
def test_non_positive_dt(dmp, dt):
    with raises("dt = .* must be > 0"):
        dmp.rollout(dt=dt)


@pytest.mark.parametrize("dt", [np.nan, np.inf])
def test_non_finite_dt(dmp, dt):
    with raises("dt is (nan|inf)"):
        dmp.rollout(dt=dt)


def test_dt_too_small_for_duration(dmp):
    with raises("too small for the duration"):
        dmp.rollout(dt=1e-12)


@pytest.mark.parametrize("duration", [0.0, -1.0])
def test_non_positive_duration(dmp, duration):
    with raises("duration = .* must be > 0"):
        dmp.rollout(duration=duration)


def test_wrong_rank_of_y(t):
    with raises(r"y must be 1-D or 2-D; got a 3-D array"):
        dmprs.DMP.fit(t, np.zeros((50, 2, 2)))


def test_wrong_rank_of_t(y):
    with raises(r"t must be 1-D; got a 2-D array"):
        dmprs.DMP.fit(np.zeros((50, 1)), y)


@pytest.mark.parametrize(
    "value, dtype",
    [(np.zeros((50, 2), dtype=bool), "bool"), (np.zeros((50, 2), dtype=complex), "complex128"),
     (np.array([["a", "b"]] * 50), "<U1")],
)
def test_non_real_dtypes_are_rejected(t, value, dtype):
    with raises(f"y has dtype {dtype}; expected real numbers"):
        dmprs.DMP.fit(t, value)


def test_ragged_input(t):
    with raises("y cannot be read as an array"):
        dmprs.DMP.fit(t, [[1.0, 2.0], [3.0]] * 25)


def test_bad_tau(dmp):
    for tau in (0.0, -1.0):
        with raises("tau = .* must be > 0"):
            dmp.with_tau(tau)
    with raises("tau is nan"):
        dmp.with_tau(float("nan"))


def test_goal_of_the_wrong_length(dmp):
    with raises(r"goal has shape \(3,\)"):
        dmp.with_goal([1.0, 2.0, 3.0])


def test_nan_goal_and_start(dmp):
    with raises(r"goal\[1\] is NaN"):
        dmp.with_goal([0.0, np.nan])
    with raises(r"start\[0\] is inf"):
        dmp.with_start([np.inf, 0.0])


def test_nan_weights():
    w = np.zeros((1, 5))
    w[0, 3] = np.nan
    with raises(r"weights\[0, 3\] is NaN"):
        dmprs.DMP(w, [0.0], [0.0], 1.0)


def test_weights_goal_mismatch():
    with raises("weights has 2 rows"):
        dmprs.DMP(np.zeros((2, 5)), [0.0], [0.0], 1.0)


def test_bad_constants(t, y):
    with raises("alpha_z = -1 is invalid"):
        dmprs.DMP.fit(t, y, alpha_z=-1.0)
    with raises("alpha_x is nan"):
        dmprs.DMP.fit(t, y, alpha_x=float("nan"))


def test_from_dict_rejects_foreign_and_newer_dicts(dmp):
    d = dmp.to_dict()
    with raises("not a DMP dict"):
        dmprs.DMP.from_dict({**d, "type": "other"})
    with raises("version 3 is not supported"):
        dmprs.DMP.from_dict({**d, "version": 3})
    with raises("missing tau"):
        dmprs.DMP.from_dict({k: v for k, v in d.items() if k != "tau"})
    with raises("expected a dict"):
        dmprs.DMP.from_dict([1, 2])  # type: ignore[arg-type]


def test_rollout_batch_rejects_non_dmps(dmp):
    with raises(r"dmps\[1\] is a str"):
        dmprs.rollout_batch([dmp, "x"])


def test_a_batch_too_large_for_memory_is_refused_before_it_runs():
    # 40 rollouts of 2800 s at 1 ms, each within its own bound: 40 x 8 B x (1 + 3 x 7) x 2.8e6
    # samples = 19.7 GB in all, once allocated until the process was killed
    seven = dmprs.DMP(np.zeros((7, 25)), np.ones(7), np.zeros(7), 1.0)
    pose = dmprs.CartesianDMP(np.zeros((6, 25)), [1, 0, 0, 1, 0, 0, 0], [0, 0, 0, 1, 0, 0, 0], 1.0)
    with raises(r"dmps: 40 rollouts of dt = 0\.001 would take 19\.7 GB in all, beyond 4 GB"):
        dmprs.rollout_batch([seven] * 40, 0.001, 2800.0)
    with raises(r"dmps: 3 rollouts .* would take 4\.96 GB"):  # kinds mixed: 8 B x (20 x 2 + 22) x 1e7
        dmprs.rollout_batch([pose, seven, pose], 0.001, 1e4)
    assert len(dmprs.rollout_batch([seven, pose] * 2, 0.001, 60.0)) == 4


CONSTANTS = {"alpha_z": 48.0, "beta_z": 12.0, "alpha_x": 2.0, "width_factor": 2.0}


def test_core_called_directly_still_validates():
    # The bindings are a boundary too: the Rust checks hold without the Python wrapper.
    from dmprs import _core

    with raises("n_basis = 1 is invalid"):
        _core.Dmp.fit(np.linspace(0, 1, 5), np.zeros((5, 1)), None, None, 1, CONSTANTS)
    with raises("dt = -1 is invalid"):
        _core.Dmp(np.zeros((1, 3)), np.zeros(1), np.zeros(1), 1.0, CONSTANTS).rollout(-1.0)
