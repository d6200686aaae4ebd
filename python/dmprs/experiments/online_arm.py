"""Online DMPs on the MuJoCo arm: a :class:`~dmprs.stepper.JointStepper` inside the 1 kHz servo
loop, one ``step(measured)`` per physics step with the measured joint positions fed back
(docs/method.md §2.5, docs/arm.md "A stepper in the servo loop"). Three scenarios, each against
its truth:

* :func:`held_pour`: the arm is held still by joint equality constraints for a while in the
  middle of a pour; with phase stopping (§2.5.2) the command waits for it, without it the
  command runs away and the arm jumps after it when released.
* :func:`moving_basket_throw`: the basket moves while the throw is on its way; the new landing
  point goes through the throwing experiment's generalizer and the new DMP's goal reaches the
  running stepper through ``set_goal`` (§2.5.3).
* :func:`velocity_limited_move`: a joint move that would exceed the iiwa's velocity limits runs
  through a stepper given ``velocity_max`` (temporal coupling, §2.5.4): slower, on the same path.

Needs the ``robot`` extra.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dmprs.dmp import DMP
from dmprs.errors import DmprsError, NumericalError
from dmprs.experiments import arm_throwing
from dmprs.portable import matvec_rows
from dmprs.sim import arm_model as am
from dmprs.sim import arm_scene, granular, throw_scene
from dmprs.stepper import JointStepper
from dmprs.tasks.arm_pouring import PARTICLE_VOLUME, ArmPouringAdapter, pour_poses
from dmprs.trajectory import Trajectory

#: the servo command q_c = q* + (kv / kp) qd* makes the position actuator the PD on the reference
#: (q*, qd*), so the arm does not lag a moving command (docs/arm.md)
_FEEDFORWARD = np.asarray(am.KV) / np.asarray(am.KP)
#: kernels of the joint DMPs (the pour's 4.2 s, as the pouring experiment's N = 40)
N_BASIS = 40
#: the pour: a 0.3 l bottle (150 spheres) tilted to its calibrated peak for 0.2 l (docs/arm.md,
#: "The experiment"), held still for HOLD s from HOLD_START s (mid-tilt)
POUR_VOLUME = 0.3
POUR_PEAK_TILT = 2.388
HOLD_START = 1.2
HOLD = 0.5
#: the hold's constraint: a 2 ms time constant (twice the step, the stiffest MuJoCo recommends, as
#: the contacts' arm_model.SOLREF_TIME) and an impedance near 1, so the servo's torque cannot drag it
_HOLD_SOFTNESS = f'solref="{am.SOLREF_TIME:g} 1" solimp="0.99 0.999 0.001"'
#: s the arm holds still after the movement's end, before the spheres are counted (the adapter's)
POUR_SETTLE = 0.5
#: the throw: from the basket BASKET to BASKET + BASKET_MOVE (m), moved MOVE_TIME s after the start
BASKET = (1.0, 0.0)
BASKET_MOVE = (0.0, 0.1)
MOVE_TIME = 0.3
#: the velocity-limited move: A1 and A7 turn by these (rad) with a minimum-jerk profile whose
#: peak speed is LIMIT_EXCESS times the iiwa's limit of each
FAST_MOVE = (0.8, 0.0, 0.0, 0.0, 0.0, 0.0, 1.5)
LIMIT_EXCESS = 1.5
#: the stepper's velocity_max as a fraction of the limit: the servo overshoots a command at the
#: limit slightly (docs/arm.md, "A stepper in the servo loop"), which this margin absorbs
SPEED_MARGIN = 0.99
#: s: the longest any run may last (a movement that never ends is an error)
MAX_TIME = 12.0


@dataclass(frozen=True)
class ServoRun:
    """What the servo loop did, at every physics step k (t = k dt, from 0): the stepper's
    ``command`` and ``command_velocity``, the measured joint positions ``q`` and velocities
    ``qd`` (before the step), the stepper's ``phase``; ``end_time`` when the movement ended (see
    :func:`run_servo`; NaN if it did not).
    """

    times: NDArray[np.float64]
    command: NDArray[np.float64]
    command_velocity: NDArray[np.float64]
    q: NDArray[np.float64]
    qd: NDArray[np.float64]
    phase: NDArray[np.float64]
    end_time: float

    @property
    def tracking_error(self) -> float:
        """The largest |q - command| of any joint (rad); the command is the one of the step before
        the measurement (it is what the servo was following).
        """
        return float(np.abs(self.q[1:] - self.command[:-1]).max())


class ServoStepper(Protocol):
    """What :func:`run_servo` drives: a :class:`~dmprs.stepper.JointStepper`, or anything with its
    period, phase, ``step(measured)`` giving the joint command and velocity first, and ``done``.
    """

    @property
    def dt(self) -> float:
        """The control period (s)."""

    @property
    def phase(self) -> float:
        """The phase of the movement that runs."""

    def step(self, measured: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64], Any]:
        """The next command ``(q, qd, ...)`` given the measured joint positions."""

    def done(self) -> bool:
        """Whether the movement has ended."""


def run_servo(model: Any, data: Any, stepper: ServoStepper, *, end_phase: float = 0.0, after_end: float = 0.0,
              before_step: Callable[[float], None] | None = None,
              stop: Callable[[], bool] | None = None, max_time: float = MAX_TIME) -> ServoRun:
    """Runs the servo loop from ``data``'s state: each physics step asks ``stepper.step`` for the
    command with the measured joint positions, commands it (with the velocity feed-forward) and
    steps MuJoCo. The movement ends when ``stepper.done()`` or its phase falls to
    ``end_phase`` (``exp(-alpha_x)`` is where the rollout ends, t = tau, whatever the clock did);
    the loop ends ``after_end`` s later, or when ``stop()`` (asked after each physics step) says so; raises NumericalError past ``max_time`` or if MuJoCo diverges.
    ``before_step(t)`` may change the scene (a hold, a moved basket) before the step at ``t``.
    """
    import mujoco

    dt = float(model.opt.timestep)
    if not math.isclose(stepper.dt, dt):
        raise DmprsError(f"the stepper's period {stepper.dt} s is not the physics step {dt} s")
    n_max = round(max_time / dt)
    times: NDArray[np.float64] = np.arange(n_max + 1, dtype=np.float64) * dt
    command, velocity = np.empty((n_max + 1, 7)), np.empty((n_max + 1, 7))
    q, qd, phase = np.empty((n_max + 1, 7)), np.empty((n_max + 1, 7)), np.empty(n_max + 1)
    end_time = math.nan
    for k in range(n_max + 1):
        t = times[k]
        if before_step is not None:
            before_step(t)
        q[k], qd[k] = data.qpos[:7], data.qvel[:7]
        phase[k] = stepper.phase
        y, yd, _ = stepper.step(q[k])  # phase stopping compares this with the last command
        command[k], velocity[k] = y, yd
        data.ctrl[:7] = y + _FEEDFORWARD * yd
        if math.isnan(end_time) and (stepper.done() or stepper.phase <= end_phase):
            end_time = t
        if t >= end_time + after_end - 1e-9:
            break
        mujoco.mj_step(model, data)
        if k % 100 == 0:
            _check_health(mujoco, data, t)
        if stop is not None and stop():
            break
    else:
        raise NumericalError(f"the movement did not end within {max_time:g} s")
    _check_health(mujoco, data, t)
    end = k + 1
    return ServoRun(times[:end], command[:end], velocity[:end], q[:end], qd[:end], phase[:end], end_time)


def _check_health(mujoco: Any, data: Any, when: float) -> None:
    if any(data.warning[w].number > 0 for w in range(len(data.warning))) or not np.isfinite(data.qpos).all():
        raise NumericalError(f"the simulation diverged at t = {when:.3f} s")


# --- a) the held pour ------------------------------------------------------------------------------


def pour_dmp(volume: float = POUR_VOLUME, peak_tilt: float = POUR_PEAK_TILT) -> DMP:
    """The scripted pour (:func:`~dmprs.tasks.arm_pouring.pour_poses`) as a joint DMP: the
    adapter's IK solution fitted with :data:`N_BASIS` kernels.
    """
    joints, _, _, problems = ArmPouringAdapter(volume).plan(pour_poses(peak_tilt))
    if problems or joints is None:
        raise DmprsError(f"the pour was refused: {'; '.join(problems)}")
    return DMP.fit(joints.t, joints.y, N_BASIS)


def _holdable(liquid: arm_scene.SettledLiquid) -> Any:
    """The liquid's scene with one inactive equality per arm joint (``q_j = c``; the hold sets c)."""
    import mujoco

    xml = arm_scene.liquid_xml(liquid.n, liquid.seed, liquid.solver)
    equalities = "".join(f'<joint name="hold_{j}" joint1="{j}" active="false" {_HOLD_SOFTNESS}/>' for j in am.JOINT_NAMES)
    return mujoco.MjModel.from_xml_string(xml.replace("</mujoco>", f"<equality>{equalities}</equality>\n</mujoco>"))


@dataclass(frozen=True)
class PourRun:
    """One pour through the stepper: the servo loop's record (``run``), the spheres in the glass
    at the end and their volume (l), and how far the held joints moved during the hold (rad,
    the largest of any joint; 0 without a hold).
    """

    run: ServoRun
    n_glass: int
    poured_volume: float
    hold_drift: float
    hold: tuple[float, float] | None

    @property
    def phase_kept(self) -> float:
        """The phase at the hold's end over the phase at its start (1: the clock stood still; an
        unheld clock keeps ``exp(-alpha_x duration / tau)``); NaN without a hold.
        """
        if self.hold is None:
            return math.nan
        k0, k1 = (round(t / (self.run.times[1] - self.run.times[0])) for t in (self.hold[0], sum(self.hold)))
        return float(self.run.phase[k1] / self.run.phase[k0])


def held_pour(dmp: DMP, *, alpha_e: float, hold: tuple[float, float] | None = (HOLD_START, HOLD),
              volume: float = POUR_VOLUME, liquid_seed: int = 0) -> PourRun:
    """Pours ``dmp`` (a joint DMP from the home configuration, e.g. :func:`pour_dmp`) through a
    stepper with phase-stopping gain ``alpha_e`` (0: off); ``hold = (start, duration)`` s holds
    every joint where it is by an equality constraint for that window, a physical hold the
    servo pushes against. The spheres are counted :data:`POUR_SETTLE` s after the movement's end
    (the phase of t = tau), as the adapter counts them after the trajectory's end.
    """
    import mujoco

    n = round(volume / PARTICLE_VOLUME)
    liquid = arm_scene.settled_liquid(n, liquid_seed)
    model = _holdable(liquid)
    data = mujoco.MjData(model)
    data.qpos[:], data.qvel[:] = liquid.qpos, liquid.qvel
    mujoco.mj_forward(model, data)
    held: list[NDArray[np.float64]] = []

    def before_step(t: float) -> None:
        if hold is None:
            return
        inside = hold[0] <= t + 1e-9 < hold[0] + hold[1]
        if inside and not data.eq_active[0]:
            model.eq_data[:7, 0] = data.qpos[:7]  # q_j = c_0: hold here
            data.eq_active[:7] = 1
        elif not inside and data.eq_active[0]:
            data.eq_active[:7] = 0
        if inside:
            held.append(data.qpos[:7].copy())

    stepper = dmp.stepper(model.opt.timestep, alpha_e=alpha_e)
    run = run_servo(model, data, stepper, end_phase=math.exp(-dmp.alpha_x), after_end=POUR_SETTLE,
                    before_step=before_step)
    n_glass = spheres_in_glass(model, data, n)
    drift = float(np.abs(np.array(held) - held[0]).max()) if held else 0.0
    return PourRun(run, n_glass, n_glass * PARTICLE_VOLUME, drift, hold)


def spheres_in_glass(model: Any, data: Any, n: int) -> int:
    """How many of the ``n`` spheres of the liquid scene's ``data`` are in the glass now."""
    import mujoco

    mujoco.mj_kinematics(model, data)
    return int(granular.in_glass(data.qpos[7:].reshape(n, 7)[:, :3]).sum())


# --- b) the moving basket --------------------------------------------------------------------------


@dataclass(frozen=True)
class ThrowRun:
    """One throw through the stepper: the servo loop's record and where the ball first touched
    the floor (x, y; m; NaN if it did not).
    """

    run: ServoRun
    landing: NDArray[np.float64]


def _throw(stepper: JointStepper, before_step: Callable[[float], None] | None = None) -> ThrowRun:
    import mujoco

    model = throw_scene.model()
    data = mujoco.MjData(model)
    data.qpos[:], data.qvel[:] = throw_scene.settled_ball()
    mujoco.mj_forward(model, data)
    prev = data.qpos[7:10].copy()
    landing = np.full(2, np.nan)

    def landed() -> bool:
        pos = data.qpos[7:10]
        if pos[2] <= throw_scene.BALL_RADIUS:  # the crossing within this step, as simulate_throw
            f = (prev[2] - throw_scene.BALL_RADIUS) / (prev[2] - pos[2])
            landing[:] = prev[:2] + f * (pos[:2] - prev[:2])
            return True
        prev[:] = pos
        return False

    run = run_servo(model, data, stepper, after_end=throw_scene.MAX_FLIGHT, before_step=before_step, stop=landed)
    return ThrowRun(run, landing)


@dataclass(frozen=True)
class BasketRun:
    """The moving-basket throw: the baskets before and after the move (m), the landing when the
    new goal reaches the stepper (``updated``), when it does not (``ignored``), and of the new
    basket's own DMP executed from the start (``planned``); the generalized goals (rad) and tau (s)
    before and after.
    """

    basket: NDArray[np.float64]
    moved: NDArray[np.float64]
    updated: ThrowRun
    ignored: ThrowRun
    planned: ThrowRun
    goals: tuple[NDArray[np.float64], NDArray[np.float64]]
    tau: tuple[float, float]


def moving_basket_throw(basket: ArrayLike = BASKET, move: ArrayLike = BASKET_MOVE, move_time: float = MOVE_TIME,
                        *, alpha_e: float = 0.0, generalizer: str = "linear") -> BasketRun:
    """Throws at ``basket`` (x, y; m) with the throwing experiment's generalized DMP; ``move_time``
    s after the start the basket moves by ``move``, the generalizer answers the new query, and
    the new DMP's goal (and tau, if it changed) go to the running stepper. ``alpha_e``: the phase
    stopping gain (a throw's speed is its outcome, so it is off by default).
    """
    old = np.asarray(basket, dtype=float)
    new = old + np.asarray(move, dtype=float)
    experiment = arm_throwing.setup(old, generalizer=generalizer)
    dmp_old, dmp_new = experiment.generalizer.predict(old), experiment.generalizer.predict(new)
    if not (isinstance(dmp_old, DMP) and isinstance(dmp_new, DMP)):
        raise DmprsError("the throwing generalizer returned a Cartesian DMP; expected joint DMPs")
    dt = throw_scene.model().opt.timestep

    def stepper(dmp: DMP) -> JointStepper:
        return dmp.stepper(dt, alpha_e=alpha_e)

    def updated() -> ThrowRun:
        s = stepper(dmp_old)

        def before_step(t: float) -> None:
            if abs(t - move_time) < dt / 2:
                # The goal filter (§2.5.3) moves the attractor smoothly; the weights stay the old
                # DMP's: the stepper keeps its forcing term, so only g (and tau) can change online.
                s.set_goal(dmp_new.goal)
                if dmp_new.tau != s.nominal_tau:
                    s.set_tau(dmp_new.tau)

        return _throw(s, before_step)

    return BasketRun(old, new, updated(), _throw(stepper(dmp_old)), _throw(stepper(dmp_new)),
                     (dmp_old.goal, dmp_new.goal), (dmp_old.tau, dmp_new.tau))


# --- c) the velocity limit -------------------------------------------------------------------------


def fast_move() -> Trajectory:
    """A minimum-jerk move of A1 and A7 (:data:`FAST_MOVE`) from the home configuration whose
    peak joint speeds are :data:`LIMIT_EXCESS` times the iiwa's velocity limits.
    """
    amp = np.asarray(FAST_MOVE)
    moving = amp != 0
    # min-jerk's peak speed is 1.875 amplitude / duration: the duration that gives the excess
    duration = float((1.875 * np.abs(amp[moving]) / (LIMIT_EXCESS * np.asarray(am.VELOCITY_LIMITS)[moving])).max())
    t = np.linspace(0.0, duration, round(duration / am.TIMESTEP) + 1)
    s = t / duration
    shape = 10 * s**3 - 15 * s**4 + 6 * s**5
    return Trajectory(t, np.asarray(arm_scene.home_configuration()) + np.outer(shape, amp))


@dataclass(frozen=True)
class LimitRun:
    """The velocity-limited move: the free run and the limited one, the limits (rad/s), and the
    DMP's nominal path (its rollout at the physics step, until rest).
    """

    free: ServoRun
    limited: ServoRun
    limits: NDArray[np.float64]
    nominal: NDArray[np.float64]
    alpha_x: float

    def speed_ratio(self, run: ServoRun, measured: bool = False) -> float:
        """The largest commanded (or measured) joint speed of ``run`` over its limit."""
        return float((np.abs(run.qd if measured else run.command_velocity) / self.limits).max())

    def duration(self, run: ServoRun) -> float:
        """When ``run``'s phase reached ``exp(-alpha_x)``, the nominal movement's end (t = tau)."""
        return float(run.times[np.argmax(run.phase <= math.exp(-self.alpha_x))])

    def deviation(self, run: ServoRun, measured: bool = False) -> float:
        """The largest distance (rad, joint space) of ``run``'s commands (or measured positions)
        from the DMP's nominal path.
        """
        return float(path_deviation(run.q if measured else run.command, self.nominal).max())


def velocity_limited_move(trajectory: Trajectory | None = None, *, alpha_e: float = 0.0) -> LimitRun:
    """Runs the DMP of ``trajectory`` (default :func:`fast_move`) on the arm without particles,
    once through a free stepper and once through one given the iiwa's velocity limits times
    :data:`SPEED_MARGIN` as ``velocity_max``; both run until the stepper is done.
    """
    import mujoco

    trajectory = fast_move() if trajectory is None else trajectory
    dmp = DMP.fit(trajectory.t, trajectory.y, N_BASIS)
    model = am.load()
    limits = np.asarray(am.VELOCITY_LIMITS)

    def run(**options: Any) -> ServoRun:
        data = mujoco.MjData(model)
        data.qpos[:7] = trajectory.y[0]
        data.ctrl[:7] = trajectory.y[0]
        mujoco.mj_forward(model, data)
        return run_servo(model, data, dmp.stepper(model.opt.timestep, alpha_e=alpha_e, **options))

    nominal = dmp.rollout(model.opt.timestep, until_rest=True).y
    return LimitRun(run(), run(velocity_max=SPEED_MARGIN * limits), limits, nominal, dmp.alpha_x)


def path_deviation(points: NDArray[np.float64], path: NDArray[np.float64], chunk: int = 512) -> NDArray[np.float64]:
    """The distance of each of ``points`` (K, D) to the polyline ``path`` (P, D): to the nearest
    point on any of its segments, resolved to about 1e-7 of the coordinates' scale (below that,
    rounding may pick a segment a few samples off the nearest).
    """
    a, ab = path[:-1], np.diff(path, axis=0)
    length2 = np.maximum((ab * ab).sum(axis=1), 1e-300)
    a2, a_ab = (a * a).sum(axis=1), (a * ab).sum(axis=1)
    out = np.empty(len(points))
    for i in range(0, len(points), chunk):
        p = points[i:i + chunk]
        # every point against every segment by matrix products (|p - a|^2 expanded), which loses
        # digits to cancellation; the nearest segment's distance is then recomputed directly
        along = matvec_rows(p, ab) - a_ab
        s = np.clip(along / length2, 0.0, 1.0)
        d2 = (p * p).sum(axis=1)[:, None] - 2 * matvec_rows(p, a) + a2 - 2 * s * along + s * s * length2
        best = np.argmin(d2, axis=1)
        dist = np.full(len(p), np.inf)
        for j in (np.maximum(best - 1, 0), best, np.minimum(best + 1, len(a) - 1)):  # its neighbours too
            sj = np.clip(((p - a[j]) * ab[j]).sum(axis=1) / length2[j], 0.0, 1.0)
            dist = np.minimum(dist, np.linalg.norm(p - (a[j] + sj[:, None] * ab[j]), axis=1))
        out[i:i + chunk] = dist
    return out
