"""The scripted demonstration throws: a minimum-jerk turn of the base to the throwing direction,
then a minimum-jerk swing of the shoulder (A2), elbow (A4) and wrist (A6) together, the cup
moving along its opening; the ball leaves the cup while the swing decelerates.
"""

from __future__ import annotations

import math

import numpy as np

from dmprs.errors import InvalidInputError
from dmprs.profiles import min_jerk
from dmprs.sim.throw_scene import HOME
from dmprs.trajectory import Trajectory

#: rad: the swing of A2, A4, A6 at full strength (strength 1), in the throwing direction
#: (A2 and A6 forward, A4 (axis -y) unbending). At strength 1 and SWING_TIME, the peak joint
#: speeds are 1.875 x amplitude / time = 1.34, 1.21, 2.14 rad/s: 91, 92 and 91 % of the iiwa's
#: 1.48, 1.31 and 2.36 rad/s.
SWING = (0.0, -0.5, 0.0, 0.45, 0.0, -0.8, 0.0)
#: s: the base's turn to the throwing direction, then the swing
TURN_TIME = 0.8
SWING_TIME = 0.7
#: the demonstrations: (strength, base yaw in rad): the corners of a 2 x 2 grid and its centre.
#: Strengths 0.75-0.9 land the ball ~0.9-1.4 m from the base (measured: the labels); the yaw
#: turns the landing by about as much. The largest peak joint speed is 83 % of its limit, so
#: a learner may extrapolate by 20 % and stay within the limits.
DEMOS = ((0.75, -0.25), (0.75, 0.25), (0.9, -0.25), (0.9, 0.25), (0.825, 0.0))


def throw_trajectory(strength: float, yaw: float, dt: float = 0.002) -> Trajectory:
    """A scripted throw from :data:`~dmprs.sim.throw_scene.HOME`: A1 turns by ``yaw`` rad in
    :data:`TURN_TIME`, then A2, A4, A6 swing by ``strength x`` :data:`SWING` in
    :data:`SWING_TIME` (minimum-jerk profiles, :func:`dmprs.profiles.min_jerk`), sampled every
    ``dt`` s, with exact velocities and accelerations.
    """
    k, phi = float(strength), float(yaw)
    if not (math.isfinite(k) and k > 0):
        raise InvalidInputError(f"strength = {strength!r} must be > 0")
    if not math.isfinite(phi):
        raise InvalidInputError(f"yaw = {yaw!r} must be a finite angle in rad")
    total = TURN_TIME + SWING_TIME
    t = np.linspace(0.0, total, round(total / dt) + 1)
    turn = min_jerk(t / TURN_TIME)
    swing = min_jerk((t - TURN_TIME) / SWING_TIME)
    amp = k * np.asarray(SWING)
    y = np.asarray(HOME) + np.outer(swing[0], amp)
    yd = np.outer(swing[1] / SWING_TIME, amp)
    ydd = np.outer(swing[2] / SWING_TIME**2, amp)
    y[:, 0] += phi * turn[0]
    yd[:, 0] = phi * turn[1] / TURN_TIME
    ydd[:, 0] = phi * turn[2] / TURN_TIME**2
    return Trajectory(t, y, yd, ydd)
