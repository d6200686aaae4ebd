"""PlannedAdapter: pose trajectories solved into joint trajectories by a planner (the arm's IK and
checks) on this machine and executed by a joint adapter; nothing reaches the robot that the
planner refuses.
"""

from __future__ import annotations

import numpy as np

from dmprs.adapters import BaseAdapter, Outcome, Status
from dmprs.adapters.planned import PlannedAdapter
from dmprs.tasks.arm_pouring import ArmPouringAdapter, pour_poses
from dmprs.trajectory import CartesianTrajectory, Trajectory


class JointRobot(BaseAdapter):
    """A joint robot that records what it is sent and reports a fixed reading."""

    def __init__(self, spec):
        super().__init__(spec)
        self.sent: list[Trajectory] = []
        self.stops = 0

    def stop(self) -> None:
        self.stops += 1
        super().stop()

    def _execute(self, trajectory: Trajectory) -> Outcome:
        self.sent.append(trajectory)
        return Outcome(Status.OK, signals={"poured_volume": 0.2}, executed=trajectory)


def planned() -> tuple[PlannedAdapter, ArmPouringAdapter, JointRobot]:
    planner = ArmPouringAdapter()
    robot = JointRobot(planner.spec)
    return PlannedAdapter(planner, robot), planner, robot


def test_the_robot_executes_the_planners_joint_solution():
    adapter, planner, robot = planned()
    poses = pour_poses(2.0)
    with adapter:
        out = adapter.execute(poses, timeout_s=30)
    assert out.status is Status.OK and out.signals == {"poured_volume": 0.2}
    joints, *_ = planner.plan(poses)
    assert len(robot.sent) == 1 and joints is not None
    np.testing.assert_array_equal(robot.sent[0].y, joints.y)
    np.testing.assert_array_equal(robot.sent[0].t, joints.t)


def test_what_the_planner_refuses_never_reaches_the_robot():
    adapter, _, robot = planned()
    poses = pour_poses(2.0)
    far = poses.pose.copy()
    far[:, 0] += 2.0  # two metres beyond the arm's reach, and away from home
    with adapter:
        out = adapter.execute(CartesianTrajectory.from_pose(poses.t, far))
        wrong = adapter.execute(np.zeros(3))  # type: ignore[arg-type]
    assert out.status is Status.REJECTED and "start" in out.message
    assert wrong.status is Status.REJECTED and "expected a dmprs.Trajectory" in wrong.message
    assert robot.sent == []


def test_stop_reaches_the_robot():
    adapter, _, robot = planned()
    adapter.stop()
    assert robot.stops == 1
