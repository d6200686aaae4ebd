"""Ros2TrajectoryAdapter (dmprs.ros2, Cyclone DDS) against a joint_trajectory_controller played by
the Rust robot node (ros2-client / RustDDS): execution, recording by joint name, fresh signals,
every way a trial can end, and the adapter conformance check. Each test has its own domain on
loopback.
"""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest

from dmprs._core import RobotNode
from dmprs.adapters import AdapterSpec, Status, check_adapter
from dmprs.errors import InvalidInputError
from dmprs.ros2 import Node
from dmprs.ros2 import messages as m
from dmprs.ros2.adapter import Ros2TrajectoryAdapter, SignalTopic, signal_specs
from dmprs.ros2.recorder import JointStateRecorder
from dmprs.trajectory import Trajectory
from tests.ros2_helpers import ControllerThread

#: the robot's joints, in its own order; the adapter names them in another
ROBOT_JOINTS = ["a1", "a2", "a3"]
JOINTS = ("a3", "a1", "a2")
CONTROLLER = "/joint_trajectory_controller"
SCALE = SignalTopic("reading", "/scale/reading", "std_msgs/msg/Float64", "data", unit="kg")
CAMERA = SignalTopic("landing_x", "/camera/landing", "geometry_msgs/msg/PointStamped", "point.x", unit="m")
RATE = 250.0  # Hz: the robot's /joint_states
CLOCK0 = 1000.0  # s: the robot's clock when it starts (its stamps are its own, not ours)


def spec(signals=(SCALE, CAMERA)) -> AdapterSpec:
    return AdapterSpec("ros2-test", JOINTS, ("rad",) * 3, 0.004, signal_specs(signals),
                       position_min=(-3.0,) * 3, position_max=(3.0,) * 3, velocity_max=(5.0,) * 3,
                       max_duration=5.0)


def move(duration: float = 0.4) -> Trajectory:
    """A smooth move of every joint out and back, sampled every 4 ms, in the adapter's joint order."""
    t = np.linspace(0.0, duration, round(duration / 0.004) + 1)
    s = np.sin(np.pi * t / duration) ** 2
    y = np.stack([0.3 * s, -0.2 * s, 0.1 * s], axis=1)
    return Trajectory(t, y, np.gradient(y, t, axis=0))


class Controller(ControllerThread):
    """A joint_trajectory_controller played on the Rust node: /joint_states at RATE on the robot's
    clock, each accepted goal followed by interpolating its points, then finished as ``ending``
    says; after a goal, the scale and the camera publish a reading (sum of the joints, and the first
    joint), and before any goal a stale one.
    """

    def __init__(self, robot: RobotNode, ending: str = "succeed", scale: float | None = None,
                 robot_domain: int = 0, abort_text: str = "a2 left its path"):
        super().__init__()
        self.robot, self.ending, self.scale, self.robot_domain = robot, ending, scale, robot_domain
        self.abort_text = abort_text
        self.q = np.zeros(3)
        self.clock = CLOCK0
        self.goals: list = []
        self.canceled: list[bytes] = []

    def run(self) -> None:
        self.robot.publish_signal(SCALE.topic, -1.0, self.clock)  # stale: before any motion
        self.robot.publish_signal(CAMERA.topic, [-1.0, 0.0, 0.0], self.clock)
        active, start = None, 0.0
        while not self.halt.is_set():
            self.clock += 1 / RATE
            goal = self.robot.poll_goal(0.0)
            if goal is not None:
                self.goals.append(goal)
                if active is not None:  # as joint_trajectory_controller does: the new goal preempts
                    self.robot.finish_goal(active.id, m.GoalStatus.STATUS_CANCELED, m.FollowJointTrajectory_Result.SUCCESSFUL,
                                           "Current goal cancelled due to new incoming action.")
                active, start = goal, self.clock
            cancels = self.robot.poll_cancels()
            if active is not None and active.id in cancels:
                self.canceled.append(active.id)
                self.robot.finish_goal(active.id, m.GoalStatus.STATUS_CANCELED)
                active = None
            if active is not None:
                tr = active.trajectory
                elapsed = self.clock - start
                self.q = np.array([np.interp(elapsed, tr.times, tr.positions[:, j]) for j in range(3)])
                if self.ending == "abort" and elapsed > tr.times[-1] / 2:
                    self.robot.finish_goal(active.id, m.GoalStatus.STATUS_ABORTED,
                                           m.FollowJointTrajectory_Result.PATH_TOLERANCE_VIOLATED, self.abort_text)
                    active = None
                elif self.ending == "invalid":
                    self.robot.finish_goal(active.id, m.GoalStatus.STATUS_ABORTED,
                                           m.FollowJointTrajectory_Result.INVALID_JOINTS, "a3 is locked")
                    active = None
                elif elapsed >= tr.times[-1] and self.ending == "succeed":
                    self.robot.publish_joint_state(self.clock, self.q[[0, 1, 2]])
                    self.robot.finish_goal(active.id, m.GoalStatus.STATUS_SUCCEEDED)
                    active = None
                    time.sleep(0.05)  # the readings come a little after the motion, as a scale's would
                    self.clock += 0.05
                    if self.scale is None:
                        self.robot.publish_signal(SCALE.topic, float(self.q.sum()), time.time())
                    else:  # another publisher's reading (the robot node refuses a non-finite one)
                        with Node("stray_scale", self.robot_domain) as node:
                            stray = node.create_publisher(m.message_class("std_msgs/msg/Float64"), SCALE.topic)
                            stray.wait_for_subscribers(1, 5.0)
                            stray.publish(m.message_class("std_msgs/msg/Float64")(data=self.scale))
                            time.sleep(0.2)
                    self.robot.publish_signal(CAMERA.topic, [float(self.q[0]), 0.0, 0.0], self.clock)
            if not (self.ending == "silent" and self.goals):
                self.robot.publish_joint_state(self.clock, self.q)
            time.sleep(1 / RATE)

    def wait_for_cancel(self, timeout: float = 5.0) -> None:
        """Until the controller has seen a cancel request (the adapter returns once it is sent)."""
        deadline = time.monotonic() + timeout
        while not self.canceled and time.monotonic() < deadline:
            time.sleep(0.01)



@pytest.fixture
def robot(domain_id: int):
    node = RobotNode(domain_id, CONTROLLER.strip("/"), ROBOT_JOINTS, float_signals=[SCALE.topic],
                     point_signals=[CAMERA.topic])
    yield node
    node.shutdown()


def adapter(domain_id: int, **options) -> Ros2TrajectoryAdapter:
    options.setdefault("signals", (SCALE, CAMERA))
    return Ros2TrajectoryAdapter(spec(options["signals"]), domain_id=domain_id, controller=CONTROLLER,
                                 answer_timeout=5.0, **options)


def test_a_trial_runs_on_the_robot_and_is_recorded_by_joint_name(robot, domain_id):
    command = move()
    with Controller(robot) as controller, adapter(domain_id, path_tolerance=0.05, goal_tolerance=0.01) as a:
        out = a.execute(command, timeout_s=10.0)
    assert out.status is Status.OK, out.message
    (goal,) = controller.goals
    # the goal crossed the wire intact, reordered to the robot's joints by name
    order = [JOINTS.index(j) for j in ROBOT_JOINTS]
    np.testing.assert_allclose(goal.trajectory.times, command.t, rtol=0, atol=1e-9)  # whole ns on the wire
    np.testing.assert_array_equal(goal.trajectory.positions, command.y[:, order])
    np.testing.assert_array_equal(goal.trajectory.velocities, command.yd[:, order])
    assert [tol[:2] for tol in goal.path_tolerance] == [(j, 0.05) for j in JOINTS]
    # executed: the robot's motion in the adapter's joint order, timed by the robot's stamps
    executed = out.executed
    assert executed is not None and np.all(np.diff(executed.t) > 0)
    assert executed.t[-1] == pytest.approx(len(executed.t) / RATE, rel=0.2)
    assert np.abs(executed.y).max(axis=0) == pytest.approx(np.abs(command.y).max(axis=0), abs=0.01)
    # the readings after the motion, never the stale ones published before it
    assert out.signals["reading"] == pytest.approx(float(controller.q.sum()))
    assert out.signals["reading"] != -1.0 and out.signals["landing_x"] == pytest.approx(float(controller.q[0]))


def test_the_topic_mode_publishes_the_trajectory(robot, domain_id):
    with Controller(robot), adapter(domain_id, mode="topic", signals=(), settle=0.1) as a:
        out = a.execute(move(0.2), timeout_s=10.0)
        (sent,) = robot.poll_trajectories()
    assert out.status is Status.OK, out.message
    np.testing.assert_array_equal(sent.positions[:, 0], move(0.2).y[:, JOINTS.index("a1")])


def test_joints_the_robot_does_not_have_are_rejected_naming_its_joints(robot, domain_id):
    wrong = AdapterSpec("ros2-test", ("a1", "a2", "gripper"), ("rad",) * 3, 0.004, ())
    with Controller(robot) as controller, Ros2TrajectoryAdapter(wrong, domain_id=domain_id, controller=CONTROLLER) as a:
        out = a.execute(move())
    assert out.status is Status.REJECTED
    assert "no joint(s) gripper" in out.message and "a1, a2, a3" in out.message
    assert controller.goals == []  # nothing was sent


@pytest.mark.parametrize(("ending", "status", "why"), [
    ("abort", Status.ABORTED, "path tolerance violated: a2 left its path"),
    ("invalid", Status.REJECTED, "invalid joints: a3 is locked"),
])
def test_the_controllers_answer_maps_to_a_status_with_its_error_string(robot, domain_id, ending, status, why):
    with Controller(robot, ending), adapter(domain_id, signals=()) as a:
        out = a.execute(move(), timeout_s=10.0)
    assert out.status is status and out.message == why


def test_a_robot_that_never_finishes_is_a_timeout_and_the_goal_is_canceled(robot, domain_id):
    with Controller(robot, "never") as controller, adapter(domain_id, signals=()) as a:
        start = time.monotonic()
        out = a.execute(move(), timeout_s=1.0)
        took = time.monotonic() - start
        controller.wait_for_cancel()
    assert out.status is Status.TIMEOUT and "canceled" in out.message
    assert took < 1.0 + 5.0 + 0.5  # the deadline, and one answer_timeout for the cancel at most
    assert controller.canceled == [controller.goals[0].id]
    assert out.executed is not None  # what the robot did until then


def test_a_robot_that_falls_silent_mid_goal_is_an_error_within_the_answer_timeout(robot, domain_id):
    with Controller(robot, "silent"), adapter(domain_id, signals=()) as a:
        a.answer_timeout = 0.5
        start = time.monotonic()
        out = a.execute(move(), timeout_s=30.0)
    assert out.status is Status.ERROR and "no /joint_states for" in out.message
    assert time.monotonic() - start < 5.0


def test_a_second_client_preempting_the_goal_is_an_error_for_the_first(robot, domain_id):
    with Controller(robot), adapter(domain_id, signals=()) as first, adapter(domain_id, signals=()) as second:
        outcomes = {}
        threading.Thread(target=lambda: outcomes.setdefault("first", first.execute(move(2.0), timeout_s=10.0))).start()
        time.sleep(0.5)
        outcomes["second"] = second.execute(move(0.2), timeout_s=10.0)
        deadline = time.monotonic() + 5.0
        while "first" not in outcomes and time.monotonic() < deadline:
            time.sleep(0.01)
    assert outcomes["second"].status is Status.OK, outcomes["second"].message
    assert outcomes["first"].status is Status.ERROR
    assert "canceled by another client: Current goal cancelled due to new incoming action." in outcomes["first"].message


def test_stop_cancels_the_running_goal(robot, domain_id):
    with Controller(robot, "never") as controller, adapter(domain_id, signals=()) as a:
        threading.Timer(0.5, a.stop).start()
        out = a.execute(move(), timeout_s=10.0)
        controller.wait_for_cancel()
    assert out.status is Status.STOPPED
    assert controller.canceled == [controller.goals[0].id]


def test_no_robot_is_an_error_within_the_answer_timeout(domain_id):
    with Ros2TrajectoryAdapter(spec(()), domain_id=domain_id, answer_timeout=0.5) as a:
        start = time.monotonic()
        out = a.execute(move())
    assert out.status is Status.ERROR and "no /joint_states within 0.5 s" in out.message
    assert time.monotonic() - start < 2.0


def test_a_signal_that_never_comes_is_an_error(robot, domain_id):
    silent = SignalTopic("weight", "/scale/weight", "std_msgs/msg/Float64", "data")
    with Controller(robot), Ros2TrajectoryAdapter(spec((silent,)), domain_id=domain_id, controller=CONTROLLER,
                                                  signals=(silent,), answer_timeout=0.5) as a:
        out = a.execute(move(0.2), timeout_s=10.0)
    assert out.status is Status.ERROR and "/scale/weight" in out.message
    assert out.executed is not None


@pytest.mark.parametrize("reading", [float("nan"), float("inf")])
def test_a_signal_that_is_not_a_number_is_an_error_naming_its_topic(robot, domain_id, reading):
    with Controller(robot, scale=reading, robot_domain=domain_id), adapter(domain_id) as a:
        out = a.execute(move(0.2), timeout_s=10.0)
    assert out.status is Status.ERROR and "/scale/reading" in out.message and "not a measurement" in out.message
    assert out.executed is not None  # the motion's record is kept


def test_the_adapter_passes_the_conformance_check(robot, domain_id):
    with Controller(robot):
        passed = check_adapter(adapter(domain_id), move(0.2), deterministic=False)
    assert "execute" in " ".join(passed)


@pytest.mark.parametrize(("options", "why"), [
    ({"mode": "service"}, "mode = 'service' is invalid"),
    ({"signals": (SCALE,)}, "no SignalTopic for signal(s) landing_x"),
    ({"path_tolerance": -1.0}, "path_tolerance = -1.0"),
    ({"answer_timeout": float("nan")}, "answer_timeout = nan"),
])
def test_options_are_checked_at_the_boundary(options, why):
    with pytest.raises(InvalidInputError, match=why.replace("(", r"\(").replace(")", r"\)")):
        Ros2TrajectoryAdapter(spec(), **{"signals": (SCALE, CAMERA), **options})


@pytest.mark.parametrize(("args", "why"), [
    (("x", "/t", "std_msgs/msg/String", "data"), "is not one of"),
    (("x", "/t", "std_msgs/msg/Float64", "value"), "has no field 'value'"),
    (("x", "/t", "geometry_msgs/msg/PointStamped", "header"), "is not a number"),
])
def test_signal_topics_are_checked(args, why):
    with pytest.raises(InvalidInputError, match=why):
        SignalTopic(*args)


def test_malformed_joint_states_are_skipped_and_only_they_are_an_error(domain_id):
    # a robot whose /joint_states carry fewer positions than names: a clear error, never garbage
    with Node("bad_robot", domain_id) as bad, Ros2TrajectoryAdapter(spec(()), domain_id=domain_id, mode="topic",
                                                                    answer_timeout=1.0) as a:
        states = bad.create_publisher(m.JointState, "/joint_states")
        commands = bad.create_subscription(m.JointTrajectory, CONTROLLER + "/joint_trajectory")
        stop = threading.Event()

        def publish() -> None:
            while not stop.is_set():
                states.publish(m.JointState(header=m.Header(stamp=m.Time(sec=int(time.time()))),
                                            name=list(ROBOT_JOINTS), position=[0.0, 0.0]))
                time.sleep(0.004)

        threading.Thread(target=publish, daemon=True).start()
        try:
            assert commands.wait_for_publishers(1, 5.0)
            out = a.execute(move(0.2), timeout_s=10.0)
        finally:
            stop.set()
    assert out.status is Status.ERROR and "fewer than two /joint_states samples" in out.message
    assert "skipped" in out.message


@pytest.mark.parametrize("bad", [233, -1, 2**40])
def test_the_robot_node_takes_the_domains_every_entry_point_takes(bad):
    with pytest.raises(InvalidInputError, match=f"domain_id = {bad} must be an integer in 0..232"):
        RobotNode(bad, CONTROLLER.strip("/"), ROBOT_JOINTS)


def test_the_robot_node_refuses_bad_values_with_dmprs_errors_and_takes_integer_positions(robot):
    robot.publish_joint_state(CLOCK0, np.array([0, 1, 2], dtype=np.int64))  # integers are positions
    for status in (300, -1, 3):
        with pytest.raises(InvalidInputError, match="status"):
            robot.finish_goal(b"\x00" * 16, status)
    with pytest.raises(InvalidInputError, match="error_code"):
        robot.finish_goal(b"\x00" * 16, 4, error_code=2**40)
    with pytest.raises(InvalidInputError, match="position"):
        robot.publish_joint_state(CLOCK0, np.array([1 + 1j, 0, 0]))


def test_joint_states_no_robot_could_send_are_skipped_and_the_outcome_says_so(robot, domain_id):
    # mid-motion another publisher sends a sample stamped 2^31 - 1 s, one with a NaN and one
    # with 1e200: the recording keeps the robot's samples around them, and says what it skipped
    command = move(0.6)

    def strays() -> None:
        time.sleep(0.3)
        with Node("stray_states", domain_id) as node:
            stray = node.create_publisher(m.JointState, "/joint_states")
            for stamp, q in ((2**31 - 1, [0.1, 0.1, 0.1]), (CLOCK0 + 0.3, [np.nan, 0, 0]), (CLOCK0 + 0.3, [1e200, 0, 0])):
                sec, nanosec = divmod(int(stamp * 1e9), 1_000_000_000)
                stray.publish(m.JointState(header=m.Header(stamp=m.Time(sec=sec, nanosec=nanosec), frame_id=""),
                                           name=ROBOT_JOINTS, position=q, velocity=[], effort=[]))
            time.sleep(0.1)

    with Controller(robot), adapter(domain_id) as a:
        threading.Thread(target=strays, daemon=True).start()
        out = a.execute(command, timeout_s=10.0)
    assert out.status is Status.OK, out.message
    assert out.executed is not None and out.executed.duration < command.duration + 0.5
    assert np.isfinite(out.executed.y).all()
    assert "3 /joint_states sample(s) skipped as no robot's" in out.message


def test_a_result_with_a_huge_error_string_still_crosses_to_cyclone_cut(robot, domain_id):
    # RustDDS fragments a sample over about 64 KB, which Cyclone drops: the node cuts the text
    text = "x" * 70_000 + " the end"
    with Controller(robot, "abort", abort_text=text), adapter(domain_id) as a:
        out = a.execute(move(0.4), timeout_s=10.0)
    assert out.status is Status.ABORTED, out.message
    assert "xxxx... (cut)" in out.message and "the end" not in out.message
    assert len(out.message) < 5000


def test_one_signal_topic_cannot_be_of_two_types(domain_id):
    with pytest.raises(InvalidInputError, match="given twice"):
        RobotNode(domain_id, CONTROLLER.strip("/"), ROBOT_JOINTS, float_signals=["/scale/reading"],
                  point_signals=["/scale/reading"])


@pytest.mark.parametrize("stray_stamp", [2**31 - 1, 1.0])
def test_a_stray_joint_state_before_the_robots_first_is_skipped_and_counted(robot, domain_id, stray_stamp):
    # another publisher's sample, stamped decades ahead of the robot's clock or long before it,
    # arrives before the robot's first: the recording is the robot's alone
    with Node("recording", domain_id) as node, Node("stray_states", domain_id) as other:
        stray = other.create_publisher(m.JointState, "/joint_states")
        recorder = JointStateRecorder(node, list(JOINTS)).start()
        assert stray.wait_for_subscribers(1, 5.0)
        sec, nanosec = divmod(int(stray_stamp * 1e9), 1_000_000_000)
        stray.publish(m.JointState(header=m.Header(stamp=m.Time(sec=sec, nanosec=nanosec), frame_id=""),
                                   name=ROBOT_JOINTS, position=[0.1, 0.1, 0.1], velocity=[], effort=[]))
        time.sleep(0.3)
        for k in range(100):
            robot.publish_joint_state(CLOCK0 + k / RATE, [0.0, 0.0, k / 100])
            time.sleep(1 / RATE)
        time.sleep(0.2)
        recording = recorder.stop()
    assert recorder.implausible == 1
    assert len(recording.times) >= 50
    assert CLOCK0 <= recording.times.min() and recording.times.max() < CLOCK0 + 100 / RATE
    assert np.all(np.diff(recording.times) > 0)
