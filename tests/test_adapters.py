"""The adapter interface: the shared check, statuses, recording and replay, conformance."""

import threading
import time

import numpy as np
import pytest

import dmprs
from dmprs.adapters import (
    AdapterConformanceError,
    AdapterError,
    AdapterSpec,
    BaseAdapter,
    Outcome,
    RecordingAdapter,
    ReplayAdapter,
    SignalSpec,
    Status,
    check_adapter,
    load_adapter,
)
from dmprs.tasks.analytic import AnalyticAdapter, bump


def spec(**kw) -> AdapterSpec:
    base = {"name": "toy", "dof_names": ("a", "b"), "dof_units": ("rad", "m"), "control_period": 0.01,
                "signals": (SignalSpec("s", "m"),), "position_min": (-1.0, -1.0),
                "position_max": (1.0, 1.0), "velocity_max": (2.0, 2.0), "acceleration_max": (50.0, 50.0),
                "start_pose": (0.0, 0.0), "start_tolerance": 0.01, "max_duration": 5.0}
    base.update(kw)
    return AdapterSpec(**base)


def line(a: float = 0.5, n: int = 101, duration: float = 1.0) -> dmprs.Trajectory:
    t = np.linspace(0, duration, n)
    s = 10 * (t / duration) ** 3 - 15 * (t / duration) ** 4 + 6 * (t / duration) ** 5
    return dmprs.Trajectory(t, np.stack([a * s, -a * s], 1))


def test_valid_trajectory_passes_the_check():
    assert spec().check(line()) == []


@pytest.mark.parametrize(
    "make, words",
    [
        (lambda: line(a=1.5), "position of a is 1.5 rad at t = 1 s, above the maximum 1"),
        (lambda: line(a=0.9, duration=0.4), "velocity of a"),
        (lambda: line(a=0.9, duration=0.2), "acceleration of a"),
        (lambda: line(duration=6.0), "duration 6 s exceeds the limit 5 s"),
        (lambda: dmprs.Trajectory(np.linspace(0, 1, 11), np.full((11, 2), 0.5)), "a starts at 0.5 rad"),
        (lambda: dmprs.Trajectory(np.linspace(0, 1, 11), np.zeros((11, 3))), "trajectory has 3 DOFs"),
    ],
)
def test_check_rejects_with_a_clear_reason(make, words):
    problems = spec().check(make())
    assert any(words in p for p in problems), problems


def test_check_reports_nan_even_in_trusted_trajectories():
    y = line().y.copy()
    y[5, 1] = np.nan
    bad = dmprs.Trajectory._trusted(line().t.copy(), y, None, None)
    assert spec().check(bad) == ["y[5, 1] (b) is not finite"]


def test_spec_validation():
    with pytest.raises(dmprs.InvalidInputError, match="2 dof_names but 1 dof_units"):
        spec(dof_units=("rad",))
    with pytest.raises(dmprs.InvalidInputError, match="control_period"):
        spec(control_period=0.0)
    with pytest.raises(dmprs.InvalidInputError, match="position_max has 1 entries"):
        spec(position_max=(1.0,))


class Toy(BaseAdapter):
    """A minimal adapter whose behaviour the tests choose."""

    def __init__(self, behaviour="ok"):
        super().__init__(spec())
        self.behaviour = behaviour
        self.executed = 0

    def _execute(self, trajectory):
        self.executed += 1
        if self.behaviour == "raise":
            raise RuntimeError("gripper jammed")
        if self.behaviour == "slow":
            for _ in range(200):
                if self._interrupted():
                    return self._interrupted_outcome()
                time.sleep(0.005)
        return Outcome(Status.OK, signals={"s": float(trajectory.y[-1, 0])}, executed=trajectory)


def test_execute_before_connect_is_an_error():
    with pytest.raises(AdapterError, match="before connect"):
        Toy().execute(line())


def test_rejected_and_dry_run_never_execute():
    a = Toy()
    with a:
        assert a.execute(line(a=3.0)).status is Status.REJECTED
        assert a.execute(line(), dry_run=True).status is Status.DRY_RUN
        assert a.executed == 0
        assert a.execute(line()).ok


def test_an_adapter_that_raises_gives_an_error_outcome():
    with Toy("raise") as a:
        o = a.execute(line())
    assert o.status is Status.ERROR and "gripper jammed" in o.message


def test_timeout_and_stop():
    with Toy("slow") as a:
        assert a.execute(line(), timeout_s=0.02).status is Status.TIMEOUT
        timer = threading.Timer(0.02, a.stop)
        timer.start()
        o = a.execute(line())
        timer.join()
        assert o.status is Status.STOPPED


def test_recording_and_replay_serve_the_same_outcomes(tmp_path):
    rec = RecordingAdapter(AnalyticAdapter(noise=0.05), tmp_path / "rec")
    outcomes = []
    with rec:
        for k, a in enumerate([0.5, 1.0, 1.5]):
            rec.reset(seed=k)
            outcomes.append(rec.execute(bump(a)))
        rec.execute(bump(9.0))  # rejected, recorded too
    replay = ReplayAdapter(tmp_path / "rec", spec=AnalyticAdapter().spec)
    assert len(replay) == 4
    with replay:
        for a, o in zip([0.5, 1.0, 1.5], outcomes, strict=True):
            again = replay.execute(bump(a))
            assert again.status is Status.OK
            assert again.signals == o.signals
            assert again.executed == o.executed
        assert replay.execute(bump(9.0)).status is Status.REJECTED
        assert replay.execute(bump(1.0)).status is Status.ERROR  # nothing left


def test_replay_refuses_a_different_trajectory(tmp_path):
    rec = RecordingAdapter(AnalyticAdapter(), tmp_path)
    with rec:
        rec.execute(bump(1.0))
    with ReplayAdapter(tmp_path, spec=AnalyticAdapter().spec) as replay:
        o = replay.execute(bump(1.1))
    assert o.status is Status.ERROR and "differs" in o.message


def test_replay_of_a_missing_recording(tmp_path):
    with pytest.raises(dmprs.InvalidInputError, match="not a dmprs recording"):
        ReplayAdapter(tmp_path, spec=AnalyticAdapter().spec)


@pytest.mark.parametrize("make", [
    lambda tmp: AnalyticAdapter(),
    lambda tmp: AnalyticAdapter(noise=0.1),
    lambda tmp: RecordingAdapter(AnalyticAdapter(), tmp / "r"),
    lambda tmp: Toy(),
])
def test_every_adapter_in_the_repo_conforms(tmp_path, make):
    adapter = make(tmp_path)
    valid = bump(1.0) if adapter.spec.n_dof == 1 else line()
    assert "execute returns the declared signals" in check_adapter(adapter, valid)


def _record_two_trials(folder, *then):
    """Records two trials of ``bump(1.0)`` from seed 0 into ``folder``, then executes the
    trajectories ``then`` without a reset.
    """
    rec = RecordingAdapter(AnalyticAdapter(), folder)
    with rec:
        for _ in range(2):
            rec.reset(seed=0)
            rec.execute(bump(1.0))
        for trajectory in then:
            rec.execute(trajectory)


def test_replay_adapter_conforms(tmp_path):
    _record_two_trials(tmp_path, bump(99.0))
    replay = ReplayAdapter(tmp_path, spec=AnalyticAdapter().spec)
    check_adapter(replay, bump(1.0))


def test_conformance_catches_a_broken_adapter():
    class Broken(Toy):
        def check(self, trajectory):
            return []  # accepts everything

        def _execute(self, trajectory):
            return Outcome(Status.OK, signals={"other": 1.0})

    with pytest.raises(AdapterConformanceError) as info:
        check_adapter(Broken(), line())
    msg = str(info.value)
    assert "check rejects NaN" in msg and "declared signal" in msg


def test_load_adapter_by_name_and_unknown_names():
    assert isinstance(load_adapter("analytic", noise=0.0), AnalyticAdapter)
    with pytest.raises(dmprs.InvalidInputError, match="unknown adapter 'ur5'"):
        load_adapter("ur5")


def test_third_party_adapters_come_from_entry_points(monkeypatch):
    from importlib.metadata import EntryPoint

    from dmprs.adapters import registry

    ep = EntryPoint(name="toy_arm", value="tests.test_adapters:Toy", group="dmprs.adapters")
    monkeypatch.setattr(registry, "entry_points", lambda group: [ep] if group == "dmprs.adapters" else [])
    monkeypatch.syspath_prepend(str(__import__("pathlib").Path(__file__).parent.parent))
    assert "toy_arm" in registry.available_adapters()
    assert type(load_adapter("toy_arm")).__name__ == "Toy"


def test_timeout_holds_for_an_adapter_that_never_polls():
    class Sleeper(Toy):
        def _execute(self, trajectory):
            time.sleep(0.3)  # ignores _interrupted()
            return Outcome(Status.OK, signals={"s": 1.0}, executed=trajectory)

    with Sleeper() as adapter:
        outcome = adapter.execute(line(), timeout_s=0.05)
        assert outcome.status is Status.TIMEOUT and "timeout_s = 0.05" in outcome.message
        assert adapter.execute(line(), timeout_s=5.0).status is Status.OK
        with pytest.raises(dmprs.InvalidInputError, match="timeout_s"):
            adapter.execute(line(), timeout_s=-1)


@pytest.mark.parametrize(
    "signals, problem",
    [
        ({"s": float("nan")}, "non-finite"),
        ({"s": np.array([1.0, np.inf])}, "non-finite"),
        ({"s": "1.0"}, "not a real number"),
        ({"s": None}, "not a real number"),
        ({"s": True}, "not a real number"),
        ({"s": 1.0, "t": 2.0}, "not declared"),
        ({}, "missing"),
    ],
)
def test_conformance_fails_bad_signals(signals, problem):
    class BadSignals(Toy):
        def _execute(self, trajectory):
            return Outcome(Status.OK, signals=signals, executed=trajectory)

    with pytest.raises(AdapterConformanceError, match=problem):
        check_adapter(BadSignals(), line())


def test_declared_labels_and_absent_nans_pass_conformance_undeclared_ones_fail():
    from dmprs.adapters import SignalSpec

    declared = (SignalSpec("s", "m"), SignalSpec("t0", "s", nan_if_absent=True), SignalSpec("r", "", kind="label"))
    sp = spec(signals=declared)
    assert sp.signal_problems({"s": 1.0, "t0": float("nan"), "r": "upright"}) == []
    problems = sp.signal_problems({"s": float("nan"), "t0": float("inf"), "r": 3})
    assert len(problems) == 3 and "not a label" in problems[2]


@pytest.mark.parametrize(("outcome", "problem"), [
    (lambda tr: Outcome("ok", signals={"s": 1.0}, executed=tr), "status is the str 'ok', not a dmprs.adapters.Status"),
    (lambda tr: Outcome(Status.OK, signals=[("s", 1.0)], executed=tr), "signals is list"),
    (lambda tr: Outcome(Status.OK, signals={"s": 1.0}, executed=tr.y), "executed is ndarray"),
    (lambda tr: Outcome(Status.OK, signals={"s": 1.0}, executed=tr, message=None), "message is NoneType"),
    (lambda tr: Outcome(Status.OK, signals={"s": "1"}, executed=tr), "not a real number"),
])
def test_conformance_checks_the_types_of_an_outcome(outcome, problem):
    class Sloppy(Toy):
        def _execute(self, trajectory):
            return outcome(trajectory)

    with pytest.raises(AdapterConformanceError, match=problem):
        check_adapter(Sloppy(), line())


def test_conformance_checks_the_outcome_of_a_rejection_too():
    class BadRejection(Toy):
        def execute(self, trajectory, dry_run=False, timeout_s=None):
            out = super().execute(trajectory, dry_run, timeout_s)
            return Outcome(out.status.value, message=out.message) if out.status is not Status.OK else out

    with pytest.raises(AdapterConformanceError, match=r"dry run: .*status is the str 'dry_run'"):
        check_adapter(BadRejection(), line())


def test_replay_of_a_damaged_recording_is_an_error_outcome_not_a_hang(tmp_path):
    import json
    import os

    _record_two_trials(tmp_path)
    (tmp_path / "trial_0000.npz").unlink()
    os.mkfifo(tmp_path / "trial_0000.npz")
    lines = (tmp_path / "recording.jsonl").read_text().splitlines()
    lines[1] = json.dumps({**json.loads(lines[1]), "file": "../../etc/passwd"})
    (tmp_path / "recording.jsonl").write_text("\n".join(lines) + "\n")
    with ReplayAdapter(tmp_path, spec=AnalyticAdapter().spec) as replay:
        first, second = replay.execute(bump(1.0)), replay.execute(bump(1.0))
    assert first.status is Status.ERROR and "is a FIFO" in first.message
    assert second.status is Status.ERROR and "not a recorded trial_NNNN.npz" in second.message
