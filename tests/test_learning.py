"""The learning loop end to end on the analytic task: convergence, the trial log, crash safety,
resume, faults, and the database growing with experience.
"""

import json

import numpy as np
import pytest

import dmprs
from dmprs import experiments
from dmprs.adapters import Outcome, Status
from dmprs.loop import learn
from dmprs.runlog import RunLog, RunLogError
from dmprs.tasks.analytic import outcome_map


def setup(**kw):
    return experiments.make("analytic", **kw)


def test_error_learning_reaches_the_desired_outcome():
    s = setup()
    result = learn(s.task, s.generalizer, s.desired_query, s.make_learner("error"), max_trials=20)
    assert result.converged
    assert result.n_trials <= 6
    last = result.trials[-1]
    assert last.success and abs(last.eps[0]) < s.task.tol
    # independent truth: the executed peak maps to the desired outcome through the true map
    assert abs(outcome_map(last.signals["peak"]) - 1.5) < s.task.tol
    np.testing.assert_array_equal(result.learned_query, last.query)


def test_the_first_trial_is_the_plain_generalization():
    s = setup()
    result = learn(s.task, s.generalizer, s.desired_query, s.make_learner("error"), max_trials=20)
    np.testing.assert_array_equal(result.trials[0].query, s.desired_query)


@pytest.mark.parametrize("name", ["error", "weighted", "secant", "golden", "golden-robust", "root"])
def test_every_query_learner_converges_on_the_analytic_task(name):
    s = setup()
    result = learn(s.task, s.generalizer, s.desired_query, s.make_learner(name), max_trials=30)
    assert result.converged, (name, [t.eps for t in result.trials])


class _Passing:
    """A learner that passes every call to ``inner``; a test overrides ``tell`` to watch what
    the learn loop tells.
    """

    converged = False
    done = property(lambda self: self.inner.done)
    status_detail = property(lambda self: self.inner.status_detail)

    def __init__(self, inner):
        self.inner = inner

    def ask(self):
        return self.inner.ask()

    def tell(self, q, eps):
        self.inner.tell(q, eps)


def test_each_trial_is_on_disk_before_the_learner_sees_it(tmp_path):
    s = setup()
    log_path = tmp_path / "trials.jsonl"

    class Watching(_Passing):
        def tell(self, q, eps):
            lines = log_path.read_text().splitlines()
            assert json.loads(lines[-1])["query"] == list(np.atleast_1d(q))
            super().tell(q, eps)

    result = learn(s.task, s.generalizer, s.desired_query, Watching(s.make_learner("error")), log_dir=tmp_path)
    assert len(log_path.read_text().splitlines()) == len(result.trials)


def test_a_crash_loses_no_finished_trial_and_resume_continues_identically(tmp_path):
    s = setup(noise=0.002, tol=0.004)
    reference = learn(s.task, s.generalizer, s.desired_query, s.make_learner("error"), max_trials=20)
    assert reference.n_trials >= 3

    class Crashing(_Passing):
        told = 0

        def tell(self, q, eps):
            self.told += 1
            if self.told == 2:
                raise KeyboardInterrupt
            super().tell(q, eps)

    with pytest.raises(KeyboardInterrupt):
        learn(s.task, s.generalizer, s.desired_query, Crashing(s.make_learner("error")), log_dir=tmp_path)
    trials, cut = RunLog(tmp_path).read()
    assert len(trials) == 2 and cut is None

    resumed = learn(s.task, s.generalizer, s.desired_query, s.make_learner("error"),
                    max_trials=20, log_dir=tmp_path, resume=True)
    assert [t.query.tolist() for t in resumed.trials] == [t.query.tolist() for t in reference.trials]
    assert [t.eps.tolist() for t in resumed.trials] == [t.eps.tolist() for t in reference.trials]


def test_a_line_cut_mid_write_is_reported_and_the_complete_trials_kept(tmp_path):
    s = setup()
    learn(s.task, s.generalizer, s.desired_query, s.make_learner("error"), max_trials=2, log_dir=tmp_path)
    with open(tmp_path / "trials.jsonl", "a") as f:
        f.write('{"trial": 2, "query": [1.4')  # the crash
    trials, cut = RunLog(tmp_path).read()
    assert len(trials) == 2 and "cut mid-write" in cut
    result = learn(s.task, s.generalizer, s.desired_query, s.make_learner("error"),
                   max_trials=20, log_dir=tmp_path, resume=True)
    assert result.converged and "cut mid-write" in result.cut_note
    trials, cut = RunLog(tmp_path).read()
    assert cut is None and len(trials) == len(result.trials)


def test_resume_with_a_differently_configured_learner_is_refused(tmp_path):
    s = setup(tol=1e-9)  # cannot converge in the 2 trials run
    learn(s.task, s.generalizer, s.desired_query, s.make_learner("error"), max_trials=2, log_dir=tmp_path)
    with pytest.raises(RunLogError, match="the learner now asks"):
        learn(s.task, s.generalizer, s.desired_query, s.make_learner("golden"),
              max_trials=20, log_dir=tmp_path, resume=True)


def test_an_unreadable_run_directory(tmp_path):
    with pytest.raises(RunLogError, match="not a run directory"):
        RunLog(tmp_path / "missing").read()
    (tmp_path / "run.json").write_text("{not json")
    with pytest.raises(RunLogError, match=r"run.json is not a readable run description"):
        RunLog(tmp_path).meta()
    (tmp_path / "run.json").write_text('{"schema_version": 99}')
    with pytest.raises(RunLogError, match="schema version 99"):
        RunLog(tmp_path).meta()


def test_a_log_dir_that_already_holds_trials_is_not_overwritten(tmp_path):
    s = setup()
    learn(s.task, s.generalizer, s.desired_query, s.make_learner("error"), max_trials=1, log_dir=tmp_path)
    with pytest.raises(RunLogError, match="already holds trials"):
        learn(s.task, s.generalizer, s.desired_query, s.make_learner("error"), log_dir=tmp_path)


@pytest.mark.parametrize("fault, status", [("raise", "error"), ("slow", "timeout")])
def test_an_adapter_that_fails_mid_trial_stops_the_run_cleanly(tmp_path, fault, status):
    s = setup()
    adapter = s.task.adapter
    original = adapter._execute
    calls = {"n": 0}

    def faulty(trajectory):
        calls["n"] += 1
        if calls["n"] == 2:
            if fault == "raise":
                raise ConnectionError("robot controller went away")
            while not adapter._interrupted():
                pass
            return adapter._interrupted_outcome()
        return original(trajectory)

    adapter._execute = faulty
    result = learn(s.task, s.generalizer, s.desired_query, s.make_learner("error"),
                   log_dir=tmp_path, timeout_s=0.05)
    assert not result.converged and status in result.stop_reason
    trials, _ = RunLog(tmp_path).read()
    assert [t.status for t in trials] == ["ok", status]
    assert trials[0].eps is not None and trials[1].eps is None


def test_a_non_ok_outcome_never_reaches_the_learner():
    s = setup()
    s.task.adapter._execute = lambda trajectory: Outcome(Status.ABORTED, message="safety stop")

    class Strict(_Passing):
        def tell(self, q, eps):
            raise AssertionError("tell must not be called")

    result = learn(s.task, s.generalizer, s.desired_query, Strict(s.make_learner("error")))
    assert result.trials[0].status == "aborted" and result.n_trials == 0


def test_bad_arguments():
    s = setup()
    lrn = s.make_learner("error")
    with pytest.raises(dmprs.InvalidInputError, match=r"desired_query has shape \(2,\), expected \(1,\)"):
        learn(s.task, s.generalizer, [1.0, 2.0], lrn)
    with pytest.raises(dmprs.InvalidInputError, match="max_trials"):
        learn(s.task, s.generalizer, s.desired_query, lrn, max_trials=0)
    with pytest.raises(dmprs.InvalidInputError, match="unknown learner 'sgd'"):
        s.make_learner("sgd")
    with pytest.raises(dmprs.InvalidInputError, match="unknown experiment 'juggling'"):
        experiments.run("juggling")


def test_learned_movements_grow_the_database_and_speed_up_nearby_queries():
    # The paper's conclusion: the richer the database, the fewer trials a new query needs.
    s = setup(desired=1.5, tol=0.002)
    first = learn(s.task, s.generalizer, s.desired_query, s.make_learner("error"), max_trials=20,
                  database=s.database)
    assert first.converged and len(s.database) == 3
    nearby = np.array([1.62])
    before = learn(s.task, s.generalizer, nearby, s.make_learner("error").__class__(nearby), max_trials=20)
    # piecewise-linear generalization over the grown database: the two demos nearest the query
    richer = dmprs.Generalizer(s.database.nearest(nearby, 2), method="linear", n_basis=25)
    after = learn(s.task, richer, nearby, s.make_learner("error").__class__(nearby), max_trials=20)
    assert before.converged and after.converged
    assert abs(after.trials[0].eps[0]) < abs(before.trials[0].eps[0]) / 3
    assert after.n_trials < before.n_trials, (before.n_trials, after.n_trials)


def _analytic_run(tmp_path, trials=3):
    from click.testing import CliRunner

    from dmprs.cli import main

    CliRunner().invoke(main, ["learn", "analytic", "--log-dir", str(tmp_path), "--max-trials", str(trials),
                              "--noise", "0.05", "--desired", "1.2"])
    return tmp_path


def test_damage_to_a_run_log_is_reported_not_resumed_over(tmp_path):
    from dmprs.runlog import RunLog, RunLogError

    path = _analytic_run(tmp_path / "a")
    trials, _ = RunLog(path).read()
    assert len(trials) >= 2
    (path / "trial_0001.npz").unlink()
    with pytest.raises(RunLogError, match=r"trial_0001\.npz is missing"):
        RunLog(path).read()
    path = _analytic_run(tmp_path / "b")
    (path / "trials.jsonl").write_text("")
    with pytest.raises(RunLogError, match=r"lists 0 trial\(s\) but the directory also holds trial_0001"):
        RunLog(path).read()


def test_the_trial_log_is_strict_json_and_reads_back_non_finite_values(tmp_path):
    import json

    import numpy as np

    from dmprs.runlog import RunLog, RunLogError, TrialRecord

    log = RunLog.create(tmp_path, {"task": "t"})
    record = TrialRecord(0, np.array([0.5]), "ok", eps=np.array([0.25]), signals={"s": -np.inf, "n": np.nan})
    log.append(record, None, None)
    line = (tmp_path / "trials.jsonl").read_text()
    json.loads(line, parse_constant=lambda c: pytest.fail(f"bare {c} in the log"))
    back = RunLog(tmp_path).read()[0][0]
    assert back.signals["s"] == -np.inf and np.isnan(back.signals["n"]) and back.eps[0] == 0.25
    # a trial's query and error are finite: the trial runner never logs others, so one is damage
    log.append(TrialRecord(1, np.array([0.5]), "ok", eps=np.array([np.inf])), None, None)
    with pytest.raises(RunLogError, match=r"trials\.jsonl, trial 1: 'eps' is \[inf\]: not finite"):
        RunLog(tmp_path).read()
