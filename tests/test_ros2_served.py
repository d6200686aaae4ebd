"""The throwing and pouring arms served as ROS 2 robots (on the Rust node) and learned through the
wire with Ros2TrajectoryAdapter (Cyclone): the same trials as in process, bit for bit; a robot
killed mid-trial loses no finished trial and the run resumes once it is back.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from typing import Self

import numpy as np
import pytest
from click.testing import CliRunner

from dmprs.adapters import Status
from dmprs.cli import main
from dmprs.experiments import arm_pouring, arm_throwing
from dmprs.loop import learn
from dmprs.ros2 import Node, messages
from dmprs.ros2.action import ActionClient
from dmprs.ros2.adapter import FOLLOW_JOINT_TRAJECTORY, joint_trajectory
from dmprs.ros2.served import REST, serve, throwing_adapter
from dmprs.runlog import RunLog
from dmprs.tasks.arm_throwing import DEMOS, ArmThrowingAdapter, throw_trajectory

TARGET = (1.05, 0.12)  # m: between the demonstrations' landings
SPEED = 10.0  # the served robot plays each motion back at 10 x real time


class Served:
    """A task's robot served in a thread for the duration of a ``with`` block."""

    def __init__(self, domain_id: int, task: str = "arm-throwing", **options):
        self.stop, self.ready = threading.Event(), threading.Event()
        self.thread = threading.Thread(target=serve, args=(task, domain_id), daemon=True, kwargs={
            "speed": SPEED, "stop": self.stop, "on_ready": self.ready.set, "loopback_only": True, **options})

    def __enter__(self) -> Self:
        self.thread.start()
        assert self.ready.wait(30)
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop.set()
        self.thread.join(30)


def learned(robot: str, domain_id: int = 0, **options):
    setup = arm_throwing.setup(TARGET, tol=0.003, robot=robot, domain_id=domain_id)
    return learn(setup.task, setup.generalizer, setup.desired_query, setup.make_learner("secant"),
                 max_trials=6, **options)


def test_learning_through_ros2_takes_the_same_trials_as_in_process(domain_id):
    here = learned("sim")
    with Served(domain_id):
        there = learned("ros2", domain_id)
    assert here.n_trials >= 2, "a 3 mm basket takes the learner some trials"
    assert (there.converged, there.trials_to_success, there.n_trials) == (
        here.converged, here.trials_to_success, here.n_trials)
    for a, b in zip(here.trials, there.trials, strict=True):
        assert b.status == "ok"
        # the scene executes the times a controller receives (whole nanoseconds): the same throws
        assert (b.query.tolist(), b.signals["landing_x"], b.signals["landing_y"]) == (
            a.query.tolist(), a.signals["landing_x"], a.signals["landing_y"])


POUR = 0.7  # l in the bottle


def learned_pour(robot: str, cache: str, domain_id: int = 0):
    setup = arm_pouring.setup(POUR, robot=robot, domain_id=domain_id, cache_dir=cache)
    return learn(setup.task, setup.generalizer, setup.desired_query, setup.make_learner("root"), max_trials=4)


def test_pouring_through_ros2_is_the_same_pour_as_in_process(domain_id, calibration_cache):
    here = learned_pour("sim", calibration_cache)
    with Served(domain_id, "arm-pouring", bottle_volume=POUR):
        there = learned_pour("ros2", calibration_cache, domain_id)
    assert (there.converged, there.trials_to_success, there.n_trials) == (
        here.converged, here.trials_to_success, here.n_trials)
    for a, b in zip(here.trials, there.trials, strict=True):
        assert b.status == "ok"
        # a granular pour turns any change of its command into another pour: equal means the same
        assert (b.query.tolist(), b.signals["poured_volume"]) == (a.query.tolist(), a.signals["poured_volume"])


def serve_process(domain_id: int) -> subprocess.Popen:
    process = subprocess.Popen(
        [sys.executable, "-m", "dmprs", "robot", "serve", "arm-throwing", "--domain-id", str(domain_id),
         "--speed", "1", "--loopback-only"], stderr=subprocess.PIPE, text=True, env=os.environ.copy())
    assert "serving" in process.stderr.readline()
    return process


def test_a_robot_killed_mid_trial_loses_no_finished_trial_and_the_run_resumes(domain_id, tmp_path):
    run_dir = tmp_path / "run"
    robot = serve_process(domain_id)
    try:
        # the first trial finishes, the robot dies during the second
        def kill_in_second_trial() -> None:
            log = run_dir / "trials.jsonl"
            while not (log.exists() and log.read_text().count("\n") >= 1):
                time.sleep(0.05)
            time.sleep(0.5)
            robot.send_signal(signal.SIGKILL)

        threading.Thread(target=kill_in_second_trial, daemon=True).start()
        setup = arm_throwing.setup(TARGET, tol=0.003, robot="ros2", domain_id=domain_id)
        setup.task.adapter.answer_timeout = 2.0
        start = time.monotonic()
        result = learn(setup.task, setup.generalizer, setup.desired_query, setup.make_learner("secant"),
                       max_trials=8, log_dir=run_dir, timeout_s=20.0,
                       meta={"experiment": "arm-throwing", "learner_name": "secant", "learner_options": {},
                             "setup_options": {"target": TARGET, "tol": 0.003, "robot": "ros2",
                                               "domain_id": domain_id}})
        assert time.monotonic() - start < 30  # the death is noticed in answer_timeout, not timeout_s
    finally:
        robot.kill()
        robot.wait()
    statuses = [t.status for t in result.trials]
    assert statuses == ["ok", Status.ERROR.value], statuses
    assert "went silent" in result.trials[-1].message
    finished = sum(s == "ok" for s in statuses)
    assert len(RunLog(run_dir).read()[0]) == len(statuses)
    robot = serve_process(domain_id)
    try:
        resumed = CliRunner().invoke(main, ["resume", str(run_dir), "--max-trials", str(len(statuses) + 1)])
    finally:
        robot.kill()
        robot.wait()
    trials = RunLog(run_dir).read()[0]
    assert [t.status for t in trials][:finished] == ["ok"] * finished  # nothing finished was lost
    assert len(trials) > len(statuses) and trials[-1].status == "ok", resumed.output


@pytest.mark.parametrize(("options", "why"), [({"robot": "moon"}, "robot = 'moon' is invalid"),
                                             ({"robot": "ros2", "domain_id": -1}, "domain_id")])
def test_the_robot_option_is_checked(options, why):
    with pytest.raises(ValueError, match=why):
        arm_throwing.setup(TARGET, **options)


def test_dmprs_learn_with_robot_ros2(domain_id):
    with Served(domain_id):
        result = CliRunner().invoke(main, ["learn", "arm-throwing", "--target", *map(str, TARGET), "--robot", "ros2",
                                           "--domain-id", str(domain_id), "--max-trials", "3"])
    assert result.exit_code == 0, result.output
    assert "success in trial 1" in result.output


def throw():
    return throw_trajectory(*DEMOS[2])


def test_the_served_arm_moves_through_the_joint_trajectory_topic_as_through_the_action(domain_id):
    with Served(domain_id):
        with throwing_adapter(domain_id, mode="topic") as by_topic:
            topic = by_topic.execute(throw(), timeout_s=60.0)
        with throwing_adapter(domain_id) as by_action:
            action = by_action.execute(throw(), timeout_s=60.0)
    assert action.status is Status.OK, action.message
    assert topic.status is Status.OK, topic.message
    # the same times reach the scene either way: the same throw, bit for bit
    assert (topic.signals["landing_x"], topic.signals["landing_y"]) == (
        action.signals["landing_x"], action.signals["landing_y"])
    # the recording covers the motion to its end (the action's also has the wait before it),
    # and the topic's stops there, not with the rest after it (REST)
    assert topic.executed is not None and action.executed is not None
    assert throw().duration - 0.05 <= topic.executed.duration < throw().duration + REST
    np.testing.assert_allclose(topic.executed.y[-1], action.executed.y[-1], atol=0.01)


def arm_moves(domain_id: int, timeout: float = 30.0) -> None:
    """Returns once the served arm's /joint_states leave the pose they began in."""
    with Node("watcher", domain_id) as node:
        states = node.create_subscription(messages.JointState, "/joint_states")
        deadline, start = time.monotonic() + timeout, None
        while time.monotonic() < deadline:
            for state in states.take():
                start = start if start is not None else list(state.position)
                if list(state.position) != start:
                    return
            time.sleep(0.005)
    raise AssertionError(f"the arm did not move within {timeout:g} s")


def test_a_trajectory_on_the_topic_replaces_the_running_goal(domain_id):
    outcomes = {}
    with (Served(domain_id, speed=1.0), throwing_adapter(domain_id) as by_action,
          throwing_adapter(domain_id, mode="topic") as by_topic):
        first = threading.Thread(target=lambda: outcomes.setdefault("goal", by_action.execute(throw(), timeout_s=60.0)))
        first.start()
        arm_moves(domain_id)  # the goal is played back at real time: the topic's comes mid-motion
        outcomes["topic"] = by_topic.execute(throw(), timeout_s=60.0)
        first.join(60.0)
    assert outcomes["goal"].status is Status.ERROR
    assert "replaced by a trajectory on /joint_trajectory_controller/joint_trajectory" in outcomes["goal"].message
    assert outcomes["topic"].status is Status.OK, outcomes["topic"].message


def test_a_goal_canceled_while_it_waits_never_runs(domain_id):
    joints = ArmThrowingAdapter().spec.dof_names
    goal = messages.FollowJointTrajectory_Goal(trajectory=joint_trajectory(joints, throw()))
    with Served(domain_id, speed=1.0), Node("client", domain_id) as node:
        client = ActionClient(node, FOLLOW_JOINT_TRAJECTORY, "/joint_trajectory_controller/follow_joint_trajectory")
        running = client.send_goal(goal, 10.0)
        waiting = client.send_goal(goal, 10.0)
        assert running.accepted and waiting.accepted
        answer = client.cancel(waiting, 10.0)
        assert answer.return_code == 0  # accepted for canceling
        assert client.result(running, 60.0)[0] == messages.GoalStatus.STATUS_SUCCEEDED
        ran = time.monotonic()
        status, _ = client.result(waiting, 60.0)
        # canceled when its turn came, at once: not after a throw played back at real time
        assert status == messages.GoalStatus.STATUS_CANCELED
        assert time.monotonic() - ran < 0.5
