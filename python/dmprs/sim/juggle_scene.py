"""Bouncing a ball on a paddle held by the arm of :mod:`dmprs.sim.arm_model` (paddle juggling,
Schaal, Sternad & Atkeson 1996): the rhythm of the paddle sets how high the ball flies.

The scene is composed from the arm model's pieces: the same KUKA LBR iiwa 14 links, joints,
limits, masses and joint servo (``arm_model.arm_bodies``, ``KP``, ``KV``, ``TORQUE_LIMITS``),
standing at the origin. Where the pouring scene holds a bottle, the flange holds a round
**paddle** whose face is the tool body's origin and whose normal is the tool body's z; at
:func:`home` it is level, face up, at :data:`PADDLE_HOME` (the arm's x-z plane,
:mod:`dmprs.sim.paddle_ik`). Physics only; the task (:mod:`dmprs.tasks.arm_juggling`) validates
the trajectory and scores.

* **The ball** is a 40 mm rubber ball on a vertical **slide joint** through the paddle's centre:
  the outcome asked for, the apex, is vertical, and an open-loop rhythm has no way to correct the
  sideways drift a free ball picks up from millirad tilts of a tracked paddle (a juggler corrects
  it by watching the ball). The joint's position is the height of the ball's lowest point above
  the paddle's face at rest, so an apex is read off it directly.
* **Restitution**: the ball meets only the paddle, through one explicit contact pair with
  MuJoCo's direct spring-damper reference (``solref = (-k, -b)``) and a constant impedance
  ``d`` (``solimp = (d, d, ...)``): the penetration then obeys ``r'' + d b r' + d k r = 0``, a
  damped oscillator of natural frequency ``sqrt(d k)`` and damping ratio
  ``zeta = b sqrt(d) / (2 sqrt(k))``, whose rebound speed is ``e = exp(-pi zeta / sqrt(1 -
  zeta^2))`` times the approach speed, both relative to the paddle (the coefficient of
  restitution). Contacts are frictionless (``condim`` 1), so the ball does not spin.
* **Sub-steps**: the contact lasts ``pi / sqrt(d k)`` = 5 ms; the physics runs at
  :data:`SUBSTEPS` steps per servo period so that an impact spans 20 steps (at the servo's 1 ms,
  its 5 steps gave rebounds scattered by +-0.07 in ``e`` with how the impact fell on the step
  grid, which kept the bouncing from settling). The servo's command changes once per 1 ms, as on
  the arm.
* **The start** (the hand): the ball is held above the paddle and released so that it meets the
  paddle in the first full-amplitude period of the commanded rhythm, ``phase`` rad after the
  paddle passes upward through its mid-height, from about the height that rhythm keeps it at
  (``g P^2 / 8`` above the mid-height, ``P`` the rhythm's period) plus ``height_offset``; the
  :class:`Drop` of a seed draws both, and the contact's damping ratio, so that seeds differ
  physically. Dropped at an arbitrary time the ball often lands while the paddle moves down and
  dies into chattering, an attractor of a sinusoidal paddle as stable as the bouncing.
* **The apex** of a flight is the highest the ball's lowest point gets between two contacts,
  above the paddle's face at rest (the joint's position); free flight under gravity, so a
  flight's apex is its takeoff height plus ``v^2 / 2 g`` to the integrator's error.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dmprs.portable import exp
from dmprs.sim import arm_model as am
from dmprs.sim.paddle_ik import level_paddle_joints

#: m: the paddle's centre at home, (x, z) in the arm's x-z plane (the base at the origin)
PADDLE_HOME = (0.76, 0.55)
#: m: the paddle's radius and half thickness; kg: its mass (a wooden paddle)
PADDLE_RADIUS = 0.1
PADDLE_HALF_THICKNESS = 0.005
PADDLE_MASS = 0.3
#: m, kg: a 40 mm rubber ball
BALL_RADIUS = 0.02
BALL_MASS = 0.05
#: 1/s^2: the contact's stiffness k (an acceleration per metre of penetration)
CONTACT_STIFFNESS = 4.0e5
#: the contact's impedance d, constant over the penetration
CONTACT_IMPEDANCE = 0.99
#: the contact's damping ratio by default: e = exp(-pi zeta / sqrt(1 - zeta^2)) = 0.70, a rubber
#: ball on wood
DAMPING_RATIO = 0.1128
#: physics steps per servo period (1 ms): see the module's docs
SUBSTEPS = 4
#: s: the physics step
TIMESTEP = am.TIMESTEP / SUBSTEPS
#: a swing of the commanded paddle counts as full amplitude above this fraction of the largest
FULL_SWING = 0.95
#: m: a commanded paddle swinging less than this is not a rhythm the hand drops the ball into
MIN_SWING = 0.005
#: physics steps between stop/timeout/health checks
STOP_CHECK_EVERY = 40


@functools.lru_cache(maxsize=1)
def home() -> tuple[float, ...]:
    """The home configuration (rad): the paddle level at :data:`PADDLE_HOME`."""
    return tuple(float(v) for v in level_paddle_joints(*PADDLE_HOME))


def restitution(damping_ratio: float) -> float:
    """The coefficient of restitution of the contact with damping ratio ``zeta``:
    ``exp(-pi zeta / sqrt(1 - zeta^2))`` (the damped oscillator's rebound, module docs).
    """
    z = float(damping_ratio)
    return float(exp(-math.pi * z / math.sqrt(1.0 - z * z)))


def paddle_geoms() -> list[str]:
    """The paddle in the tool body's frame: a disc whose face is the body's origin, normal +z."""
    return [(f'<geom name="paddle" type="cylinder" size="{PADDLE_RADIUS} {PADDLE_HALF_THICKNESS}" '
             f'pos="0 0 {-PADDLE_HALF_THICKNESS}" mass="{PADDLE_MASS}" contype="0" conaffinity="0" '
             'rgba="0.6 0.4 0.2 1"/>')]


def juggle_xml(damping_ratio: float = DAMPING_RATIO) -> str:
    """The juggling scene as an MJCF string: floor, arm with paddle, the ball on its slide joint
    resting on the paddle's face at home, and the ball-paddle contact of ``damping_ratio``.
    """
    x, z = PADDLE_HOME
    k, d = CONTACT_STIFFNESS, CONTACT_IMPEDANCE
    b = 2.0 * float(damping_ratio) * math.sqrt(k / d)  # zeta = b sqrt(d) / (2 sqrt(k))
    return f"""{am.header("dmprs arm juggling", condim=1, timestep=TIMESTEP)}
<worldbody>
<light pos="1 -1 3" dir="0 0.3 -1"/>
<geom name="floor" type="plane" size="3 3 0.1" contype="0" conaffinity="0" rgba="0.3 0.3 0.3 1"/>
<geom name="base" type="cylinder" size="0.09 {am.LINK_OFFSETS[0] / 2:.9g}" pos="0 0 {am.LINK_OFFSETS[0] / 2:.9g}"
      contype="0" conaffinity="0" rgba="0.9 0.9 0.9 1"/>
{am.arm_bodies(paddle_geoms())}
<body name="ball" pos="{x} 0 {z + BALL_RADIUS}">
<joint name="ball" type="slide" axis="0 0 1"/>
<geom name="ball" type="sphere" size="{BALL_RADIUS}" mass="{BALL_MASS}" contype="0" conaffinity="0"
      rgba="0.95 0.8 0.1 1"/>
</body>
</worldbody>
<contact>
<pair geom1="ball" geom2="paddle" condim="1" solref="{-k:.17g} {-b:.17g}" solimp="{d} {d} 0.001"/>
</contact>
{am.FOOTER}"""


@functools.lru_cache(maxsize=8)
def model(damping_ratio: float = DAMPING_RATIO) -> Any:
    """The compiled ``mujoco.MjModel`` of :func:`juggle_xml` (shared: read-only here)."""
    import mujoco

    return mujoco.MjModel.from_xml_string(juggle_xml(damping_ratio))


def gravity() -> float:
    """g (m/s^2) of the scene."""
    return -float(model().opt.gravity[2])


def paddle_heights(q: NDArray[np.float64]) -> NDArray[np.float64]:
    """The height (m) of the paddle's centre above its height at home, for each row of ``q``
    (T, 7), by the model's forward kinematics.
    """
    import mujoco

    m = model()
    d = mujoco.MjData(m)
    site = m.site("mouth").id
    out = np.empty(len(q))
    for i, row in enumerate(q):
        d.qpos[:7] = row
        mujoco.mj_kinematics(m, d)
        out[i] = d.site_xpos[site][2]
    return out - PADDLE_HOME[1]


@dataclass(frozen=True)
class Drop:
    """How the hand starts the ball: ``phase`` (rad) after the paddle's upward mid-height crossing
    at which the ball meets it, ``height_offset`` (m) added to the height the rhythm keeps it at,
    and the contact's ``damping_ratio``.
    """

    phase: float = 0.6
    height_offset: float = 0.0
    damping_ratio: float = DAMPING_RATIO

    @classmethod
    def of_seed(cls, seed: int) -> Drop:
        """A drop drawn from ``seed``: phase uniform in [0.4, 0.8] rad, height offset in +-3 cm,
        damping ratio in +-0.01 of :data:`DAMPING_RATIO` (restitution 0.68-0.72).
        """
        rng = np.random.default_rng(seed)
        phase, offset, zeta = rng.uniform(-1.0, 1.0, 3)
        return cls(0.6 + 0.2 * float(phase), 0.03 * float(offset), DAMPING_RATIO + 0.01 * float(zeta))


@dataclass(frozen=True)
class Rhythm:
    """The commanded paddle's rhythm as the hand sees it: the full-amplitude swings from ``start``
    to ``end`` (s), their ``period`` (s) and ``amplitude`` (m, half a swing), and the first full
    upward swing from ``rise_low`` to ``rise_high`` (s) at heights ``z_low``, ``z_high`` (m).
    """

    start: float
    end: float
    period: float
    amplitude: float
    rise_low: float
    rise_high: float
    z_low: float
    z_high: float


def rhythm_of(t: NDArray[np.float64], z: NDArray[np.float64]) -> Rhythm | None:
    """The :class:`Rhythm` of paddle heights ``z`` (m) at times ``t`` (s): swings between turning
    points of the height, the full ones at least :data:`FULL_SWING` of the largest; None if the
    largest is below :data:`MIN_SWING` or there is no full upward swing.
    """
    dz = np.diff(z)
    turns = np.flatnonzero(dz[1:] * dz[:-1] < 0) + 1
    if len(turns) < 3:
        return None
    swings = np.diff(z[turns])
    size = np.abs(swings)
    if size.max() < MIN_SWING:
        return None
    full = np.flatnonzero(size >= FULL_SWING * size.max())
    ups = [i for i in full if swings[i] > 0]
    if not ups:
        return None
    i = ups[0]
    half = np.diff(t[turns])[full]
    return Rhythm(float(t[turns[full[0]]]), float(t[turns[full[-1] + 1]]), 2.0 * float(half.mean()),
                  float(size[full].mean()) / 2.0, float(t[turns[i]]), float(t[turns[i + 1]]),
                  float(z[turns[i]]), float(z[turns[i + 1]]))


@dataclass(frozen=True)
class Release:
    """The ball is held ``height`` m above the paddle's face at rest until ``time`` s."""

    time: float
    height: float


def plan_release(t: NDArray[np.float64], z: NDArray[np.float64], rhythm: Rhythm, drop: Drop) -> Release:
    """Where and when the hand lets go (module docs): the ball meets the commanded paddle
    (heights ``z`` at ``t``) ``drop.phase`` rad after its upward mid-height crossing in
    ``rhythm``'s first full upward swing, falling from ``g P^2 / 8 + drop.height_offset`` above
    the swing's middle.
    """
    g = gravity()
    half = rhythm.rise_high - rhythm.rise_low
    arrive = rhythm.rise_low + half * (0.5 + drop.phase / math.pi)
    middle = (rhythm.z_low + rhythm.z_high) / 2.0
    height = middle + g * rhythm.period * rhythm.period / 8.0 + drop.height_offset
    fall = height - float(np.interp(arrive, t, z))
    return Release(arrive - math.sqrt(2.0 * fall / g), height)


@dataclass(frozen=True)
class JuggleResult:
    """What one run did. Per completed flight (from a takeoff off the paddle to the next contact):
    ``takeoff_time`` (s), ``takeoff_height`` (m), ``takeoff_velocity`` (m/s, upward), ``apex``
    (m, the highest the ball's lowest point got, above the paddle's face at rest),
    ``landing_time`` (s) and ``landing_height`` (m, at the first step of the next contact). ``release``: when and from where the ball was let go; ``fell``: whether
    the ball dropped below the paddle's reach; ``times``/``q``/``q_ref``/``ball``: the executed
    and reference joints and the ball's height at every servo period.
    """

    takeoff_time: NDArray[np.float64]
    takeoff_height: NDArray[np.float64]
    takeoff_velocity: NDArray[np.float64]
    apex: NDArray[np.float64]
    landing_time: NDArray[np.float64]
    landing_height: NDArray[np.float64]
    release: Release
    fell: bool
    times: NDArray[np.float64]
    q: NDArray[np.float64]
    q_ref: NDArray[np.float64]
    ball: NDArray[np.float64]
    interrupted: bool = False


def simulate_juggle(t: NDArray[np.float64], q: NDArray[np.float64], qd: NDArray[np.float64], release: Release,
                    damping_ratio: float = DAMPING_RATIO,
                    should_stop: Callable[[], bool] | None = None) -> JuggleResult:
    """Follows the joint trajectory ``q`` (T, 7) with velocities ``qd`` at times ``t`` (its first
    sample must be :func:`home`) with the servo, the ball held at ``release.height`` until
    ``release.time``, and records every flight. The caller validates the trajectory; this
    function trusts it. ``should_stop()`` is asked every :data:`STOP_CHECK_EVERY` physics steps;
    when it says so the run ends there (``interrupted``).
    """
    import mujoco

    m = model(damping_ratio)
    d = mujoco.MjData(m)
    d.qpos[:7] = q[0]
    d.qpos[7] = release.height
    d.ctrl[:] = q[0]
    mujoco.mj_forward(m, d)
    dt = am.TIMESTEP
    n_move = max(1, math.ceil((t[-1] - t[0]) / dt - 1e-9))
    times = np.arange(n_move + 1) * dt
    q_ref = np.stack([np.interp(t[0] + times, t, q[:, j]) for j in range(7)], axis=1)
    qd_ref = np.stack([np.interp(t[0] + times, t, qd[:, j]) for j in range(7)], axis=1)
    # q_c = q* + (kv / kp) qd*: the position actuator then is the PD on the reference (docs/arm.md)
    command = q_ref + qd_ref * (np.asarray(am.KV) / np.asarray(am.KP))
    executed = np.empty((n_move + 1, 7))
    executed[0] = d.qpos[:7]
    ball = np.empty(n_move + 1)
    ball[0] = release.height
    flights: list[tuple[float, ...]] = []
    takeoff: tuple[float, float, float] | None = None
    apex = -math.inf
    touching = False  # held, then falling: a flight begins when it leaves the paddle
    held = True
    fell = False
    step = 0
    for k in range(1, n_move + 1):
        d.ctrl[:] = command[k]
        for _ in range(SUBSTEPS):
            now = step * TIMESTEP
            if held and now < release.time:
                d.qpos[7] = release.height
                d.qvel[7] = 0.0
            else:
                held = False
            mujoco.mj_step(m, d)
            step += 1
            z = float(d.qpos[7])
            contact = d.ncon > 0
            if contact and takeoff is not None:
                flights.append((*takeoff, apex, step * TIMESTEP, z))
                takeoff = None
            elif not contact and touching:
                takeoff = (step * TIMESTEP, z, float(d.qvel[7]))
                apex = z
            if takeoff is not None and z > apex:
                apex = z
            touching = contact
            if step % STOP_CHECK_EVERY == 0:
                am.check_health(mujoco, d, step * TIMESTEP)
                if should_stop is not None and should_stop():
                    return _result(flights, release, fell, times[:k + 1], executed[:k], q_ref[:k + 1],
                                   ball[:k], interrupted=True)
        executed[k] = d.qpos[:7]
        ball[k] = d.qpos[7]
        if ball[k] < -PADDLE_RADIUS:  # below the paddle's face by more than its size: it missed
            fell = True
            return _result(flights, release, fell, times[:k + 1], executed[:k + 1], q_ref[:k + 1], ball[:k + 1])
    am.check_health(mujoco, d, step * TIMESTEP)
    return _result(flights, release, fell, times, executed, q_ref, ball)


def _result(flights: list[tuple[float, ...]], release: Release, fell: bool,
            times: NDArray[np.float64], q: NDArray[np.float64], q_ref: NDArray[np.float64],
            ball: NDArray[np.float64], interrupted: bool = False) -> JuggleResult:
    cols = np.array(flights, dtype=float).reshape(-1, 6).T.copy()
    n = min(len(times), len(q))
    return JuggleResult(cols[0], cols[1], cols[2], cols[3], cols[4], cols[5], release, fell, times[:n], q[:n],
                        q_ref[:n], ball[:n], interrupted)
