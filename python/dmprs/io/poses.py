"""Pose trajectories: positions and unit quaternions over time, as ``(T, 7)`` arrays
``x, y, z, qw, qx, qy, qz`` (the layout :class:`dmprs.CartesianDMP` fits).

Quaternions are stored scalar first, normalized, and on one hemisphere from sample to sample
(``q`` and ``-q`` are the same rotation; a sign flip between two samples would look like a jump
of 2 pi to anything that differentiates the orientation). ROS messages store them scalar last.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from dmprs._arrays import as_float_array, as_scalar, check_finite, check_increasing
from dmprs.errors import InvalidInputError

__all__ = ["PoseTrajectory", "quat_conjugate", "quat_multiply", "quat_rotate", "slerp"]


def quat_multiply(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """Hamilton product of (..., 4) scalar-first quaternions."""
    aw, ax, ay, az = np.moveaxis(a, -1, 0)
    bw, bx, by, bz = np.moveaxis(b, -1, 0)
    return np.stack([
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    ], axis=-1)


def quat_conjugate(q: NDArray[np.float64]) -> NDArray[np.float64]:
    """The inverse of a unit quaternion."""
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def quat_rotate(q: NDArray[np.float64], v: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rotates (..., 3) vectors by (..., 4) unit quaternions: q v q*."""
    qv = np.concatenate([np.zeros(v.shape[:-1] + (1,)), v], axis=-1)
    return quat_multiply(quat_multiply(q, qv), quat_conjugate(q))[..., 1:]


def _continuous(q: NDArray[np.float64]) -> NDArray[np.float64]:
    """Flips signs so that consecutive quaternions are on the same hemisphere."""
    out = q.copy()
    for j in range(1, len(out)):
        if np.dot(out[j], out[j - 1]) < 0:
            out[j] = -out[j]
    return out


def slerp(q0: NDArray[np.float64], q1: NDArray[np.float64], s: NDArray[np.float64]) -> NDArray[np.float64]:
    """Spherical linear interpolation between rows of (M, 4) unit quaternions at fractions s (M,)."""
    dot = np.sum(q0 * q1, axis=-1)
    q1 = np.where(dot[:, None] < 0, -q1, q1)
    dot = np.abs(dot).clip(-1.0, 1.0)
    theta = np.arccos(dot)
    small = theta < 1e-9
    sin = np.where(small, 1.0, np.sin(theta))
    w0 = np.where(small, 1.0 - s, np.sin((1.0 - s) * theta) / sin)
    w1 = np.where(small, s, np.sin(s * theta) / sin)
    out = w0[:, None] * q0 + w1[:, None] * q1
    return out / np.linalg.norm(out, axis=1, keepdims=True)


def interpolate_poses(t: NDArray[np.float64], poses: NDArray[np.float64],
                      t_new: NDArray[np.float64]) -> NDArray[np.float64]:
    """Poses at ``t_new`` (within [t[0], t[-1]]): positions linearly, orientations by slerp."""
    j = np.clip(np.searchsorted(t, t_new, side="right") - 1, 0, len(t) - 2)
    s = ((t_new - t[j]) / (t[j + 1] - t[j])).clip(0.0, 1.0)
    pos = poses[j, :3] + s[:, None] * (poses[j + 1, :3] - poses[j, :3])
    return np.hstack([pos, slerp(poses[j, 3:], poses[j + 1, 3:], s)])


@dataclass(frozen=True, eq=False)
class PoseTrajectory:
    """Poses ``(T, 7)`` = x, y, z (m), qw, qx, qy, qz at times ``t`` (T,) (s), of ``child_frame``
    in ``frame``. Quaternions are normalized and made sign-continuous on construction."""

    t: NDArray[np.float64]
    poses: NDArray[np.float64]
    frame: str = ""
    child_frame: str = ""

    def __post_init__(self) -> None:
        t = as_float_array(self.t, "t", 1)
        check_increasing(t)
        p = as_float_array(self.poses, "poses", 2)
        if p.shape != (t.shape[0], 7):
            raise InvalidInputError(
                f"poses has shape {p.shape}, expected ({t.shape[0]}, 7): x, y, z, qw, qx, qy, qz per sample")
        check_finite(p, "poses")
        norms = np.linalg.norm(p[:, 3:], axis=1)
        if (norms < 1e-9).any():
            j = int(np.argmax(norms < 1e-9))
            raise InvalidInputError(f"poses[{j}] has a zero quaternion; orientations must be rotations")
        p = np.hstack([p[:, :3], _continuous(p[:, 3:] / norms[:, None])])
        for name, arr in (("t", t), ("poses", p)):
            arr = arr.copy()
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)

    @property
    def positions(self) -> NDArray[np.float64]:
        """(T, 3) in m."""
        return self.poses[:, :3]

    @property
    def quaternions(self) -> NDArray[np.float64]:
        """(T, 4) scalar first."""
        return self.poses[:, 3:]

    @property
    def n_samples(self) -> int:
        return int(self.t.shape[0])

    @property
    def duration(self) -> float:
        return float(self.t[-1] - self.t[0])

    def __len__(self) -> int:
        return self.n_samples

    def resample(self, rate: float) -> PoseTrajectory:
        """Uniform samples at ``rate`` Hz from t[0] (positions linear, orientations slerp), times
        from 0."""
        dt = 1.0 / as_scalar(rate, "rate", positive=True)
        t_new = self.t[0] + np.arange(int(np.floor(self.duration / dt + 1e-9)) + 1) * dt
        return PoseTrajectory(t_new - self.t[0], interpolate_poses(self.t, self.poses, t_new),
                              self.frame, self.child_frame)

    def between(self, start: float, stop: float) -> PoseTrajectory:
        """The samples with start <= t <= stop."""
        keep = (self.t >= start) & (self.t <= stop)
        return PoseTrajectory(self.t[keep], self.poses[keep], self.frame, self.child_frame)

    def __repr__(self) -> str:
        frames = f", {self.child_frame} in {self.frame}" if self.frame or self.child_frame else ""
        return f"PoseTrajectory(n_samples={self.n_samples}, duration={self.duration:.6g} s{frames})"


def angular_speed(t: NDArray[np.float64], q: NDArray[np.float64]) -> NDArray[np.float64]:
    """|omega| (rad/s) per sample from consecutive unit quaternions: the rotation angle between
    neighbours over their time step (averaged at inner samples)."""
    step = 2 * np.arccos(np.abs(np.sum(q[1:] * q[:-1], axis=1)).clip(0.0, 1.0)) / np.diff(t)
    return np.concatenate([[step[0]], (step[1:] + step[:-1]) / 2, [step[-1]]])


def split_poses_at_rest(poses: PoseTrajectory, *, speed_tol: float, angular_speed_tol: float,
                        min_rest: float = 0.2, min_duration: float = 0.3) -> list[PoseTrajectory]:
    """The movements of a long pose recording: where the linear speed exceeds ``speed_tol`` (m/s)
    or the angular speed ``angular_speed_tol`` (rad/s), cut as :func:`dmprs.io.split_at_rest`
    cuts joint recordings; each with times from 0."""
    from dmprs.io.segment import moving_ranges

    tol = as_scalar(speed_tol, "speed_tol", positive=True)
    ang = as_scalar(angular_speed_tol, "angular_speed_tol", positive=True)
    if poses.n_samples < 3:
        raise InvalidInputError(f"a pose recording of {poses.n_samples} samples has no movement to cut")
    linear = np.linalg.norm(np.gradient(poses.positions, poses.t, axis=0), axis=1)
    moving = (linear > tol) | (angular_speed(poses.t, poses.quaternions) > ang)
    ranges = moving_ranges(poses.t, moving, as_scalar(min_rest, "min_rest"),
                           as_scalar(min_duration, "min_duration"))
    if not ranges:
        raise InvalidInputError(
            f"no movement faster than {tol:g} m/s or {ang:g} rad/s for at least {min_duration:g} s "
            f"in a pose recording of {poses.duration:.4g} s")
    out = []
    for start, stop in ranges:
        piece = poses.between(start, stop)
        out.append(PoseTrajectory(piece.t - piece.t[0], piece.poses, poses.frame, poses.child_frame))
    return out
