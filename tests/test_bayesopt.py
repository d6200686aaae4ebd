"""Bayesian optimization (the bayesian-optimization package) as a one-query-at-a-time ask/tell
learner in the query space: it asks what the package's own loop asks, finds roots of smooth maps,
stays in its box, is deterministic, and learns, logs and resumes through dmprs.learn from the
same first trial as the paper's learners.
"""

import warnings

import numpy as np
import pytest

from dmprs import experiments
from dmprs.bayesopt import BayesOpt
from dmprs.errors import InvalidInputError, LearnerStateError
from dmprs.experiments.base import search_box
from dmprs.loop import learn
from tests.conftest import crash_after, drive


def eps_of(root):
    """A smooth monotone map with its root at ``root``; eps > 0 below it (docs/method.md §5.3)."""
    root = np.asarray(root, dtype=float)
    return lambda x: (root + 0.2 * np.sin(root)) - (x + 0.2 * np.sin(x))


def test_asks_what_the_package_asks_in_its_own_loop():
    from bayes_opt import BayesianOptimization

    eps = eps_of([0.7])
    mine = BayesOpt([0.2], lower=[-1.0], upper=[2.0], seed=4, random_starts=2, max_trials=8)
    ref = BayesianOptimization(f=None, pbounds={"q000": (-1.0, 2.0)}, random_state=np.random.RandomState(4),
                               verbose=0, allow_duplicate_points=True)
    queue = [{"q000": 0.2}, *ref.random_sample(2)]
    for _ in range(8):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            params = queue.pop(0) if queue else ref.suggest()
        expected = np.clip(float(np.asarray(params["q000"]).reshape(-1)[0]), -1.0, 2.0)
        q = mine.ask()
        assert q.tolist() == [expected]
        e = eps(q)
        mine.tell(q, e)
        ref.register({"q000": expected}, -float(np.abs(e[0])))


@pytest.mark.parametrize("root", [[0.7], [0.3, -1.2]])
def test_finds_the_root_of_a_smooth_map_within_its_box(root):
    lower, upper = np.full(len(root), -2.0), np.full(len(root), 2.0)
    lrn = drive(BayesOpt(np.zeros(len(root)), lower=lower, upper=upper, seed=1, random_starts=1, max_trials=60,
                       tol=0.01), eps_of(root))
    assert lrn.converged, lrn.status_detail
    np.testing.assert_allclose(lrn.history[-1].q, root, atol=0.02)  # |eps| < 0.01, slope >= 0.8
    qs = np.array([t.q for t in lrn.history])
    assert (qs >= lower).all() and (qs <= upper).all()
    np.testing.assert_array_equal(qs[0], np.zeros(len(root)))  # the first trial is x0


def queries(seed):
    lrn = drive(BayesOpt([0.5, 0.5], lower=0.0, upper=1.0, seed=seed, random_starts=1, max_trials=8),
              eps_of([0.2, 0.8]))
    return np.array([t.q for t in lrn.history])


def test_deterministic_and_seeded():
    state = np.random.get_state()
    try:
        first = queries(3)
        np.random.seed(99)  # numpy's global state plays no part
        assert queries(3).tobytes() == first.tobytes()
    finally:
        np.random.set_state(state)
    assert not np.array_equal(queries(3), queries(4))


def test_out_of_order_and_bad_input_are_clear_errors():
    lrn = BayesOpt([0.0], lower=-1.0, upper=1.0, max_trials=3)
    with pytest.raises(LearnerStateError, match="without a pending ask"):
        lrn.tell([0.0], [1.0])
    q = lrn.ask()
    np.testing.assert_array_equal(lrn.ask(), q)
    with pytest.raises(LearnerStateError, match="pending query"):
        lrn.tell(q + 0.5, [1.0])
    with pytest.raises(InvalidInputError, match="not finite"):
        lrn.tell(q, [np.inf])
    with pytest.raises(InvalidInputError, match="shape"):
        lrn.tell(q, [1.0, 2.0])
    with pytest.raises(InvalidInputError, match="hold x0"):
        BayesOpt([3.0], lower=-1.0, upper=1.0)
    with pytest.raises(InvalidInputError, match="seed"):
        BayesOpt([0.0], lower=-1.0, upper=1.0, seed=-1)
    with pytest.raises(InvalidInputError, match="random_starts"):
        BayesOpt([0.0], lower=-1.0, upper=1.0, random_starts=-2)
    lrn = drive(BayesOpt([0.0], lower=-1.0, upper=1.0, max_trials=2), eps_of([0.9]))
    assert lrn.status == "trial-cap"
    with pytest.raises(LearnerStateError, match="after done"):
        lrn.ask()


def test_search_box_holds_the_demos_and_the_desired_query_with_a_tenth_to_spare():
    lower, upper = search_box([[0.3], [1.0]], [0.5])
    np.testing.assert_allclose(lower, [0.23])
    np.testing.assert_allclose(upper, [1.07])
    lower, upper = search_box([[0.5, 0.0], [0.75, 1.0]], [1.5, 0.5])  # q0 beyond the demos
    np.testing.assert_allclose(lower, [0.4, -0.1])
    np.testing.assert_allclose(upper, [1.6, 1.1])
    assert search_box([[2.0]], [2.0]) == ((1.0,), (3.0,))


def test_learns_from_the_same_first_trial_and_resumes_from_its_log(tmp_path):
    s = experiments.make("analytic")
    lower, upper = s.settings.box
    assert lower[0] < min(s.low, s.desired_query[0]) and upper[0] > max(s.high, s.desired_query[0])
    full = learn(s.task, s.generalizer, s.desired_query, s.make_learner("bo", seed=2), max_trials=25)
    assert full.converged
    np.testing.assert_array_equal(full.trials[0].query, s.desired_query)
    cut = tmp_path / "run"
    learn(s.task, s.generalizer, s.desired_query, s.make_learner("bo", seed=2), max_trials=25, log_dir=cut)
    crash_after(cut, 3)
    s2 = experiments.make("analytic")
    resumed = learn(s2.task, s2.generalizer, s2.desired_query, s2.make_learner("bo", seed=2), max_trials=25,
                    log_dir=cut, resume=True)
    assert [t.query.tolist() for t in resumed.trials] == [t.query.tolist() for t in full.trials]
    default = s.make_learner("bo-default", seed=2)
    qs = [default.ask()]
    default.tell(qs[0], [0.5])
    assert qs[0].tolist() == s.desired_query.tolist()
