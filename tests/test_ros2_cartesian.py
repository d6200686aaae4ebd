"""Ros2PoseAdapter (dmprs.ros2, Cyclone DDS) streaming a CartesianDMP's rollout to a Cartesian
controller played by the Rust robot node (ros2-client / RustDDS): every target crosses the wire
intact, in order and on time; the executed motion is the robot's current pose; fresh signals only;
a robot elsewhere is refused; stop, silence and bad options. Each test has its own domain on
loopback.
"""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest

from dmprs import CartesianDMP
from dmprs._core import RobotNode
from dmprs.adapters import AdapterSpec, Status, check_adapter
from dmprs.errors import InvalidInputError
from dmprs.ros2 import Node, messages
from dmprs.ros2.adapter import SignalTopic, signal_specs
from dmprs.ros2.cartesian import CARTESIAN_CONTROLLER, Ros2PoseAdapter, pose_stamped
from dmprs.trajectory import CartesianTrajectory
from tests.ros2_helpers import ControllerThread

CAMERA = SignalTopic("final_x", "/camera/tool", "geometry_msgs/msg/PointStamped", "point.x", unit="m")
RATE = 500.0  # Hz: the controller's current_pose
CLOCK0 = 2000.0  # s: the robot's clock when it starts
HOME = np.array([0.4, 0.0, 0.3, 1.0, 0.0, 0.0, 0.0])
DT = 0.004  # s between the trajectory's samples


def spec() -> AdapterSpec:
    return AdapterSpec("ros2-pose-test", ("x", "y", "z"), ("m",) * 3, DT, signal_specs((CAMERA,)),
                       velocity_max=(1.0,) * 3, start_pose=tuple(HOME), start_tolerance=0.005,
                       max_duration=5.0, pose=True)


def rollout(duration: float = 0.4) -> CartesianTrajectory:
    """A CartesianDMP's rollout from HOME: 10 cm along x and y, 0.5 rad about z, in ``duration`` s."""
    t = np.linspace(0.0, duration, 101)
    s = 0.5 - 0.5 * np.cos(np.pi * t / duration)
    half = 0.25 * s
    pose = np.column_stack([HOME[0] + 0.1 * s, 0.1 * s, np.full_like(s, HOME[2]),
                            np.cos(half), np.zeros_like(s), np.zeros_like(s), np.sin(half)])
    dmp = CartesianDMP.fit(t, pose, n_basis=20)
    return dmp.rollout(dt=DT)


class Controller(ControllerThread):
    """A Cartesian controller on the Rust node: its pose follows the newest target at once
    (perfect tracking), published at RATE on the robot's clock; after the stream stops, the camera
    reports the tool's x, and before any target a stale one.
    """

    def __init__(self, robot: RobotNode, pose=HOME, silent: bool = False):
        super().__init__()
        self.robot, self.pose, self.silent = robot, np.array(pose, dtype=float), silent
        self.clock = CLOCK0
        self.stamps: list[float] = []
        self.targets: list[np.ndarray] = []
        self.frames: list[str] = []
        self.arrivals: list[float] = []

    def run(self) -> None:
        self.robot.publish_signal(CAMERA.topic, [-1.0, 0.0, 0.0], self.clock)  # stale
        quiet, start = 0, time.monotonic()
        while not self.halt.is_set():
            self.clock = CLOCK0 + time.monotonic() - start  # the robot's clock runs in real time
            stamps, poses, frames = self.robot.poll_poses()
            now = time.monotonic()
            if len(stamps):
                self.stamps += stamps.tolist()
                self.targets += list(poses)
                self.frames += frames
                self.arrivals += [now] * len(stamps)
                self.pose, quiet = poses[-1].copy(), 0
            elif self.targets:
                quiet += 1
                if quiet == 25:  # 50 ms without a target: the motion is over
                    self.robot.publish_signal(CAMERA.topic, [float(self.pose[0]), 0.0, 0.0], self.clock)
            if not (self.silent and self.targets):
                self.robot.publish_pose(self.clock, self.pose)
            time.sleep(1 / RATE)


@pytest.fixture
def robot(domain_id: int):
    node = RobotNode(domain_id, "joint_trajectory_controller", ["a1"], point_signals=[CAMERA.topic])
    yield node
    node.shutdown()


def adapter(domain_id: int, **options) -> Ros2PoseAdapter:
    return Ros2PoseAdapter(spec(), domain_id=domain_id, signals=(CAMERA,), frame_id="world",
                           answer_timeout=options.pop("answer_timeout", 3.0), **options)


def test_a_rollout_is_streamed_intact_in_order_and_on_time(robot, domain_id):
    tr = rollout()
    with Controller(robot) as controller, adapter(domain_id) as a:
        out = a.execute(tr, timeout_s=10)
        time.sleep(0.1)
    assert out.status is Status.OK, out.message
    # every target crossed the wire bit for bit, in order, in the given frame
    np.testing.assert_array_equal(np.array(controller.targets), tr.pose)
    assert set(controller.frames) == {"world"}
    # stamped on the robot's clock: its pose's stamp when the stream began plus each sample's time
    stamps = np.array(controller.stamps)
    np.testing.assert_allclose(np.diff(stamps), np.diff(tr.t), atol=2e-9)
    assert CLOCK0 < stamps[0] < CLOCK0 + 100
    # paced at the samples' times: the stream takes the trajectory's duration, not a burst
    took = controller.arrivals[-1] - controller.arrivals[0]
    assert took == pytest.approx(tr.t[-1] - tr.t[0], abs=0.1)
    # the executed motion is the robot's current pose, on its clock, ending at the last target
    executed = out.executed
    assert isinstance(executed, CartesianTrajectory) and np.all(np.diff(executed.t) > 0)
    np.testing.assert_allclose(executed.pose[-1], tr.pose[-1], atol=1e-4)  # the rollout has come to rest
    np.testing.assert_allclose(executed.pose[0], HOME, atol=1e-12)
    # the camera's reading after the motion, never the stale one from before
    assert out.signals["final_x"] == tr.pose[-1, 0]


def test_a_robot_away_from_the_start_is_refused_and_sent_nothing(robot, domain_id):
    elsewhere = HOME + np.array([0.02, 0, 0, 0, 0, 0, 0])
    with Controller(robot, pose=elsewhere) as controller, adapter(domain_id) as a:
        out = a.execute(rollout(), timeout_s=10)
    assert out.status is Status.REJECTED
    assert "the robot is at [0.42, 0.0, 0.3" in out.message and "20 mm" in out.message
    assert controller.targets == []


class StrayPose(threading.Thread):
    """Another publisher of the controller's current pose (Cyclone DDS, not the robot node, which
    refuses to publish a non-finite pose), publishing ``pose`` every 2 ms until stopped.
    """

    def __init__(self, domain_id: int, pose):
        super().__init__(daemon=True)
        self.domain_id, self.pose, self.halt = domain_id, np.array(pose, dtype=float), threading.Event()

    def run(self) -> None:
        with Node("stray_pose", self.domain_id) as node:
            publisher = node.create_publisher(messages.PoseStamped, f"{CARTESIAN_CONTROLLER}/current_pose")
            while not self.halt.is_set():
                publisher.publish(pose_stamped(self.pose, time.time(), "world"))
                time.sleep(0.002)


@pytest.mark.parametrize(("pose", "why"), [
    ([0.4, 0.0, 0.3, 0.0, 0.0, 0.0, 0.0], "has norm 0, not a unit quaternion"),
    ([float("nan"), 0.0, 0.3, 1.0, 0.0, 0.0, 0.0], "is not a finite pose"),
])
def test_a_robot_reporting_no_usable_pose_is_refused_and_sent_nothing(robot, domain_id, pose, why):
    stray = StrayPose(domain_id, pose)
    stray.start()
    try:
        with adapter(domain_id) as a:
            out = a.execute(rollout(), timeout_s=10)
    finally:
        stray.halt.set()
        stray.join()
    assert out.status is Status.REJECTED and why in out.message
    stamps, _, _ = robot.poll_poses()
    assert len(stamps) == 0  # no target reached the robot


def test_stop_ends_the_stream_where_it_is(robot, domain_id):
    tr = rollout(2.0)
    with Controller(robot) as controller, adapter(domain_id) as a:
        threading.Timer(0.5, a.stop).start()
        out = a.execute(tr, timeout_s=10)
    assert out.status is Status.STOPPED
    assert 0 < len(controller.targets) < len(tr.t) // 2
    assert out.executed is not None and out.executed.t[-1] < 1.0


def test_a_silent_robot_and_no_robot_are_errors(robot, domain_id):
    with Controller(robot, silent=True), adapter(domain_id, answer_timeout=1.0) as a:
        out = a.execute(rollout(), timeout_s=10)
    assert out.status is Status.ERROR and "went silent" in out.message
    start = time.monotonic()
    with adapter(domain_id + 1 if domain_id < 232 else 0, answer_timeout=0.5) as a:
        out = a.execute(rollout(), timeout_s=10)
    assert out.status is Status.ERROR and f"no {CARTESIAN_CONTROLLER}/current_pose" in out.message
    assert time.monotonic() - start < 5


def test_the_adapter_passes_the_conformance_check(robot, domain_id):
    with Controller(robot):
        passed = check_adapter(adapter(domain_id), rollout(0.2), deterministic=False)
    assert "execute" in " ".join(passed)


def test_a_joint_spec_is_refused():
    joint = AdapterSpec("joints", ("a1",), ("rad",), 0.004, signal_specs((CAMERA,)))
    with pytest.raises(InvalidInputError, match="takes pose trajectories"):
        Ros2PoseAdapter(joint, signals=(CAMERA,))
