"""The final-velocity throw (issue 41): each scripted throw split at its release, the movement up
to it a DMP with a final velocity (the release position and velocity its goal and final
velocity), then a braking movement, joined as a dmprs.Sequence; the release state is generalized
with the rest, and the arm learns a basket with it.
"""

from __future__ import annotations

import numpy as np
import pytest

from dmprs.dmp import DMP
from dmprs.errors import InvalidInputError
from dmprs.experiments.arm_throwing import N_BASIS, demonstrations
from dmprs.experiments.arm_throwing import setup as arm_throwing_setup
from dmprs.loop import learn
from dmprs.tasks.arm_throwing import DEMOS, ArmThrowing, throw_trajectory
from dmprs.tasks.arm_throwing.release import BRAKE_TIME, RELEASE_TIME, braking, release_sequence, split
from dmprs.trajectory import Trajectory

STRONG = (0.9, -0.25)  # a demonstration's (strength, yaw)


def _release_dmp(strength: float = STRONG[0], yaw: float = STRONG[1]) -> tuple[DMP, Trajectory, Trajectory]:
    before, after = split(throw_trajectory(strength, yaw))
    return DMP.fit(before.t, before.y, N_BASIS, before.yd, before.ydd, final_velocity="demo"), before, after


def test_the_split_is_at_the_swings_peak_speed() -> None:
    """Up to the release the swing accelerates, after it it decelerates: the release sample is the
    scripted swing's fastest, and the two parts share it.
    """
    scripted = throw_trajectory(*STRONG)
    before, after = split(scripted)
    assert before.t[-1] == pytest.approx(RELEASE_TIME, abs=1e-12)
    assert after.t[-1] == pytest.approx(BRAKE_TIME, abs=1e-12)
    np.testing.assert_array_equal(before.y[-1], after.y[0])
    speed = np.abs(scripted.yd[:, 1])
    assert int(np.argmax(speed)) == len(before.t) - 1
    np.testing.assert_allclose(before.ydd[-1], 0.0, atol=1e-9)


def test_the_movement_up_to_the_release_reaches_the_release_state_to_the_integrators_order() -> None:
    """The fitted DMP's goal and final velocity are the demonstration's release position and
    velocity; its rollout arrives there with errors that halve with dt (explicit Euler).
    """
    dmp, before, _ = _release_dmp()
    np.testing.assert_array_equal(dmp.goal, before.y[-1])
    np.testing.assert_array_equal(dmp.final_velocity, before.yd[-1])
    errors = []
    for dt in (0.002, 0.001):
        tr = dmp.rollout(dt)
        assert tr.t[-1] == pytest.approx(dmp.tau, abs=1e-12)
        errors.append((np.abs(tr.y[-1] - before.y[-1]).max(), np.abs(tr.yd[-1] - before.yd[-1]).max()))
    (y2, v2), (y1, v1) = errors
    assert y2 < 1e-3 and v2 < 1e-2  # rad, rad/s: against a peak speed of 1.9 rad/s
    assert 0.4 < y1 / y2 < 0.6 and 0.4 < v1 / v2 < 0.6


def test_the_joint_velocity_is_continuous_through_the_release() -> None:
    """The sequence hands over in motion: across the join the velocity jumps by no more than an
    Euler step inside the movement does, and the jumps of velocity and acceleration shrink with
    dt at first order (the velocity's carries the fit's acceleration error at the release too).
    """
    dmp, _, _ = _release_dmp()
    jumps = []
    for dt in (0.002, 0.001):
        tr = release_sequence(dmp).rollout(dt)
        j = round(dmp.tau / dt)  # the braking's first sample
        assert tr.t[j] == pytest.approx(RELEASE_TIME, abs=1e-12)
        jumps.append((np.abs(tr.yd[j] - tr.yd[j - 1]).max(), np.abs(tr.ydd[j] - tr.ydd[j - 1]).max()))
        inside = np.abs(np.diff(tr.yd[j - 20:j], axis=0)).max()  # the steps just before the join
        assert jumps[-1][0] <= 2.0 * inside
    (v2, a2), (v1, a1) = jumps
    assert 0.3 < v1 / v2 < 0.7 and 0.4 < a1 / a2 < 0.6  # measured 0.60 and 0.53


def test_the_braking_is_the_demonstrations_remainder() -> None:
    """The braking scales one fitted deceleration by each joint's release velocity: the sequence
    follows the whole scripted throw within 3 mrad and ends at its end, nearly at rest.
    """
    for strength, yaw in (STRONG, (0.75, 0.25)):
        scripted = throw_trajectory(strength, yaw)
        dmp, _, after = _release_dmp(strength, yaw)
        brake = braking(dmp)
        np.testing.assert_array_equal(brake.start, dmp.goal)
        np.testing.assert_allclose(brake.goal, after.y[-1], atol=2e-3)
        tr = release_sequence(dmp).rollout(0.002)
        assert len(tr.t) == len(scripted.t)
        assert np.abs(tr.y - scripted.y).max() < 3e-3
        assert np.abs(tr.yd[-1]).max() < 1e-2


def test_the_demonstrations_land_near_todays_and_the_ball_leaves_during_the_braking() -> None:
    """The same scripted throws encoded either way land within a few cm of each other (the tight
    cup amplifies mrad to cm, docs/throwing.md); the ball leaves the cup after the release (the
    cup's deceleration must first beat gravity's pull) but within the braking.
    """
    today = np.array([label for label, _ in demonstrations()])
    final = np.array([label for label, _ in demonstrations(release=True)])
    assert np.linalg.norm(today - final, axis=1).max() < 0.04
    task = ArmThrowing()
    with task.adapter as adapter:
        for strength, yaw in DEMOS[2:4]:
            adapter.reset(seed=0)
            outcome = adapter.execute(task.trajectory(_release_dmp(strength, yaw)[0]))
            assert outcome.ok
            assert RELEASE_TIME < outcome.signals["release_time"] < RELEASE_TIME + BRAKE_TIME / 2


def test_the_release_state_is_generalized_and_a_basket_is_learned() -> None:
    """setup(release=True) generalizes [w, tau, g, y0, gd] (piecewise linear on the five demos):
    at a demo's landing it gives that demo's release velocity; an unseen basket beyond the demos'
    range (2 cm) is hit within a few trials.
    """
    s = arm_throwing_setup((1.3, 0.1), "linear", tol=0.02, release=True)
    assert s.generalizer.n_parameters == 7 * N_BASIS + 1 + 3 * 7
    label, first = demonstrations(release=True)[2]
    np.testing.assert_allclose(s.generalizer.predict(label).final_velocity, first.yd[-1], rtol=1e-9, atol=1e-12)
    r = learn(s.task, s.generalizer, s.desired_query, s.make_learner("secant"), max_trials=10, seed=0)
    assert r.converged and r.trials_to_success <= 6


def test_bad_options_are_refused_by_name() -> None:
    with pytest.raises(InvalidInputError, match="release"):
        arm_throwing_setup((1.0, 0.0), release=1)
    with pytest.raises(InvalidInputError, match="trajectory"):
        split("a throw")
    short = throw_trajectory(*STRONG)
    with pytest.raises(InvalidInputError, match="trajectory has no sample at the release"):
        split(Trajectory(short.t[:500], short.y[:500]))
    with pytest.raises(InvalidInputError, match="dmp"):
        braking(np.zeros(7))


def test_the_reproduction_part_puts_todays_throw_beside_the_final_velocity_throw() -> None:
    """The part repeats the throwing part's baskets with the final-velocity throw; its table reads
    today's trials from the throwing part's runs of the same reproduction, basket for basket, and
    it comes after every earlier part.
    """
    from dmprs.reproduce import release_throwing, throwing
    from dmprs.reproduce.parts import BY_KIND, PARTS
    from dmprs.reproduce.run import dispatch

    assert BY_KIND[release_throwing.KIND] is release_throwing.PART
    kinds = [p.kind for p in PARTS]
    assert kinds[:kinds.index(release_throwing.KIND)] == ["growing", "noisy", "throwing", "juggling", "online", "versus"]
    mine, theirs = release_throwing.plan_release(quick=True), throwing.plan_throwing(quick=True)
    assert [(s.target, s.region, s.generalizer, s.learner, s.tol) for s in mine] == \
        [(s.target, s.region, s.generalizer, s.learner, s.tol) for s in theirs]
    results = [dispatch(s) for s in theirs + mine]
    assert {r["kind"] for r in results} == {"throwing", release_throwing.KIND}
    data = release_throwing.summarize_release(results)
    for row in data["rows"]:
        today = [r["trials_to_success"] for r in results if r["kind"] == "throwing" and r["region"] == row["region"]]
        final = [r["trials_to_success"] for r in results
                 if r["kind"] == release_throwing.KIND and r["region"] == row["region"]]
        assert row["today"]["runs"] == len(today) and row["today"]["successes"] == sum(v is not None for v in today)
        assert row["final_velocity"]["runs"] == len(final)
    assert 0.0 < data["demos"]["max_shift"] < 0.04
    md = release_throwing.markdown_release(data)
    assert "| today's throw | final-velocity throw |" in md and "not run" not in md
    alone = release_throwing.summarize_release([r for r in results if r["kind"] != "throwing"])
    assert all(row["today"] is None for row in alone["rows"])
    assert "not run" in release_throwing.markdown_release(alone)
