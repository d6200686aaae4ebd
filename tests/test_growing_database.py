"""A database that grows: what Database.add does with a query already present, and learn(...,
database=) never losing a finished run to it.
"""

import numpy as np
import pytest

import dmprs
from dmprs.errors import InvalidInputError
from dmprs.experiments import analytic
from dmprs.learners import ErrorLearning
from dmprs.loop import learn


def traj(k: int) -> dmprs.Trajectory:
    rng = np.random.default_rng(k)
    t = np.linspace(0.0, 1.0, 60)
    return dmprs.Trajectory(t, np.cumsum(rng.standard_normal((60, 2)), axis=0))


def grown() -> dmprs.Database:
    db = dmprs.Database(("x",))
    for k, q in enumerate((0.0, 1.0, 2.0)):
        db.add(q, traj(k), label=f"demo {k}")
    return db


def test_refuse_is_the_default_and_changes_nothing():
    db = grown()
    with pytest.raises(InvalidInputError, match=r"demonstration 1 already has the query \[1\.0\].*on_duplicate"):
        db.add(1.0, traj(9))
    assert len(db) == 3 and db[1].label == "demo 1"


def test_replace_takes_the_place_of_the_old_demo(tmp_path):
    db = grown()
    db.add(1.0, traj(9), label="new", on_duplicate="replace")
    assert [d.label for d in db] == ["demo 0", "new", "demo 2"]
    assert db[1].trajectory == traj(9)
    db.save(tmp_path / "db")
    assert [d.label for d in dmprs.Database.load(tmp_path / "db")] == ["demo 0", "new", "demo 2"]


def test_replace_of_a_kept_repeat_leaves_one_demo():
    db = grown()
    db.add(1.0, traj(8), on_duplicate="keep")
    db.add(1.0, traj(9), label="new", on_duplicate="replace")
    assert [d.label for d in db] == ["demo 0", "new", "demo 2"]


def test_keep_keeps_both_and_survives_a_round_trip(tmp_path):
    db = grown()
    db.add(1.0, traj(9), label="again", on_duplicate="keep")
    assert len(db) == 4 and db[3].label == "again"
    db.save(tmp_path / "db")
    back = dmprs.Database.load(tmp_path / "db")
    assert [d.label for d in back] == ["demo 0", "demo 1", "demo 2", "again"]
    np.testing.assert_array_equal(back.queries[:, 0], [0.0, 1.0, 2.0, 1.0])


def test_unknown_policy():
    with pytest.raises(InvalidInputError, match="on_duplicate = 'merge' is invalid"):
        grown().add(5.0, traj(9), on_duplicate="merge")


def test_lwr_gp_refuses_repeats_with_a_clear_message():
    db = grown()
    db.add(1.0, traj(9), on_duplicate="keep")
    with pytest.raises(InvalidInputError, match="'lwr-gp' cannot use repeated queries"):
        dmprs.Generalizer(db, "lwr-gp", n_basis=10)


def relearn(policy: str | None) -> tuple[dmprs.Database, list]:
    """Learns the same desired outcome twice into one database (the second run is a repeat)."""
    s = analytic.setup()
    results = []
    for _ in range(2):
        kw = {} if policy is None else {"database_policy": policy}
        results.append(learn(s.task, s.generalizer, s.desired_query, ErrorLearning(s.desired_query),
                             database=s.database, **kw))
    return s.database, results


def test_learn_replaces_a_relearned_query_by_default():
    db, (first, second) = relearn(None)
    assert first.converged and second.converged
    assert len(db) == 3 and "not added" not in second.stop_reason
    np.testing.assert_array_equal(np.sort(db.queries[:, 0])[1], 1.5)


def test_learn_keeps_the_run_when_the_database_refuses():
    db, (_, second) = relearn("refuse")
    assert second.converged and second.learned_query is not None
    assert "not added to the database" in second.stop_reason and "already has the query" in second.stop_reason
    assert len(db) == 3


def test_learn_with_keep_adds_the_repeat():
    db, _ = relearn("keep")
    assert len(db) == 4


def test_learn_checks_the_policy_before_any_trial():
    s = analytic.setup()
    with pytest.raises(InvalidInputError, match="database_policy"):
        learn(s.task, s.generalizer, s.desired_query, ErrorLearning(s.desired_query),
              database=s.database, database_policy="sometimes")
