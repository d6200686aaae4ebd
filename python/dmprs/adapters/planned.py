"""Pose trajectories planned into joint trajectories on this machine and executed by a joint
adapter: a real robot's joint controller driven by a task learned in Cartesian space.
"""

from __future__ import annotations

import time
from typing import Any, Protocol

from dmprs.adapters.base import Adapter, BaseAdapter
from dmprs.adapters.spec import AdapterSpec, Outcome, Status
from dmprs.trajectory import Trajectory


class Planner(Protocol):
    """The dry pass of a scene adapter (e.g. :class:`~dmprs.tasks.arm_pouring.ArmPouringAdapter`):
    ``plan`` gives the joint trajectory of a pose trajectory (or ``None`` and the problems),
    ``check`` every problem of it (unreachable poses, limits, collisions).
    """

    def plan(self, trajectory: Any) -> tuple[Trajectory | None, float, float, list[str]]:
        """(joint trajectory or None, largest IK position and orientation residuals, problems)."""

    def check(self, trajectory: Any) -> list[str]:
        """Every problem that keeps ``trajectory`` from being executed."""


class PlannedAdapter(BaseAdapter):
    """``planner``'s joint solution of each trajectory, executed by ``robot``.

    Checking is the planner's (the IK reaches every pose; the joint solution keeps to the limits
    and hits nothing) before anything is sent; the outcome, its signals and its executed motion
    are the robot's. ``spec`` is what the learner sees (default: the robot's).
    """

    def __init__(self, planner: Planner, robot: Adapter[Trajectory], spec: AdapterSpec | None = None) -> None:
        super().__init__(spec if spec is not None else robot.spec)
        self.planner, self.robot = planner, robot

    def connect(self) -> None:
        """Connects the robot."""
        self.robot.connect()
        super().connect()

    def disconnect(self) -> None:
        """Disconnects the robot."""
        self.robot.disconnect()
        super().disconnect()

    def _reset(self, seed: int | None) -> None:
        self.robot.reset(seed)

    def check(self, trajectory: Any) -> list[str]:
        """The planner's problems with ``trajectory`` (none: it can be sent)."""
        return self.planner.check(trajectory)

    def stop(self) -> None:
        """Stops the robot's motion too."""
        super().stop()
        self.robot.stop()

    def _execute(self, trajectory: Any) -> Outcome:
        joints, _, _, problems = self.planner.plan(trajectory)
        if joints is None:
            return Outcome(Status.REJECTED, message="; ".join(problems) or "the planner found no joint trajectory")
        remaining = None if self._deadline is None else max(0.0, self._deadline - time.monotonic())
        return self.robot.execute(joints, timeout_s=remaining)
