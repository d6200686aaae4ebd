"""Recorded poses as :class:`~dmprs.CartesianTrajectory` (what :class:`dmprs.CartesianDMP`
fits): positions and unit quaternions, ``pose`` (T, 7) = ``x, y, z, qw, qx, qy, qz``.

Readers build them with :func:`pose_trajectory`, which normalizes the quaternions and puts them
on one hemisphere from sample to sample (``q`` and ``-q`` are the same rotation; a sign flip
between two samples would look like a jump of 2 pi to anything that differentiates the
orientation). ROS messages store quaternions scalar last; dmprs scalar first. The quaternion
arithmetic is :mod:`dmprs.quaternion`'s.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dmprs import quaternion
from dmprs._arrays import as_float_array, as_scalar, check_finite, check_increasing
from dmprs.errors import InvalidInputError
from dmprs.io.segment import moving_ranges, uniform_count
from dmprs.trajectory import CartesianTrajectory

__all__ = [
    "pose_trajectory", "poses_between", "resample_poses",
    "split_poses_at_rest",
]


def interpolate_poses(t: NDArray[np.float64], poses: NDArray[np.float64],
                      t_new: NDArray[np.float64]) -> NDArray[np.float64]:
    """Poses at ``t_new`` (within [t[0], t[-1]]): positions linearly, orientations by slerp."""
    j = np.clip(np.searchsorted(t, t_new, side="right") - 1, 0, len(t) - 2)
    s = ((t_new - t[j]) / (t[j + 1] - t[j])).clip(0.0, 1.0)
    pos = poses[j, :3] + s[:, None] * (poses[j + 1, :3] - poses[j, :3])
    return np.hstack([pos, quaternion.slerp(poses[j, 3:], poses[j + 1, 3:], s)])


def pose_trajectory(t: ArrayLike, poses: ArrayLike) -> CartesianTrajectory:
    """A :class:`~dmprs.CartesianTrajectory` from recorded poses (T, 7) ``x, y, z, qw, qx, qy,
    qz``: quaternions normalized (recordings store them to a few digits) and made sign-continuous.
    """
    tt = as_float_array(t, "t", 1)
    check_increasing(tt)
    p = as_float_array(poses, "poses", 2)
    if p.shape != (tt.shape[0], 7):
        raise InvalidInputError(
            f"poses has shape {p.shape}, expected ({tt.shape[0]}, 7): x, y, z, qw, qx, qy, qz per sample")
    check_finite(p, "poses")
    norms = np.linalg.norm(p[:, 3:], axis=1)
    if (norms < 1e-9).any():
        j = int(np.argmax(norms < 1e-9))
        raise InvalidInputError(f"poses[{j}] has a zero quaternion; orientations must be rotations")
    return CartesianTrajectory(tt, p[:, :3], quaternion.continuous(p[:, 3:] / norms[:, None]))


def resample_poses(trajectory: CartesianTrajectory, rate: float) -> CartesianTrajectory:
    """Uniform samples at ``rate`` Hz from the first one (positions linearly, orientations by
    slerp), times from 0; recorded velocities are dropped.
    """
    n = uniform_count(trajectory.duration, rate, 7)
    t = trajectory.t
    t_new = t[0] + np.arange(n) * (1.0 / float(rate))
    return pose_trajectory(t_new - t[0], interpolate_poses(t, trajectory.pose, t_new))


def poses_between(trajectory: CartesianTrajectory, start: float, stop: float) -> CartesianTrajectory:
    """The samples with start <= t <= stop, with times from 0."""
    keep = (trajectory.t >= start) & (trajectory.t <= stop)
    if keep.sum() < 2:
        raise InvalidInputError(
            f"({start:g}, {stop:g}) s holds {int(keep.sum())} samples of a pose recording from "
            f"{trajectory.t[0]:g} to {trajectory.t[-1]:g} s")
    t = trajectory.t[keep]
    return pose_trajectory(t - t[0], trajectory.pose[keep])


def angular_speed(t: NDArray[np.float64], q: NDArray[np.float64]) -> NDArray[np.float64]:
    """|omega| (rad/s) per sample from consecutive unit quaternions: the rotation angle between
    neighbours over their time step (averaged at inner samples).
    """
    step = 2 * np.arccos(np.abs(np.sum(q[1:] * q[:-1], axis=1)).clip(0.0, 1.0)) / np.diff(t)
    return np.concatenate([[step[0]], (step[1:] + step[:-1]) / 2, [step[-1]]])


def split_poses_at_rest(poses: CartesianTrajectory, *, speed_tol: float, angular_speed_tol: float,
                        min_rest: float = 0.2, min_duration: float = 0.3) -> list[CartesianTrajectory]:
    """The movements of a long pose recording: where the linear speed exceeds ``speed_tol`` (m/s)
    or the angular speed ``angular_speed_tol`` (rad/s), cut as :func:`dmprs.io.split_at_rest`
    cuts joint recordings; each with times from 0.
    """
    tol = as_scalar(speed_tol, "speed_tol", positive=True)
    ang = as_scalar(angular_speed_tol, "angular_speed_tol", positive=True)
    if poses.n_samples < 3:
        raise InvalidInputError(f"a pose recording of {poses.n_samples} samples has no movement to cut")
    linear = np.linalg.norm(np.gradient(poses.position, poses.t, axis=0), axis=1)
    moving = (linear > tol) | (angular_speed(poses.t, poses.quaternion) > ang)
    ranges = moving_ranges(poses.t, moving, as_scalar(min_rest, "min_rest"),
                           as_scalar(min_duration, "min_duration"))
    if not ranges:
        raise InvalidInputError(
            f"no movement faster than {tol:g} m/s or {ang:g} rad/s for at least {min_duration:g} s "
            f"in a pose recording of {poses.duration:.4g} s")
    return [poses_between(poses, start, stop) for start, stop in ranges]
