"""A robot behind ROS 2 as a dmprs adapter: joint trajectories to a ``joint_trajectory_controller``.

:class:`Ros2TrajectoryAdapter` sends each trial's :class:`~dmprs.Trajectory` to the controller's
``FollowJointTrajectory`` action (or, for a controller without one, publishes it on its
``joint_trajectory`` topic), records what the robot did from ``/joint_states`` by joint name,
and reads the outcome signals from topics (:class:`SignalTopic`), taking only samples stamped
after the motion ended, so a stale reading is never scored.

How a trial ends, from the controller's answer (control_msgs' ``FollowJointTrajectory`` result
codes and action_msgs' goal status):

====================================================  ==========================================
goal refused at acceptance, INVALID_GOAL, INVALID_JOINTS,  ``rejected`` (with the controller's
OLD_HEADER_TIMESTAMP; joints the robot does not have        error string, or the robot's joints)
PATH_TOLERANCE_VIOLATED, GOAL_TOLERANCE_VIOLATED            ``aborted`` (with its error string)
no answer within ``timeout_s`` (the goal is canceled)       ``timeout``
:meth:`stop` (the goal is canceled)                         ``stopped``
goal canceled by someone else, no ``/joint_states``,        ``error``
a signal that never came
====================================================  ==========================================
"""

from __future__ import annotations

import dataclasses
import math
import time
from typing import Any

import numpy as np

from dmprs.adapters.base import BaseAdapter
from dmprs.adapters.spec import AdapterSpec, Outcome, SignalSpec, Status
from dmprs.errors import InvalidInputError
from dmprs.ros2 import messages, names
from dmprs.ros2.action import STATUS_NAMES, ActionClient, GoalHandle
from dmprs.ros2.node import Node, Subscription, stamp_seconds
from dmprs.ros2.qos import DEFAULT
from dmprs.ros2.recorder import JointRecording, JointStateRecorder, increasing
from dmprs.trajectory import AnyTrajectory, Trajectory, nanoseconds

FOLLOW_JOINT_TRAJECTORY = "control_msgs/action/FollowJointTrajectory"
_RESULT = messages.FollowJointTrajectory_Result
#: the result codes that mean the controller refused the goal, and those that mean it stopped it
_REJECTING = {_RESULT.INVALID_GOAL: "invalid goal", _RESULT.INVALID_JOINTS: "invalid joints",
              _RESULT.OLD_HEADER_TIMESTAMP: "old header stamp"}
_ABORTING = {_RESULT.PATH_TOLERANCE_VIOLATED: "path tolerance violated",
             _RESULT.GOAL_TOLERANCE_VIOLATED: "goal tolerance violated"}
#: s between looks at the result, the stop flag and the deadline while a goal runs
_POLL = 0.02
#: the signal types a SignalTopic may read, and whether they carry a header stamp
SIGNAL_TYPES = {"std_msgs/msg/Float64": False, "geometry_msgs/msg/PointStamped": True}


@dataclasses.dataclass(frozen=True)
class SignalTopic:
    """An outcome signal read from a topic: ``SignalTopic("poured_volume", "/scale/volume",
    "std_msgs/msg/Float64", "data", unit="l")`` or a camera's landing point
    ``SignalTopic("landing_x", "/camera/landing", "geometry_msgs/msg/PointStamped", "point.x", unit="m")``.

    ``field`` is a dotted path into the message. A sample counts only when it is stamped after the
    motion ended: by its header stamp when the type has a header, against the robot's clock when
    the goal was sent (its latest ``/joint_states`` stamp) plus the trajectory's duration; else by
    when its publisher wrote it, against when the controller's answer arrived.
    """

    name: str
    topic: str
    type: str
    field: str
    unit: str = ""
    description: str = ""

    def __post_init__(self) -> None:
        if self.type not in SIGNAL_TYPES:
            raise InvalidInputError(f"signal {self.name!r}: type {self.type!r} is not one of {', '.join(SIGNAL_TYPES)}")
        message = messages.message_class(self.type)()
        value: Any = message
        for part in self.field.split("."):
            if not hasattr(value, part):
                raise InvalidInputError(f"signal {self.name!r}: {self.type} has no field {self.field!r}")
            value = getattr(value, part)
        if not isinstance(value, float):
            raise InvalidInputError(f"signal {self.name!r}: {self.type}'s {self.field!r} is not a number")

    def read(self, message: Any) -> float:
        """The signal's value in ``message``."""
        value = message
        for part in self.field.split("."):
            value = getattr(value, part)
        return float(value)


def _duration(ns: Any) -> Any:
    """A ``builtin_interfaces/Duration`` of ``ns`` whole nanoseconds."""
    sec, nanosec = divmod(int(ns), 1_000_000_000)
    return messages.Duration(sec=sec, nanosec=nanosec)


def joint_trajectory(joint_names: tuple[str, ...], trajectory: Trajectory) -> Any:
    """``trajectory`` as a ``trajectory_msgs/JointTrajectory``, times from its first sample (in
    whole nanoseconds, :func:`~dmprs.trajectory.controller_times`).
    """
    t = nanoseconds(trajectory.t - trajectory.t[0])
    fields = [("positions", trajectory.y), ("velocities", trajectory.yd), ("accelerations", trajectory.ydd)]
    points = [messages.JointTrajectoryPoint(
        **{name: ([] if values is None else [float(v) for v in values[k]]) for name, values in fields},
        time_from_start=_duration(t[k])) for k in range(len(t))]
    return messages.JointTrajectory(joint_names=list(joint_names), points=points)


def _tolerances(joint_names: tuple[str, ...], position: float | None) -> list[Any]:
    if position is None:
        return []
    return [messages.JointTolerance(name=j, position=float(position), velocity=0.0, acceleration=0.0)
            for j in joint_names]


class Ros2Adapter(BaseAdapter):
    """What the ROS 2 adapters share: joining the domain as a node, and reading the outcome
    signals from topics once the motion has ended (:meth:`_signals`).

    Every :class:`SignalTopic` must be one of the spec's signals and every signal needs one.
    ``settle`` (s) is how long the outcome takes to settle once the motion has ended (liquid
    still flowing, a ball still rolling): the signals are read from samples stamped at least that
    long after the end. ``answer_timeout`` bounds each wait for the robot. ``config`` is a Cyclone
    XML configuration (e.g. :data:`~dmprs.ros2.LOOPBACK_CONFIG`), else ``CYCLONEDDS_URI`` is read
    as a ROS 2 node reads it.
    """

    def __init__(self, spec: AdapterSpec, *, domain_id: int | None, signals: tuple[SignalTopic, ...], settle: float,
                 answer_timeout: float, node_name: str, namespace: str, config: str | None,
                 **more_times: float | None) -> None:
        declared = {s.name for s in spec.signals}
        for s in signals:
            if s.name not in declared:
                raise InvalidInputError(f"signal topic {s.name!r} is not a signal of {spec.name} ({', '.join(sorted(declared))})")
        missing = declared - {s.name for s in signals}
        if missing:
            raise InvalidInputError(f"{spec.name}: no SignalTopic for signal(s) {', '.join(sorted(missing))}")
        for name, value in (("settle", settle), ("answer_timeout", answer_timeout), *more_times.items()):
            if value is not None and not (isinstance(value, (int, float)) and np.isfinite(value) and value >= 0):
                raise InvalidInputError(f"{name} = {value!r} must be a finite number >= 0")
        super().__init__(spec)
        self.domain_id, self.signal_topics = names.domain_id(domain_id), tuple(signals)
        self.settle, self.answer_timeout = float(settle), float(answer_timeout)
        self._node_args = (node_name, self.domain_id, namespace, config)
        self._node: Node | None = None
        self._signals: list[tuple[SignalTopic, Subscription[Any]]] = []

    def connect(self) -> None:
        """Joins the ROS 2 domain: the node, the adapter's endpoints (:meth:`_open`), the signals."""
        if self._node is None:
            name, domain_id, namespace, config = self._node_args
            self._node = Node(name, domain_id, namespace, config)
            self._open(self._node)
            self._signals = [(s, self._node.create_subscription(messages.message_class(s.type), s.topic, DEFAULT))
                             for s in self.signal_topics]
        super().connect()

    def _open(self, node: Node) -> None:
        """Hook: create the adapter's publishers, subscriptions and clients on ``node``."""

    def disconnect(self) -> None:
        """Leaves the domain."""
        if self._node is not None:
            self._node.close()
        self._node, self._signals = None, []
        super().disconnect()

    def _signals_after(self, robot_end: float, ended: float, executed: AnyTrajectory) -> Outcome:
        """The outcome with each signal's first sample stamped ``settle`` s after the motion ended:
        ``robot_end`` on the robot's clock for stamped types, ``ended`` (this machine's clock,
        when the end was seen) for the others.
        """
        signals: dict[str, Any] = {}
        for topic, subscription in self._signals:
            after = (robot_end if SIGNAL_TYPES[topic.type] else ended) + self.settle
            sample = subscription.wait_for_sample(after, self.settle + self.answer_timeout)
            if sample is None:
                return Outcome(Status.ERROR, executed=executed, message=(
                    f"no {topic.topic} sample stamped {self.settle:g} s or more after the motion ended "
                    f"within {self.settle + self.answer_timeout:g} s"))
            value = topic.read(sample)
            if not math.isfinite(value):
                return Outcome(Status.ERROR, executed=executed, message=(
                    f"{topic.topic} published {value!r} for the signal {topic.name!r}: not a measurement"))
            signals[topic.name] = value
        return Outcome(Status.OK, signals=signals, executed=executed)


class Ros2TrajectoryAdapter(Ros2Adapter):
    """Joint trajectories executed by a ROS 2 robot's ``joint_trajectory_controller``.

    ``spec`` declares the joints (``dof_names``, matched by name with the robot's), limits and
    signals, as for any adapter. ``mode`` is ``"action"``
    (``<controller>/follow_joint_trajectory``) or ``"topic"`` (``<controller>/joint_trajectory``,
    starting as it arrives: no answer comes, the motion is taken as ended when the robot's clock,
    as its ``/joint_states`` stamps show, has passed the trajectory's duration since it was sent).
    ``path_tolerance`` and ``goal_tolerance`` (rad, per joint) go into the goal;
    ``goal_time_tolerance`` (s) too. ``answer_timeout`` bounds each wait for the robot
    (discovery, the goal's acceptance, ``/joint_states``, a signal); ``signals``, ``settle`` and
    ``config`` as for :class:`Ros2Adapter`.
    """

    def __init__(self, spec: AdapterSpec, *, domain_id: int | None = None, controller: str = "/joint_trajectory_controller",
                 mode: str = "action", signals: tuple[SignalTopic, ...] = (), joint_states: str = "/joint_states",
                 path_tolerance: float | None = None, goal_tolerance: float | None = None,
                 goal_time_tolerance: float = 0.0, settle: float = 0.0, answer_timeout: float = 5.0,
                 node_name: str = "dmprs_adapter", namespace: str = "/", config: str | None = None) -> None:
        if spec.pose:
            raise InvalidInputError(f"{spec.name}: Ros2TrajectoryAdapter takes joint trajectories (pose=False)")
        if mode not in ("action", "topic"):
            raise InvalidInputError(f"mode = {mode!r} is invalid: use 'action' or 'topic'")
        super().__init__(spec, domain_id=domain_id, signals=signals, settle=settle, answer_timeout=answer_timeout,
                         node_name=node_name, namespace=namespace, config=config, path_tolerance=path_tolerance,
                         goal_tolerance=goal_tolerance, goal_time_tolerance=goal_time_tolerance)
        self.controller, self.mode, self.joint_states = controller, mode, joint_states
        self.path_tolerance, self.goal_tolerance = path_tolerance, goal_tolerance
        self.goal_time_tolerance = float(goal_time_tolerance)
        self._client: ActionClient | None = None
        self._publisher: Any = None
        self._probe: Subscription[Any] | None = None

    def _open(self, node: Node) -> None:
        if self.mode == "action":
            self._client = ActionClient(node, FOLLOW_JOINT_TRAJECTORY, f"{self.controller}/follow_joint_trajectory")
        else:
            self._publisher = node.create_publisher(messages.JointTrajectory, f"{self.controller}/joint_trajectory")
        self._probe = node.create_subscription(messages.JointState, self.joint_states, DEFAULT)

    def disconnect(self) -> None:
        """Leaves the domain."""
        super().disconnect()
        self._client, self._publisher, self._probe = None, None, None

    def _robot_now(self) -> tuple[list[str], float] | None:
        """The joints the robot publishes and its clock now, from a fresh ``/joint_states``
        sample (None if none came).
        """
        assert self._probe is not None
        self._probe.take()
        sample = self._probe.take_one(self.answer_timeout)
        return None if sample is None else (list(sample.name), stamp_seconds(sample))

    def _execute(self, trajectory: Trajectory) -> Outcome:
        assert self._node is not None
        joints = self.spec.dof_names
        now = self._robot_now()
        if now is None:
            return Outcome(Status.ERROR, message=f"no {self.joint_states} within {self.answer_timeout:g} s: "
                           "is the robot running, on this ROS_DOMAIN_ID and network?")
        robot_joints, robot_start = now
        unknown = [j for j in joints if j not in robot_joints]
        if unknown:
            return Outcome(Status.REJECTED, message=f"the robot has no joint(s) {', '.join(unknown)}; "
                           f"its joints are {', '.join(robot_joints)}")
        recorder = JointStateRecorder(self._node, list(joints), self.joint_states).start()
        try:
            until: float | None = None  # the motion's end on the robot's clock, when only the clock tells it
            if self.mode == "action":
                status, message = self._follow(trajectory, recorder)
            else:
                status, message, until = self._publish(trajectory, recorder, robot_start)
            # the motion's end on this machine's clock, for signals without a header stamp
            ended = time.time()
        finally:
            recording = recorder.stop()
        executed = _executed(recording, until)
        if status is not Status.OK:
            return Outcome(status, executed=executed, message=message)
        if executed is None:
            return Outcome(Status.ERROR, message=f"fewer than two {self.joint_states} samples while it moved "
                           f"({recorder.skipped} skipped: without the joints {', '.join(joints)}, or with "
                           "fewer positions than names)")
        # on the robot's clock the motion cannot end before its start plus the trajectory's duration
        outcome = self._signals_after(robot_start + float(trajectory.t[-1] - trajectory.t[0]), ended, executed)
        if recorder.implausible:
            note = (f"{recorder.implausible} {self.joint_states} sample(s) skipped as no robot's (not finite, "
                    "beyond any joint's range, or stamped far ahead of the robot's clock)")
            outcome = dataclasses.replace(outcome, message="; ".join(m for m in (outcome.message, note) if m))
        return outcome

    def _follow(self, trajectory: Trajectory, recorder: JointStateRecorder) -> tuple[Status, str]:
        """The trajectory through the action: (status, why) once the goal has ended, or once the
        robot has fallen silent (no ``/joint_states`` for ``answer_timeout``).
        """
        assert self._client is not None
        joints = self.spec.dof_names
        goal = messages.FollowJointTrajectory_Goal(
            trajectory=joint_trajectory(joints, trajectory),
            path_tolerance=_tolerances(joints, self.path_tolerance),
            goal_tolerance=_tolerances(joints, self.goal_tolerance),
            goal_time_tolerance=_duration(nanoseconds(self.goal_time_tolerance)))
        handle = self._client.send_goal(goal, self.answer_timeout)
        if not handle.accepted:
            return Status.REJECTED, f"{self._client.action_name} refused the goal (ROS 2 carries no reason)"
        while True:
            answer = self._client.result(handle, _POLL)
            if answer is not None:
                return _ended(*answer)
            if self._interrupted():
                # what the robot last said of the goal tells a lost answer from a goal still running
                last = STATUS_NAMES.get(self._client.statuses().get(handle.goal_id, -1), "none")
                self._cancel(handle)
                outcome = self._interrupted_outcome()
                return outcome.status, f"{outcome.message}; the goal was canceled (its last status: {last})"
            silent = time.monotonic() - recorder.last_arrival
            if silent > self.answer_timeout:
                return Status.ERROR, (f"the robot went silent: no {self.joint_states} for {silent:.1f} s "
                                      "while its goal ran (is it still running?)")

    def _cancel(self, handle: GoalHandle) -> None:
        assert self._client is not None
        self._client.cancel(handle, self.answer_timeout)

    def _publish(self, trajectory: Trajectory, recorder: JointStateRecorder,
                 robot_start: float) -> tuple[Status, str, float | None]:
        """The trajectory on the controller's topic; the motion ends when the robot's clock has
        passed its duration since the robot acknowledged the trajectory (that end is returned).
        Not this machine's clock: a simulated robot's runs at its own pace, and stands still while
        its physics computes.
        """
        if not self._publisher.wait_for_subscribers(1, self.answer_timeout):
            return Status.ERROR, f"nothing subscribes to {self.controller}/joint_trajectory", None
        self._publisher.publish(joint_trajectory(self.spec.dof_names, trajectory))
        # a zero stamp starts the trajectory as it arrives, and it has arrived once acknowledged:
        # its start on the robot's clock is the clock as seen then, not when it was sent (the
        # robot may take a while to match this publisher, on a clock that may run faster)
        if not self._publisher.wait_for_acknowledgments(self.answer_timeout):
            return Status.ERROR, (f"{self.controller}/joint_trajectory was not acknowledged within "
                                  f"{self.answer_timeout:g} s: the robot may not have it"), None
        latest = recorder.latest_stamp
        sent = robot_start if latest is None else max(robot_start, latest)
        end = sent + float(trajectory.t[-1] - trajectory.t[0])
        seen, since = recorder.latest_stamp, time.monotonic()
        while True:
            latest = recorder.latest_stamp
            if latest is not None and latest >= end:
                return Status.OK, "", end
            if self._interrupted():
                outcome = self._interrupted_outcome()
                return outcome.status, outcome.message, end
            if latest != seen:
                seen, since = latest, time.monotonic()
            elif time.monotonic() - since > self.answer_timeout:
                if latest is None:  # nothing usable came: the recording says why
                    return Status.OK, "", end
                return Status.ERROR, (f"the robot's clock stopped at {latest:.3f} s, before the trajectory's end at "
                                      f"{end:.3f} s: no new {self.joint_states} stamp for {self.answer_timeout:g} s"), end
            time.sleep(_POLL)


def _ended(goal_status: int, result: Any) -> tuple[Status, str]:
    """A finished goal's status and result as a dmprs status and message."""
    code, text = int(result.error_code), str(result.error_string)
    if goal_status == messages.GoalStatus.STATUS_SUCCEEDED and code == _RESULT.SUCCESSFUL:
        return Status.OK, ""
    if code in _REJECTING:
        return Status.REJECTED, f"{_REJECTING[code]}: {text}"
    if code in _ABORTING:
        return Status.ABORTED, f"{_ABORTING[code]}: {text}"
    if goal_status == messages.GoalStatus.STATUS_CANCELED:
        return Status.ERROR, f"the goal was canceled by another client: {text}"
    return Status.ERROR, f"the goal ended with status {goal_status} and error code {code}: {text}"


def _executed(recording: JointRecording, until: float | None = None) -> Trajectory | None:
    """The recorded motion, timed by the robot's stamps from its first sample, up to the first
    sample stamped at or after ``until`` on the robot's clock; None if too short.
    """
    keep = increasing(recording.times)
    if until is not None:
        # what came after the motion's end (the rest, the next motion) is not this motion's;
        # the first sample at or after the end is, the end being known to a state's period
        after = np.flatnonzero(keep & (recording.times >= until))
        if after.size:
            keep[after[0] + 1:] = False
    t = recording.times[keep]
    if len(t) < 2:
        return None
    yd = recording.velocities[keep]
    return Trajectory(t - t[0], recording.positions[keep], None if np.isnan(yd).any() else yd)


def signal_specs(signals: tuple[SignalTopic, ...]) -> tuple[SignalSpec, ...]:
    """The :class:`~dmprs.adapters.SignalSpec` of each signal topic, for an adapter's spec."""
    return tuple(SignalSpec(s.name, s.unit, s.description) for s in signals)
