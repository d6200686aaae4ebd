"""The arm experiment's encoding and generalization, without simulating: the demonstrations as
CartesianDMPs, their linear generalization against a second method (the library's Generalizer on
the rotation vector, which for a rotation about one fixed axis is the discrete DMP of the angle),
and the pose <-> tangent maps. The pours themselves are tested in test_arm_pouring.py.
"""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from dmprs.cartesian import CartesianDMP
from dmprs.database import Database
from dmprs.generalize import Generalizer
from dmprs.sim.arm_scene import HOME_POSE
from dmprs.tasks.arm_pouring import (
    ArmPouring,
    demonstration_tangent,
    pose_to_tangent,
    pour_poses,
    tangent_to_pose,
)
from dmprs.trajectory import CartesianTrajectory

PEAKS = {0.3: 2.3, 1.0: 1.8}  # rad: about the calibrated peak tilts


@pytest.fixture(scope="module")
def generalizers():
    demos = [(v, CartesianDMP.fit(pour_poses(p).t, pour_poses(p).pose, n_basis=40)) for v, p in PEAKS.items()]
    poses, tangent = Database(query_names=("bottle_volume",)), Database(query_names=("bottle_volume",))
    for v, p in PEAKS.items():
        poses.add([v], CartesianTrajectory.from_pose(pour_poses(p).t, pour_poses(p).pose))
        tangent.add([v], demonstration_tangent(p))
    return (Generalizer(poses, method="linear", n_basis=40), Generalizer(tangent, method="linear", n_basis=40),
            demos)


@pytest.mark.parametrize("q", [0.3, 0.45, 0.6, 0.9, 1.0, 1.1])
def test_cartesian_generalization_equals_the_angle_dmp(generalizers, q):
    cart, angle, _ = generalizers
    task = ArmPouring(0.5)
    assert isinstance(cart.predict([q]), CartesianDMP)  # two code paths: CartesianDMP, 6-D DMP
    assert not isinstance(angle.predict([q]), CartesianDMP)
    a = task.trajectory(cart.predict([q]))
    b = task.trajectory(angle.predict([q]))
    np.testing.assert_allclose(a.pose, b.pose, atol=1e-12)


def test_generalization_reproduces_the_demonstrations(generalizers):
    cart, _, demos = generalizers
    for v, dmp in demos:
        got = cart.predict([v])
        for name in ("weights", "goal", "start", "tau"):
            np.testing.assert_allclose(getattr(got, name), getattr(dmp, name), atol=1e-12)
        rollout = cart.predict([v]).rollout(dt=0.002)
        demo = pour_poses(PEAKS[v])
        # the DMP reproduces the scripted pour: within 3 mm and 3 mrad (N = 40 kernels, 4.2 s)
        assert np.abs(rollout.pose[:, :3] - demo.pose[:, :3]).max() < 3e-3
        assert np.abs(rollout.pose[:, 3:] - demo.pose[:, 3:]).max() < 3e-3


def test_generalized_tilt_lies_between_the_demos(generalizers):
    cart, _, _ = generalizers
    peak = {q: 2 * np.arccos(np.clip(cart.predict([q]).rollout(dt=0.01).pose[:, 3], -1, 1)).max()
            for q in (0.3, 0.65, 1.0)}
    assert peak[1.0] < peak[0.65] < peak[0.3]
    assert peak[0.65] == pytest.approx(0.5 * (PEAKS[0.3] + PEAKS[1.0]), abs=0.01)


unit = st.lists(st.floats(-1, 1), min_size=4, max_size=4).filter(lambda v: 0.1 < np.linalg.norm(v))


@settings(max_examples=50, deadline=None)
@given(unit, unit, st.lists(st.floats(-2, 2), min_size=3, max_size=3))
def test_tangent_map_round_trips(q, ref, position):
    q = np.array(q) / np.linalg.norm(q)
    ref = np.array(ref) / np.linalg.norm(ref)
    pose = np.concatenate([position, q])[None]
    back = tangent_to_pose(pose_to_tangent(pose, ref), ref)
    np.testing.assert_allclose(back[0, :3], position, atol=1e-12)
    assert abs(abs(float(np.dot(back[0, 3:], q))) - 1) < 1e-9  # the same rotation
    assert np.linalg.norm(pose_to_tangent(pose, ref)[0, 3:]) <= np.pi + 1e-9  # the short way round


def test_the_demonstrations_are_validated_pose_trajectories():
    t = np.linspace(0, 1, 5)
    with pytest.raises(ValueError, match="shape"):
        CartesianTrajectory.from_pose(t, np.zeros((5, 6)))
    with pytest.raises(ValueError, match="increasing"):
        CartesianTrajectory.from_pose(t[::-1], np.tile(HOME_POSE, (5, 1)))
    assert isinstance(pour_poses(2.0), CartesianTrajectory)


def test_a_generalized_pose_trajectory_can_be_logged_and_recorded(generalizers, tmp_path):
    from dmprs.adapters import RecordingAdapter
    from dmprs.runlog import RunLog, TrialRecord

    cart, _, _ = generalizers
    task = ArmPouring(0.5)
    command = task.trajectory(cart.predict([0.6]))
    log = RunLog.create(tmp_path / "run", {"task": task.name})
    log.append(TrialRecord(0, np.array([0.6]), "rejected"), command, None)
    recorder = RecordingAdapter(task.adapter, tmp_path / "rec")
    with recorder:
        out = recorder.execute(command, dry_run=True)
    assert out.status.value == "dry_run"
    assert len(list((tmp_path / "rec").glob("trial_*.npz"))) == 1


def test_noise_floor_and_setup_run_the_generalized_movement(monkeypatch):
    from dmprs.experiments import arm_pouring as arm_experiments

    demos = tuple((np.array([v]), pour_poses(p), None) for v, p in PEAKS.items())  # uncalibrated
    monkeypatch.setattr(arm_experiments, "demonstrations", lambda *a, **k: demos)
    setup = arm_experiments.setup(0.2)
    assert setup.paper_learner == "golden" and (setup.low, setup.high) == (0.3, 1.0)
    rows = arm_experiments.noise_floor(0.2, offsets=(0.0, 1e-4))
    assert [r["query"] for r in rows] == pytest.approx([0.2, 0.2001])
    assert all(0 <= r["poured_volume"] <= 0.2 for r in rows)
