"""The arm reaches, pours and returns without stopping: three Cartesian DMPs joined as one
:class:`dmprs.Sequence` (docs/method.md §2.9), its stepper inside the MuJoCo arm's 1 kHz servo
loop through the arm's inverse kinematics, with the granular liquid in the bottle (docs/arm.md,
"Reach, pour and return as one sequence").

The demonstration is the scripted pour of :mod:`dmprs.experiments.online_arm` (its bottle and
calibrated peak tilt) with the way back home and its phases overlapping
(:func:`~dmprs.tasks.arm_pouring.pour_and_return_poses`), cut in the middle of each overlap, where
the mouth moves and the bottle turns, into the reach, the pour (tilt, hold, tilt back) and the
return. The reach and the pour end moving: each is fitted with the demonstration's velocity at
its cut as its final velocity (§2.8), so that it hands over in motion; the return ends at rest.

Beside it, :func:`pour` runs the same movements one after another, each ending at rest (the
demonstration's phases without overlap, cut where they rest, each a DMP without a final
velocity): each starts from rest where the one before arrived when its phase has run out.

Needs the ``robot`` extra.
"""

from __future__ import annotations

import math
from collections.abc import Sequence as Sequential
from dataclasses import dataclass
from itertools import pairwise
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dmprs.cartesian import CartesianDMP
from dmprs.errors import DmprsError, InvalidInputError
from dmprs.experiments import online_arm as oa
from dmprs.portable import norms
from dmprs.sequence import Sequence
from dmprs.sim import arm_model as am
from dmprs.sim import arm_scene
from dmprs.sim.arm_ik import ArmKinematics
from dmprs.tasks.arm_pouring import PARTICLE_VOLUME, pour_and_return_cuts, pour_and_return_poses
from dmprs.tasks.arm_pouring.adapter import REACH_ORIENTATION_TOL, REACH_POSITION_TOL
from dmprs.trajectory import CartesianTrajectory

#: s the phases of the sequence's demonstration overlap: the cuts fall in the middle of each
#: overlap, where the mouth moves and the bottle turns at once. Longer overlaps join faster
#: movements, but the pour's moving orientation goal starts tau |omega_g| away from the bottle,
#: which must stay within a full turn (docs/cartesian.md, "A final velocity")
OVERLAP = 0.4
#: the executions :func:`pour` knows: the sequence, and the same movements each ending at rest
EXECUTIONS = ("sequence", "stops")
#: below both of these (m/s, rad/s) the commanded mouth counts as still
STILL = (1e-3, 1e-2)


def pieces(overlap: float = OVERLAP, peak_tilt: float = oa.POUR_PEAK_TILT) -> list[CartesianDMP]:
    """The reach, the pour and the return of :func:`pour_and_return_poses` (``overlap``), cut at
    :func:`pour_and_return_cuts`, each fitted as a :class:`~dmprs.CartesianDMP` with
    :data:`~dmprs.experiments.online_arm.N_BASIS` kernels; with an overlap the reach and the pour
    end moving, with the demonstration's velocity as their final velocity.
    """
    demo = pour_and_return_poses(peak_tilt, overlap)
    step = float(demo.t[1] - demo.t[0])
    cuts = [0, *(round(c / step) for c in pour_and_return_cuts(overlap)), demo.n_samples - 1]
    moving = overlap > 0
    return [CartesianDMP.fit(demo.t[a:b + 1] - demo.t[a], demo.pose[a:b + 1], oa.N_BASIS,
                             final_velocity="demo" if moving and k < 2 else None)
            for k, (a, b) in enumerate(pairwise(cuts))]


class IKStepper:
    """Joint commands from Cartesian steppers, one servo period at a time: each pose command goes
    through the arm's IK (:meth:`~dmprs.sim.arm_ik.ArmKinematics.follow`, from the last
    command's joints) and its twist through the IK's velocity form
    (:meth:`~dmprs.sim.arm_ik.ArmKinematics.joint_velocity`), with the surface
    :func:`~dmprs.experiments.online_arm.run_servo` drives (``dt``, ``phase``, ``step``,
    ``done``).

    ``stages`` run one after another: each (a CartesianStepper or a CartesianSequenceStepper)
    until its last movement's phase has run out (``exp(-alpha_x)``, its t = tau), the next from
    rest at the pose the last command reached. Open loop: the measured joints are not fed back,
    so the pose commands are the stages' rollouts. A pose the IK cannot reach, or a joint command
    beyond the arm's position or velocity limits, raises DmprsError.

    Records every command: ``pose`` (K, 7), ``velocity`` and ``acceleration`` (K, 6, linear then
    angular, world frame) and ``movement`` (K,), which movement gave it (counted over the stages).
    """

    def __init__(self, stages: Sequential[Any], movements: Sequential[int], alpha_x: float,
                 kinematics: ArmKinematics, start: NDArray[np.float64]) -> None:
        if len(stages) != len(movements) or not stages:
            raise InvalidInputError(f"{len(stages)} stages for {len(movements)} movement counts")
        self._stages, self._movements = list(stages), list(movements)
        self._end_phase = math.exp(-alpha_x)
        self._kin = kinematics
        self._q = np.array(start, dtype=float)
        self._stage = 0
        self.pose: list[NDArray[np.float64]] = []
        self.velocity: list[NDArray[np.float64]] = []
        self.acceleration: list[NDArray[np.float64]] = []
        self.movement: list[int] = []

    @property
    def dt(self) -> float:
        """The control period (s), the stages'."""
        return float(self._stages[0].dt)

    @property
    def phase(self) -> float:
        """The phase of the movement that runs."""
        return float(self._stages[self._stage].phase)

    def _ran_out(self) -> bool:
        stepper = self._stages[self._stage]
        last = getattr(stepper, "active", 0) == self._movements[self._stage] - 1
        return bool(last and stepper.phase <= self._end_phase)

    def done(self) -> bool:
        """Whether the last stage's last movement has run its tau."""
        return self._stage == len(self._stages) - 1 and self._ran_out()

    def step(self, measured: NDArray[np.float64] | None = None) -> tuple[NDArray[np.float64], NDArray[np.float64], None]:
        """The next joint command ``(q, qd, None)``; ``measured`` is not used (open loop)."""
        if self._ran_out() and self._stage < len(self._stages) - 1:
            self._stage += 1
            self._stages[self._stage].reset(start=self.pose[-1])
        stepper = self._stages[self._stage]
        pose, velocity, acceleration = (a.copy() for a in stepper.step())
        q, position_error, orientation_error = self._kin.follow(self._q, pose, self.dt)
        when = f"t = {len(self.pose) * self.dt:.3f} s"
        if position_error > REACH_POSITION_TOL or orientation_error > REACH_ORIENTATION_TOL:
            raise DmprsError(f"the pose at {when} is unreachable: the IK is left {position_error * 1000:.3g} mm "
                             f"and {orientation_error:.3g} rad away")
        qd = self._kin.joint_velocity(q, velocity)
        if (q < self._kin.lower).any() or (q > self._kin.upper).any() or \
                (np.abs(qd) > np.asarray(am.VELOCITY_LIMITS)).any():
            raise DmprsError(f"the joint command at {when} is beyond the arm's position or velocity limits")
        self._q = q
        self.pose.append(pose)
        self.velocity.append(velocity)
        self.acceleration.append(acceleration)
        self.movement.append(sum(self._movements[:self._stage]) + getattr(stepper, "active", 0))
        return q, qd, None


@dataclass(frozen=True)
class SequenceRun:
    """One execution of :func:`pour`: the servo loop's record (``run``), the Cartesian commands
    at every physics step (``commands``, with their velocities and accelerations, and
    ``movement``, which movement gave each: as :class:`IKStepper` records them), the mouth as
    measured at each step (``measured``: the forward kinematics of the measured joints before
    the step, and its velocity ``J qd``), and the volume in the glass at the end (l).
    """

    run: oa.ServoRun
    commands: CartesianTrajectory
    movement: NDArray[np.int64]
    measured: CartesianTrajectory
    poured_volume: float

    @property
    def joins(self) -> NDArray[np.int64]:
        """The steps whose command is the first of a movement after the first."""
        return np.flatnonzero(np.diff(self.movement)) + 1

    @property
    def end_time(self) -> float:
        """When the last movement had run its tau (s)."""
        return self.run.end_time

    @property
    def still_time(self) -> float:
        """How long (s) the commanded mouth was still (below :data:`STILL`) before the end."""
        moving = self.run.times < self.end_time
        v = twist(self.commands)
        still = (norms(v[:, :3]) < STILL[0]) & (norms(v[:, 3:]) < STILL[1]) & moving
        return float(still.sum() * (self.run.times[1] - self.run.times[0]))


def twist(trajectory: CartesianTrajectory, derivative: int = 1) -> NDArray[np.float64]:
    """The linear, then the angular velocity of ``trajectory`` (T, 6); their accelerations with
    ``derivative=2``.
    """
    linear, angular = ((trajectory.velocity, trajectory.angular_velocity) if derivative == 1 else
                       (trajectory.acceleration, trajectory.angular_acceleration))
    if derivative not in (1, 2) or linear is None or angular is None:
        raise InvalidInputError(f"the trajectory has no derivative {derivative!r} (1: velocities, 2: accelerations)")
    return np.hstack([linear, angular])


def pour(execution: str = "sequence", *, liquid_seed: int = 0, overlap: float = OVERLAP) -> SequenceRun:
    """Pours from the bottle of :mod:`dmprs.experiments.online_arm` with the liquid of
    ``liquid_seed``: ``"sequence"`` runs the :func:`pieces` of ``overlap`` as one
    :class:`dmprs.Sequence`, ``"stops"`` the pieces without overlap one after another, each
    ending at rest (see the module). The spheres are counted
    :data:`~dmprs.experiments.online_arm.POUR_SETTLE` s after the last movement's tau.
    """
    import mujoco

    if execution not in EXECUTIONS:
        raise InvalidInputError(f"execution = {execution!r}: expected one of {', '.join(EXECUTIONS)}")
    n = round(oa.POUR_VOLUME / PARTICLE_VOLUME)
    liquid = arm_scene.settled_liquid(n, liquid_seed)
    data = mujoco.MjData(liquid.model)
    data.qpos[:], data.qvel[:] = liquid.qpos, liquid.qvel
    mujoco.mj_forward(liquid.model, data)
    dt = float(liquid.model.opt.timestep)
    stages: list[Any]
    if execution == "sequence":
        dmps = pieces(overlap)
        stages, movements = [Sequence(dmps).stepper(dt)], [len(dmps)]
    else:
        dmps = pieces(0.0)
        stages, movements = [d.stepper(dt) for d in dmps], [1] * len(dmps)
    kin = ArmKinematics()
    stepper = IKStepper(stages, movements, dmps[0].alpha_x, kin, data.qpos[:7])
    run = oa.run_servo(liquid.model, data, stepper, after_end=oa.POUR_SETTLE)
    n_glass = oa.spheres_in_glass(liquid.model, data, n)
    pose, v, a = (np.array(x) for x in (stepper.pose, stepper.velocity, stepper.acceleration))
    commands = CartesianTrajectory(run.times, pose[:, :3], pose[:, 3:], v[:, :3], v[:, 3:], a[:, :3], a[:, 3:])
    at = np.stack([kin.pose(q) for q in run.q])
    moving = np.stack([kin.twist(q, qd) for q, qd in zip(run.q, run.qd, strict=True)])
    measured = CartesianTrajectory(run.times, at[:, :3], at[:, 3:], moving[:, :3], moving[:, 3:])
    return SequenceRun(run, commands, np.array(stepper.movement, dtype=np.int64), measured, n_glass * PARTICLE_VOLUME)
