"""A job's memo of pours: a pour simulated once is read back, bit for bit, by every later call with
the same inputs, in any process; without a memo folder nothing is kept.
"""

import multiprocessing
import pickle

import numpy as np

from dmprs.sim import pour_memo
from dmprs.sim.pour_record import PourRecord
from dmprs.tasks import PouringAdapter
from dmprs.tasks.pouring import tilt_profile


def record(n_glass: int, interrupted: bool = False) -> PourRecord:
    return PourRecord(times=np.arange(3.0), sample_times=np.zeros(1), glass_counts=np.array([n_glass]),
                      region=np.zeros(2, dtype=np.int8), positions=np.zeros((2, 3)), n_particles=2, n_bottle=2 - n_glass,
                      n_glass=n_glass, n_spilled=0, interrupted=interrupted)


class Counting:
    def __init__(self, result):
        self.calls, self.result = 0, result

    def __call__(self):
        self.calls += 1
        return self.result


def test_without_a_memo_folder_every_call_simulates(monkeypatch):
    monkeypatch.delenv(pour_memo.MEMO_DIR, raising=False)
    simulate = Counting(record(1))
    for _ in range(2):
        assert pour_memo.memoized("s", (1, np.zeros(3)), simulate) is simulate.result
    assert simulate.calls == 2


def test_a_pour_is_simulated_once_per_inputs_and_read_back(monkeypatch, tmp_path):
    monkeypatch.setenv(pour_memo.MEMO_DIR, str(tmp_path))
    simulate = Counting(record(1))
    inputs = (3, 0.5, np.linspace(0.0, 1.0, 5))
    first = pour_memo.memoized("s", inputs, simulate)
    again = pour_memo.memoized("s", (3, 0.5, np.linspace(0.0, 1.0, 5)), simulate)
    assert simulate.calls == 1
    assert again is not first and np.array_equal(again.times, first.times) and again.n_glass == 1
    # any input that differs, in value, dtype or shape, or another scene is another pour
    for scene, other in (("s", (3, 0.5, np.linspace(0.0, 1.0, 5) + np.array([0, 0, 0, 0, 1e-12]))),
                         ("s", (3, 0.5, np.linspace(0.0, 1.0, 5).astype(np.float32))),
                         ("s", (3, 0.5, np.linspace(0.0, 1.0, 5)[None, :])),
                         ("s", (4, 0.5, np.linspace(0.0, 1.0, 5))),
                         ("t", inputs)):
        pour_memo.memoized(scene, other, simulate)
    assert simulate.calls == 6
    assert not list(tmp_path.glob("*.part"))


def test_an_interrupted_or_unstarted_pour_is_not_kept(monkeypatch, tmp_path):
    monkeypatch.setenv(pour_memo.MEMO_DIR, str(tmp_path))
    for result in (record(0, interrupted=True), None):
        simulate = Counting(result)
        pour_memo.memoized("s", (1,), simulate)
        pour_memo.memoized("s", (1,), simulate)
        assert simulate.calls == 2
    assert not list(tmp_path.iterdir())


def pour(volume: float, peak: float):
    adapter = PouringAdapter(volume, liquid_seed=1)
    with adapter:
        adapter.reset(seed=0)
        return adapter.execute(tilt_profile(peak, (1.0, 1.0, 1.0)))


def same_outcome(a, b) -> bool:
    if a.status != b.status or a.signals.keys() != b.signals.keys():
        return False
    same = all(np.array_equal(np.asarray(a.signals[k]), np.asarray(b.signals[k])) for k in a.signals)
    return same and np.array_equal(a.executed.t, b.executed.t) and np.array_equal(a.executed.y, b.executed.y)


def test_a_pour_read_back_in_another_process_is_the_simulated_one_bit_for_bit(monkeypatch, tmp_path):
    monkeypatch.delenv(pour_memo.MEMO_DIR, raising=False)
    simulated = pour(0.2, 1.9)
    monkeypatch.setenv(pour_memo.MEMO_DIR, str(tmp_path))
    with multiprocessing.get_context("spawn").Pool(1) as pool:  # the memo is written in a worker
        written = pool.apply(pour, (0.2, 1.9))
    assert len(list(tmp_path.glob("pouring-*.pickle"))) == 1
    read = pour(0.2, 1.9)
    assert same_outcome(simulated, written) and same_outcome(simulated, read)
    assert len(list(tmp_path.glob("pouring-*.pickle"))) == 1
    other = pour(0.2, 1.8)  # another trajectory is simulated, not read
    assert len(list(tmp_path.glob("pouring-*.pickle"))) == 2
    assert not same_outcome(simulated, other)


def test_what_is_read_back_is_what_was_kept_not_a_fresh_simulation(monkeypatch, tmp_path):
    """A planted file stands in for the pour: the memo really is read, not recomputed."""
    monkeypatch.setenv(pour_memo.MEMO_DIR, str(tmp_path))
    simulate = Counting(record(1))
    pour_memo.memoized("s", (7,), simulate)
    (path,) = tmp_path.glob("s-*.pickle")
    path.write_bytes(pickle.dumps(record(2)))
    got = pour_memo.memoized("s", (7,), simulate)
    assert simulate.calls == 1 and got.n_glass == 2
