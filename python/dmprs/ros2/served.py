"""The MuJoCo throwing arm served as a ROS 2 robot, and the adapter that learns through it.

:func:`serve_throwing` runs the throwing scene (:mod:`dmprs.sim.throw_scene`) behind what a
``ros2_control`` robot exposes, on the Rust robot node (ros2-client / RustDDS, the other ROS 2
stack than dmprs's own Cyclone side): the ``joint_trajectory_controller``'s
``follow_joint_trajectory`` action and ``joint_trajectory`` topic, ``/joint_states`` and
``/clock`` on the simulation's clock, and a camera's landing point
(``geometry_msgs/PointStamped`` on :data:`LANDING_TOPIC`). Each goal is simulated at once and
played back at ``speed`` times real time; the arm is back home for the next one, as the
in-process adapter is.

:func:`throwing_adapter` is the client side: a :class:`~dmprs.ros2.Ros2TrajectoryAdapter` with the
in-process adapter's joints and limits, reading ``landing_x`` and ``landing_y`` from the camera.
"""

from __future__ import annotations

import dataclasses
import threading
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from dmprs._core import RobotNode
from dmprs.adapters import Status
from dmprs.ros2 import messages
from dmprs.ros2.adapter import Ros2TrajectoryAdapter, SignalTopic, signal_specs
from dmprs.sim.throw_scene import HOME
from dmprs.tasks.arm_throwing.adapter import ArmThrowingAdapter
from dmprs.trajectory import Trajectory

CONTROLLER = "/joint_trajectory_controller"
#: where the camera publishes the ball's first contact with the floor
LANDING_TOPIC = "/landing_camera/point"
LANDING = (SignalTopic("landing_x", LANDING_TOPIC, "geometry_msgs/msg/PointStamped", "point.x", "m",
                       "x where the ball first touched the floor"),
           SignalTopic("landing_y", LANDING_TOPIC, "geometry_msgs/msg/PointStamped", "point.y", "m",
                       "y where the ball first touched the floor"))
#: Hz: /joint_states while idle and during playback (every other servo step of the 1 kHz scene)
STATE_RATE = 500.0
#: s: the robot's clock when it starts
CLOCK_START = 0.0
_RESULT = messages.FollowJointTrajectory_Result


def throwing_adapter(domain_id: int, **options: Any) -> Ros2TrajectoryAdapter:
    """A :class:`~dmprs.ros2.Ros2TrajectoryAdapter` for a throwing robot on ``domain_id``: the
    in-process adapter's joints, limits and start, the camera's landing point as the signals;
    ``options`` go to the adapter (``answer_timeout``, ``config``, ...).
    """
    spec = dataclasses.replace(ArmThrowingAdapter().spec, name="arm-throwing-ros2", signals=signal_specs(LANDING))
    return Ros2TrajectoryAdapter(spec, domain_id=domain_id, controller=CONTROLLER, signals=LANDING, **options)


class _Clock:
    """The robot's clock: simulated seconds, advanced as states are played back."""

    def __init__(self, node: RobotNode) -> None:
        self.node, self.now = node, CLOCK_START

    def tick(self, seconds: float) -> float:
        self.now += seconds
        self.node.publish_clock(self.now)
        return self.now


def serve_throwing(domain_id: int, *, speed: float = 1.0, stop: threading.Event | None = None,
                   on_ready: Callable[[], None] | None = None, loopback_only: bool = False) -> int:
    """Serves the throwing arm on ``domain_id`` until ``stop`` is set; returns the goals served.

    A goal the scene refuses (its start away from home, a limit broken) ends as INVALID_GOAL with
    the scene's reason; one whose ball never lands ends as succeeded without a landing point (the
    arm did move; the camera saw nothing), which the client reports as an error.
    """
    stop = stop or threading.Event()
    node = RobotNode(domain_id, CONTROLLER.strip("/"), list(ArmThrowingAdapter().spec.dof_names),
                     point_signals=[LANDING_TOPIC], loopback_only=loopback_only)
    clock, home, period = _Clock(node), np.asarray(HOME, dtype=float), 1.0 / STATE_RATE
    served = 0
    try:
        with ArmThrowingAdapter() as scene:
            if on_ready is not None:
                on_ready()
            while not stop.is_set():
                node.publish_joint_state(clock.tick(period), home)
                goal = node.poll_goal(period / speed)
                if goal is None:
                    continue
                served += 1
                _throw(node, clock, scene, goal, speed, stop)
    finally:
        node.shutdown()
    return served


def _throw(node: RobotNode, clock: _Clock, scene: ArmThrowingAdapter, goal: Any, speed: float,
           stop: threading.Event) -> None:
    """Simulates one goal and plays it back: joint states, feedback, the landing point, the result."""
    tr = goal.trajectory
    command = Trajectory(tr.times, tr.positions, tr.velocities)
    scene.reset(seed=0)
    out = scene.execute(command)
    if out.status is Status.REJECTED:
        node.finish_goal(goal.id, messages.GoalStatus.STATUS_ABORTED, _RESULT.INVALID_GOAL, out.message)
        return
    executed = out.executed
    if isinstance(executed, Trajectory):
        step = max(1, round(1.0 / (STATE_RATE * float(np.median(np.diff(executed.t))))))
        start = time.monotonic()
        t0 = clock.now
        for k in range(0, len(executed.t), step):
            if stop.is_set() or goal.id in node.poll_cancels():
                node.finish_goal(goal.id, messages.GoalStatus.STATUS_CANCELED)
                return
            clock.now = t0 + float(executed.t[k] - executed.t[0])
            node.publish_clock(clock.now)
            node.publish_joint_state(clock.now, executed.y[k])
            # paced at speed x real time, so that the client sees a motion, not a burst
            time.sleep(max(0.0, start + (clock.now - t0) / speed - time.monotonic()))
    if out.ok:
        node.publish_signal(LANDING_TOPIC, [out.signals["landing_x"], out.signals["landing_y"], 0.0],
                            clock.tick(0.001))
    node.finish_goal(goal.id, messages.GoalStatus.STATUS_SUCCEEDED)
