"""dmprs.learners: the ask/tell Python API, known answers, and every kind of bad input."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

from dmprs import learners as L
from dmprs.errors import InvalidInputError, LearnerStateError
from tests.conftest import drive


def run(learner, eps_of: Callable[[np.ndarray], object]) -> int:
    """How many trials ``learner`` takes on ``eps_of`` until it stops."""
    return int(drive(learner, eps_of).n_trials)


def sine_eps(q0: float):
    return lambda q: q0 - (q[0] + 0.3 * np.sin(q[0]))


def true_root(q0: float) -> float:
    lo, hi = -5.0, 5.0
    for _ in range(200):
        m = 0.5 * (lo + hi)
        lo, hi = (m, hi) if q0 - (m + 0.3 * np.sin(m)) > 0 else (lo, m)
    return 0.5 * (lo + hi)


def test_import_paths():
    import dmprs.learners

    assert dmprs.learners is L
    assert issubclass(LearnerStateError, dmprs.DmprsError)
    assert issubclass(LearnerStateError, RuntimeError)
    assert dmprs.LearnerStateError is LearnerStateError


# ---- known answers ------------------------------------------------------------------------------


def test_identity_gain_on_the_ideal_map_converges_in_one_trial():
    q0 = np.array([0.4, -1.2, 3.0])
    el = L.ErrorLearning(q0)
    assert run(el, lambda q: q0 - q) == 1
    assert el.converged and el.status == "converged"
    np.testing.assert_array_equal(el.best.q, q0)


def test_ask_returns_float_arrays_and_accepts_floats():
    el = L.ErrorLearning(0.5)
    q = el.ask()
    assert isinstance(q, np.ndarray) and q.dtype == np.float64 and q.shape == (1,)
    np.testing.assert_array_equal(el.ask(), q)  # asking again repeats the pending query
    el.tell(float(q[0]), 0.25)  # plain floats are fine for n = 1
    assert el.ask()[0] == pytest.approx(0.75)
    assert el.history[0].q[0] == 0.5 and el.history[0].feedback[0] == 0.25


@pytest.mark.parametrize("mode", ["paper", "robust"])
def test_golden_section_on_q_plus_0_3_sin_q(mode):
    g = L.GoldenSection(1.0, low=0.3, high=1.8, mode=mode, tol=1e-3)
    run(g, sine_eps(1.0))
    assert g.converged
    assert g.best.q[0] == g.history[-1].q[0]  # the last executed query is the answer
    assert abs(g.best.q[0] - true_root(1.0)) < 1e-3 / 0.7


def test_root_finder_needs_fewer_trials_than_golden_section_on_a_smooth_map():
    g = L.GoldenSection(1.0, low=0.3, high=1.8, mode="robust")
    r = L.IllinoisRootFinder(1.0, low=0.3, high=1.8)
    assert run(r, sine_eps(1.0)) < run(g, sine_eps(1.0))
    assert r.converged and abs(r.best.q[0] - true_root(1.0)) < 1e-3 / 0.7
    lo, hi = r.bracket
    assert lo < hi


def matchbox_like(q: np.ndarray) -> float:
    """The outcome jumps across the target, with a narrow success window [0.93, 0.97]."""
    x = q[0]
    qa = x - 0.15 if x < 0.93 else (1.0 if x <= 0.97 else x + 0.15)
    return 1.0 - qa


def test_discontinuous_map():
    for learner in (L.GoldenSection(1.0, low=0.5, high=1.5), L.GoldenSection(1.0, low=0.5, high=1.5, mode="robust"), L.IllinoisRootFinder(1.0, low=0.5, high=1.5)):
        run(learner, matchbox_like)
        assert learner.converged, learner
        assert 0.93 <= learner.best.q[0] <= 0.97
    el = L.ErrorLearning(1.0, max_trials=20)
    run(el, matchbox_like)
    assert el.status == "trial-cap"  # K = I jumps back and forth across the window


def test_noisy_measurements():
    root = true_root(1.0)
    for seed in range(5):
        rng = np.random.default_rng(seed)

        def noisy(q, rng=rng):
            return 1.0 - (q[0] + 0.3 * np.sin(q[0])) + 0.003 * rng.standard_normal()

        for learner in (L.GoldenSection(1.0, low=0.3, high=1.8, mode="robust", tol=0.01), L.IllinoisRootFinder(1.0, low=0.3, high=1.8, tol=0.01), L.ErrorLearning(1.0, tol=0.01)):
            run(learner, noisy)
            assert learner.status in ("converged", "bracketed")
            assert abs(learner.best.q[0] - root) < 0.04


def wrong_sign(q):
    return (q[0] + 0.3 * np.sin(q[0])) - 1.0


@pytest.mark.parametrize(
    "make",
    [
        lambda: L.ErrorLearning(1.2, low=0.0, high=3.0, max_trials=100),
        lambda: L.GoldenSection(1.2, low=0.5, high=2.0, mode="robust", max_trials=100),
        lambda: L.GoldenSection(1.2, low=0.5, high=2.0, mode="paper", max_trials=100),
        lambda: L.IllinoisRootFinder(1.2, low=0.5, high=2.0, max_trials=100),
    ],
)
def test_a_wrong_sign_convention_hits_a_bound_and_reports_it(make):
    learner = make()
    n = run(learner, wrong_sign)
    assert learner.status == "hit-bound", learner.status_detail
    assert "upper limit" in learner.status_detail
    assert n < 100
    with pytest.raises(LearnerStateError, match="stopped"):
        learner.ask()


def test_policy_gradient_does_not_depend_on_the_sign_of_eps():
    # It descends J = eps^T eps, which is the same for either sign convention.
    pg = L.PolicyGradient(1.2, low=0.0, high=3.0, max_trials=100)
    run(pg, wrong_sign)
    assert pg.converged
    assert abs(pg.best.q[0] - true_root(1.0)) < 1e-3 / 0.7


def test_a_wrong_sign_without_limits_is_reported_as_divergence():
    el = L.ErrorLearning(1.2, max_trials=100)
    assert run(el, wrong_sign) < 15
    assert el.status == "diverged"


def test_secant_and_finite_difference_gains_fix_slope_two():
    for jac, trials in (("secant", 3), ("finite-difference", 3)):
        el = L.ErrorLearning(1.0, jacobian=jac)
        assert run(el, lambda q: 1.0 - 2.0 * q[0]) == trials
        assert el.best.q[0] == pytest.approx(0.5)
        assert el.jacobian[0, 0] == pytest.approx(2.0)
    el = L.ErrorLearning(1.0, jacobian=2.0)  # a fixed Jacobian: one exact Newton step
    assert run(el, lambda q: 1.0 - 2.0 * q[0]) == 2


def test_weighted_error_learning_uses_the_task_scale():
    el = L.ErrorLearning(0.0, weighted=True, scale=0.05)
    el.tell(el.ask(), 0.1)
    assert el.ask()[0] == pytest.approx(np.exp(-4.0) * 0.1)


def test_policy_gradient_counts_perturbed_trials():
    pg = L.PolicyGradient(1.0, delta=0.05, tol=1e-9)
    n = run(pg, lambda q: 1.0 - (q[0] + 0.2))
    assert n == 4  # centre, +delta, -delta, exact new centre
    assert pg.best.q[0] == pytest.approx(0.8)


def test_power_and_pi2_reduce_a_quadratic_cost_and_are_deterministic():
    target = np.sin(np.arange(10) * 0.7)

    def power_run(seed):
        p = L.PoWER(np.zeros(10), 0.3, seed=seed, max_trials=300)
        run(p, lambda th: np.exp(-np.sum((th - target) ** 2)))
        return p

    a, b = power_run(3), power_run(3)
    assert np.sum((a.mean - target) ** 2) < 0.2 * np.sum(target**2)
    assert [t.q.tolist() for t in a.history] == [t.q.tolist() for t in b.history]
    assert a.best.feedback[0] == max(t.feedback[0] for t in a.history)

    def pi2_run(seed):
        p = L.PI2(np.zeros((2, 5)), 0.2, seed=seed, max_trials=300, cost_tol=0.02)
        run(p, lambda th: np.sum((th - target) ** 2))
        return p

    c, d = pi2_run(4), pi2_run(4)
    np.testing.assert_array_equal(c.theta, d.theta)
    assert c.converged
    assert np.sum((c.theta - target) ** 2) <= 0.02


def test_pi2_terminal_only_without_projection_is_pi_bb():
    p = L.PI2(np.zeros(8), 0.3, seed=2, projection=False, n_rollouts=6, n_reuse=2, h=10.0)
    target = np.linspace(-1, 1, 8)
    cost = lambda th: np.sum((th - target) ** 2)
    theta = p.ask()
    p.tell(theta, cost(theta))
    samples = []
    for _ in range(6):
        th = p.ask()
        samples.append((th, cost(th)))
        p.tell(th, samples[-1][1])
    c = np.array([s for _, s in samples])
    w = np.exp(-10 * (c - c.min()) / (c.max() - c.min()))
    w /= w.sum()
    expected = theta + sum(wk * (th - theta) for wk, (th, _) in zip(w, samples, strict=True))
    np.testing.assert_allclose(p.theta, expected, rtol=0, atol=1e-12)


# ---- bad input ---------------------------------------------------------------------------------


@pytest.fixture(params=["error", "golden", "root", "pg"])
def query_learner(request):
    return {
        "error": lambda: L.ErrorLearning(0.5),
        "golden": lambda: L.GoldenSection(0.5, low=0.0, high=1.0),
        "root": lambda: L.IllinoisRootFinder(0.5, low=0.0, high=1.0),
        "pg": lambda: L.PolicyGradient(0.5),
    }[request.param]()


def test_nan_eps(query_learner):
    q = query_learner.ask()
    with pytest.raises(InvalidInputError, match=r"eps\[0\] is NaN"):
        query_learner.tell(q, np.nan)
    query_learner.tell(q, 0.1)  # the failed tell changed nothing
    assert query_learner.n_trials == 1


def test_eps_of_the_wrong_dimension(query_learner):
    q = query_learner.ask()
    with pytest.raises(InvalidInputError, match="eps has 2 entries, expected 1"):
        query_learner.tell(q, [0.1, 0.2])
    with pytest.raises(InvalidInputError, match="eps must be 0-D or 1-D"):
        query_learner.tell(q, [[0.1]])
    with pytest.raises(InvalidInputError, match="dtype"):
        query_learner.tell(q, "0.1")


def test_tell_without_ask(query_learner):
    with pytest.raises(LearnerStateError, match="without a pending ask"):
        query_learner.tell(0.5, 0.1)


def test_tell_of_a_query_that_was_not_asked(query_learner):
    query_learner.ask()
    with pytest.raises(LearnerStateError, match="pending ask\\(\\) returned"):
        query_learner.tell(0.75, 0.1)


@pytest.mark.parametrize("cls", [L.GoldenSection, L.IllinoisRootFinder])
@pytest.mark.parametrize("low, high", [(1.0, 1.0), (2.0, 1.0)])
def test_low_not_below_high(cls, low, high):
    with pytest.raises(InvalidInputError, match="must be < high"):
        cls(0.5, low=low, high=high)


def test_error_learning_limits_and_parameters():
    with pytest.raises(InvalidInputError, match="must be < high"):
        L.ErrorLearning([0.5, 0.5], low=[0.0, 1.0], high=[1.0, 0.5])
    with pytest.raises(InvalidInputError, match=r"q0 = 2 .* must lie within"):
        L.ErrorLearning(2.0, low=0.0, high=1.0)
    with pytest.raises(InvalidInputError, match="q0\\[1\\] is NaN"):
        L.ErrorLearning([0.0, np.nan])
    with pytest.raises(InvalidInputError, match=r"jacobian = 'newton'|jacobian = \"newton\""):
        L.ErrorLearning(0.0, jacobian="newton")
    with pytest.raises(InvalidInputError, match="invertible"):
        L.ErrorLearning([0.0, 0.0], jacobian=np.zeros((2, 2)))
    with pytest.raises(InvalidInputError, match="gain has shape"):
        L.ErrorLearning([0.0, 0.0], gain=np.eye(3))
    with pytest.raises(InvalidInputError, match="scale = 0 is invalid"):
        L.ErrorLearning(0.0, scale=0.0)
    with pytest.raises(InvalidInputError, match="max_trials = 0"):
        L.ErrorLearning(0.0, max_trials=0)
    with pytest.raises(InvalidInputError, match=r"mode = 'fast'|mode = \"fast\""):
        L.GoldenSection(0.5, low=0.0, high=1.0, mode="fast")


def test_baseline_bad_input():
    with pytest.raises(InvalidInputError, match="sigma has 3 entries, expected 1 or 4"):
        L.PoWER(np.zeros(4), [0.1, 0.1, 0.1])
    with pytest.raises(InvalidInputError, match=r"sigma = -0.1"):
        L.PoWER(np.zeros(4), -0.1)
    p = L.PoWER(np.zeros(4), 0.1)
    th = p.ask()
    with pytest.raises(InvalidInputError, match="return = -1 is invalid"):
        p.tell(th, -1.0)
    with pytest.raises(InvalidInputError, match="seed"):
        L.PoWER(np.zeros(4), 0.1, seed=-1)
    with pytest.raises(InvalidInputError, match="n_reuse = 10 is invalid"):
        L.PI2(np.zeros(4), 0.1, n_reuse=10)
    with pytest.raises(InvalidInputError, match="n_dof = 3"):
        L.PI2(np.zeros((2, 4)), 0.1, n_dof=3)
    pi = L.PI2(np.zeros(4), 0.1, n_steps=20)
    th = pi.ask()
    with pytest.raises(InvalidInputError, match="costs has 3 entries, expected 1 or 20"):
        pi.tell(th, [1.0, 2.0, 3.0])
    with pytest.raises(InvalidInputError, match=r"costs\[1\] is inf"):
        pi.tell(th, np.r_[1.0, np.inf, np.zeros(18)])


def test_policy_gradient_reports_a_root_beyond_its_limit():
    pg = L.PolicyGradient(0.2, low=0.0, high=0.5, max_trials=200)
    run(pg, sine_eps(1.0))  # root at 0.787 > high
    assert pg.status == "hit-bound" and "upper limit 0.5" in pg.status_detail
    assert pg.n_trials < 200


# ---- one constructor shape ---------------------------------------------------------------------


@pytest.mark.parametrize("cls", [L.ErrorLearning, L.GoldenSection, L.IllinoisRootFinder, L.PolicyGradient])
def test_every_query_learner_takes_q0_as_a_float_or_a_1d_array(cls):
    a, b = cls(0.5, low=0.0, high=1.0), cls(np.array([0.5]), low=[0.0], high=np.array([1.0]))
    np.testing.assert_array_equal(a.ask(), b.ask())
    a.tell(a.ask(), 0.1)
    b.tell(b.ask(), 0.1)
    np.testing.assert_array_equal(a.ask(), b.ask())


@pytest.mark.parametrize("cls", [L.GoldenSection, L.IllinoisRootFinder])
def test_the_bracketing_learners_require_their_limits(cls):
    with pytest.raises(InvalidInputError, match="low is required"):
        cls(0.5, high=1.0)
    with pytest.raises(InvalidInputError, match="high is required"):
        cls(0.5, low=0.0)
    with pytest.raises(InvalidInputError, match="q0 has 2 entries, expected 1 entry"):
        cls([0.5, 0.5], low=0.0, high=1.0)


def test_a_default_left_out_is_the_core_default():
    # PolicyGradient's decay defaults to Spall's 0.602 in the core (alpha_m = alpha0/(m+1)^decay)
    pg, explicit = L.PolicyGradient(1.0), L.PolicyGradient(1.0, decay=0.602, alpha0=0.5, delta=0.05)
    for p in (pg, explicit):
        run(p, lambda q: 1.0 - 2.0 * q[0])
    assert [t.q.tolist() for t in pg.history] == [t.q.tolist() for t in explicit.history]
    assert L.GoldenSection(0.5, low=0.0, high=2.0).bracket == (0.0, 2.0)


def test_out_of_range_counts_are_clear_errors():
    with pytest.raises(InvalidInputError, match="max_trials = 1180591620717411303424 is invalid"):
        L.ErrorLearning(0.5, max_trials=2**70)
    with pytest.raises(InvalidInputError, match="max_trials must be an integer"):
        L.GoldenSection(0.5, low=0.0, high=1.0, max_trials=2.5)
    with pytest.raises(InvalidInputError, match="tol must be a real number"):
        L.IllinoisRootFinder(0.5, low=0.0, high=1.0, tol="abc")
    with pytest.raises(InvalidInputError, match="mode must be a string"):
        L.GoldenSection(0.5, low=0.0, high=1.0, mode=5)


def test_a_bracket_whose_width_overflows_is_named():
    with pytest.raises(InvalidInputError, match="width overflows") as info:
        L.GoldenSection(0.5, low=-1e308, high=1e308)
    assert "q_tol" not in str(info.value)


# ---- never a non-finite query (issue 13) ------------------------------------------------------


def test_a_learner_never_asks_a_non_finite_query():
    p = L.PoWER(np.zeros(3), 0.3)
    p.tell(p.ask(), 1e308)  # a finite return: divided by the largest, it cannot overflow the mean
    assert p.status == "running" and np.isfinite(p.mean).all() and np.isfinite(p.ask()).all()
    with pytest.raises(InvalidInputError, match=r"sigma = 1e200 .* overflows"):
        L.PoWER(np.zeros(3), 1e200)
    el = L.ErrorLearning(1.0, gain=1e308)
    el.tell(el.ask(), 10.0)
    assert el.status == "diverged"
    pg = L.PolicyGradient(0.0, delta=1e300)
    run(pg, lambda q: 0.5 - q[0])
    assert pg.status == "diverged"
    assert all(np.isfinite(t.q).all() for t in pg.history)


def test_pi2_refuses_sizes_that_cannot_be_meant():
    for n_steps in (2**40, 10**9):
        with pytest.raises(InvalidInputError, match="n_steps x n_basis"):
            L.PI2(np.zeros(5), 0.1, n_steps=n_steps)


def test_pi2_says_which_rollout_is_its_evaluation():
    # independent truth: the evaluation rollout is the noiseless current theta, the others are not
    learner = L.PI2(np.zeros(6), 0.2, seed=1, n_steps=20, n_updates=4)
    flags = []
    while not learner.done:
        theta = learner.ask()
        flags.append(learner.asked_evaluation)
        assert learner.asked_evaluation == bool(np.array_equal(theta, learner.theta))
        learner.tell(theta, float(np.sum(theta**2)))
    assert flags[0] and 1 < sum(flags) < len(flags)


def test_golden_sections_noise_guard_options_are_validated():
    with pytest.raises(InvalidInputError, match="noise"):
        L.GoldenSection(0.5, low=0.0, high=1.0, noise=-0.1)
    with pytest.raises(InvalidInputError, match="max_repeats"):
        L.GoldenSection(0.5, low=0.0, high=1.0, noise=0.1, max_repeats=0)
    g = L.GoldenSection(0.5, low=0.0, high=1.0, noise=0.1)
    g.tell(g.ask(), [0.05])  # doubtful: asked again, the bracket unmoved
    assert g.ask()[0] == 0.5 and g.bracket == (0.0, 1.0) and g.reopened == 0
