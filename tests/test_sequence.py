"""dmprs.Sequence against independent truth: the DMP itself (a sequence of one), eq. 1 at a join
(the acceleration an unaided start would jump to), the integrator's own Euler relations across
every join and the order in dt of what is left, each DMP's own rollout (where each movement
ends), the stepper against the rollout, and the refusals.
"""

from __future__ import annotations

import copy
import pickle

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import dmprs
from dmprs.sequence import Sequence, SequenceStepper
from tests.conftest import min_jerk
from tests.test_stepper import run

#: waypoints of a 3-DOF reach, place and return
WAYPOINTS = np.array([[0.0, 0.5, -0.2], [1.0, -0.3, 0.4], [0.2, 0.7, 1.0], [-0.5, 0.1, 0.3]])
TAUS = (0.6, 0.45, 0.8)


def leg(a: np.ndarray, b: np.ndarray, tau: float, final_velocity=None) -> dmprs.DMP:
    """A DMP fitted to a min-jerk move from ``a`` to ``b`` with a bump (at rest at both ends),
    or, with ``final_velocity``, to one reaching ``b`` with that velocity.
    """
    t = np.linspace(0.0, tau, 600)
    s = t / tau
    y = a + np.outer(min_jerk(s), b - a) + 0.2 * np.outer(np.sin(np.pi * s) ** 2, [1.0, -1.0, 0.5])
    if final_velocity is not None:
        # s^5 - s^4 has value 0 and slope 1 at s = 1, 0 and flat at s = 0.
        y = y + np.outer(tau * (s**5 - s**4), final_velocity)
    return dmprs.DMP.fit(t, y, 30, final_velocity=final_velocity)


def legs() -> list[dmprs.DMP]:
    return [leg(WAYPOINTS[k], WAYPOINTS[k + 1], TAUS[k]) for k in range(3)]


def moving_legs() -> list[dmprs.DMP]:
    """Movements that hand over in motion (the first two reach their goals moving)."""
    v = [np.array([0.8, -0.5, 0.3]), np.array([-0.6, 0.4, 0.9]), None]
    return [leg(WAYPOINTS[k], WAYPOINTS[k + 1], TAUS[k], v[k]) for k in range(3)]


def joins(taus, dt: float) -> list[int]:
    """The samples at which movements 1, 2, ... start: their taus in whole steps, one after
    the other.
    """
    return list(np.cumsum([round(t / dt) for t in taus[:-1]]))


def unaided_acceleration(dmp: dmprs.DMP, y: np.ndarray, yd: np.ndarray) -> np.ndarray:
    """Eq. 1 at phase 1 from ``(y, yd)``: the first acceleration of ``dmp`` started there
    without the join's term, ``(alpha_z (beta_z (g - y) - tau yd) + f(1)) / tau^2``.
    """
    psi = np.exp(-dmp.widths * (1.0 - dmp.centers) ** 2)
    f = dmp.weights @ psi / psi.sum()
    return (dmp.alpha_z * (dmp.beta_z * (dmp.goal - y) - dmp.tau * yd) + f) / dmp.tau**2


# --- a sequence of one ----------------------------------------------------------------------------

@pytest.mark.parametrize("options", [{}, {"until_rest": True}, {"duration": 1.3}])
def test_a_sequence_of_one_is_its_dmp(options) -> None:
    dmp = legs()[0]
    seq, own = Sequence([dmp]).rollout(0.002, **options), dmp.rollout(0.002, **options)
    for name in ("t", "y", "yd", "ydd"):
        assert np.array_equal(getattr(seq, name), getattr(own, name)), name


def test_the_stepper_of_one_is_its_dmps_stepper() -> None:
    dmp = legs()[1]
    seq, own = Sequence([dmp]).stepper(0.001), dmp.stepper(0.001)
    for k in range(1500):
        held = own.output[0] - (0.01 if 200 <= k < 400 else 0.0)  # phase stopping for a while
        a, b = seq.step(held), own.step(held)
        assert all(np.array_equal(x, y) for x, y in zip(a, b, strict=True)), k
        assert seq.done() == own.done()


# --- the joins ------------------------------------------------------------------------------------

def test_the_movements_follow_one_another_at_their_taus() -> None:
    seq = Sequence(legs())
    tr = seq.rollout(0.001)
    assert tr.n_samples == 600 + 450 + 800 + 1
    np.testing.assert_array_equal(tr.t, np.arange(tr.n_samples) * 0.001)
    stepper = seq.stepper(0.001)
    active = []
    for _ in range(tr.n_samples):
        stepper.step()
        active.append(stepper.active)
    assert np.flatnonzero(np.diff(active)).tolist() == [j - 1 for j in joins(TAUS, 0.001)]


@pytest.mark.parametrize("make", [legs, moving_legs])
def test_position_and_velocity_go_on_as_the_integrator_steps(make) -> None:
    dt = 0.001
    tr = Sequence(make()).rollout(dt)
    for j in joins(TAUS, dt):
        np.testing.assert_allclose(tr.y[j], tr.y[j - 1] + tr.yd[j - 1] * dt, rtol=0, atol=1e-12)
        np.testing.assert_allclose(tr.yd[j], tr.yd[j - 1] + tr.ydd[j - 1] * dt, rtol=0, atol=1e-10)


def test_the_joins_jumps_are_first_order_in_dt() -> None:
    """Halving dt halves the jump of y, yd and ydd across every join (a join in motion)."""
    dmps = moving_legs()
    jumps = []
    for dt in (0.002, 0.001, 0.0005):
        tr = Sequence(dmps).rollout(dt)
        jumps.append([[np.abs(v[j] - v[j - 1]).max() for v in (tr.y, tr.yd, tr.ydd)] for j in joins(TAUS, dt)])
    jumps_ = np.array(jumps)  # (dt, join, y/yd/ydd)
    ratios = jumps_[:-1] / jumps_[1:]
    assert np.all((ratios > 1.7) & (ratios < 2.3)), ratios


def test_an_unaided_start_would_jump_in_acceleration() -> None:
    """What the join's term removes: eq. 1 started at the join without it jumps by O(1); with
    it the join's sample changes ydd as the samples before it do.
    """
    dmps, dt = moving_legs(), 0.001
    tr = Sequence(dmps).rollout(dt)
    for k, j in enumerate(joins(TAUS, dt), start=1):
        unaided = unaided_acceleration(dmps[k], tr.y[j], tr.yd[j])
        would = np.abs(unaided - tr.ydd[j - 1]).max()
        did = np.abs(tr.ydd[j] - tr.ydd[j - 1]).max()
        before = np.abs(tr.ydd[j - 1] - tr.ydd[j - 2]).max()
        assert did < 1.5 * before and would > 20 * did, (k, would, did, before)


def test_each_movement_ends_where_its_dmp_takes_it() -> None:
    """By its tau the start in motion and the join's term have faded: a movement ends where its
    own DMP's rollout from rest at the same start ends, and a fitted one at its goal.
    """
    dmps, dt = legs(), 0.001
    tr = Sequence(dmps).rollout(dt)
    starts = joins(TAUS, dt)
    ends = [*(j - 1 for j in starts[1:]), tr.n_samples - 1]
    for k, (j0, end) in enumerate(zip(starts, ends, strict=True), start=1):
        own = dmps[k].with_start(tr.y[j0]).rollout(dt)
        np.testing.assert_allclose(tr.y[end], own.y[end - j0], rtol=0, atol=1e-6)
    for k, end in enumerate([starts[0] - 1, *ends]):
        np.testing.assert_allclose(tr.y[end], WAYPOINTS[k + 1], atol=2e-2)
    rest = Sequence(dmps).rollout(dt, until_rest=True)
    np.testing.assert_allclose(rest.y[-1], WAYPOINTS[-1], rtol=0, atol=1e-4)
    np.testing.assert_allclose(rest.yd[-1], 0.0, atol=1e-3)


# --- the stepper ----------------------------------------------------------------------------------

def test_the_stepper_is_the_rollout_bit_for_bit() -> None:
    seq = Sequence(moving_legs())
    tr = seq.rollout(0.001)
    y, yd, ydd = run(seq.stepper(0.001), tr.n_samples)
    assert np.array_equal(y, tr.y) and np.array_equal(yd, tr.yd) and np.array_equal(ydd, tr.ydd)


def test_a_copy_steps_on_as_the_original_across_a_join() -> None:
    stepper = Sequence(legs()).stepper(0.001)
    run(stepper, 500)
    twin = copy.deepcopy(stepper)
    assert type(twin) is SequenceStepper
    a, b = run(stepper, 400), run(twin, 400)  # across the join at 600
    assert all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))
    assert stepper.active == twin.active == 1


def test_a_held_robot_delays_the_hand_over() -> None:
    seq = Sequence(legs())
    stepper = seq.stepper(0.001)
    held = None
    for k in range(20_000):
        if k == 300:
            held = stepper.output[0].copy()
        before = stepper.active
        stepper.step(held if 300 <= k < 700 else None)
        if stepper.active != before and before == 0:
            assert k > 700  # held 400 periods: the first movement ran on past 600
        if stepper.done():
            break
    assert stepper.done() and stepper.active == 2 and not stepper.blocked()
    np.testing.assert_allclose(stepper.output[0], WAYPOINTS[-1], atol=1e-4)


def test_reset_starts_the_sequence_again() -> None:
    stepper = Sequence(legs()).stepper(0.001)
    first = run(stepper, 1200)
    assert stepper.active == 2 and stepper.steps == 1200
    stepper.reset()
    assert stepper.active == 0 and stepper.steps == 0
    again = run(stepper, 1200)
    assert all(np.array_equal(x, y) for x, y in zip(first, again, strict=True))


def test_set_tau_and_set_goal_act_on_the_movement_that_runs() -> None:
    stepper = Sequence(legs()).stepper(0.001, goal_filter=None)
    # The first movement, 0.6 s -> 0.9 s from the second period on (as a JointStepper's): its
    # first period at 0.6 s counts 1.5 of the new, so it hands over on sample 899, not 900.
    stepper.set_tau(0.9)
    active = []
    for _ in range(900 + 450 + 10):
        stepper.step()
        active.append(stepper.active)
    assert np.flatnonzero(np.diff(active)).tolist() == [898, 1348]
    assert stepper.nominal_tau == pytest.approx(TAUS[2])
    goal = WAYPOINTS[-1] + [0.1, -0.2, 0.05]
    stepper.set_goal(goal)
    np.testing.assert_array_equal(stepper.goal_target, goal)
    while not stepper.done():
        stepper.step()
    np.testing.assert_allclose(stepper.output[0], goal, rtol=0, atol=1e-4)


def test_a_duration_counts_from_the_first_start() -> None:
    seq = Sequence(legs())
    short, long = seq.rollout(0.001, 0.5), seq.rollout(0.001, 2.5)
    assert short.n_samples == 501 and long.n_samples == 2501
    full = seq.rollout(0.001)
    np.testing.assert_array_equal(short.y, full.y[:501])
    np.testing.assert_array_equal(long.y[: full.n_samples], full.y)


def test_it_has_the_joint_steppers_surface() -> None:
    public = {name for name in dir(dmprs.JointStepper) if not name.startswith("_")}
    assert public <= set(dir(SequenceStepper))
    assert "active" in dir(SequenceStepper)


def test_determinism() -> None:
    a, b = Sequence(moving_legs()).rollout(0.001), Sequence(moving_legs()).rollout(0.001)
    assert a == b


# --- the object -----------------------------------------------------------------------------------

def test_the_sequence_is_an_immutable_value() -> None:
    dmps = legs()
    seq = Sequence(dmps)
    assert len(seq) == 3 and list(seq) == dmps and seq[1] == dmps[1] and seq.n_dof == 3
    assert seq.tau == pytest.approx(sum(TAUS))
    np.testing.assert_array_equal(seq.start, dmps[0].start)
    np.testing.assert_array_equal(seq.goal, dmps[-1].goal)
    assert pickle.loads(pickle.dumps(seq)) == seq
    assert seq != Sequence(dmps[:2])
    assert "n_movements=3" in repr(seq)
    with pytest.raises(AttributeError):
        seq.dmps = ()  # type: ignore[misc]


# --- refusals -------------------------------------------------------------------------------------

def test_bad_input_is_refused_by_name() -> None:
    dmps = legs()
    one_dof = dmprs.DMP.fit(np.linspace(0, 1, 50), np.linspace(0, 1, 50), 10)
    cases = [
        (lambda: Sequence([]), "dmps"),
        (lambda: Sequence(dmps[0]), "dmps"),
        (lambda: Sequence([dmps[0], "dmp"]), "dmps[1]"),
        (lambda: Sequence([dmps[0], one_dof]), "dmps[1]"),
        (lambda: Sequence(dmps).rollout(0.0), "dt"),
        (lambda: Sequence(dmps).rollout(float("nan")), "dt"),
        (lambda: Sequence(moving_legs()[:2]).rollout(until_rest=True), "until_rest"),
        (lambda: Sequence(dmps).stepper(0.001, velocity_max=1.0), "velocity_max"),
        (lambda: Sequence(dmps).stepper(0.001, acceleration_max=[1.0, 2.0, 3.0]), "acceleration_max"),
        (lambda: Sequence(dmps).stepper(0.001).step(np.zeros(2)), "measured"),
        (lambda: Sequence(dmps).stepper(0.001).step(coupling=[np.nan] * 3), "coupling"),
        (lambda: SequenceStepper(dmps, 0.001), "sequence"),  # type: ignore[arg-type]
    ]
    for call, name in cases:
        with pytest.raises(dmprs.InvalidInputError, match=name.replace("[", r"\[")) as info:
            call()
        assert isinstance(info.value, ValueError)


# --- random sequences -----------------------------------------------------------------------------

@settings(max_examples=30, deadline=None)
@given(
    n_dof=st.integers(1, 3),
    steps=st.lists(st.integers(150, 900), min_size=2, max_size=4),
    seed=st.integers(0, 2**32 - 1),
    dt=st.sampled_from([0.001, 0.004]),
)
def test_random_joins_are_as_smooth_as_the_movements(n_dof, steps, seed, dt) -> None:
    """Every join continues the Euler step in y and yd, and is no rougher in ydd than the
    roughest sample inside a movement.
    """
    rng = np.random.default_rng(seed)
    taus = [k * dt for k in steps]
    dmps = [dmprs.DMP(rng.uniform(-80, 80, (n_dof, 10)), rng.uniform(-2, 2, n_dof), np.zeros(n_dof), tau)
            for tau in taus]
    tr = Sequence(dmps).rollout(dt)
    assert tr.n_samples == sum(steps) + 1
    at = joins(taus, dt)
    jumps = np.abs(np.diff(tr.ydd, axis=0)).max(axis=1)  # jumps[j - 1]: from sample j - 1 to j
    inside = np.delete(jumps, [j - 1 for j in at]).max()
    for j in at:
        scale = 1.0 + np.abs(tr.y[j - 1]) + np.abs(tr.yd[j - 1])
        assert np.all(np.abs(tr.y[j] - tr.y[j - 1] - tr.yd[j - 1] * dt) < 1e-12 * scale)
        assert np.all(np.abs(tr.yd[j] - tr.yd[j - 1] - tr.ydd[j - 1] * dt) < 1e-11 * (scale + np.abs(tr.ydd[j - 1])))
        assert jumps[j - 1] <= 1.01 * inside + 1e-9
