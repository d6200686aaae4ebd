"""A Cartesian task end to end through dmprs.learn, and the pose checks of AdapterSpec.

The analytic "tilt" adapter takes pose trajectories; its outcome is a nonlinear map of the final
tilt about x, ``y = tilt + 0.2 sin(tilt)``, so the learned query can be checked against the
known inverse.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.spatial.transform import Rotation

import dmprs
from dmprs.adapters import AdapterSpec, BaseAdapter, Outcome, SignalSpec, Status
from dmprs.learners import ErrorLearning
from dmprs.tasks.base import Task
from tests.conftest import min_jerk


def outcome_map(tilt: float) -> float:
    return tilt + 0.2 * np.sin(tilt)


def pose_spec(**kw) -> AdapterSpec:
    base = {
        "name": "tilt", "dof_names": ("x", "y", "z"), "dof_units": ("m", "m", "m"),
        "control_period": 0.002, "signals": (SignalSpec("outcome", "rad", "tilt + 0.2 sin(tilt)"),),
        "pose": True, "position_max": (1.0, 1.0, 1.0), "angular_velocity_max": 20.0,
        "start_pose": (0.0, 0.0, 0.5, 1.0, 0.0, 0.0, 0.0), "start_tolerance": 1e-6, "min_samples": 3,
    }
    base.update(kw)
    return AdapterSpec(**base)


class TiltAdapter(BaseAdapter):
    def __init__(self) -> None:
        super().__init__(pose_spec())

    def _execute(self, trajectory):  # type: ignore[override]
        final = Rotation.from_quat(np.array(trajectory.quaternion[-1]), scalar_first=True)
        tilt = float(final.as_rotvec()[0])
        return Outcome(Status.OK, signals={"outcome": outcome_map(tilt)}, executed=trajectory)


class TiltTask(Task):
    name = "tilt"
    query_names = ("outcome",)
    query_units = ("rad",)
    tol = 1e-3

    def measure(self, outcome):
        return np.array([outcome.signals["outcome"]])


def tilt_demo(angle: float) -> dmprs.CartesianTrajectory:
    t = np.linspace(0.0, 1.0, 500)
    a = min_jerk(t)
    q = Rotation.from_rotvec(np.outer(angle * a, [1.0, 0.0, 0.0])).as_quat(scalar_first=True)
    p = np.stack([0.1 * a, 0.0 * a, 0.5 + 0.0 * a], axis=1)
    return dmprs.CartesianTrajectory(t, p, q)


def test_a_cartesian_task_learns_through_dmprs_learn() -> None:
    task = TiltTask(TiltAdapter())
    db = dmprs.Database(("outcome",), ("rad",))
    for angle in (0.3, 1.2):  # labelled with the outcome each produces
        db.add(outcome_map(angle), tilt_demo(angle))
    gen = dmprs.Generalizer(db, "linear", n_basis=20)
    desired = 0.9
    result = dmprs.learn(task, gen, desired, ErrorLearning(np.array([desired]), max_trials=20), max_trials=20)
    assert result.converged, [t.message for t in result.trials]
    tilt = float(Rotation.from_quat(
        np.array(gen.predict(result.learned_query).rollout(0.002).quaternion[-1]), scalar_first=True
    ).as_rotvec()[0])
    assert abs(outcome_map(tilt) - desired) < 1e-3
    # Independent truth: the tilt that gives the desired outcome through the known map.
    assert abs(tilt - brentq(lambda x: outcome_map(x) - desired, 0.0, 2.0)) < 2e-3


def test_the_pose_spec_accepts_a_valid_rollout_and_names_each_violation() -> None:
    spec = pose_spec()
    tr = dmprs.CartesianDMP.fit_trajectory(tilt_demo(1.0), 20).rollout(0.002)
    assert spec.check(tr) == []
    [wrong] = spec.check(dmprs.Trajectory(tr.t, tr.position))
    assert "expected a dmprs.CartesianTrajectory" in wrong
    fast = pose_spec(angular_velocity_max=1.0)
    [problem] = fast.check(tr)
    assert "angular velocity is 1.8" in problem and "above the maximum 1" in problem
    # Without measured angular velocities the spec differentiates the quaternions itself.
    bare = dmprs.CartesianTrajectory(tr.t, tr.position, tr.quaternion)
    [again] = fast.check(bare)
    assert "angular velocity is 1.8" in again
    moved = pose_spec(start_pose=(0.0, 0.0, 0.5, np.cos(0.05), np.sin(0.05), 0.0, 0.0))
    assert "orientation starts 0.1 rad" in moved.check(tr)[0]


def test_the_pose_spec_refuses_a_non_unit_quaternion() -> None:
    tr = dmprs.CartesianDMP.fit_trajectory(tilt_demo(1.0), 20).rollout(0.002)
    q = np.array(tr.quaternion)
    q[100] *= 1.0 + 5e-7  # a trajectory accepts this (within 1e-6) ...
    q[200] *= 1.0 + 5e-7
    ok = dmprs.CartesianTrajectory(tr.t, tr.position, q)
    assert pose_spec().check(ok) == []
    bad = object.__new__(dmprs.CartesianTrajectory)  # ... a hand-built one may not be
    for name in ("t", "position", "velocity", "angular_velocity", "acceleration", "angular_acceleration"):
        object.__setattr__(bad, name, getattr(tr, name))
    q[150] *= 1.01
    object.__setattr__(bad, "quaternion", q)
    [problem] = pose_spec().check(bad)
    assert "norm 1.01" in problem and "t = 0.3 s" in problem


def test_a_pose_spec_is_validated() -> None:
    with pytest.raises(dmprs.InvalidInputError, match="3 position DOFs"):
        pose_spec(dof_names=("x", "y"), dof_units=("m", "m"))
    with pytest.raises(dmprs.InvalidInputError, match="start_pose has 3 entries, expected 7"):
        pose_spec(start_pose=(0.0, 0.0, 0.5))
    with pytest.raises(dmprs.InvalidInputError, match="angular limits need pose=True"):
        AdapterSpec("j", ("a",), ("rad",), 0.01, (), angular_velocity_max=1.0)
