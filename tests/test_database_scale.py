"""dmprs.Database at scale: the duplicate check without a scan, nearest(k) through a k-d tree
against a full stable sort, and the append-only save (what it writes, and what it still checks).
"""

import os

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import dmprs
from dmprs import database as dbmod
from dmprs.errors import InvalidInputError

T = np.linspace(0.0, 1.0, 20)


def small_db(queries) -> dmprs.Database:
    db = dmprs.Database(("a", "b"))
    for k, q in enumerate(queries):
        db.add(q, dmprs.Trajectory(T, np.outer(T, [1.0 + k, -1.0])), on_duplicate="keep")
    return db


def brute_force_nearest(queries: np.ndarray, q: np.ndarray, k: int) -> list[int]:
    """What nearest(k) was before the index: a full stable sort of the distances."""
    return sorted(np.argsort(np.linalg.norm(queries - q, axis=1), kind="stable")[:k].tolist())


# A coarse grid makes ties (equal distances) and repeated queries common.
grid = st.integers(-3, 3).map(lambda i: i * 0.5)


@settings(max_examples=150, deadline=None)
@given(st.lists(st.tuples(grid, grid), min_size=1, max_size=40), st.tuples(grid, grid), st.data())
def test_nearest_matches_a_full_stable_sort_ties_included(points, probe, data):
    queries = np.array(points, dtype=float)
    db = small_db(queries)
    k = data.draw(st.integers(1, len(points)))
    chosen = db.nearest(np.array(probe), k)
    expected = brute_force_nearest(queries, np.array(probe), k)
    assert [d.query.tolist() for d in chosen] == [queries[i].tolist() for i in expected]
    assert [d for d in chosen] == [db[i] for i in expected]  # the same records, in database order


def test_nearest_follows_adds():
    db = small_db([[0.0, 0.0], [1.0, 0.0]])
    assert db.nearest([0.9, 0.0], 1)[0].query.tolist() == [1.0, 0.0]
    db.add([0.9, 0.0], dmprs.Trajectory(T, np.outer(T, [5.0, 1.0])))
    assert db.nearest([0.9, 0.0], 1)[0].query.tolist() == [0.9, 0.0]


def test_duplicates_are_found_without_a_scan_but_as_before():
    db = small_db([[0.0, 1.0], [2.0, 3.0]])
    traj = dmprs.Trajectory(T, np.outer(T, [3.0, 3.0]))
    with pytest.raises(InvalidInputError, match=r"demonstration 0 already has the query \[-0.0, 1.0\]"):
        db.add([-0.0, 1.0], traj)  # -0.0 == 0.0, as np.array_equal says
    db.add([0.0, 1.0], traj, on_duplicate="keep")
    db.add([0.0, 1.0], traj, on_duplicate="replace")  # both earlier ones give way
    assert [d.query.tolist() for d in db] == [[0.0, 1.0], [2.0, 3.0]]
    assert db[0].trajectory is traj
    with pytest.raises(InvalidInputError, match="already has the query"):
        db.add([0.0, 1.0], traj)
    sub = db.nearest([2.0, 3.0], 1)
    with pytest.raises(InvalidInputError, match="already has the query"):
        sub.add([2.0, 3.0], traj)  # the subset knows its own queries


def count_writes(monkeypatch) -> list[str]:
    written: list[str] = []
    real = dbmod._atomic_write

    def spy(target, data, **kw):
        written.append(target.name)
        real(target, data, **kw)

    monkeypatch.setattr(dbmod, "_atomic_write", spy)
    return written


def test_a_save_after_one_more_demo_writes_that_demo_and_the_manifest(tmp_path, monkeypatch):
    path = tmp_path / "db"
    small_db([[float(i), 0.0] for i in range(30)]).save(path)
    before = {p.name: p.stat().st_ino for p in path.iterdir()}
    db = dmprs.Database.load(path)
    written = count_writes(monkeypatch)
    db.add([99.0, 0.0], dmprs.Trajectory(T, np.outer(T, [7.0, 7.0])))
    db.save(path)
    assert len(written) == 2 and written[-1] == "manifest.json"
    assert all(path.joinpath(n).stat().st_ino == i for n, i in before.items() if n.startswith("demo_"))
    written.clear()
    db.add([98.0, 0.0], dmprs.Trajectory(T, np.outer(T, [8.0, 7.0])))
    db.save(path)  # the same object again: it remembers its own save
    assert len(written) == 2
    loaded = dmprs.Database.load(path)
    assert len(loaded) == 32 and loaded[-1].query.tolist() == [98.0, 0.0]


def test_a_directory_changed_by_another_save_is_checked_in_full(tmp_path, monkeypatch):
    path = tmp_path / "db"
    mine = small_db([[0.0, 0.0], [1.0, 0.0]])
    mine.save(path)
    small_db([[5.0, 5.0]]).save(path)  # another database replaces the manifest and prunes
    written = count_writes(monkeypatch)
    mine.save(path)
    assert len(written) == 3  # both demos again (the other save removed them), and the manifest
    assert [d.query.tolist() for d in dmprs.Database.load(path)] == [[0.0, 0.0], [1.0, 0.0]]


def test_a_demo_file_swapped_behind_the_manifest_is_rewritten(tmp_path):
    path = tmp_path / "db"
    db = small_db([[0.0, 0.0], [1.0, 0.0]])
    db.save(path)
    victim = min(path.glob("demo_*.npz"))
    data = victim.read_bytes()
    victim.unlink()
    victim.write_bytes(data[:-10])  # a new inode, truncated
    db.save(path)
    assert victim.read_bytes() == data
    assert len(dmprs.Database.load(path)) == 2


def test_a_failed_save_trusts_nothing_next_time(tmp_path, monkeypatch):
    path = tmp_path / "db"
    db = small_db([[0.0, 0.0]])
    db.save(path)
    db.add([1.0, 0.0], dmprs.Trajectory(T, np.outer(T, [2.0, 2.0])))
    real = dbmod._atomic_write

    def crash_on_manifest(target, data, **kw):
        if target.name == "manifest.json":
            raise dbmod.DatabaseError("crash")
        real(target, data, **kw)

    monkeypatch.setattr(dbmod, "_atomic_write", crash_on_manifest)
    with pytest.raises(dbmod.DatabaseError):
        db.save(path)
    assert db._synced is None
    monkeypatch.setattr(dbmod, "_atomic_write", real)
    (path / ".manifest.json.abc12345.tmp").write_bytes(b"half")  # what an interrupted write leaves
    db.save(path)
    assert not (path / ".manifest.json.abc12345.tmp").exists()
    assert len(dmprs.Database.load(path)) == 2
    assert sorted(os.listdir(path)) == sorted(
        [".dmprs.lock", "manifest.json", *(d._entry.file for d in db)])
