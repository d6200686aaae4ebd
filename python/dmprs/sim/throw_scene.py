"""Throwing a ball into a basket with the arm of :mod:`dmprs.sim.arm_model`.

The scene is composed from the arm model's pieces: the same KUKA LBR iiwa 14 links, joints,
limits, masses and joint servo at 1 kHz (``arm_model.arm_bodies``, ``KP``, ``KV``,
``TORQUE_LIMITS``), standing on a pedestal ``PEDESTAL_HEIGHT`` above the floor (z = 0) and turned
by pi about z, so that the swing of A2, A4 and A6 that throws toward the arm's -x throws toward
the world's +x. Where the pouring scene holds a bottle, the flange holds a tight **cup** (a short
launch tube) with a **ball** in it; the cup's opening looks along the flange's -x (the bottle's
mouth axis of ``arm_model``), i.e. along the direction the swing moves the cup. Nothing grasps or releases the
ball: it rests in the cup while the cup accelerates and leaves it when the cup decelerates
faster than gravity pulls it back in.

Physics only; the task (:mod:`dmprs.tasks.arm_throwing`) validates the trajectory and scores.

* The **landing point** is where the ball first touches the floor: the (x, y) of its centre at the
  instant its height equals its radius, interpolated linearly within the 1 ms step in which it
  crossed (the ball is in free flight there, so the error of the interpolation is below
  ``g dt^2 / 8`` ~ 1 um in height).
* The **release** is the first step after the ball's last contact with the cup; the ball's state
  there is returned, so a test can compare the landing with the closed-form ballistic one (MuJoCo
  has no air drag unless the model asks for it, and this one does not).
* Contacts are frictionless (``condim`` 1, as the arm model's): the ball slides out of the cup
  without rolling, so it flies without spin.
"""

from __future__ import annotations

import functools
import itertools
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dmprs.errors import NumericalError
from dmprs.portable import norm
from dmprs.sim import arm_model as am

#: m: the pedestal the arm stands on (a table's height), so that the floor is open around it
PEDESTAL_HEIGHT = 0.75
#: m: half the side of the pedestal's square top
PEDESTAL_HALF = 0.15
#: m: the ball's radius and its mass (kg): a 40 mm rubber ball
BALL_RADIUS = 0.02
BALL_MASS = 0.05
#: m: the cup's inner radius and depth: 1 mm wider than the ball and one ball radius deep, a short
#: launch tube: the ball can only leave along the cup's axis. In a wide frictionless cup (35 mm)
#: the ball slid sideways after the base's turn and landings moved by up to 17 cm for a 3 mrad
#: change of the trajectory (measured, docs/throwing.md); in this one by ~1 cm.
CUP_RADIUS = 0.021
CUP_DEPTH = 0.02
#: s: settling of the ball in the cup at the home configuration before a throw
SETTLE_TIME = 0.3
#: s: the longest flight after the trajectory ends before the throw counts as a failure
MAX_FLIGHT = 3.0
#: physics steps (1 ms each) between stop/timeout checks
STOP_CHECK_EVERY = 10
#: the home configuration (rad): the arm leaning back, elbow and wrist bent so the cup opens up
HOME = (0.0, 0.4, 0.0, -0.6, 0.0, 0.55, 0.0)


def cup_geoms() -> list[str]:
    """The cup in the frame of ``arm_model``'s tool body: bottom on the flange axis ``BRACKET``
    beyond the flange (the tool body's z = -BOTTLE_LENGTH / 2), opening along the body's +z.
    """
    z0 = -am.BOTTLE_LENGTH / 2
    geoms = am.wall("cup", CUP_RADIUS, z0, CUP_RADIUS, z0 + CUP_DEPTH, rgba="0.8 0.3 0.2 1")
    geoms.append(f'<geom name="cup_bottom" class="container" type="cylinder" '
                 f'size="{CUP_RADIUS + 2 * am.WALL:.9g} {am.WALL}" pos="0 0 {z0 - am.WALL:.9g}" rgba="0.8 0.3 0.2 1"/>')
    return geoms


def throw_xml() -> str:
    """The throwing scene as an MJCF string: floor, pedestal, arm with cup, ball (placed at the
    origin: :func:`settled_ball` puts it in the cup).
    """
    h, p = PEDESTAL_HEIGHT, PEDESTAL_HALF
    return f"""{am.header("dmprs arm throwing", condim=1)}
<worldbody>
<light pos="1 -1 3" dir="0 0.3 -1"/>
<geom name="floor" type="plane" size="5 5 0.1" contype="1" conaffinity="1" rgba="0.3 0.3 0.3 1"/>
<geom name="pedestal" type="box" size="{p} {p} {h / 2:.9g}" pos="0 0 {h / 2:.9g}" contype="1" conaffinity="1"
      rgba="0.55 0.4 0.3 1"/>
<body name="mount" pos="0 0 {h:.9g}" quat="0 0 0 1">
<geom name="base" type="cylinder" size="0.09 {am.LINK_OFFSETS[0] / 2:.9g}" pos="0 0 {am.LINK_OFFSETS[0] / 2:.9g}"
      contype="0" conaffinity="0" rgba="0.9 0.9 0.9 1"/>
{am.arm_bodies(cup_geoms())}
</body>
<body name="ball" pos="0 0 {BALL_RADIUS}">
<freejoint name="ball"/>
<geom name="ball" type="sphere" size="{BALL_RADIUS}" mass="{BALL_MASS}" contype="1" conaffinity="1"
      rgba="0.95 0.8 0.1 1"/>
</body>
</worldbody>
{am.FOOTER}"""


@functools.lru_cache(maxsize=1)
def model() -> Any:
    """The compiled ``mujoco.MjModel`` of :func:`throw_xml` (shared: MjModel is read-only here)."""
    import mujoco

    return mujoco.MjModel.from_xml_string(throw_xml())


def _cup_geoms(m: Any) -> frozenset[int]:
    return frozenset(g for g in range(m.ngeom) if m.geom(g).name.startswith("cup"))


@functools.lru_cache(maxsize=1)
def settled_ball() -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(qpos, qvel) of the scene at :data:`HOME` with the ball settled in the cup for
    :data:`SETTLE_TIME` s (read-only); raises NumericalError if it is not in the cup then.
    """
    import mujoco

    m = model()
    d = mujoco.MjData(m)
    d.qpos[:7] = HOME
    mujoco.mj_kinematics(m, d)
    tool = m.body("bottle").id
    axis = d.xmat[tool].reshape(3, 3)[:, 2]  # the cup's opening
    bottom = d.xpos[tool] + axis * (-am.BOTTLE_LENGTH / 2)
    d.qpos[7:10] = bottom + axis * (BALL_RADIUS + 0.002)
    d.qpos[10:14] = (1.0, 0.0, 0.0, 0.0)
    d.ctrl[:] = HOME
    for _ in range(round(SETTLE_TIME / am.TIMESTEP)):
        mujoco.mj_step(m, d)
    am.check_health(mujoco, d, SETTLE_TIME)
    cups = _cup_geoms(m)
    if not any(int(g) in cups for g in d.contact.geom[: d.ncon].ravel()):
        raise NumericalError(f"the ball is not in the cup after settling: at {d.qpos[7:10].round(3).tolist()} m")
    qpos, qvel = d.qpos.copy(), d.qvel.copy()
    qpos.setflags(write=False)
    qvel.setflags(write=False)
    return qpos, qvel


@dataclass(frozen=True)
class Reach:
    """Where a throw can land: between ``low`` and ``high`` m from the base's axis (x = y = 0).

    ``low``: the pedestal's footprint (a ball landing closer would be inside it). ``high``: an
    upper bound from the physics: the ball's speed is at most ``release_speed`` = sum over the
    joints of (velocity limit x the longest the chain from that joint to the ball can be; the
    distances between consecutive joint anchors are fixed by the links), it is released at most
    ``release_height`` m up (the first anchor's height plus the whole chain) and at most the
    chain's length from the axis, and flies without drag: the farthest a projectile gets from
    height h at speed v is ``(v / g) sqrt(v^2 + 2 g h)``.
    """

    low: float
    high: float
    release_speed: float
    release_height: float


@functools.lru_cache(maxsize=1)
def reach() -> Reach:
    """The :class:`Reach` of this scene's arm, from its model (computed once)."""
    import mujoco

    m = model()
    d = mujoco.MjData(m)
    d.qpos[:] = settled_ball()[0]
    mujoco.mj_kinematics(m, d)
    points = [d.xanchor[m.joint(j).id].copy() for j in am.JOINT_NAMES] + [d.qpos[7:10].copy()]
    links = [norm(b - a) for a, b in itertools.pairwise(points)]
    chain = [sum(links[j:]) for j in range(7)]  # the longest joint j -> ball can be
    speed = sum(w * r for w, r in zip(am.VELOCITY_LIMITS, chain, strict=True))
    height = float(points[0][2]) + chain[0]
    g = -float(m.opt.gravity[2])
    return Reach(PEDESTAL_HALF + BALL_RADIUS, chain[0] + speed / g * math.sqrt(speed**2 + 2 * g * height),
                 speed, height)


@dataclass(frozen=True)
class ThrowResult:
    """What one throw did. ``landing`` (x, y; m) where the ball first touched the floor and
    ``landing_time`` (s from the trajectory's start), NaN if it did not land within
    :data:`MAX_FLIGHT` s after the trajectory; ``release_time`` (s), ``release_position`` and
    ``release_velocity`` (m, m/s) of the ball at the first step after its last contact with the
    cup (NaN if it never left); ``hit`` names what the ball touched, other than the cup, before
    the floor ("" if nothing); ``times``/``q``/``q_ref`` the executed and reference joint
    positions at every physics step while the trajectory ran.
    """

    landing: NDArray[np.float64]
    landing_time: float
    release_time: float
    release_position: NDArray[np.float64]
    release_velocity: NDArray[np.float64]
    hit: str
    times: NDArray[np.float64]
    q: NDArray[np.float64]
    q_ref: NDArray[np.float64]
    interrupted: bool = False

    @property
    def landed(self) -> bool:
        """Whether the ball came down (its landing point is finite)."""
        return bool(np.isfinite(self.landing).all())


def simulate_throw(t: NDArray[np.float64], q: NDArray[np.float64], qd: NDArray[np.float64],
                   should_stop: Callable[[], bool] | None = None) -> ThrowResult:
    """Follows the joint trajectory ``q`` (T, 7) with velocities ``qd`` at times ``t`` (its first
    sample must be :data:`HOME`: the ball is settled there) with the servo at 1 kHz, holds the
    last sample, and stops when the ball touches the floor (or :data:`MAX_FLIGHT` s after the
    end). The caller validates the trajectory; this function trusts it. ``should_stop()`` is
    asked every :data:`STOP_CHECK_EVERY` steps; when it says so the throw ends there, not landed
    (``interrupted``).
    """
    import mujoco

    m = model()
    d = mujoco.MjData(m)
    qpos0, qvel0 = settled_ball()
    d.qpos[:] = qpos0
    d.qvel[:] = qvel0
    mujoco.mj_forward(m, d)
    dt = am.TIMESTEP
    n_move = max(1, math.ceil((t[-1] - t[0]) / dt - 1e-9))
    times = np.arange(n_move + 1) * dt
    q_ref = np.stack([np.interp(t[0] + times, t, q[:, j]) for j in range(7)], axis=1)
    qd_ref = np.stack([np.interp(t[0] + times, t, qd[:, j]) for j in range(7)], axis=1)
    qd_ref[-1] = 0.0
    # q_c = q* + (kv / kp) qd*: the position actuator then is the PD on the reference (docs/arm.md)
    command = q_ref + qd_ref * (np.asarray(am.KV) / np.asarray(am.KP))
    executed = np.empty((n_move + 1, 7))
    executed[0] = d.qpos[:7]
    cups = _cup_geoms(m)
    ball_geom, floor_geom = m.geom("ball").id, m.geom("floor").id
    nan3 = np.full(3, np.nan)
    release = (math.nan, nan3, nan3)
    in_cup = True
    hit = ""
    prev = d.qpos[7:10].copy()
    n_total = n_move + round(MAX_FLIGHT / dt)
    for k in range(1, n_total + 1):
        d.ctrl[:] = command[min(k, n_move)]
        mujoco.mj_step(m, d)
        if k <= n_move:
            executed[k] = d.qpos[:7]
        pos = d.qpos[7:10]
        pairs = d.contact.geom[: d.ncon]
        touching = {int(g) for a, b in pairs for g in (a, b) if ball_geom in (a, b)} - {ball_geom}
        if touching & cups:  # (back) in the cup: a bounce inside it is not the release
            in_cup = True
            release = (math.nan, nan3, nan3)
        elif in_cup:
            in_cup = False
            release = (k * dt, pos.copy(), d.qvel[7:10].copy())
        if pos[2] <= BALL_RADIUS:
            f = (prev[2] - BALL_RADIUS) / (prev[2] - pos[2])  # the crossing within this step
            landing = prev[:2] + f * (pos[:2] - prev[:2])
            am.check_health(mujoco, d, k * dt)
            return ThrowResult(landing, (k - 1 + f) * dt, release[0], release[1], release[2], hit,
                               times, executed, q_ref)
        if not hit and touching - cups - {floor_geom}:
            hit = m.geom(min(touching - cups - {floor_geom})).name
        prev[:] = pos
        if k % 100 == 0:
            am.check_health(mujoco, d, k * dt)
        if should_stop is not None and k % STOP_CHECK_EVERY == 0 and should_stop():
            n = min(k, n_move)
            return ThrowResult(np.full(2, np.nan), math.nan, release[0], release[1], release[2], hit,
                               times[: n + 1], executed[: n + 1], q_ref[: n + 1], interrupted=True)
    am.check_health(mujoco, d, n_total * dt)
    return ThrowResult(np.full(2, np.nan), math.nan, release[0], release[1], release[2], hit, times, executed,
                       q_ref)
