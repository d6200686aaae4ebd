"""Regressions for the reliability issue: each input here once panicked, aborted, hung, leaked a
non-dmprs exception type or returned garbage; now each gives a finite result or a clear error.
"""

from __future__ import annotations

import os
import signal
import threading
import time

import numpy as np
import pytest

import dmprs
from dmprs.errors import DmprsError, InvalidInputError, NumericalError

T50 = np.linspace(0.0, 1.0, 50)


@pytest.mark.parametrize("alpha_x", [17.5, 18.42])
def test_a_large_alpha_x_fits_up_to_the_design_matrix_floor(alpha_x: float) -> None:
    dmp = dmprs.DMP.fit(T50, np.sin(T50), alpha_x=alpha_x)
    assert np.isfinite(dmp.weights).all()
    db = dmprs.Database(["q"])
    for q in (0.0, 1.0):
        db.add([q], dmprs.Trajectory(T50, (1 + q) * np.sin(T50)))
    assert np.isfinite(dmprs.Generalizer(db, alpha_x=alpha_x).predict([0.5]).weights).all()


def test_a_fit_whose_phase_falls_below_the_design_matrix_floor_is_refused() -> None:
    # The fuzz campaign's case: three samples, alpha_x = 22.6. Fitted, its rollout went to 1587
    # for a 0.5 movement; now the fit says why it cannot be done, for a DMP and a generalizer.
    with pytest.raises(InvalidInputError, match=r"alpha_x = 22\.6 is invalid: must be at most 18\.42"):
        dmprs.DMP.fit([0, 2.5, 5], [0, 0.35, 0.5], n_basis=2, alpha_z=98, alpha_x=22.6, width_factor=5)
    db = dmprs.Database(["q"])
    for q in (0.0, 1.0):
        db.add([q], dmprs.Trajectory(T50, (1 + q) * np.sin(T50)))
    for method in ("linear", "lwr-gp"):
        with pytest.raises(InvalidInputError, match="alpha_x = 30 is invalid"):
            dmprs.Generalizer(db, method, alpha_x=30.0)


def test_a_rollout_is_bounded_in_work_even_until_rest() -> None:
    # 900 Euler sub-steps per sample (alpha_z = 9e5 at dt / tau = 1e-3): 100 s of it is
    # refused at once; going on "until rest" with an unreachable tolerance stops at the same
    # bound (after a few seconds at most), instead of running for minutes.
    dmp = dmprs.DMP(np.ones((1, 25)), [1.0], [0.0], 1.0, alpha_z=9e5)
    with pytest.raises(NumericalError, match="more than the 5e7 state updates"):
        dmp.rollout(duration=100.0)
    with pytest.raises(NumericalError, match="more than the 5e7 state updates"):
        dmp.rollout(until_rest=True, rest_tol=1e-300)


def test_a_stiff_rollout_is_stable_and_ends_near_the_demonstration() -> None:
    t = np.linspace(0.0, 0.01, 11)
    dmp = dmprs.DMP.fit(t, np.sin(50 * t))
    for duration in (None, 2.0):
        tr = dmp.rollout(duration=duration)
        assert np.isfinite(tr.y).all()
    # With until_rest it reaches the goal (it used to end at -16.3, or 3e294 with duration=2).
    assert abs(dmp.rollout(until_rest=True).y[-1, 0] - np.sin(0.5)) < 1e-3


@pytest.mark.parametrize(
    "make",
    [
        lambda d: d.with_goal([1e308]).rollout(),
        lambda d: dmprs.rollout_batch([d.with_goal([1e308])]),
        lambda d: d.with_start([-1e308]).with_goal([1e308]).rollout(),
    ],
)
def test_an_overflowing_rollout_is_an_error_not_a_result(make) -> None:
    with pytest.raises(NumericalError, match=r"too large for f64"):
        make(dmprs.DMP.fit(T50, np.sin(T50)))


def test_a_step_too_coarse_for_the_stiffness_is_refused_naming_it() -> None:
    dmp = dmprs.DMP.fit(T50, np.sin(T50), alpha_z=1e9)
    with pytest.raises(NumericalError, match=r"dt = 0.001 .*tau = 1\b.*alpha_z = 1e9"):
        dmp.rollout()


def test_stiff_but_valid_settings_give_finite_rollouts() -> None:
    # alpha_z = 1e4 used to give 496 NaN of 1001 values; tau = 1 ms at dt = 1 ms inf.
    assert np.isfinite(dmprs.DMP.fit(T50, np.sin(T50), alpha_z=1e4).rollout().y).all()
    assert np.isfinite(dmprs.DMP.fit(T50, np.sin(T50)).with_tau(1e-3).rollout(duration=1.0).y).all()


@pytest.mark.parametrize(
    "call, name",
    [
        (lambda: dmprs.DMP.fit(T50, np.sin(T50), n_basis=10_000), "n_basis = 10000"),
        (lambda: dmprs.DMP.fit(T50, np.sin(T50), n_basis=2**70), "n_basis"),
        (lambda: dmprs.GaussianProcess(n_restarts=10**6).fit(T50, np.sin(T50)), "n_restarts = 1000000"),
        (lambda: dmprs.GaussianProcess(max_iter=2**64).fit(T50, np.sin(T50)), "max_iter"),
    ],
)
def test_sizes_that_cannot_be_meant_are_refused_at_once(call, name: str) -> None:
    start = time.perf_counter()
    with pytest.raises(InvalidInputError, match=name):
        call()
    assert time.perf_counter() - start < 1.0


def test_a_long_gp_fit_stops_on_ctrl_c() -> None:
    x = np.linspace(0.0, 10.0, 300)
    gp = dmprs.GaussianProcess(n_restarts=1000)
    # Python installs its KeyboardInterrupt handler only if SIGINT was not ignored at start, and a
    # shell ignores SIGINT in background jobs (`&`, nohup): set the handler this test relies on.
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    timer = threading.Timer(0.3, os.kill, (os.getpid(), signal.SIGINT))
    start = time.perf_counter()
    try:
        timer.start()
        with pytest.raises(KeyboardInterrupt):
            gp.fit(x, np.sin(x))
    finally:
        timer.join()
        signal.signal(signal.SIGINT, previous)
    # A thousand restarts at m = 300 take minutes; the interrupt lands within one restart.
    assert time.perf_counter() - start < 10.0


@pytest.mark.parametrize(
    "call",
    [
        lambda d: d.rollout(dt=2**2000),
        lambda d: d.rollout(dt="0.01"),
        lambda d: d.with_tau("1"),
        lambda d: d.rollout(until_rest="no"),
        lambda d: dmprs.rollout_batch(None),
        lambda d: dmprs.DMP.from_dict({**d.to_dict(), "tau": 10**400}),
        lambda d: dmprs.DMP.from_dict({**d.to_dict(), "unknown": 1}),
        lambda d: dmprs.DMP.from_dict({**d.to_dict(), "beta_z": None}),
        lambda d: dmprs.DMP.from_dict({**d.to_dict(), "version": True}),
        lambda d: dmprs.GaussianProcess(signal_var_bounds=(2.0, 1.0)).fit(T50, T50, optimize=False),
    ],
)
def test_garbage_and_overflowing_arguments_are_invalid_input(call) -> None:
    with pytest.raises(InvalidInputError):
        call(dmprs.DMP.fit(T50, np.sin(T50)))


def test_messages_name_what_the_caller_passed() -> None:
    with pytest.raises(InvalidInputError, match=r"^y = values up to .*e199 .*rescale") as info:
        dmprs.GaussianProcess().fit(T50, np.sin(T50) * 1e200)
    assert "signal_var" not in str(info.value)
    db = dmprs.Database(["q"])
    for q in (0.0, 1.0, 2.0):
        db.add([q], dmprs.Trajectory(T50, (1 + q) * T50))
    with pytest.raises(InvalidInputError, match=r"gp_noise = 1e-300 "):
        dmprs.Generalizer(db, "lwr-gp", gp_noise=1e-300)
    with pytest.raises(InvalidInputError, match=r"^dt = 1e-300 is invalid"):
        dmprs.DMP.fit(T50, T50).rollout(dt=1e-300)


def test_every_error_above_is_a_dmprs_error() -> None:
    assert issubclass(InvalidInputError, DmprsError) and issubclass(NumericalError, DmprsError)
