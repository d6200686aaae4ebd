"""Error learning over n-D queries (docs/method.md §5.4): J from numerical derivatives through
trials, refined by Broyden's update, and a trust region for maps far from linear; checked on maps
whose roots are known in closed form.
"""

import numpy as np
import pytest

from dmprs import learners as L

A = np.array([[2.6, 0.6], [-0.4, 2.3]])  # far from K = I: eq. 16 with J = I overshoots and diverges


def linear_map(q):
    return A @ q + 0.05 * np.sin(3 * q)


TARGET = np.array([0.8, -0.3])


def run(learner, outcome, target, cap):
    """Drives an ask/tell learner on eps = target - outcome(q); returns (trials, learner)."""
    n = 0
    while not learner.done and n < cap:
        q = learner.ask()
        learner.tell(q, target - outcome(q))
        n += 1
    return n, learner


@pytest.mark.parametrize("options, budget", [
    ({"jacobian": "finite-difference", "broyden": True}, 8),
    ({"jacobian": "finite-difference", "broyden": True, "trust_radius": 0.5}, 10),
    ({"jacobian": "secant"}, 15),
])
def test_an_unseen_smooth_2d_map_is_solved_within_a_budget(options, budget):
    n, learner = run(L.ErrorLearning(np.zeros(2), tol=1e-4, max_trials=40, **options), linear_map, TARGET, 40)
    assert learner.converged, (options, learner.status_detail)
    assert n <= budget, (options, n)
    # independent truth: the executed query solves the map to the tolerance
    assert np.abs(linear_map(learner.best.q) - TARGET).max() < 1e-4


def test_broyden_refines_the_finite_difference_jacobian_towards_the_true_one():
    learner = L.ErrorLearning(np.zeros(2), jacobian="finite-difference", broyden=True, tol=1e-9, max_trials=12)
    run(learner, lambda q: A @ q, TARGET, 12)
    np.testing.assert_allclose(learner.jacobian, A, atol=1e-6)  # exact for a linear map


def test_identity_gain_diverges_where_the_derivative_based_learner_converges():
    plain = L.ErrorLearning(np.zeros(2), tol=1e-4, max_trials=40)
    _, plain = run(plain, linear_map, TARGET, 40)
    assert not plain.converged


def test_a_trust_region_tames_a_strongly_nonlinear_map():
    def cubic(q):  # far from linear: the slope at q0 = 0 is 0.2, ten times smaller than elsewhere
        return 0.2 * q + q**3

    target = np.array([1.5, -2.0])
    roots = []
    for t in target:  # closed form: the real root of x^3 + 0.2 x - t
        r = np.roots([1, 0, 0.2, -t])
        roots.append(float(r[np.abs(r.imag) < 1e-9].real[0]))
    untamed = L.ErrorLearning(np.zeros(2), jacobian="finite-difference", broyden=True, tol=1e-4, max_trials=30)
    tamed = L.ErrorLearning(np.zeros(2), jacobian="finite-difference", broyden=True, trust_radius=0.5,
                            tol=1e-4, max_trials=30)
    n_tamed, tamed = run(tamed, cubic, target, 30)
    run(untamed, cubic, target, 30)
    assert tamed.converged, tamed.status_detail
    np.testing.assert_allclose(tamed.best.q, roots, atol=1e-3)
    assert n_tamed <= 20
    assert untamed.n_trials >= n_tamed or not untamed.converged


def test_a_map_without_a_root_stops_instead_of_looping():
    # tanh never reaches 2: the learner must stop by itself, well before its trial cap
    learner = L.ErrorLearning(np.zeros(2), jacobian="secant", trust_radius=0.5, tol=1e-3, max_trials=200)
    n, learner = run(learner, np.tanh, np.array([2.0, -2.0]), 200)
    assert learner.done and not learner.converged
    assert learner.status == "diverged" and n < 100
    assert np.isfinite(learner.best.q).all()


def test_bad_trust_radius_is_refused():
    for bad in (0.0, -1.0, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="trust_radius"):
            L.ErrorLearning(np.zeros(2), trust_radius=bad)
    with pytest.raises(ValueError, match="broyden"):
        L.ErrorLearning(np.zeros(2), broyden="yes")
