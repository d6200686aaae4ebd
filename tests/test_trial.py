"""One trial runner for every loop: bad adapter output becomes a logged error trial that never
reaches the learner, the run stops cleanly and can be resumed; the weight-space baselines log
through the same runner and resume bit for bit.
"""

import json

import numpy as np
import pytest

from dmprs import experiments
from dmprs.adapters import Outcome, Status
from dmprs.baselines import BaselineSpec, run_baseline
from dmprs.errors import RunLogError
from dmprs.loop import learn
from dmprs.runlog import RunLog
from tests.conftest import crash_after


def setup():
    return experiments.make("analytic")


class Untold:
    """A learner wrapper that fails the test if a bad trial reaches it."""

    def __init__(self, inner):
        self.inner = inner

    done = property(lambda self: self.inner.done)
    converged = property(lambda self: self.inner.converged)
    status = property(lambda self: self.inner.status)
    status_detail = property(lambda self: self.inner.status_detail)

    def ask(self):
        return self.inner.ask()

    def tell(self, q, eps):
        assert np.isfinite(np.atleast_1d(eps)).all(), "a non-finite error reached the learner"
        self.inner.tell(q, eps)


GOOD = {"outcome": 1.0, "peak": 0.9}
BAD_OUTCOMES = {
    "nan signal": lambda tr: Outcome(Status.OK, signals={**GOOD, "outcome": float("nan")}, executed=tr),
    "inf signal": lambda tr: Outcome(Status.OK, signals={**GOOD, "outcome": float("inf")}, executed=tr),
    "string signal": lambda tr: Outcome(Status.OK, signals={**GOOD, "outcome": "high"}, executed=tr),
    "array signal": lambda tr: Outcome(Status.OK, signals={**GOOD, "outcome": np.ones(3)}, executed=tr),
    "missing signal": lambda tr: Outcome(Status.OK, signals={"peak": 0.9}, executed=tr),
    "undeclared signal": lambda tr: Outcome(Status.OK, signals={**GOOD, "extra": 1.0}, executed=tr),
    "plain-string status": lambda tr: Outcome("ok", signals=GOOD, executed=tr),  # type: ignore[arg-type]
    "not an outcome": lambda tr: {"status": "ok"},
    "signals not a mapping": lambda tr: Outcome(Status.OK, signals=[1.0, 2.0], executed=tr),  # type: ignore[arg-type]
}


@pytest.mark.parametrize("case", sorted(BAD_OUTCOMES))
def test_bad_adapter_output_is_a_logged_error_trial_and_the_run_resumes(case, tmp_path):
    s = setup()
    good_execute = s.task.adapter._execute
    calls = {"n": 0}

    def flaky(trajectory):
        calls["n"] += 1
        return BAD_OUTCOMES[case](trajectory) if calls["n"] == 2 else good_execute(trajectory)

    s.task.adapter._execute = flaky
    result = learn(s.task, s.generalizer, s.desired_query, Untold(s.make_learner("error")),
                   log_dir=tmp_path, max_trials=20)
    assert not result.converged
    assert [t.status for t in result.trials] == ["ok", "error"]
    assert "trial 2 ended with status error" in result.stop_reason
    assert result.trials[1].eps is None and result.trials[1].message
    # strict JSON: every logged line parses without NaN/Infinity tokens being needed for eps
    lines = (tmp_path / "trials.jsonl").read_text().splitlines()
    assert len(lines) == 2 and json.loads(lines[1])["status"] == "error"

    # with the adapter repaired the run resumes where it stopped and succeeds
    s2 = setup()
    resumed = learn(s2.task, s2.generalizer, s2.desired_query, s2.make_learner("error"),
                    log_dir=tmp_path, resume=True, max_trials=20)
    assert resumed.converged
    assert [t.status for t in resumed.trials[:2]] == ["ok", "error"]
    np.testing.assert_array_equal(resumed.trials[2].query, result.trials[1].query)  # retried


def test_a_scoring_failure_is_logged_not_raised(tmp_path):
    s = setup()
    s.task.measure = lambda outcome: np.array([outcome.signals["no such signal"]])
    result = learn(s.task, s.generalizer, s.desired_query, s.make_learner("error"), log_dir=tmp_path)
    assert [t.status for t in result.trials] == ["error"]
    assert "cannot score the outcome (KeyError" in result.trials[0].message


def test_an_adapter_that_raises_is_a_logged_error_trial(tmp_path):
    s = setup()

    def boom(trajectory):
        raise RuntimeError("servo fault")

    s.task.adapter.execute = lambda trajectory, dry_run=False, timeout_s=None: boom(trajectory)
    result = learn(s.task, s.generalizer, s.desired_query, s.make_learner("error"), log_dir=tmp_path)
    assert result.trials[0].status == "error" and "servo fault" in result.trials[0].message
    assert len(RunLog(tmp_path).read()[0]) == 1


def test_a_database_that_refuses_the_success_does_not_lose_the_run():
    s = setup()

    class Refusing:
        def add(self, query, trajectory, *, on_duplicate="refuse"):
            from dmprs.errors import DatabaseError

            raise DatabaseError("the database is read-only")

    result = learn(s.task, s.generalizer, s.desired_query, s.make_learner("error"), database=Refusing())
    assert result.converged and "not added to the database: the database is read-only" in result.stop_reason


BASELINE = BaselineSpec("analytic", "pi2", seed=3, budget=25, sigma_frac=0.1, scale=0.5)


@pytest.mark.parametrize("method", ["pi2", "power"])
def test_baselines_log_every_rollout_and_resume_identically(method, tmp_path):
    spec = BaselineSpec("analytic", method, seed=3, budget=25, sigma_frac=0.1, scale=0.5)
    reference = run_baseline(spec)
    logged = run_baseline(spec, log_dir=tmp_path / "full")
    assert logged == reference  # logging changes nothing
    trials, _ = RunLog(tmp_path / "full").read()
    assert len(trials) == reference["n_trials"]
    assert [t.status for t in trials] == [h["status"] for h in reference["history"]]

    # cut the log after a few rollouts (as a crash would) and resume: the same run, bit for bit
    cut = tmp_path / "cut"
    run_baseline(spec, log_dir=cut)
    crash_after(cut, 4)
    assert run_baseline(spec, log_dir=cut, resume=True) == reference


def test_a_baseline_resumed_with_another_seed_is_refused(tmp_path):
    run_baseline(BASELINE, log_dir=tmp_path)
    other = BaselineSpec("analytic", "pi2", seed=4, budget=25, sigma_frac=0.1, scale=0.5)
    with pytest.raises(RunLogError, match="other weights than the learner now asks"):
        run_baseline(other, log_dir=tmp_path, resume=True)
