"""The periodic stepper: the rollout's step when nothing is in play, and around it a start and a
stop at rest, filtered changes, phase stopping and limits, every command consistent.
"""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import dmprs
from dmprs import DmprsError
from dmprs.errors import InvalidInputError

DT = 0.001
PERIOD = 0.8


def rhythm() -> dmprs.PeriodicDMP:
    t = np.arange(0.0, 2 * PERIOD, DT)
    w = 2 * math.pi / PERIOD
    y = np.column_stack([0.3 * np.sin(w * t) + 0.1 * np.cos(2 * w * t), 1.0 + 0.2 * np.cos(w * t)])
    return dmprs.PeriodicDMP.fit(t, y, period=PERIOD, n_basis=30)


def run(stepper, steps: int, events=None, measured=None):
    """The commands of ``steps`` steps as arrays (y, yd, ydd), with events[k]() before step k
    and measured(k, last_y) as the measurement.
    """
    out = np.empty((3, steps, stepper.n_dof))
    last = None
    for k in range(steps):
        if events and k in events:
            events[k](stepper)
        m = None if measured is None or last is None else measured(k, last)
        y, yd, ydd = stepper.step(m)
        out[:, k] = (y, yd, ydd)
        last = out[0, k]
    return out


def test_with_nothing_in_play_it_is_the_rollout_bit_for_bit() -> None:
    dmp = rhythm()
    tr = dmp.rollout(DT, duration=3.0, phase=0.7)
    got = run(dmp.stepper(DT, ramp=0.0, phase=0.7), len(tr.t))
    assert np.array_equal(got[0], tr.y) and np.array_equal(got[1], tr.yd) and np.array_equal(got[2], tr.ydd)


def test_every_command_is_consistent_through_changes_a_held_robot_and_the_stop() -> None:
    dmp = rhythm()
    events = {1000: lambda s: s.set_tau(dmp.tau / 1.5), 2000: lambda s: s.set_goal([0.2, 0.8]),
              2500: lambda s: s.set_amplitude(2 * dmp.amplitude), 5000: lambda s: s.stop()}
    held = np.array([0.0, 1.0])

    def measured(k, last):
        return held if 3000 <= k < 3400 else last

    y, yd, ydd = run(dmp.stepper(DT, velocity_max=3.0), 8000, events, measured)
    np.testing.assert_allclose(yd[1:], yd[:-1] + DT * ydd[:-1], rtol=0, atol=1e-9)
    np.testing.assert_allclose(y[1:], y[:-1] + DT * yd[1:], rtol=0, atol=1e-12)
    assert np.isfinite(y).all() and np.abs(yd).max() <= 3.0 * (1 + 1e-12)


def test_it_starts_and_stops_at_rest_with_the_acceleration_of_the_steady_rhythm() -> None:
    # faded in over one period from rest at the start, out over one after stop(): the commanded
    # acceleration stays within 1.25 times the steady rhythm's largest
    dmp = rhythm()
    stepper = dmp.stepper(DT, ramp=1.0)
    steps_in = int(6 * PERIOD / DT)
    y, yd, ydd = run(stepper, steps_in)
    assert np.array_equal(y[0], dmp.start) and not yd[0].any()
    steady = np.abs(dmp.rollout(DT, duration=6 * PERIOD).ydd[int(4 * PERIOD / DT):]).max(axis=0)
    stepper.stop()
    tail = run(stepper, int(4 * PERIOD / DT))
    assert stepper.done()
    np.testing.assert_allclose(tail[0][-1], dmp.goal, atol=1e-9)
    np.testing.assert_allclose(tail[1][-1], 0.0, atol=1e-9)
    peak = np.abs(np.concatenate([ydd, tail[2]])).max(axis=0)
    assert (peak <= 1.25 * steady).all(), peak / steady


def test_a_new_period_amplitude_and_baseline_are_reached() -> None:
    dmp = rhythm()
    stepper = dmp.stepper(DT, ramp=0.0)
    run(stepper, 2000)
    stepper.set_tau(dmp.tau * 1.25)
    stepper.set_amplitude(0.5 * dmp.amplitude)
    stepper.set_goal(dmp.goal + np.array([0.1, -0.1]))
    y = run(stepper, 8000)[0][-int(PERIOD * 1.25 / DT):]  # the last new period
    reference = dmp.with_tau(dmp.tau * 1.25).with_amplitude(0.5 * dmp.amplitude).with_goal(dmp.goal + np.array([0.1, -0.1]))
    steady = reference.rollout(DT, duration=6 * reference.period).y[-len(y):]
    np.testing.assert_allclose(np.ptp(y, axis=0), np.ptp(steady, axis=0), rtol=1e-3)
    np.testing.assert_allclose((y.max(0) + y.min(0)) / 2, (steady.max(0) + steady.min(0)) / 2, atol=1e-3)
    assert stepper.nominal_tau == pytest.approx(dmp.tau * 1.25, rel=1e-12)


def test_a_held_robot_holds_the_phase_and_the_rhythm_resumes() -> None:
    dmp = rhythm()
    stepper = dmp.stepper(DT, ramp=0.0)
    run(stepper, 500)
    phase = stepper.phase
    held = stepper.step()[0].copy() + 0.05
    for _ in range(1000):
        stepper.step(held)
    # a second held 0.05 off: the clock slowed by 1 + 1e4 (2 x 0.05^2) = 51
    assert stepper.phase - phase < 1.0 / dmp.tau / 40
    y = stepper.step()[0]
    assert stepper.tau == dmp.tau  # released (no limits to respect): the nominal clock at once
    assert np.isfinite(y).all()


def test_limits_hold_on_every_command() -> None:
    dmp = rhythm().with_tau(rhythm().tau / 2)  # twice as fast
    free = np.abs(dmp.rollout(DT, duration=3 * dmp.period).yd).max(axis=0)
    vmax = 0.5 * free
    _, yd, _ = run(dmp.stepper(DT, ramp=0.0, velocity_max=vmax), 4000)
    assert (np.abs(yd) <= vmax * (1 + 1e-12)).all()
    free_acc = np.abs(dmp.rollout(DT, duration=3 * dmp.period).ydd).max(axis=0)
    amax = 0.5 * free_acc
    for ramp in (0.0, 1.0):
        stepper = dmp.stepper(DT, ramp=ramp, acceleration_max=amax)
        flagged, within = [], []
        for _ in range(4000):
            ydd = stepper.step()[2]
            flagged.append(stepper.over_limit())
            within.append(bool((np.abs(ydd) <= amax * (1 + 1e-12)).all()))
        # met on every sample the coupling's feasibility condition allows, and each other sample
        # flagged: none at full amplitude, a few as the envelope rises
        assert all(w or f for w, f in zip(within, flagged, strict=True))
        assert sum(flagged) <= (0 if ramp == 0.0 else 4), sum(flagged)


def test_a_copy_steps_as_the_original_bit_for_bit() -> None:
    stepper = rhythm().stepper(DT)
    run(stepper, 700)
    twin = copy.deepcopy(stepper)
    assert type(twin) is type(stepper)
    a, b = run(stepper, 500), run(twin, 500)
    assert np.array_equal(a, b)


def test_bad_options_and_measurements_are_named_and_change_nothing() -> None:
    dmp = rhythm()
    for options, name in [({"ramp": -1.0}, "ramp"), ({"change_filter": 0.0}, "change_filter"),
                          ({"velocity_max": 0.0}, "velocity_max"), ({"alpha_e": -1.0}, "alpha_e")]:
        with pytest.raises(InvalidInputError, match=name):
            dmp.stepper(DT, **options)
    with pytest.raises(InvalidInputError, match="dt"):
        dmp.stepper(0.2)  # one Euler step of 0.2 s at tau 0.13: the spring is unstable
    with pytest.raises(InvalidInputError, match=r"dmprs\.PeriodicDMP"):
        dmprs.PeriodicStepper(dmprs.DMP.fit(np.linspace(0, 1, 50), np.linspace(0, 1, 50)))
    stepper = dmp.stepper(DT)
    with pytest.raises(InvalidInputError, match="tau"):
        stepper.set_tau(1e-4)
    with pytest.raises(InvalidInputError, match=r"^tau = 1e-9 is invalid: is too short for dt"):
        stepper.set_tau(1e-9)  # beyond the sub-steps the rollout would take: the option is named
    run(stepper, 10)
    phase, steps = stepper.phase, stepper.steps
    for bad in ([np.nan, 1.0], [1.0], [1e300, 1.0]):
        with pytest.raises(DmprsError, match="measured"):
            stepper.step(bad)
    for call, arg, name in [("set_goal", [1.0], "goal"), ("set_amplitude", [np.inf, 1.0], "amplitude"),
                            ("stop", [0.0, 0.0, 0.0], "rest")]:
        with pytest.raises(DmprsError, match=name):
            getattr(stepper, call)(arg)
    assert (stepper.phase, stepper.steps) == (phase, steps)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 5), st.floats(-1e3, 1e3, allow_nan=False)), max_size=12),
       st.floats(1e-4, 2e-2), st.booleans())
def test_whatever_it_is_told_it_sends_finite_commands_within_its_velocity_limit_or_refuses(
    calls: list[tuple[int, float]], dt: float, measuring: bool
) -> None:
    # hostile calls between steps (baselines and amplitudes up to 1e3, any tau, measurements up
    # to 1e3 off): each either is refused with a dmprs error, changing nothing, or taken; every
    # command sent is finite and within the velocity limit
    dmp = rhythm()
    stepper = dmp.stepper(dt, velocity_max=2.0)
    actions = [
        lambda v: stepper.set_goal([v, -v]),
        lambda v: stepper.set_amplitude([abs(v), 1.0]),
        lambda v: stepper.set_tau(abs(v) * 1e-3),
        lambda v: stepper.stop([v, 0.0]),
        lambda v: stepper.step([v, v]),
        lambda v: None,
    ]
    for action, value in calls:
        try:
            actions[action](value)
        except DmprsError:
            pass
        for _ in range(50):
            try:
                y, yd, ydd = stepper.step(stepper.step()[0] + 0.01 if measuring else None)
            except DmprsError:
                break
            assert np.isfinite(y).all() and np.isfinite(yd).all() and np.isfinite(ydd).all()
            assert (np.abs(yd) <= 2.0 * (1 + 1e-12)).all()
