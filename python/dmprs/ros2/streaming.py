"""A joint or periodic stepper streamed to a ROS 2 robot at the control rate (docs/method.md
§2.5, §12.6).

:func:`stream` runs a :class:`~dmprs.JointStepper` or :class:`~dmprs.PeriodicStepper` online
against a robot's ``forward_position_controller``: every control period it takes the newest ``/joint_states``
sample (joints matched by name), steps the DMP with it (phase stopping closes on the measured
positions: a held robot holds the phase), and publishes the command as a
``std_msgs/Float64MultiArray`` in the controller's joint order. The loop keeps its period against
the monotonic clock; a period it overruns is counted, not made up.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from dmprs.errors import AdapterError, DmprsError, InvalidInputError
from dmprs.ros2 import messages
from dmprs.ros2.node import Node, check_timeout
from dmprs.ros2.qos import DEFAULT
from dmprs.ros2.recorder import joint_columns, plausible

#: the command topic of ros2_controllers' forward_position_controller
FORWARD_COMMANDS = "/forward_position_controller/commands"


@dataclasses.dataclass(frozen=True)
class StreamResult:
    """What a stream did: per control period its time (s from the start, this machine's clock),
    the stepper's phase, the command sent and the measured positions used (NaN before the first
    sample); whether the stepper finished, and how many periods were overrun. ``skipped``
    counts the joint states no robot could have sent (not finite, beyond any joint's range),
    which were not used; ``error`` is why the stream ended early, if the stepper refused a step
    (the record up to it is kept).
    """

    times: np.ndarray
    phases: np.ndarray
    commands: np.ndarray
    measured: np.ndarray
    done: bool
    overruns: int
    skipped: int = 0
    error: str = ""


class _Latest:
    """The newest ``/joint_states`` positions in a given joint order."""

    def __init__(self, node: Node, joint_names: Sequence[str], topic: str) -> None:
        self.names = tuple(joint_names)
        self.subscription = node.create_subscription(messages.JointState, topic, DEFAULT.with_depth(100))
        self.position: np.ndarray | None = None
        self.skipped = 0
        self._columns: dict[tuple[str, ...], list[int] | None] = {}

    def update(self) -> np.ndarray | None:
        for message in self.subscription.take():
            columns = joint_columns(self._columns, message, self.names)
            if columns is None:
                continue
            q = [float(message.position[c]) for c in columns]
            if plausible(q):
                self.position = np.array(q)
            else:
                self.skipped += 1
        return self.position


def stream(stepper: Any, node: Node, joint_names: Sequence[str], *, controller_joints: Sequence[str] | None = None,
           topic: str = FORWARD_COMMANDS, joint_states: str = "/joint_states", phase_stopping: bool = True,
           timeout: float = 60.0, answer_timeout: float = 5.0,
           should_stop: Callable[[], bool] | None = None) -> StreamResult:
    """Streams ``stepper``'s commands to ``topic`` every ``stepper.dt`` s until it is done,
    ``timeout`` s have passed or ``should_stop()`` is true. ``joint_names`` name the stepper's
    DOFs on the robot; ``controller_joints`` is the controller's joint order (its ``joints``
    parameter: a Float64MultiArray carries no names), by default ``joint_names``. With
    ``phase_stopping`` each step gets the newest measured positions; without, the stepper runs
    open loop. Waits up to ``answer_timeout`` for the controller and the first joint state
    (AdapterError after it).
    """
    names = tuple(joint_names)
    if len(names) != len(stepper.goal) or len(set(names)) != len(names):
        raise InvalidInputError(f"joint_names {list(names)!r} must name the stepper's {len(stepper.goal)} DOFs once each")
    order_names = names if controller_joints is None else tuple(controller_joints)
    if sorted(order_names) != sorted(names):
        raise InvalidInputError(f"controller_joints {list(order_names)!r} must be joint_names {list(names)!r} reordered")
    order = [names.index(j) for j in order_names]
    deadline = time.monotonic() + check_timeout(timeout) * 1e-9
    publisher = node.create_publisher(messages.Float64MultiArray, topic)
    latest = _Latest(node, names, joint_states)
    if not publisher.wait_for_subscribers(1, answer_timeout):
        raise AdapterError(f"nothing subscribes to {node.resolve(topic)} within {answer_timeout:g} s")
    if latest.subscription.take_one(answer_timeout) is None:
        raise AdapterError(f"no {joint_states} within {answer_timeout:g} s")
    latest.update()
    dt = float(stepper.dt)
    times, phases, commands, measured = [], [], [], []
    overruns, start, error = 0, time.monotonic(), ""
    tick = start
    while not stepper.done() and time.monotonic() < deadline and not (should_stop and should_stop()):
        position = latest.update()
        try:
            y = stepper.step(position if phase_stopping and position is not None else None)[0]
        except DmprsError as exc:  # nothing more is sent; what was sent stays on record
            error = f"the stepper refused the step at {tick - start:.3f} s: {exc}"
            break
        publisher.publish(messages.Float64MultiArray(data=[float(y[i]) for i in order]))
        times.append(tick - start)
        phases.append(stepper.phase)
        commands.append(np.array(y))
        measured.append(np.full(len(names), np.nan) if position is None else position)
        tick += dt
        wait = tick - time.monotonic()
        if wait > 0:
            time.sleep(wait)
        else:
            overruns += 1
            tick = time.monotonic()
    n = len(names)
    return StreamResult(np.array(times), np.array(phases), np.array(commands).reshape(-1, n),
                        np.array(measured).reshape(-1, n), bool(stepper.done()), overruns, latest.skipped, error)
