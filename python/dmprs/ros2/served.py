"""The MuJoCo arm served as a ROS 2 robot, and the adapters that learn through it.

:func:`serve` runs a task's scene (the throwing scene of :mod:`dmprs.sim.throw_scene` or the
pouring scene of :mod:`dmprs.sim.arm_scene`) behind what a ``ros2_control`` robot exposes, on the
Rust robot node (ros2-client / RustDDS, the other ROS 2 stack than dmprs's own Cyclone side): the
``joint_trajectory_controller``'s ``follow_joint_trajectory`` action and ``joint_trajectory``
topic, ``/joint_states`` and ``/clock`` on the simulation's clock, and the task's sensors: a
camera's landing point (``geometry_msgs/PointStamped`` on :data:`LANDING_TOPIC`) or a scale under
the glass (``std_msgs/Float64`` in l on :data:`SCALE_TOPIC`, published continuously).

Each goal, and each ``trajectory_msgs/JointTrajectory`` on the controller's ``joint_trajectory``
topic, is simulated first and then played back at ``speed`` times real time. While the physics
computes, the robot's clock stands still, as a simulator's ``/clock`` does when it runs slower
than real time, and ``/joint_states`` repeats the standing pose at that stamp. After each motion
the arm is back home (and for pouring the glass emptied and the bottle refilled) for the next
one, as the in-process adapters are.

As ``joint_trajectory_controller`` does, a trajectory on the topic starts at its header stamp
on the robot's clock (a zero stamp: as it arrives), and from then on replaces what runs: the
motion being played back stops there (a goal it cuts short ends aborted, saying so) and the new
one runs; of several waiting for their start, the newest wins. Goals wait in the order they
came; one canceled while it waits ends canceled when its turn comes, without moving.

:func:`throwing_adapter` and :func:`pouring_adapter` are the client side: a
:class:`~dmprs.ros2.Ros2TrajectoryAdapter` with the in-process adapter's joints and limits,
reading the task's signals from the sensors; for pouring, behind a
:class:`~dmprs.adapters.planned.PlannedAdapter` that solves the pose trajectory's IK on the
client, as a Cartesian task on a joint-controlled robot does.
"""

from __future__ import annotations

import dataclasses
import threading
import time
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dmprs._core import RobotNode
from dmprs.adapters import BaseAdapter, Outcome, Status
from dmprs.adapters.planned import PlannedAdapter
from dmprs.errors import InvalidInputError
from dmprs.ros2 import messages, names
from dmprs.ros2.adapter import Ros2TrajectoryAdapter, SignalTopic, signal_specs
from dmprs.sim.throw_scene import HOME
from dmprs.tasks.arm_pouring import ArmPouringAdapter
from dmprs.tasks.arm_throwing.adapter import ArmThrowingAdapter
from dmprs.trajectory import Trajectory

CONTROLLER = "/joint_trajectory_controller"
#: where the camera publishes the ball's first contact with the floor
LANDING_TOPIC = "/landing_camera/point"
LANDING = (SignalTopic("landing_x", LANDING_TOPIC, "geometry_msgs/msg/PointStamped", "point.x", "m",
                       "x where the ball first touched the floor"),
           SignalTopic("landing_y", LANDING_TOPIC, "geometry_msgs/msg/PointStamped", "point.y", "m",
                       "y where the ball first touched the floor"))
#: where the scale under the glass publishes the liquid in the glass (l)
SCALE_TOPIC = "/glass_scale/volume"
SCALE = (SignalTopic("poured_volume", SCALE_TOPIC, "std_msgs/msg/Float64", "data", "l",
                     "liquid in the glass, read once the pour has settled"),)
#: Hz: /joint_states while idle and during playback (every other servo step of the 1 kHz scene)
STATE_RATE = 500.0
#: s: a thrown arm rests at its last sample this long before it is back home, as a real arm
#: holds its last command; a client timing the motion from its side sees it end at rest
REST = 0.1
#: the scale publishes with every this many joint states (50 Hz)
SCALE_EVERY = 10
#: s: the robot's clock when it starts
CLOCK_START = 0.0
#: s: what a pour's reading waits for beyond the scene's hold, so that it is the settled one
SCALE_MARGIN = 0.25
#: the tasks that can be served
TASKS = ("arm-throwing", "arm-pouring")
_RESULT = messages.FollowJointTrajectory_Result


def throwing_adapter(domain_id: int | None = None, **options: Any) -> Ros2TrajectoryAdapter:
    """A :class:`~dmprs.ros2.Ros2TrajectoryAdapter` for a throwing robot on ``domain_id``: the
    in-process adapter's joints, limits and start, the camera's landing point as the signals;
    ``options`` go to the adapter (``answer_timeout``, ``config``, ...).
    """
    spec = dataclasses.replace(ArmThrowingAdapter().spec, name="arm-throwing-ros2", signals=signal_specs(LANDING))
    return Ros2TrajectoryAdapter(spec, domain_id=domain_id, controller=CONTROLLER, signals=LANDING, **options)


def pouring_adapter(domain_id: int | None = None, **options: Any) -> PlannedAdapter:
    """An adapter for a pouring robot on ``domain_id``: pose trajectories solved into joint
    trajectories by the arm's IK and checked (limits, collisions) on this machine, then sent to
    the robot's controller; ``poured_volume`` read from the scale once the pour has settled.
    ``options`` go to the :class:`~dmprs.ros2.Ros2TrajectoryAdapter` (``answer_timeout``, ...).
    """
    planner = ArmPouringAdapter()  # its dry pass only: the liquid is the robot's
    spec = dataclasses.replace(planner.spec, name="arm-pouring-ros2", signals=signal_specs(SCALE))
    options.setdefault("settle", planner.liquid.hold + SCALE_MARGIN)
    robot = Ros2TrajectoryAdapter(spec, domain_id=domain_id, controller=CONTROLLER, signals=SCALE, **options)
    return PlannedAdapter(planner, robot)


class _Clock:
    """The robot's clock: simulated seconds, advanced as states are played back."""

    def __init__(self, node: RobotNode) -> None:
        self.node, self.now = node, CLOCK_START

    def tick(self, seconds: float) -> float:
        self.now += seconds
        self.node.publish_clock(self.now)
        return self.now


class _Incoming:
    """What the controller has received besides goals: the cancel requests (kept until their goal
    ends, so that a goal canceled while it waits never runs) and the newest topic trajectory
    waiting for its start on the robot's clock.
    """

    def __init__(self, node: RobotNode) -> None:
        self.node = node
        self.canceled: set[bytes] = set()
        self.waiting: tuple[float, Any] | None = None  # (start on the robot's clock, trajectory)

    def poll(self, now: float) -> None:
        self.canceled.update(self.node.poll_cancels())
        for trajectory in self.node.poll_trajectories():
            # a zero stamp starts as it arrives; a later trajectory replaces one still waiting
            self.waiting = (trajectory.stamp if trajectory.stamp > 0.0 else now, trajectory)

    def due(self, now: float) -> bool:
        """Whether a topic trajectory's start has come: it replaces what runs."""
        return self.waiting is not None and now >= self.waiting[0]

    def take(self) -> Any:
        assert self.waiting is not None
        trajectory, self.waiting = self.waiting[1], None
        return trajectory


class _Robot:
    """A served scene: the arm's home, its sensors, and what they read before, during and after a motion."""

    float_topics: tuple[str, ...] = ()
    point_topics: tuple[str, ...] = ()

    def __init__(self, scene: BaseAdapter[Any], home: NDArray[np.float64]) -> None:
        self.scene, self.home = scene, home

    def new_goal(self) -> None:
        """The scene as at the start (the in-process learning loop's reset)."""
        self.scene.reset(seed=None)

    def started(self, outcome: Outcome) -> None:
        """The simulated outcome of the goal whose motion is about to be played back."""

    def sense(self, node: RobotNode, now: float, t: float | None) -> None:
        """The sensors' samples with one joint state at ``now``; ``t`` is the time into the
        motion being played back (None when idle).
        """

    @property
    def rest(self) -> float:
        """s on the robot's clock: how long the arm rests at its last sample after a motion,
        its sensors sampling, before it is back home for the next one.
        """
        return REST

    def measured(self, node: RobotNode, clock: _Clock, outcome: Outcome) -> None:
        """The sensors' samples once the motion has ended and the arm has rested."""


class _Throwing(_Robot):
    point_topics = (LANDING_TOPIC,)

    def __init__(self) -> None:
        super().__init__(ArmThrowingAdapter(), np.asarray(HOME, dtype=float))

    def new_goal(self) -> None:
        self.scene.reset(seed=0)

    def measured(self, node: RobotNode, clock: _Clock, outcome: Outcome) -> None:
        node.publish_signal(LANDING_TOPIC, [outcome.signals["landing_x"], outcome.signals["landing_y"], 0.0],
                            clock.tick(0.001))


class _Pouring(_Robot):
    """The scale reads the glass every :data:`SCALE_EVERY` states: the poured volume over the
    motion and the scene's hold, then the final count until the next goal empties the glass.
    """

    float_topics = (SCALE_TOPIC,)

    scene: ArmPouringAdapter

    def __init__(self, bottle_volume: float, liquid_seed: int) -> None:
        scene = ArmPouringAdapter(bottle_volume, liquid_seed=liquid_seed)
        super().__init__(scene, np.asarray(scene.home, dtype=float))
        self.reading, self.curve, self.states = 0.0, (np.zeros(1), np.zeros(1)), 0

    def new_goal(self) -> None:
        super().new_goal()
        self.reading, self.curve = 0.0, (np.zeros(1), np.zeros(1))

    def sense(self, node: RobotNode, now: float, t: float | None) -> None:
        self.states += 1
        if t is not None:
            times, volumes = self.curve
            self.reading = float(volumes[max(0, int(np.searchsorted(times, t, side="right")) - 1)])
        if self.states % SCALE_EVERY == 0:
            node.publish_signal(SCALE_TOPIC, self.reading, now)

    def started(self, outcome: Outcome) -> None:
        """The poured volume over the motion, to read out as it is played back."""
        self.curve = (np.asarray(outcome.signals["poured_volume_time"]),
                      np.asarray(outcome.signals["poured_volume_curve"]))

    @property
    def rest(self) -> float:
        """The scene's hold: the liquid settles before the scale shows the count."""
        return self.scene.liquid.hold

    def measured(self, node: RobotNode, clock: _Clock, outcome: Outcome) -> None:
        """The scale shows the settled count."""
        self.reading = float(outcome.signals["poured_volume"])


def serve(task: str, domain_id: int | None = None, *, speed: float = 1.0, stop: threading.Event | None = None,
          on_ready: Callable[[], None] | None = None, loopback_only: bool = False,
          bottle_volume: float = 0.5, liquid_seed: int = 0) -> int:
    """Serves ``task``'s arm (one of :data:`TASKS`) on ``domain_id`` (default: ``ROS_DOMAIN_ID``'s,
    else 0) until ``stop`` is set;
    returns the goals and topic trajectories served. ``bottle_volume`` (l) and ``liquid_seed`` are
    the pouring robot's bottle and liquid (the in-process adapter's options).

    A goal the scene refuses (its start away from home, a limit broken) ends as INVALID_GOAL with
    the scene's reason; a thrown ball that never lands ends as succeeded without a landing point
    (the arm did move; the camera saw nothing), which the client reports as an error.
    """
    if task == "arm-throwing":
        robot: _Robot = _Throwing()
    elif task == "arm-pouring":
        robot = _Pouring(bottle_volume, liquid_seed)
    else:
        raise InvalidInputError(f"task = {task!r} cannot be served: use one of {', '.join(TASKS)}")
    stop = stop or threading.Event()
    node = RobotNode(names.domain_id(domain_id), CONTROLLER.strip("/"), list(robot.scene.spec.dof_names),
                     float_signals=list(robot.float_topics), point_signals=list(robot.point_topics),
                     loopback_only=loopback_only)
    clock, period = _Clock(node), 1.0 / STATE_RATE
    incoming = _Incoming(node)
    served = 0
    try:
        with robot.scene:
            if on_ready is not None:
                on_ready()
            while not stop.is_set():
                now = clock.tick(period)
                node.publish_joint_state(now, robot.home)
                robot.sense(node, now, None)
                incoming.poll(now)
                if incoming.due(now):
                    served += 1
                    _run(node, clock, robot, incoming.take(), None, speed, stop, incoming)
                    continue
                goal = node.poll_goal(period / speed)
                if goal is None:
                    continue
                served += 1
                try:
                    _run(node, clock, robot, goal.trajectory, goal.id, speed, stop, incoming)
                finally:
                    incoming.canceled.discard(goal.id)
    finally:
        node.shutdown()
    return served


#: why a goal's motion stopped before its end (besides ``stop``)
_CANCELED, _REPLACED = "canceled", "replaced"
_REPLACED_TEXT = f"replaced by a trajectory on {CONTROLLER}/joint_trajectory"


def _interrupted(incoming: _Incoming, clock: _Clock, goal_id: bytes | None, stop: threading.Event) -> str | None:
    """Why the motion being simulated or played back must stop now, or None."""
    incoming.poll(clock.now)
    if stop.is_set() or (goal_id is not None and goal_id in incoming.canceled):
        return _CANCELED
    return _REPLACED if incoming.due(clock.now) else None


def _simulate(node: RobotNode, clock: _Clock, robot: _Robot, command: Trajectory, goal_id: bytes | None,
              stop: threading.Event, incoming: _Incoming) -> Outcome | str:
    """The scene's outcome of ``command``, computed in a worker while ``/joint_states`` repeats
    the standing pose at the stopped clock; why it stopped if it was canceled or replaced meanwhile.
    """
    result: list[Outcome] = []
    worker = threading.Thread(target=lambda: result.append(robot.scene.execute(command)), daemon=True)
    worker.start()
    why = None
    while worker.is_alive():
        node.publish_joint_state(clock.now, robot.home)
        if why is None:
            why = _interrupted(incoming, clock, goal_id, stop)
            if why is not None:
                robot.scene.stop()
        worker.join(1.0 / STATE_RATE)
    return why if why is not None else result[0]


def _end(node: RobotNode, goal_id: bytes | None, why: str) -> None:
    """Ends a goal whose motion stopped early (a topic trajectory has no one to tell)."""
    if goal_id is None:
        return
    if why == _CANCELED:
        node.finish_goal(goal_id, messages.GoalStatus.STATUS_CANCELED)
    else:
        node.finish_goal(goal_id, messages.GoalStatus.STATUS_ABORTED, _RESULT.SUCCESSFUL, _REPLACED_TEXT)


def _run(node: RobotNode, clock: _Clock, robot: _Robot, tr: Any, goal_id: bytes | None, speed: float,
         stop: threading.Event, incoming: _Incoming) -> None:
    """Simulates one goal (``goal_id``) or topic trajectory (None) and plays it back: joint
    states, the sensors, the goal's result.
    """
    incoming.poll(clock.now)
    if goal_id is not None and goal_id in incoming.canceled:
        # canceled while it waited for the goal before it: it never moves
        node.finish_goal(goal_id, messages.GoalStatus.STATUS_CANCELED)
        return
    robot.new_goal()
    out = _simulate(node, clock, robot, Trajectory(tr.times, tr.positions, tr.velocities), goal_id, stop, incoming)
    if isinstance(out, str):
        _end(node, goal_id, out)
        return
    if out.status is Status.REJECTED:
        if goal_id is not None:
            node.finish_goal(goal_id, messages.GoalStatus.STATUS_ABORTED, _RESULT.INVALID_GOAL, out.message)
        return
    if out.ok:
        robot.started(out)
    executed = out.executed
    if isinstance(executed, Trajectory):
        why = _play_back(node, clock, robot, executed, goal_id, speed, stop, incoming)
        if why is not None:
            _end(node, goal_id, why)
            return
    if goal_id is not None:
        node.finish_goal(goal_id, messages.GoalStatus.STATUS_SUCCEEDED)
    if out.ok:
        if isinstance(executed, Trajectory):
            _rest(node, clock, robot, executed, speed, stop)
        robot.measured(node, clock, out)


def _play_back(node: RobotNode, clock: _Clock, robot: _Robot, executed: Trajectory, goal_id: bytes | None,
               speed: float, stop: threading.Event, incoming: _Incoming) -> str | None:
    """The executed motion's joint states at :data:`STATE_RATE`, its last sample included;
    why it stopped if it was canceled or replaced meanwhile.
    """
    n = len(executed.t)
    step = max(1, round(1.0 / (STATE_RATE * float(np.median(np.diff(executed.t))))))
    samples = list(range(0, n, step))
    if samples[-1] != n - 1:
        samples.append(n - 1)
    start = time.monotonic()
    t0 = clock.now
    for k in samples:
        why = _interrupted(incoming, clock, goal_id, stop)
        if why is not None:
            return why
        t = float(executed.t[k] - executed.t[0])
        clock.now = t0 + t
        node.publish_clock(clock.now)
        node.publish_joint_state(clock.now, executed.y[k])
        robot.sense(node, clock.now, t)
        # paced at speed x real time, so that the client sees a motion, not a burst
        time.sleep(max(0.0, start + t / speed - time.monotonic()))
    return None


def _rest(node: RobotNode, clock: _Clock, robot: _Robot, executed: Trajectory, speed: float,
          stop: threading.Event) -> None:
    """The arm at rest at its last sample for ``robot.rest``, its sensors sampling."""
    last, t_end = executed.y[-1], float(executed.t[-1] - executed.t[0])
    period, start = 1.0 / STATE_RATE, time.monotonic()
    for k in range(1, round(robot.rest * STATE_RATE) + 1):
        if stop.is_set():
            break
        now = clock.tick(period)
        node.publish_joint_state(now, last)
        robot.sense(node, now, t_end + k * period)
        time.sleep(max(0.0, start + k * period / speed - time.monotonic()))
