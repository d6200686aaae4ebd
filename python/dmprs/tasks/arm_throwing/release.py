"""The final-velocity throw (docs/throwing.md, "The final-velocity throw"): a scripted throw split
at its release, the movement up to it a DMP with a final velocity (docs/method.md §2.8; Kober et
al. 2010, Mülling et al. 2013), and a braking movement after it, joined as a
:class:`dmprs.Sequence` (docs/method.md §2.9).

* The **release** is :data:`RELEASE_TIME`, the swing's peak speed: its minimum-jerk profile
  stops accelerating halfway through :data:`~dmprs.tasks.arm_throwing.SWING_TIME`, and from
  there the cup decelerates. The ball leaves the cup later, during the braking, once the
  deceleration along the cup's opening exceeds gravity's pull back in (docs/throwing.md gives
  the measured instants); the braking is fixed by the release state, so the ball's flight is
  too.
* The **braking** (:func:`braking`): the demonstrations' movement after the release is, per
  joint, the second half of a minimum-jerk profile scaled by that joint's velocity at the
  release (every swing joint's profile is ``strength x`` :data:`SWING` ``x`` one profile). One
  DMP of one DOF is fitted once to that remainder per unit release velocity; a throw's braking
  scales its weights and its distance to the goal by the release velocity ``gd``, per joint,
  from the release position ``g``. Eqs. 1-3 are linear in ``(y, g, w)`` (docs/method.md §2.7),
  so this is the remainder of every demonstration, and a braking for every generalized release
  state: the generalized parameters stay ``[w, tau, g, y0, gd]`` of the movement up to the
  release.
"""

from __future__ import annotations

import functools

import numpy as np

from dmprs._arrays import short
from dmprs.dmp import DMP
from dmprs.errors import InvalidInputError
from dmprs.sequence import Sequence
from dmprs.tasks.arm_throwing.demonstrator import SWING, SWING_TIME, TURN_TIME, throw_trajectory
from dmprs.trajectory import Trajectory

#: s from a throw's start: the swing's peak speed (the minimum-jerk profile's midpoint), where the
#: cup starts to decelerate; the movement up to it ends with the release position and velocity
RELEASE_TIME = TURN_TIME + SWING_TIME / 2
#: s: the braking movement after the release (the swing's second half)
BRAKE_TIME = SWING_TIME / 2
#: kernels of the braking DMP (per unit release velocity)
BRAKE_BASIS = 30
#: s: how close to RELEASE_TIME a trajectory must have a sample to be split there
_SAMPLE_TOL = 1e-9


def split(trajectory: Trajectory) -> tuple[Trajectory, Trajectory]:
    """A scripted throw (:func:`~dmprs.tasks.arm_throwing.throw_trajectory`) split at
    :data:`RELEASE_TIME` after its start: (up to the release, the release sample included; from
    the release on, its clock restarted at 0). The trajectory needs a sample there.
    """
    if not isinstance(trajectory, Trajectory):
        raise InvalidInputError(f"trajectory must be a dmprs.Trajectory; got {short(trajectory)}")
    t = trajectory.t - trajectory.t[0]
    k = int(np.argmin(np.abs(t - RELEASE_TIME)))
    if abs(t[k] - RELEASE_TIME) > _SAMPLE_TOL or not 2 <= k <= len(t) - 3:
        raise InvalidInputError(
            f"trajectory has no sample at the release, {RELEASE_TIME:g} s after its start, with samples "
            f"on both sides (the nearest is at {t[k]:.6g} s of {t[-1]:.6g} s)")
    yd, ydd = trajectory.yd, trajectory.ydd

    def part(s: slice, t0: float) -> Trajectory:
        return Trajectory(trajectory.t[s] - t0, trajectory.y[s], None if yd is None else yd[s],
                          None if ydd is None else ydd[s])

    return part(slice(0, k + 1), 0.0), part(slice(k, None), float(trajectory.t[k]))


@functools.lru_cache(maxsize=1)
def unit_braking() -> DMP:
    """The braking DMP of one DOF per unit release velocity: fitted to the remainder of the
    scripted full-strength throw after its release, one swing joint's, from 0 and divided by
    that joint's release velocity (so it starts at 0 moving at 1 rad/s per rad/s).
    """
    after = split(throw_trajectory(1.0, 0.0))[1]
    j = int(np.argmax(np.abs(SWING)))
    assert after.yd is not None and after.ydd is not None  # the scripted throw has both
    v = after.yd[0, j]
    return DMP.fit(after.t, (after.y[:, j] - after.y[0, j]) / v, BRAKE_BASIS, after.yd[:, j] / v,
                   after.ydd[:, j] / v)


def braking(dmp: DMP) -> DMP:
    """The movement after the release of ``dmp`` (a DMP with a final velocity): from its goal
    ``g`` (the release position), each joint brakes from its release velocity ``gd`` to rest as
    the demonstrations do, in :data:`BRAKE_TIME`: weights ``gd x`` the unit braking's, goal
    ``g + gd x`` the unit braking's distance (:func:`unit_braking`).
    """
    if not isinstance(dmp, DMP):
        raise InvalidInputError(f"dmp must be a dmprs.DMP with a final velocity; got {short(dmp)}")
    unit = unit_braking()
    gd = dmp.final_velocity
    return DMP(np.outer(gd, unit.weights[0]), dmp.goal + gd * unit.goal[0], dmp.goal, unit.tau,
               alpha_z=unit.alpha_z, beta_z=unit.beta_z, alpha_x=unit.alpha_x, width_factor=unit.width_factor)


def release_sequence(dmp: DMP) -> Sequence[DMP]:
    """The whole throw: ``dmp`` up to the release, handing over in motion to its :func:`braking`."""
    return Sequence([dmp, braking(dmp)])
