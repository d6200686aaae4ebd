"""The scripted demonstrations: one period of a level paddle moving up and down sinusoidally
about its home height, ``z(t) = A sin(2 pi t / P)``, in joint space (the closed-form IK of
:mod:`dmprs.sim.paddle_ik`).

The amplitude is chosen for the period so that the paddle's peak acceleration ``A (2 pi / P)^2``
is :data:`ACCELERATION` g: in the steady bouncing of period ``P`` the paddle meets the ball
while moving up at ``v_p = (1 - e) / (1 + e) sqrt(2 g h)`` (``h = g P^2 / 8``), i.e. where
``cos(phase) = v_p / (A 2 pi / P)``, and its deceleration there is then about 0.4 g, inside
the passively stable band ``0 > a > -2 g (1 + e^2) / (1 + e)^2`` of Schaal, Sternad & Atkeson
(1996) for the scene's e = 0.7 (-1.03 g); the servo's tracking magnifies the commanded
amplitude a little (docs/juggling.md), which keeps it inside.
"""

from __future__ import annotations

import math

import numpy as np

from dmprs.errors import InvalidInputError
from dmprs.portable import sin
from dmprs.sim.juggle_scene import PADDLE_HOME, gravity
from dmprs.sim.paddle_ik import level_paddle_joints
from dmprs.trajectory import Trajectory

#: the paddle's peak commanded acceleration, in g
ACCELERATION = 0.7
#: s: the demonstrations' periods; their apexes (measured: the labels) span about 0.15-0.35 m
DEMO_PERIODS = (0.3, 0.56)


def paddle_amplitude(period: float) -> float:
    """m: the amplitude of the scripted rhythm of ``period`` s: peak acceleration
    :data:`ACCELERATION` g, ``A = ACCELERATION g (P / 2 pi)^2``.
    """
    w = 2.0 * math.pi / period
    return ACCELERATION * gravity() / (w * w)


def rhythm_period(period: float, dt: float = 0.002) -> Trajectory:
    """One period (``period`` s, sampled every ``dt`` s or a little less so that it divides the
    period; both ends included) of the scripted joint rhythm from the paddle at home moving up,
    with its velocities and accelerations (fourth-order central differences of the closed form).
    """
    p = float(period)
    if not (math.isfinite(p) and p > 0):
        raise InvalidInputError(f"period = {period!r} must be a positive number of seconds")
    n = max(8, math.ceil(p / float(dt) - 1e-9))
    h = p / n
    a = paddle_amplitude(p)
    j = np.arange(-2, n + 3)
    x0, z0 = PADDLE_HOME
    q = level_paddle_joints(x0, z0 + a * sin((2.0 * math.pi / n) * j))
    inner = slice(2, n + 3)
    qd = (q[:-4] - q[4:] + 8.0 * (q[3:-1] - q[1:-3])) / (12.0 * h)
    qdd = (-(q[:-4] + q[4:]) + 16.0 * (q[3:-1] + q[1:-3]) - 30.0 * q[2:-2]) / (12.0 * h * h)
    return Trajectory(np.asarray(j[inner] * h, dtype=np.float64), q[inner], qd, qdd)
