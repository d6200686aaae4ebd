"""The ROS 2 transport choice, measured: dmprs's side on Cyclone DDS (Python) against the Rust
ros2-client side, each as the client of the other.

    python benches/bench_ros2.py [--goals 200] [--seconds 10] [--rate 1000]

For both stacks as the receiving/client side:
- goal sent -> goal accepted latency of control_msgs/FollowJointTrajectory (median, p95);
- `/joint_states` at `--rate` Hz for `--seconds` s: samples lost, and the receiving process's own
  CPU time per wall second while it records them.
The serving side runs in a subprocess; every run has its own domain on the loopback interface.
Floors for dmprs's side: accepted median <= 5 ms, no sample lost, <= 10 % of one core.
"""

from __future__ import annotations

import argparse
import os
import select
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

JOINTS = ["j1", "j2", "j3", "j4", "j5", "j6", "j7"]
ACTION = "/joint_trajectory_controller/follow_joint_trajectory"
FJT = "control_msgs/action/FollowJointTrajectory"
WARMUP = 1.0  # s of joint states before the measured window (discovery, matching)
GOAL_TIMEOUT = 5.0
# both clients wait this long after they see the server, before the first goal: ros2-client's
# wait_for_service returns once it has matched the server, which may not yet have matched it
DISCOVERY_SETTLE = 1.0


def goal_arrays() -> tuple[list[float], np.ndarray]:
    times = [0.5 * (k + 1) for k in range(4)]
    return times, np.linspace(0.0, 1.0, 4 * len(JOINTS)).reshape(4, len(JOINTS))


def cyclone_goal():
    from dmprs.ros2 import messages as m

    times, positions = goal_arrays()
    points = [
        m.JointTrajectoryPoint(positions=list(row), time_from_start=m.Duration(sec=int(t), nanosec=round((t % 1) * 1e9)))
        for t, row in zip(times, positions, strict=True)
    ]
    return m.FollowJointTrajectory_Goal(trajectory=m.JointTrajectory(joint_names=JOINTS, points=points))


# --- the serving side (subprocesses) -------------------------------------------------------


def serve_rust_goals(domain: int, goals: int) -> None:
    from dmprs._core import RobotNode

    robot = RobotNode(domain, "joint_trajectory_controller", JOINTS)
    print("ready", flush=True)
    deadline = time.monotonic() + 120
    done = 0
    while done < goals and time.monotonic() < deadline:
        goal = robot.poll_goal(0.5)
        if goal is not None:
            robot.finish_goal(goal.id, 4)
            done += 1
    robot.shutdown()


def serve_cyclone_goals(domain: int, goals: int) -> None:
    from dmprs.ros2 import Node
    from dmprs.ros2 import messages as m
    from dmprs.ros2.service import ServiceServer

    with Node("bench_goal_server", domain) as node:
        server = ServiceServer(node, FJT + "_SendGoal", ACTION + "/_action/send_goal")
        # ros2-client's action client also looks for the other services and topics
        ServiceServer(node, FJT + "_GetResult", ACTION + "/_action/get_result")
        ServiceServer(node, "action_msgs/srv/CancelGoal", ACTION + "/_action/cancel_goal")
        node.create_publisher(m.message_class(FJT + "_FeedbackMessage"), ACTION + "/_action/feedback")
        print("ready", flush=True)

        def accept(_request):
            now = time.time()
            return server.response_type(accepted=True, stamp=m.Time(sec=int(now), nanosec=int((now % 1) * 1e9)))

        deadline = time.monotonic() + 120
        done = 0
        while done < goals and time.monotonic() < deadline:
            done += server.serve(accept, 0.5)


def paced(rate: float, seconds: float, publish) -> None:
    """Call publish(stamp) at `rate` Hz: WARMUP s of negative stamps, then `seconds` s measured."""
    n_warm, n = round(WARMUP * rate), round(seconds * rate)
    t0 = time.perf_counter()
    for k in range(-n_warm, n):
        if k == 0:
            print("start", flush=True)
        target = t0 + (k + n_warm) / rate
        delay = target - time.perf_counter()
        if delay > 0:
            time.sleep(delay)
        publish(k / rate)
    print("end", flush=True)


def publish_rust_joint_states(domain: int, rate: float, seconds: float) -> None:
    from dmprs._core import RobotNode

    robot = RobotNode(domain, "joint_trajectory_controller", JOINTS)
    time.sleep(1.0)  # discovery
    q = np.linspace(0.0, 1.0, len(JOINTS))
    paced(rate, seconds, lambda t: robot.publish_joint_state(t, q, q))
    time.sleep(0.5)
    robot.shutdown()


def publish_cyclone_joint_states(domain: int, rate: float, seconds: float) -> None:
    from dmprs.ros2 import Node
    from dmprs.ros2 import messages as m

    with Node("bench_joint_states", domain) as node:
        publisher = node.create_publisher(m.JointState, "/joint_states")
        publisher.wait_for_subscribers(1, 10.0)
        time.sleep(0.5)
        q = list(np.linspace(0.0, 1.0, len(JOINTS)))

        def publish(t: float) -> None:
            stamp = m.Time(sec=int(np.floor(t)), nanosec=round((t - np.floor(t)) * 1e9) % 1_000_000_000)
            publisher.publish(m.JointState(header=m.Header(stamp=stamp), name=JOINTS, position=q, velocity=q))

        paced(rate, seconds, publish)
        time.sleep(0.5)


# --- the measuring side (this process) -----------------------------------------------------


class Server:
    """A serving subprocess of this script, on a domain, with a line protocol on its stdout."""

    def __init__(self, role: str, domain: int, *args: object):
        command = [sys.executable, __file__, "--role", role, "--domain", str(domain), *map(str, args)]
        self.process = subprocess.Popen(command, stdout=subprocess.PIPE, text=True)

    def expect(self, line: str, timeout: float) -> None:
        ready, _, _ = select.select([self.process.stdout], [], [], timeout)
        got = self.process.stdout.readline().strip() if ready else "(nothing)"
        if got != line:
            self.process.kill()
            raise RuntimeError(f"server said {got!r}, expected {line!r}")

    def finish(self, timeout: float = 30.0) -> None:
        try:
            self.process.wait(timeout)
        except subprocess.TimeoutExpired:
            self.process.kill()
            raise


def latency_stats(latencies: list[float]) -> tuple[float, float]:
    ms = np.array(latencies) * 1e3
    return float(np.median(ms)), float(np.percentile(ms, 95))


def goals_cyclone_client(domain: int, goals: int) -> tuple[float, float]:
    from dmprs.ros2 import ActionClient, Node

    server = Server("serve-rust-goals", domain, goals + 10)
    server.expect("ready", 30)
    with Node("bench_client", domain) as node:
        client = ActionClient(node, FJT, ACTION)
        assert client.wait_for_server(10.0), "no action server"
        time.sleep(DISCOVERY_SETTLE)
        goal = cyclone_goal()
        latencies = []
        for _ in range(goals + 10):
            t0 = time.perf_counter()
            handle = client.send_goal(goal, GOAL_TIMEOUT)
            latencies.append(time.perf_counter() - t0)
            assert handle.accepted
        server.finish()
    return latency_stats(latencies[10:])


def goals_rust_client(domain: int, goals: int) -> tuple[float, float]:
    from dmprs._core import Ros2GoalClient

    server = Server("serve-cyclone-goals", domain, goals + 10)
    server.expect("ready", 30)
    client = Ros2GoalClient(domain, ACTION)
    assert client.wait_for_server(10.0), "no action server"
    time.sleep(DISCOVERY_SETTLE)
    times, positions = goal_arrays()
    latencies = []
    for _ in range(goals + 10):
        t0 = time.perf_counter()
        accepted = client.send_goal(JOINTS, np.array(times), positions, GOAL_TIMEOUT)
        latencies.append(time.perf_counter() - t0)
        assert accepted is True, accepted
    server.finish()
    return latency_stats(latencies[10:])


def record(server: Server, rate: float, seconds: float, stop) -> tuple[int, int, float]:
    """Lost samples, received samples and CPU per wall second of this process over the window."""
    server.expect("start", 30)
    c0, w0 = time.process_time(), time.perf_counter()
    server.expect("end", seconds + 30)
    c1, w1 = time.process_time(), time.perf_counter()
    server.finish()
    stamps = np.asarray(stop())
    measured = np.unique(np.round(stamps[stamps >= 0] * rate).astype(int))
    expected = round(seconds * rate)
    return expected - len(measured), len(measured), (c1 - c0) / (w1 - w0)


def joint_states_cyclone_receiver(domain: int, rate: float, seconds: float) -> tuple[int, int, float]:
    from dmprs.ros2 import JointStateRecorder, Node

    with Node("bench_recorder", domain) as node:
        recorder = JointStateRecorder(node, JOINTS, depth=1000).start()
        server = Server("publish-rust-joint-states", domain, rate, seconds)
        return record(server, rate, seconds, lambda: recorder.stop().times)


def joint_states_rust_receiver(domain: int, rate: float, seconds: float) -> tuple[int, int, float]:
    from dmprs._core import Ros2JointStateListener

    listener = Ros2JointStateListener(domain, "/joint_states", 1000)
    server = Server("publish-cyclone-joint-states", domain, rate, seconds)
    return record(server, rate, seconds, listener.stop)


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--goals", type=int, default=200)
    parser.add_argument("--seconds", type=float, default=10.0)
    parser.add_argument("--rate", type=float, default=1000.0)
    parser.add_argument("--role")
    parser.add_argument("--domain", type=int)
    parser.add_argument("rest", nargs="*")
    args = parser.parse_args()
    if args.role:
        roles = {
            "serve-rust-goals": lambda: serve_rust_goals(args.domain, int(args.rest[0])),
            "serve-cyclone-goals": lambda: serve_cyclone_goals(args.domain, int(args.rest[0])),
            "publish-rust-joint-states": lambda: publish_rust_joint_states(
                args.domain, float(args.rest[0]), float(args.rest[1])
            ),
            "publish-cyclone-joint-states": lambda: publish_cyclone_joint_states(
                args.domain, float(args.rest[0]), float(args.rest[1])
            ),
        }
        roles[args.role]()
        return

    from dmprs.ros2 import LOOPBACK_CONFIG

    config = Path(tempfile.mkdtemp()) / "cyclonedds.xml"
    config.write_text(LOOPBACK_CONFIG)
    os.environ["CYCLONEDDS_URI"] = config.as_uri()
    base = 100 + os.getpid() % 100
    rows = []
    for i, (client, goals_fn, states_fn) in enumerate(
        [
            ("dmprs.ros2 (Cyclone DDS, Python)", goals_cyclone_client, joint_states_cyclone_receiver),
            ("ros2-client (RustDDS)", goals_rust_client, joint_states_rust_receiver),
        ]
    ):
        median, p95 = goals_fn(base + 2 * i, args.goals)
        lost, received, cpu = states_fn(base + 2 * i + 1, args.rate, args.seconds)
        rows.append((client, median, p95, lost, received, cpu))
    print(f"goals: {args.goals} (after 10 unmeasured); joint states: {args.rate:.0f} Hz for {args.seconds:.0f} s")
    print()
    print("| client / receiving side | server / publishing side | goal accepted, median (ms) | p95 (ms) "
          "| joint states lost | received | receiver CPU (% of a core) |")
    print("|---|---|---:|---:|---:|---:|---:|")
    servers = ["ros2-robot (ros2-client)", "dmprs.ros2 (Cyclone DDS)"]
    for (client, median, p95, lost, received, cpu), server in zip(rows, servers, strict=True):
        print(f"| {client} | {server} | {median:.2f} | {p95:.2f} | {lost} | {received} | {cpu * 100:.1f} |")
    print(f"\nload average at the end: {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
