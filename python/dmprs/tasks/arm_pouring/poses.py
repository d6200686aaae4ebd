"""The map between the bottle mouth's poses and the tangent space of a reference orientation, for
encoding a pour as one DMP per coordinate (the second method the Cartesian DMPs are checked
against).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from dmprs import quaternion


def pose_to_tangent(pose: NDArray[np.float64], reference: NDArray[np.float64]) -> NDArray[np.float64]:
    """Poses (T, 7) as (T, 6): the position, then the rotation vector ``2 log(q * conj(r))`` of each
    orientation relative to the unit quaternion ``reference`` r (world frame). For rotations of
    less than pi from r this is one-to-one and smooth, so a per-coordinate DMP of it is a pose DMP
    in the tangent space at r: for a rotation about one fixed axis it is exactly the discrete DMP
    of the angle, as the orientation DMP of Ude et al. 2014 is (docs/arm.md).
    """
    pose = np.asarray(pose, dtype=float)
    relative = quaternion.product(pose[:, 3:], np.broadcast_to(quaternion.conjugate(np.asarray(reference)),
                                                               (len(pose), 4)))
    return np.hstack([pose[:, :3], quaternion.log(relative)])


def tangent_to_pose(y: NDArray[np.float64], reference: NDArray[np.float64]) -> NDArray[np.float64]:
    """The inverse of :func:`pose_to_tangent`: (T, 6) -> poses (T, 7) with unit quaternions."""
    y = np.asarray(y, dtype=float)
    quat = quaternion.product(quaternion.exp(y[:, 3:]), np.broadcast_to(np.asarray(reference, dtype=float),
                                                                       (len(y), 4)))
    return np.hstack([y[:, :3], quat / np.linalg.norm(quat, axis=1, keepdims=True)])
