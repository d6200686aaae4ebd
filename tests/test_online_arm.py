"""A stepper inside the MuJoCo arm's servo loop (dmprs.experiments.online_arm): a pour held still
by joint constraints, a throw whose basket moves on the way, a move slowed to the velocity limits;
each against its truth (docs/arm.md "A stepper in the servo loop").
"""

from __future__ import annotations

import numpy as np
import pytest

from dmprs.experiments import online_arm as oa
from dmprs.tasks.arm_pouring import SUCCESS_TOLERANCE as POUR_TOLERANCE
from dmprs.tasks.arm_pouring import TARGET_VOLUME
from dmprs.tasks.arm_throwing import SUCCESS_TOLERANCE as BASKET_TOLERANCE


def test_path_deviation_is_the_distance_to_the_nearest_segment() -> None:
    path = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]])
    points = np.array([[0.5, 0.3], [2.0, 0.5], [-3.0, -4.0], [1.0, 0.5]])
    np.testing.assert_allclose(oa.path_deviation(points, path, chunk=3), [0.3, 1.0, 5.0, 0.0], atol=1e-15)


@pytest.fixture(scope="module")
def pours() -> tuple[oa.PourRun, oa.PourRun, float, float]:
    """The pour held still from HOLD_START for HOLD s, with and without phase stopping; the
    farthest the free command moves a joint in that window; the DMP's tau.
    """
    dmp = oa.pour_dmp()
    nominal = dmp.rollout(1e-3)
    k0, k1 = round(oa.HOLD_START / 1e-3), round((oa.HOLD_START + oa.HOLD) / 1e-3)
    travel = float(np.abs(nominal.y[k1] - nominal.y[k0]).max())
    return oa.held_pour(dmp, alpha_e=1e4), oa.held_pour(dmp, alpha_e=0.0), travel, dmp.tau


def test_held_pour_is_held_by_the_constraint(pours) -> None:
    stopped, running, travel, _ = pours
    # the command would move a joint by ~0.9 rad in the window; the held arm moves a tenth of that
    # or less, as the sloshing liquid shakes the light wrist: 0.04-0.14 rad over liquids 0-4,
    # with phase stopping or without (a chaotic draw, so the bound is on the spread's top)
    assert stopped.hold_drift < 0.2 * travel
    assert running.hold_drift < 0.2 * travel


def test_phase_stopping_waits_for_the_held_arm(pours) -> None:
    stopped, running, travel, tau = pours
    # without feedback the phase decays as eq. 3 does in explicit Euler (§2.4), hold or not
    steps = round(oa.HOLD / 1e-3)
    assert running.phase_kept == pytest.approx((1 - 2.0 * 1e-3 / tau) ** steps, rel=1e-9)
    # with it the clock (nearly) stops: the phase keeps most of what free running would lose
    assert 1 - stopped.phase_kept < 0.2 * (1 - running.phase_kept)
    # the command waits near the arm instead of running away from it
    assert running.run.tracking_error > 0.5 * travel
    # (the liquid shakes the held wrist, so the gap is a draw of the liquid: 0.075 rad before the
    # machine-independent numerics, 0.197 rad with them, liquid 0; free, the command runs 0.87 away)
    assert stopped.run.tracking_error < 0.3 * running.run.tracking_error
    # and the movement ends later by about the hold
    assert stopped.run.end_time - running.run.end_time > 0.8 * oa.HOLD


def test_held_pour_with_phase_stopping_pours_within_the_tolerance(pours) -> None:
    stopped, _, _, _ = pours
    assert abs(stopped.poured_volume - TARGET_VOLUME) < POUR_TOLERANCE


@pytest.fixture(scope="module")
def basket() -> oa.BasketRun:
    return oa.moving_basket_throw()


def test_moved_basket_is_hit_through_set_goal(basket) -> None:
    moved_by = float(np.linalg.norm(basket.moved - basket.basket))
    assert moved_by == pytest.approx(0.1)
    # the stepper that got the new goal lands in the moved basket ...
    assert np.linalg.norm(basket.updated.landing - basket.moved) < BASKET_TOLERANCE
    # ... the one that did not lands in the old one, out of the moved basket
    assert np.linalg.norm(basket.ignored.landing - basket.basket) < BASKET_TOLERANCE
    assert np.linalg.norm(basket.ignored.landing - basket.moved) > BASKET_TOLERANCE
    # the base's turn (done long before the landing) ended at the new DMP's goal, not the old one's
    old, new = basket.goals
    assert abs(new[0] - old[0]) > 0.05
    assert basket.updated.run.command[-1, 0] == pytest.approx(new[0], abs=1e-3)
    # all demonstrations last as long: the generalized tau does not change (to its GP's rounding)
    assert basket.tau[0] == pytest.approx(basket.tau[1], rel=1e-12)


@pytest.fixture(scope="module")
def limited() -> oa.LimitRun:
    return oa.velocity_limited_move()


def test_free_stepper_in_the_loop_commands_the_rollout(limited) -> None:
    # without feedback, limits or goal change, step k is the rollout's sample k (§2.5.1)
    n = len(limited.free.command)
    np.testing.assert_allclose(limited.free.command, limited.nominal[:n], rtol=0, atol=1e-12)


def test_velocity_limit_is_kept_on_the_same_path(limited) -> None:
    free, slow = limited.free, limited.limited
    assert limited.speed_ratio(free) == pytest.approx(oa.LIMIT_EXCESS, rel=0.01)
    assert limited.speed_ratio(slow) <= oa.SPEED_MARGIN * (1 + 1e-9)
    assert limited.speed_ratio(slow, measured=True) <= 1.0
    assert limited.duration(slow) > 1.1 * limited.duration(free)
    # the command stays on the nominal path; the arm's deviation is the servo's tracking error,
    # which the free run has as well
    assert limited.deviation(slow) < 1e-6
    assert limited.deviation(slow, measured=True) <= 1.5 * max(limited.deviation(free, measured=True), 1e-3)


def test_throw_through_the_stepper_is_deterministic(basket) -> None:
    again = oa.moving_basket_throw()
    assert np.array_equal(again.updated.landing, basket.updated.landing)
    assert np.array_equal(again.updated.run.q, basket.updated.run.q)


def test_reproduction_part_reports_every_scenario(tmp_path, pours) -> None:
    from dmprs.reproduce.online import PART
    from dmprs.reproduce.run import dispatch

    results = [dispatch(spec) for spec in PART.plan(True)]
    # the same pour a second time (the liquid's seed 0) gives the same numbers
    assert results[0]["poured_ml"] == 1000 * pours[0].poured_volume
    assert results[0]["tracking_error"] == pours[0].run.tracking_error
    assert [r["liquid_seed"] for r in results[:2]] == [0, 0]
    rows = PART.summarize(results)
    assert [r["scenario"] for r in rows] == ["held-pour", "held-pour", "moving-basket", "velocity-limit"]
    # the truths: phase stopping's pour within the tolerance, the moved basket hit, the limit kept
    assert [r["met"] for r in rows if r["scenario"] != "held-pour"] == [True, True]
    assert rows[0]["met"]
    assert "| held-pour |" in PART.markdown_of(rows)
    assert PART.figure(results, tmp_path).read_bytes()[:4] == b"\x89PNG"
