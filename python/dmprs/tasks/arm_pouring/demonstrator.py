"""The scripted "kinesthetic" demonstrations: reach over the glass, tilt about the mouth, hold,
tilt back, as poses of the mouth.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from dmprs.errors import InvalidInputError
from dmprs.portable import cos, sin
from dmprs.profiles import min_jerk
from dmprs.sim.arm_scene import HOME_POSE
from dmprs.tasks.arm_pouring.adapter import CONTROL_PERIOD
from dmprs.tasks.arm_pouring.poses import pose_to_tangent
from dmprs.trajectory import CartesianTrajectory, Trajectory

DEMO_VOLUMES = (0.3, 1.0)  #: l, the demonstrations' bottles (docs/method.md §9.1)
#: the scripted demonstration (s): reach over the glass, tilt up, hold, tilt back (docs/method.md §9.3)
DEMO_TIMING = (0.5, 1.5, 0.7, 1.5)
#: the mouth's pose while pouring: over the glass's near edge, upright (see docs/arm.md)
POUR_POSITION = (0.75, -0.175, 0.34)


def pour_poses(peak_tilt: float, timing: tuple[float, float, float, float] = DEMO_TIMING,
               dt: float = CONTROL_PERIOD) -> CartesianTrajectory:
    """The scripted demonstration as poses of the mouth: minimum-jerk reach from the home pose to
    :data:`POUR_POSITION` (upright), minimum-jerk tilt about the mouth by ``peak_tilt`` rad toward
    the glass (a rotation about the world's x axis, which turns the mouth toward -y), hold, and
    minimum-jerk tilt back to upright; the mouth stays still while the bottle tilts.
    """
    peak = _peak(peak_tilt)
    reach, up, hold, down = _phases(timing)
    total = reach + up + hold + down
    t = np.linspace(0.0, total, round(total / dt) + 1)
    start, goal = np.asarray(HOME_POSE[:3]), np.asarray(POUR_POSITION)
    position = start + min_jerk(t / reach)[0][:, None] * (goal - start)
    angle = peak * (min_jerk((t - reach) / up)[0] - min_jerk((t - reach - up - hold) / down)[0])
    return _poses(t, position, angle)


def pour_and_return_poses(peak_tilt: float, overlap: float = 0.0, timing: tuple[float, float, float, float] = DEMO_TIMING,
                          dt: float = CONTROL_PERIOD) -> CartesianTrajectory:
    """:func:`pour_poses` followed by its reach backwards, to the home pose, with the phases
    overlapping by ``overlap`` s: the tilt starts that long before the reach arrives over the
    glass, and the way back leaves that long before the bottle is upright again (0: every phase
    from rest to rest). The mouth is moving and the bottle turning throughout each overlap, so a
    cut there (:func:`pour_and_return_cuts`) falls where the movement does not stop.
    """
    peak = _peak(peak_tilt)
    reach, up, hold, down = _phases(timing)
    lap = _overlap(overlap, reach, up, down)
    tilt = reach - lap  # when the tilt starts
    leave = tilt + up + hold + down - lap  # when the way back starts
    total = leave + reach
    t = np.linspace(0.0, total, round(total / dt) + 1)
    start, goal = np.asarray(HOME_POSE[:3]), np.asarray(POUR_POSITION)
    travel = min_jerk(t / reach)[0] - min_jerk((t - leave) / reach)[0]
    angle = peak * (min_jerk((t - tilt) / up)[0] - min_jerk((t - tilt - up - hold) / down)[0])
    return _poses(t, start + travel[:, None] * (goal - start), angle)


def pour_and_return_cuts(overlap: float = 0.0, timing: tuple[float, float, float, float] = DEMO_TIMING,
                         ) -> tuple[float, float]:
    """The times (s) that cut :func:`pour_and_return_poses` into the reach, the pour (tilt, hold,
    tilt back) and the return: the middle of each overlap (with none, where the reach arrives and
    where the way back leaves, both at rest).
    """
    reach, up, hold, down = _phases(timing)
    lap = _overlap(overlap, reach, up, down)
    return reach - lap / 2, reach - lap + up + hold + down - lap / 2


def _peak(peak_tilt: float) -> float:
    peak = float(peak_tilt)
    if not math.isfinite(peak):
        raise InvalidInputError(f"peak_tilt = {peak_tilt!r} must be a finite angle in rad")
    return peak


def _poses(t: NDArray[np.float64], position: NDArray[np.float64], angle: NDArray[np.float64]) -> CartesianTrajectory:
    """The mouth at ``position`` (T, 3), the bottle tilted by ``angle`` (T,) about the world's x axis."""
    quat = np.stack([cos(angle / 2), sin(angle / 2), np.zeros_like(t), np.zeros_like(t)], axis=1)
    return CartesianTrajectory.from_pose(t, np.hstack([position, quat]))


def _phases(timing: tuple[float, float, float, float]) -> tuple[float, float, float, float]:
    """The durations (s) of the reach, the tilt up, the hold and the tilt back, validated."""
    reach, up, hold, down = (float(x) for x in timing)
    if not min(reach, up, down) > 0 or not hold >= 0 or not math.isfinite(reach + up + hold + down):
        raise InvalidInputError(f"timing = {timing!r}: reach, up and down must be > 0 s, hold >= 0 s")
    return reach, up, hold, down


def _overlap(overlap: float, reach: float, up: float, down: float) -> float:
    """``overlap`` (s) validated: no longer than the reach or either tilt it overlaps."""
    lap = float(overlap)
    if not 0.0 <= lap <= min(reach, up, down):
        raise InvalidInputError(f"overlap = {overlap!r} s must be >= 0 and no longer than the reach ({reach:g} s) "
                                f"or a tilt ({min(up, down):g} s)")
    return lap


def demonstration_tangent(peak_tilt: float) -> Trajectory:
    """The scripted demonstration of :func:`pour_poses` as a 6-D trajectory of the position and the
    rotation vector from the upright home orientation (:func:`pose_to_tangent`), with its exact
    sampling, for encoding as DMPs with the library's generalizer.
    """
    poses = pour_poses(peak_tilt)
    return Trajectory(poses.t, pose_to_tangent(poses.pose, np.asarray(HOME_POSE[3:])))

