"""Closed-form inverse kinematics of a level paddle held by the arm of :mod:`dmprs.sim.arm_model`
in the arm's x-z plane: A1, A3, A5, A7 at zero, the shoulder (A2), elbow (A4) and wrist (A6)
moving the paddle, whose face stays horizontal.

With A1 = A3 = A5 = A7 = 0 the axes of A2, A4 and A6 are +y, -y and +y, so the arm is a planar
three-link chain: link 7 is turned about y by ``theta = q2 - q4 + q6``, and the tool body's z
(the paddle's normal, the flange's -x: ``arm_model.arm_bodies``) points up when ``theta = pi/2``.
The paddle's centre (the tool body's origin, the ``mouth`` site) is then a fixed offset from the
wrist A6: ``FORWARD`` along +x (A6 to the flange, then the bracket) and ``UP`` along +z (half the
tool's length). The wrist follows from the two-link law of cosines (elbow bent, ``q4 < 0``):

    c = (x^2 + z^2 - L1^2 - L2^2) / (2 L1 L2),   q4 = -arccos(c)
    q2 = atan2(x, z) - atan2(L2 sin|q4|, L1 + L2 cos|q4|),   q6 = pi/2 - q2 + q4

with (x, z) the wrist relative to A2. The trigonometry is :mod:`dmprs.portable`'s (libm), so the
joint angles are the same bits on every machine.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dmprs.errors import InvalidInputError
from dmprs.portable import arccos, arctan2, cos, sin
from dmprs.sim import arm_model as am

#: m: A2's height above the base, and the links A2 -> A4 and A4 -> A6 (arm_model.LINK_OFFSETS)
SHOULDER = am.LINK_OFFSETS[0] + am.LINK_OFFSETS[1]
L1 = am.LINK_OFFSETS[2] + am.LINK_OFFSETS[3]
L2 = am.LINK_OFFSETS[4] + am.LINK_OFFSETS[5]
#: m: the paddle's centre from the wrist A6 when level: along x (A6 -> A7 -> flange, then the
#: bracket) and along z (the tool body's origin is half its length off the flange's axis)
FORWARD = am.LINK_OFFSETS[6] + am.LINK_OFFSETS[7] + am.BRACKET
UP = am.BOTTLE_LENGTH / 2


def level_paddle_joints(x: ArrayLike, z: ArrayLike) -> NDArray[np.float64]:
    """Joint positions (..., 7) that put the paddle's centre at ``(x, 0, z)`` (m, base frame),
    its face level and up; ``x`` and ``z`` broadcast. Raises InvalidInputError for a point out of
    the wrist's reach.
    """
    xs, zs = np.broadcast_arrays(np.asarray(x, dtype=float), np.asarray(z, dtype=float))
    wx = xs - FORWARD
    wz = zs - UP - SHOULDER
    c = (wx * wx + wz * wz - L1 * L1 - L2 * L2) / (2.0 * L1 * L2)
    if not (np.isfinite(c).all() and (np.abs(c) < 1.0).all()):
        raise InvalidInputError(f"a paddle centre (x, z) in [{xs.min():.4g}, {xs.max():.4g}] x [{zs.min():.4g}, "
                                f"{zs.max():.4g}] m is out of the arm's reach (the wrist would be "
                                f"{L1 + L2:.3g} m or more from the shoulder)")
    bend = arccos(c)
    q2 = arctan2(wx, wz) - arctan2(L2 * sin(bend), L1 + L2 * cos(bend))
    q4 = -bend
    out = np.zeros((*xs.shape, 7))
    out[..., 1] = q2
    out[..., 3] = q4
    out[..., 5] = math.pi / 2 - q2 + q4
    return out
