"""A ROS 2 action client (rcl_action's wire protocol on rmw_cyclonedds).

An action `<name>` is three services, `<name>/_action/send_goal`, `get_result` and `cancel_goal`,
and two topics, `<name>/_action/feedback` (each feedback message carries its goal's UUID) and
`<name>/_action/status` (action_msgs/msg/GoalStatusArray, transient local). As rclpy does, the
client asks for a goal's result as soon as the goal is accepted; the server answers when the
goal ends. Unlike rclpy, the client asks again when the status topic has shown the goal finished
for a while and no answer came: one DDS stack can match the other's endpoint before it is matched
in return, and a request or an answer written in between reaches no one and is never resent.
"""

from __future__ import annotations

import dataclasses
import time
import uuid
from typing import Any

from dmprs.errors import AdapterError, InvalidInputError
from dmprs.ros2 import messages
from dmprs.ros2.node import Node, check_timeout
from dmprs.ros2.qos import ACTION_STATUS, DEFAULT
from dmprs.ros2.service import ServiceClient

#: action_msgs/msg/GoalStatus codes by name.
STATUS_NAMES = {
    getattr(messages.GoalStatus, name): name.removeprefix("STATUS_").lower()
    for name in dir(messages.GoalStatus)
    if name.startswith("STATUS_")
}

#: The statuses a goal ends in.
FINISHED = frozenset(
    (messages.GoalStatus.STATUS_SUCCEEDED, messages.GoalStatus.STATUS_CANCELED, messages.GoalStatus.STATUS_ABORTED)
)

#: Seconds a finished goal's result may take to come before it is asked for again (the server
#: answers at once, and its answer is written before the status that shows the goal finished).
RESULT_RETRY = 1.0


@dataclasses.dataclass
class GoalHandle:
    """A goal sent by `ActionClient.send_goal`: its UUID, whether the server accepted it, and
    the server's acceptance stamp.
    """

    goal_id: bytes
    accepted: bool
    stamp: float
    _result_seq: int | None = None
    _asked_at: float = 0.0
    _seen_finished_at: float | None = None
    _feedback: list[Any] = dataclasses.field(default_factory=list)
    _result: tuple[int, Any] | None = None


def uuid_message(goal_id: bytes) -> Any:
    """A goal id as a ``unique_identifier_msgs/UUID``."""
    return messages.UUID(uuid=bytes(goal_id))


class ActionClient:
    """A client of one action, e.g. `ActionClient(node, "control_msgs/action/FollowJointTrajectory",
    "/joint_trajectory_controller/follow_joint_trajectory")`.
    """

    def __init__(self, node: Node, action_type: str, action: str, feedback_depth: int = 100):
        self.action_name = node.resolve(action)
        base = self.action_name + "/_action/"
        self.goal_type = messages.message_class(action_type + "_Goal")
        self._send_goal = ServiceClient(node, action_type + "_SendGoal", base + "send_goal")
        self._get_result = ServiceClient(node, action_type + "_GetResult", base + "get_result")
        self._cancel = ServiceClient(node, "action_msgs/srv/CancelGoal", base + "cancel_goal")
        self._feedback = node.create_subscription(
            messages.message_class(action_type + "_FeedbackMessage"), base + "feedback", DEFAULT.with_depth(feedback_depth)
        )
        self._status = node.create_subscription(messages.GoalStatusArray, base + "status", ACTION_STATUS)
        self._handles: dict[bytes, GoalHandle] = {}
        self._statuses: dict[bytes, int] = {}

    def wait_for_server(self, timeout: float) -> bool:
        """Block until the action's three services and two topics have a server (True) or `timeout`."""
        deadline = time.monotonic() + check_timeout(timeout) * 1e-9
        for client in (self._send_goal, self._get_result, self._cancel):
            if not client.wait_for_server(max(0.0, deadline - time.monotonic())):
                return False
        return all(
            sub.wait_for_publishers(1, max(0.0, deadline - time.monotonic())) for sub in (self._feedback, self._status)
        )

    def send_goal(self, goal: Any, timeout: float, goal_id: bytes | None = None) -> GoalHandle:
        """Send `goal` under a new UUID and wait for the server's answer (AdapterError after
        `timeout`). A rejected goal comes back with `accepted` False: ROS 2 carries no reason.
        """
        if not isinstance(goal, self.goal_type):
            raise InvalidInputError(f"{self.action_name} takes {self.goal_type.__name__}, not {type(goal).__name__}")
        deadline = time.monotonic() + check_timeout(timeout) * 1e-9
        if not self.wait_for_server(timeout):
            raise AdapterError(f"no action server for {self.action_name} within {timeout} s")
        goal_id = uuid.uuid4().bytes if goal_id is None else goal_id
        request = self._send_goal.request_type(goal_id=uuid_message(goal_id), goal=goal)
        reply = self._send_goal.wait_for_reply(self._send_goal.send(request), max(0.0, deadline - time.monotonic()))
        if reply is None:
            raise AdapterError(f"{self.action_name} did not answer the goal within {timeout} s")
        handle = GoalHandle(goal_id, bool(reply.accepted), reply.stamp.sec + reply.stamp.nanosec * 1e-9)
        if handle.accepted:
            self._handles[goal_id] = handle
            self._ask_result(handle)
        return handle

    def _ask_result(self, handle: GoalHandle) -> None:
        if handle._result_seq is not None:
            self._get_result.forget(handle._result_seq)
        handle._result_seq = self._get_result.send(self._get_result.request_type(goal_id=uuid_message(handle.goal_id)))
        handle._asked_at = time.monotonic()

    def _ask_again_if_lost(self, handle: GoalHandle) -> None:
        """A new result request once the goal has been seen finished, and its result has not come,
        for RESULT_RETRY s since both the sighting and the last request.
        """
        now = time.monotonic()
        if handle._seen_finished_at is None:
            if self.statuses().get(handle.goal_id) in FINISHED:
                handle._seen_finished_at = now
        elif now - max(handle._seen_finished_at, handle._asked_at) >= RESULT_RETRY:
            self._ask_result(handle)

    def _collect_feedback(self) -> None:
        for message in self._feedback.take():
            handle = self._handles.get(bytes(message.goal_id.uuid))
            if handle is not None:
                handle._feedback.append(message.feedback)

    def feedback(self, handle: GoalHandle, timeout: float) -> list[Any]:
        """The goal's feedback received since the last call, waiting up to `timeout` for some."""
        deadline = time.monotonic() + check_timeout(timeout) * 1e-9
        while True:
            self._collect_feedback()
            if handle._feedback or handle._result is not None:
                break
            left = deadline - time.monotonic()
            if left <= 0 or not self._feedback.wait(left):
                self._collect_feedback()
                break
        taken, handle._feedback = handle._feedback, []
        return taken

    def result(self, handle: GoalHandle, timeout: float) -> tuple[int, Any] | None:
        """(status, result) once the goal has ended, waiting up to `timeout`; None before."""
        if handle._result is None:
            if handle._result_seq is None:
                raise AdapterError("a rejected goal has no result")
            deadline = time.monotonic() + check_timeout(timeout) * 1e-9
            while True:
                left = max(0.0, deadline - time.monotonic())
                reply = self._get_result.wait_for_reply(handle._result_seq, min(left, RESULT_RETRY))
                if reply is not None:
                    handle._result = (int(reply.status), reply.result)
                    break
                self._ask_again_if_lost(handle)
                if time.monotonic() >= deadline:
                    return None
        return handle._result

    def cancel(self, handle: GoalHandle, timeout: float) -> Any:
        """Ask the server to cancel the goal; returns action_msgs/srv/CancelGoal's response."""
        request = messages.CancelGoal_Request(goal_info=messages.GoalInfo(goal_id=uuid_message(handle.goal_id)))
        return self._cancel.call(request, timeout)

    def statuses(self) -> dict[bytes, int]:
        """Each goal's latest status from the status topic (action_msgs/msg/GoalStatus codes)."""
        for array in self._status.take():
            for status in array.status_list:
                self._statuses[bytes(status.goal_info.goal_id.uuid)] = int(status.status)
        return dict(self._statuses)

    def wait_for_status(self, handle: GoalHandle, status: int, timeout: float) -> bool:
        """Block until the status topic shows the goal in `status` (True) or `timeout` passes."""
        deadline = time.monotonic() + check_timeout(timeout) * 1e-9
        while self.statuses().get(handle.goal_id) != status:
            left = deadline - time.monotonic()
            if left <= 0 or not self._status.wait(left):
                return self.statuses().get(handle.goal_id) == status
        return True
