"""Pose trajectories of the bottle's mouth (x, y, z, then a scalar-first unit quaternion), and
the map between poses and the tangent space of a reference orientation."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from dmprs._arrays import as_float_array, check_increasing
from dmprs.errors import InvalidInputError
from dmprs.trajectory import Trajectory


class PoseTrajectoryLike(Protocol):
    """What the adapter needs of a Cartesian trajectory (``CartesianTrajectory`` has it)."""

    @property
    def t(self) -> NDArray[np.float64]: ...
    @property
    def pose(self) -> NDArray[np.float64]: ...


@dataclass(frozen=True, eq=False)
class PoseTrajectory:
    """Poses of the bottle's mouth ``pose`` (T, 7: x, y, z in m, then a scalar-first unit
    quaternion) at times ``t`` (T,): the scripted demonstrations, validated on construction."""

    t: NDArray[np.float64]
    pose: NDArray[np.float64]

    def __post_init__(self) -> None:
        t = as_float_array(self.t, "t", 1)
        check_increasing(t)
        pose = as_float_array(self.pose, "pose", 2)
        if pose.shape != (len(t), 7):
            raise InvalidInputError(f"pose has shape {pose.shape}; expected ({len(t)}, 7)")
        for arr in (t, pose):
            arr.setflags(write=False)
        object.__setattr__(self, "t", t)
        object.__setattr__(self, "pose", pose)


    @property
    def y(self) -> NDArray[np.float64]:
        """The poses, under the name run logs store a command's samples by."""
        return self.pose


def _quat_mul(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """Row-wise Hamilton product of scalar-first quaternions (T, 4)."""
    w1, x1, y1, z1 = a.T
    w2, x2, y2, z2 = b.T
    return np.stack([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2], axis=1)


def pose_to_tangent(pose: NDArray[np.float64], reference: NDArray[np.float64]) -> NDArray[np.float64]:
    """Poses (T, 7) as (T, 6): the position, then the rotation vector ``2 log(q * conj(r))`` of each
    orientation relative to the unit quaternion ``reference`` r (world frame). For rotations of
    less than pi from r this is one-to-one and smooth, so a per-coordinate DMP of it is a pose DMP
    in the tangent space at r: for a rotation about one fixed axis it is exactly the discrete DMP
    of the angle, as the orientation DMP of Ude et al. 2014 is (docs/arm.md)."""
    pose = np.asarray(pose, dtype=float)
    conj = np.asarray(reference, dtype=float) * np.array([1.0, -1.0, -1.0, -1.0])
    rel = _quat_mul(pose[:, 3:], np.broadcast_to(conj, (len(pose), 4)))
    rel *= np.where(rel[:, :1] < 0, -1.0, 1.0)  # the short way round
    v = rel[:, 1:]
    norm = np.linalg.norm(v, axis=1)
    angle = 2 * np.arctan2(norm, rel[:, 0])
    scale = np.where(norm > 1e-12, angle / np.maximum(norm, 1e-300), 2.0)
    return np.hstack([pose[:, :3], v * scale[:, None]])


def tangent_to_pose(y: NDArray[np.float64], reference: NDArray[np.float64]) -> NDArray[np.float64]:
    """The inverse of :func:`pose_to_tangent`: (T, 6) -> poses (T, 7) with unit quaternions."""
    y = np.asarray(y, dtype=float)
    r = y[:, 3:]
    angle = np.linalg.norm(r, axis=1)
    axis_scale = np.where(angle > 1e-12, np.sin(angle / 2) / np.maximum(angle, 1e-300), 0.5)
    rel = np.hstack([np.cos(angle / 2)[:, None], r * axis_scale[:, None]])
    quat = _quat_mul(rel, np.broadcast_to(np.asarray(reference, dtype=float), (len(y), 4)))
    return np.hstack([y[:, :3], quat / np.linalg.norm(quat, axis=1, keepdims=True)])


def is_pose_trajectory(trajectory: Any) -> bool:
    return not isinstance(trajectory, Trajectory) and hasattr(trajectory, "pose") and hasattr(trajectory, "t")

