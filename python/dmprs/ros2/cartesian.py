"""Pose trajectories streamed to a ROS 2 Cartesian controller, as a dmprs adapter.

:class:`Ros2PoseAdapter` executes a :class:`~dmprs.CartesianTrajectory` (a ``CartesianDMP``'s
rollout) on a robot whose end effector follows a stream of target poses: FZI's
``cartesian_motion_controller`` (``<controller>/target_frame`` in, ``<controller>/current_pose``
out, both ``geometry_msgs/PoseStamped``) and the controllers that copy its interface. Every
sample is published at its time, paced by this machine's monotonic clock; what the robot did is
recorded from its current pose.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from dmprs.adapters.spec import AdapterSpec, Outcome, Status, start_problems
from dmprs.errors import InvalidInputError
from dmprs.ros2 import messages
from dmprs.ros2.adapter import Ros2Adapter, SignalTopic
from dmprs.ros2.node import Node, Subscription, stamp_seconds
from dmprs.ros2.qos import DEFAULT
from dmprs.ros2.recorder import increasing
from dmprs.trajectory import CartesianTrajectory, nanoseconds

#: FZI cartesian_controllers' motion controller, the common Cartesian controller of ros2_control
CARTESIAN_CONTROLLER = "/cartesian_motion_controller"
#: samples of the current pose kept between two looks (a 5 s motion at 1 kHz is 5000)
_DEPTH = 10000


def pose_stamped(pose: np.ndarray, stamp: float, frame_id: str) -> Any:
    """``[x, y, z, qw, qx, qy, qz]`` as a ``geometry_msgs/PoseStamped`` at ``stamp`` (s)."""
    sec, nanosec = divmod(int(nanoseconds(stamp)), 1_000_000_000)
    x, y, z, qw, qx, qy, qz = (float(v) for v in pose)
    return messages.PoseStamped(
        header=messages.Header(stamp=messages.Time(sec=sec, nanosec=nanosec), frame_id=frame_id),
        pose=messages.Pose(position=messages.Point(x=x, y=y, z=z),
                           orientation=messages.Quaternion(x=qx, y=qy, z=qz, w=qw)))


def pose_of(message: Any) -> np.ndarray:
    """A ``geometry_msgs/PoseStamped``'s pose as ``[x, y, z, qw, qx, qy, qz]``."""
    p, q = message.pose.position, message.pose.orientation
    return np.array([p.x, p.y, p.z, q.w, q.x, q.y, q.z], dtype=float)


class Ros2PoseAdapter(Ros2Adapter):
    """Pose trajectories executed by a ROS 2 robot's Cartesian controller.

    ``spec`` is a pose spec (``pose=True``: the end effector's limits and signals). Before a
    trajectory is streamed, one fresh ``current_pose`` sample must lie within
    ``spec.start_tolerance`` (m, rad) of its first pose, else it is ``rejected`` naming where the
    robot is: a Cartesian controller would jump to the first target. Each sample is then
    published on ``<controller>/target_frame`` in ``frame_id`` at its time from the start,
    stamped on the robot's clock (its current pose's stamp plus that time); the executed motion
    is the ``current_pose`` samples until one is stamped at or after the motion's end on the
    robot's clock, timed by the robot's stamps. :meth:`stop` or
    ``timeout_s`` end the stream there (the controller holds the last target). ``signals``,
    ``settle``, ``answer_timeout`` and ``config`` as for :class:`~dmprs.ros2.adapter.Ros2Adapter`.
    """

    def __init__(self, spec: AdapterSpec, *, domain_id: int | None = None, controller: str = CARTESIAN_CONTROLLER,
                 frame_id: str = "base_link", signals: tuple[SignalTopic, ...] = (), settle: float = 0.0,
                 answer_timeout: float = 5.0, node_name: str = "dmprs_adapter", namespace: str = "/",
                 config: str | None = None) -> None:
        if not spec.pose:
            raise InvalidInputError(f"{spec.name}: Ros2PoseAdapter takes pose trajectories (pose=True)")
        super().__init__(spec, domain_id=domain_id, signals=signals, settle=settle, answer_timeout=answer_timeout,
                         node_name=node_name, namespace=namespace, config=config)
        self.controller, self.frame_id = controller.rstrip("/"), frame_id
        self._publisher: Any = None
        self._current: Subscription[Any] | None = None

    def _open(self, node: Node) -> None:
        self._publisher = node.create_publisher(messages.PoseStamped, f"{self.controller}/target_frame")
        self._current = node.create_subscription(messages.PoseStamped, f"{self.controller}/current_pose",
                                                 DEFAULT.with_depth(_DEPTH))

    def disconnect(self) -> None:
        """Leaves the domain."""
        super().disconnect()
        self._publisher, self._current = None, None

    def _execute(self, trajectory: CartesianTrajectory) -> Outcome:
        assert self._current is not None
        current = f"{self.controller}/current_pose"
        self._current.take()
        first = self._current.take_one(self.answer_timeout)
        if first is None:
            return Outcome(Status.ERROR, message=f"no {current} within {self.answer_timeout:g} s: is the "
                           "Cartesian controller running, on this ROS_DOMAIN_ID and network?")
        robot_start, here = stamp_seconds(first), pose_of(first)
        tolerance = self.spec.start_tolerance
        away = [] if tolerance is None else start_problems(trajectory, tuple(here), tolerance)
        if away:
            return Outcome(Status.REJECTED, message=(
                f"the robot is at {np.round(here, 4).tolist()}, away from the trajectory's start: " + "; ".join(away)))
        if not self._publisher.wait_for_subscribers(1, self.answer_timeout):
            return Outcome(Status.ERROR, message=f"nothing subscribes to {self.controller}/target_frame")
        stamps: list[float] = [robot_start]
        poses: list[np.ndarray] = [here]

        def record() -> None:
            for message in self._current.take():  # type: ignore[union-attr]
                stamps.append(stamp_seconds(message))
                poses.append(pose_of(message))

        t = trajectory.t - trajectory.t[0]
        pose = trajectory.pose
        start = time.monotonic()
        for k in range(len(t)):
            time.sleep(max(0.0, start + t[k] - time.monotonic()))
            if self._interrupted():
                record()
                return self._interrupted_outcome(_executed(stamps, poses))
            self._publisher.publish(pose_stamped(pose[k], robot_start + float(t[k]), self.frame_id))
            record()
        # the motion has ended once the robot's clock has passed its end
        robot_end = robot_start + float(t[-1])
        deadline = time.monotonic() + self.answer_timeout
        while stamps[-1] < robot_end and time.monotonic() < deadline:
            self._current.wait(max(0.0, deadline - time.monotonic()))
            record()
        ended = time.time()
        executed = _executed(stamps, poses)
        if stamps[-1] < robot_end:
            return Outcome(Status.ERROR, executed=executed, message=(
                f"the robot went silent: no {current} stamped after the motion's end within "
                f"{self.answer_timeout:g} s (is it still running?)"))
        assert executed is not None  # two samples at least: the first, and one at or after the end
        return self._signals_after(robot_end, ended, executed)


def _executed(stamps: list[float], poses: list[np.ndarray]) -> CartesianTrajectory | None:
    """The recorded poses, timed by the robot's stamps from the first; None if too short."""
    t = np.asarray(stamps)
    keep = increasing(t)
    if keep.sum() < 2:
        return None
    return CartesianTrajectory.from_pose(t[keep] - t[0], np.asarray(poses)[keep])
