import itertools
import os

import numpy as np
import pytest

from dmprs.ros2 import LOOPBACK_CONFIG, Node


def min_jerk(s: np.ndarray) -> np.ndarray:
    return 10 * s**3 - 15 * s**4 + 6 * s**5


@pytest.fixture
def demo() -> tuple[np.ndarray, np.ndarray]:
    """A smooth 3-DOF, 1 s demonstration that starts and ends at rest."""
    t = np.linspace(0.0, 1.0, 1001)
    s = min_jerk(t)
    y = np.stack([s, 0.5 - 2.0 * s, 0.3 * np.sin(np.pi * t) ** 2], axis=1)
    return t, y


@pytest.fixture
def outside(tmp_path):
    """An empty folder beside the ones a test writes to: links planted in those point here, and
    it must stay empty (nothing written through a link).
    """
    folder = tmp_path / "outside"
    folder.mkdir()
    return folder


def drive(learner, feedback):
    """Runs an ask/tell learner until it stops, telling it ``feedback(q)`` for every ``q`` it
    asks; returns the learner.
    """
    while not learner.done:
        q = learner.ask()
        learner.tell(q, feedback(q))
    return learner


def crash_after(run_dir, n_trials: int) -> None:
    """Leaves a run directory as a crash after ``n_trials`` finished trials would: their lines in
    trials.jsonl, and beyond them at most the next trial's arrays (written just before its line).
    """
    log = run_dir / "trials.jsonl"
    lines = log.read_text().splitlines(keepends=True)
    log.write_text("".join(lines[:n_trials]))
    for npz in run_dir.glob("trial_*.npz"):
        if int(npz.stem[6:]) > n_trials:
            npz.unlink()


@pytest.fixture(scope="session")
def calibration_cache(tmp_path_factory):
    """One disk cache of the simulated demonstrations' calibrations for the whole session (the
    arm's takes about 90 s of MuJoCo): the tests that pour share it instead of each calibrating.
    """
    return str(tmp_path_factory.mktemp("calibration-cache"))


_domains = itertools.count()
SAFE_DOMAIN_IDS = 101  # the domains 1-101


@pytest.fixture
def domain_id(monkeypatch: pytest.MonkeyPatch, tmp_path) -> int:
    """A ROS 2 domain of its own for each test (from the pid and a counter), Cyclone on loopback only.

    In 1-101, the range ROS 2 recommends on Linux: a higher id puts its participants' ports
    (7400 + 250 id and up) in the kernel's ephemeral range (32768-60999), where another socket
    may hold one; 0 is the default domain of anything else on the machine.
    """
    config = tmp_path / "cyclonedds.xml"
    config.write_text(LOOPBACK_CONFIG)
    monkeypatch.setenv("CYCLONEDDS_URI", config.as_uri())
    return 1 + (os.getpid() * 7 + next(_domains)) % SAFE_DOMAIN_IDS


@pytest.fixture
def node(domain_id: int):
    """A dmprs ROS 2 node (Cyclone) in the test's domain."""
    with Node("dmprs_test", domain_id) as n:
        yield n
