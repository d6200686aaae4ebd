"""A joint stepper streamed over ROS 2 (dmprs.ros2.streaming, Cyclone) to a forward position
controller played by the Rust robot node: the commands are the DMP's rollout, and phase stopping
closes on /joint_states (a held robot holds the phase).
"""

from __future__ import annotations

import time

import numpy as np
import pytest

import dmprs
from dmprs._core import RobotNode
from dmprs.errors import AdapterError
from dmprs.ros2 import messages as m
from dmprs.ros2.streaming import stream
from tests.ros2_helpers import ControllerThread

ROBOT_JOINTS = ["j1", "j2", "j3"]
JOINTS = ["j3", "j1", "j2"]  # the stepper's DOF order, named on the robot
DT = 0.004  # s: 250 Hz


class PositionController(ControllerThread):
    """A forward position controller: publishes the last command received as its position,
    except between ``hold`` (s from the first command) when it stays where it was.
    """

    def __init__(self, robot: RobotNode, hold: tuple[float, float] | None = None):
        super().__init__()
        self.robot, self.hold = robot, hold
        self.q = np.zeros(3)
        self.received: list[np.ndarray] = []
        self.first: float | None = None

    def run(self) -> None:
        while not self.halt.is_set():
            now = time.monotonic()
            for row in self.robot.poll_commands():
                self.received.append(row.copy())
                self.first = self.first or now
                held = self.hold is not None and self.hold[0] <= now - self.first < self.hold[1]
                if not held:
                    self.q = row.copy()
            self.robot.publish_joint_state(now, self.q)
            time.sleep(0.001)


@pytest.fixture
def robot(domain_id: int):
    node = RobotNode(domain_id, "joint_trajectory_controller", ROBOT_JOINTS)
    yield node
    node.shutdown()


@pytest.fixture
def dmp(demo):
    t, y = demo
    return dmprs.DMP.fit(t, y, 30)


def test_open_loop_the_stream_is_the_rollout_and_reaches_the_robot_in_its_joint_order(robot, node, dmp):
    with PositionController(robot) as controller:
        result = stream(dmp.stepper(DT), node, JOINTS, controller_joints=ROBOT_JOINTS, phase_stopping=False)
        time.sleep(0.2)
    assert result.done
    rollout = dmp.rollout(dt=DT).y  # to tau; the stepper goes on until the DMP is at rest
    n = len(result.commands)
    assert n > len(rollout)
    np.testing.assert_allclose(result.commands[:len(rollout)], rollout, rtol=0, atol=1e-12)
    order = [JOINTS.index(j) for j in ROBOT_JOINTS]
    assert len(controller.received) == n  # reliable: every command arrived, in order
    np.testing.assert_array_equal(np.array(controller.received), result.commands[:, order])


def test_phase_stopping_closes_on_joint_states_a_held_robot_holds_the_phase(robot, node, dmp):
    hold = (0.3, 0.8)
    runs = {}
    for stopping in (True, False):
        with PositionController(robot, hold):
            runs[stopping] = stream(dmp.stepper(DT, alpha_e=1e4), node, JOINTS, controller_joints=ROBOT_JOINTS,
                                    phase_stopping=stopping)
    inside = (runs[True].times > hold[0] + 0.1) & (runs[True].times < hold[1] - 0.05)
    phase = runs[True].phases[inside]
    free = runs[False].phases
    free_advance = np.interp(hold[1] - 0.05, runs[False].times, free) - np.interp(hold[0] + 0.1, runs[False].times, free)
    # held: the phase barely moves; free: it moves as the clock says
    assert abs(phase[0] - phase[-1]) < 0.1 * abs(free_advance)  # the phase decays from 1 to 0
    assert runs[True].done and runs[False].done
    assert runs[True].times[-1] > runs[False].times[-1] + 0.3  # it waited for the robot
    np.testing.assert_allclose(runs[True].commands[-1], dmp.goal, atol=1e-3)


def test_no_controller_is_an_adapter_error(node, dmp):
    with pytest.raises(AdapterError, match="nothing subscribes to /forward_position_controller/commands"):
        stream(dmp.stepper(DT), node, JOINTS, answer_timeout=0.3)


def joint_state(names, position, stamp):
    sec, nanosec = divmod(int(stamp * 1e9), 1_000_000_000)
    return m.JointState(header=m.Header(stamp=m.Time(sec=sec, nanosec=nanosec), frame_id=""), name=list(names),
                        position=list(position), velocity=[], effort=[])


def test_joint_states_no_robot_could_send_are_skipped_and_counted(robot, node, dmp):
    stray = node.create_publisher(m.JointState, "/joint_states")
    with PositionController(robot):
        def should_stop() -> bool:  # a stray publisher's samples mid-motion, once
            if not getattr(should_stop, "sent", False) and time.monotonic() - started > 0.2:
                for q in ([np.nan, 0.0, 0.0], [1e200, 0.0, 0.0]):
                    stray.publish(joint_state(ROBOT_JOINTS, q, time.monotonic()))
                should_stop.sent = True  # type: ignore[attr-defined]
            return False

        started = time.monotonic()
        result = stream(dmp.stepper(DT, alpha_e=1e4), node, JOINTS, controller_joints=ROBOT_JOINTS,
                        should_stop=should_stop)
    assert result.done and not result.error
    assert result.skipped == 2
    assert np.isfinite(result.measured[1:]).all()
    np.testing.assert_allclose(result.commands[-1], dmp.goal, atol=1e-3)


def test_a_periodic_stepper_streams_with_a_frequency_change_mid_run_and_stops_at_rest(robot, node):
    # a rhythm faded in, sped up 1.25x after 0.6 s, stopped after 2 s: the robot receives, in
    # order, exactly the commands of the same stepper run offline with the same calls at the same
    # periods, and the stream ends when the rhythm is at rest
    t = np.arange(0.0, 2.0, DT)
    w = 2 * np.pi
    y = np.column_stack([0.2 * np.sin(w * t), 0.1 * np.cos(w * t), 0.3 + 0.05 * np.sin(2 * w * t)])
    rhythm = dmprs.PeriodicDMP.fit(t, y, period=1.0, n_basis=25)
    events = {150: lambda s: s.set_tau(rhythm.tau / 1.25), 500: lambda s: s.stop()}

    def driven(stepper):
        calls = [0]

        def should_stop() -> bool:  # called once before each period's step
            if calls[0] in events:
                events[calls[0]](stepper)
            calls[0] += 1
            return False

        return should_stop

    streamed = rhythm.stepper(DT)
    with PositionController(robot) as controller:
        result = stream(streamed, node, JOINTS, controller_joints=ROBOT_JOINTS, phase_stopping=False,
                        should_stop=driven(streamed))
        time.sleep(0.2)
    assert result.done and not result.error
    offline = rhythm.stepper(DT)
    should_stop, expected = driven(offline), []
    while not offline.done():
        should_stop()
        expected.append(offline.step()[0].copy())
    np.testing.assert_array_equal(result.commands, np.array(expected))
    order = [JOINTS.index(j) for j in ROBOT_JOINTS]
    np.testing.assert_array_equal(np.array(controller.received), result.commands[:, order])
    # the phase ran 1.25x faster once the change had settled, and the rhythm ended at its baseline
    rate = np.diff(np.unwrap(result.phases)) / DT
    assert rate[100] == pytest.approx(1 / rhythm.tau, rel=1e-9)
    assert rate[450] == pytest.approx(1.25 / rhythm.tau, rel=1e-3)
    np.testing.assert_allclose(result.commands[-1], rhythm.goal, atol=1e-9)
