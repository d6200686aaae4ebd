"""The scripted "kinesthetic" demonstrations: reach over the glass, tilt about the mouth, hold,
tilt back, as poses of the mouth.
"""

from __future__ import annotations

import math

import numpy as np

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
    peak = float(peak_tilt)
    if not math.isfinite(peak):
        raise InvalidInputError(f"peak_tilt = {peak_tilt!r} must be a finite angle in rad")
    reach, up, hold, down = (float(x) for x in timing)
    if min(reach, up, down) <= 0 or hold < 0:
        raise InvalidInputError(f"timing = {timing!r}: reach, up and down must be > 0 s, hold >= 0 s")
    total = reach + up + hold + down
    t = np.linspace(0.0, total, round(total / dt) + 1)
    start, goal = np.asarray(HOME_POSE[:3]), np.asarray(POUR_POSITION)
    position = start + min_jerk(t / reach)[0][:, None] * (goal - start)
    angle = peak * (min_jerk((t - reach) / up)[0] - min_jerk((t - reach - up - hold) / down)[0])
    quat = np.stack([cos(angle / 2), sin(angle / 2), np.zeros_like(t), np.zeros_like(t)], axis=1)
    return CartesianTrajectory.from_pose(t, np.hstack([position, quat]))


def demonstration_tangent(peak_tilt: float) -> Trajectory:
    """The scripted demonstration of :func:`pour_poses` as a 6-D trajectory of the position and the
    rotation vector from the upright home orientation (:func:`pose_to_tangent`), with its exact
    sampling, for encoding as DMPs with the library's generalizer.
    """
    poses = pour_poses(peak_tilt)
    return Trajectory(poses.t, pose_to_tangent(poses.pose, np.asarray(HOME_POSE[3:])))

