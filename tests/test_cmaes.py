"""CMA-ES (the cma package) as a one-candidate-at-a-time ask/tell learner: solves smooth
problems, is deterministic, learns in the query space through dmprs.learn and in the weight space
as a baseline that logs and resumes like PoWER and PI².
"""

import numpy as np
import pytest

from dmprs import experiments
from dmprs.baselines import BaselineSpec, run_baseline
from dmprs.cmaes import CMAES
from dmprs.errors import InvalidInputError, LearnerStateError
from dmprs.loop import learn
from dmprs.runlog import RunLog
from tests.conftest import crash_after, drive

TARGET = np.array([0.3, -1.2, 2.0])


def test_solves_a_smooth_problem_as_cma_does_with_its_own_loop():
    def f(x):
        return float(np.sum((x - TARGET) ** 2 * [1.0, 4.0, 0.25]))

    ours = drive(CMAES(np.zeros(3), 0.5, seed=7, max_trials=600, feedback="cost"), f)
    assert ours.best is not None and ours.best.score < 1e-8
    np.testing.assert_allclose(ours.best.q, TARGET, atol=1e-3)
    # the same candidates as cma's own population loop, with cma's own seed handling
    import cma

    es = cma.CMAEvolutionStrategy(np.zeros(3), 0.5, {"seed": 8, "verbose": -9, "CMA_stds": [1.0] * 3})
    mine = CMAES(np.zeros(3), 0.5, seed=7, max_trials=60, feedback="cost")
    for _ in range(3):
        batch = es.ask()
        es.tell(batch, [f(x) for x in batch])
        for x in batch:
            q = mine.ask()
            np.testing.assert_array_equal(q, x)
            mine.tell(q, f(q))


def test_error_feedback_finds_a_root_and_converges():
    root = np.array([0.3, -1.2])

    def eps(x):  # a smooth monotone map, eps > 0 below the root (docs/method.md §5.3)
        return (root + 0.2 * np.sin(root)) - (x + 0.2 * np.sin(x))

    lrn = drive(CMAES([0.0, 0.0], 0.5, seed=1, max_trials=400, tol=1e-4), eps)
    assert lrn.converged and np.all(np.abs(eps(lrn.history[-1].q)) < 1e-4)
    np.testing.assert_allclose(lrn.history[-1].q, root, atol=1e-3)


def candidates(seed, disturb=False):
    lrn = CMAES([1.0, 1.0], 0.3, seed=seed, max_trials=40, feedback="cost")
    qs = []
    while not lrn.done:
        if disturb:  # someone else uses numpy's global random state between trials
            np.random.seed(len(qs))
            np.random.standard_normal(17)
        q = lrn.ask()
        qs.append(q)
        lrn.tell(q, float(np.sum(q**2)))
    return np.array(qs)


def test_deterministic_whatever_numpys_global_state_does():
    state = np.random.get_state()
    try:
        assert candidates(5).tobytes() == candidates(5, disturb=True).tobytes()
    finally:
        np.random.set_state(state)
    assert not np.array_equal(candidates(5), candidates(6))


def test_out_of_order_and_bad_feedback_are_clear_errors():
    lrn = CMAES([0.0], 1.0, seed=0, max_trials=5)
    with pytest.raises(LearnerStateError, match="without a pending ask"):
        lrn.tell([0.0], [1.0])
    q = lrn.ask()
    np.testing.assert_array_equal(lrn.ask(), q)  # asking again: the same candidate
    with pytest.raises(LearnerStateError, match="pending query"):
        lrn.tell(q + 1.0, [1.0])
    with pytest.raises(InvalidInputError, match="not finite"):
        lrn.tell(q, [np.nan])
    with pytest.raises(InvalidInputError, match="feedback = 'reward'"):
        CMAES([0.0], 1.0, feedback="reward")
    with pytest.raises(InvalidInputError, match="sigma0"):
        CMAES([0.0], -1.0)


def test_a_query_space_learner_of_learn_from_the_same_first_trial():
    s = experiments.make("analytic")
    lrn = s.make_learner("cma", seed=2)
    result = learn(s.task, s.generalizer, s.desired_query, lrn, max_trials=40)
    assert result.converged and result.n_trials <= 40
    np.testing.assert_array_equal(result.trials[0].query, s.desired_query)  # q0 first, as the paper's learners


def test_query_space_run_resumes_from_its_log(tmp_path):
    s = experiments.make("analytic")
    full = learn(s.task, s.generalizer, s.desired_query, s.make_learner("cma", seed=2), max_trials=40)
    cut = tmp_path / "run"
    learn(s.task, s.generalizer, s.desired_query, s.make_learner("cma", seed=2), max_trials=40, log_dir=cut)
    crash_after(cut, 3)
    s2 = experiments.make("analytic")
    resumed = learn(s2.task, s2.generalizer, s2.desired_query, s2.make_learner("cma", seed=2), max_trials=40,
                    log_dir=cut, resume=True)
    assert [t.query.tolist() for t in resumed.trials] == [t.query.tolist() for t in full.trials]


def test_weight_space_baseline_logs_every_rollout_and_resumes_identically(tmp_path):
    spec = BaselineSpec("analytic", "cma", seed=3, budget=25, sigma_frac=0.1, scale=0.5)
    reference = run_baseline(spec)
    assert reference["history"][0]["status"] == "ok" and reference["n_trials"] >= 2
    assert run_baseline(spec, log_dir=tmp_path / "full") == reference
    trials, _ = RunLog(tmp_path / "full").read()
    assert len(trials) == reference["n_trials"]
    cut = tmp_path / "cut"
    run_baseline(spec, log_dir=cut)
    crash_after(cut, 4)
    assert run_baseline(spec, log_dir=cut, resume=True) == reference


def test_cma_options_pass_through():
    assert CMAES([0.0, 0.0], 1.0, options={"popsize": 9}).popsize == 9
