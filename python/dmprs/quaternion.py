"""Unit quaternions, scalar first ``(w, x, y, z)``, row-wise on ``(..., 4)`` arrays: the one home
of the quaternion arithmetic the package's Python side needs (the Rust core has its own,
``crates/dmp-core/src/quaternion.rs``, for the DMPs themselves).

``q`` and ``-q`` are the same rotation; :func:`log` and :func:`angle` take the short way round.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from dmprs import portable
from dmprs._core import UNIT_TOLERANCE
from dmprs.errors import InvalidInputError

__all__ = ["UNIT_TOLERANCE", "angle", "check_unit", "conjugate", "continuous", "exp", "log", "product", "rotate",
           "slerp"]

_CONJUGATE = np.array([1.0, -1.0, -1.0, -1.0])


def product(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """The Hamilton product ``a * b`` of ``(..., 4)`` quaternions."""
    aw, ax, ay, az = np.moveaxis(a, -1, 0)
    bw, bx, by, bz = np.moveaxis(b, -1, 0)
    return np.stack([
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    ], axis=-1)


def conjugate(q: NDArray[np.float64]) -> NDArray[np.float64]:
    """The conjugate, which is the inverse of a unit quaternion."""
    inverse: NDArray[np.float64] = q * _CONJUGATE
    return inverse


def rotate(q: NDArray[np.float64], v: NDArray[np.float64]) -> NDArray[np.float64]:
    """``(..., 3)`` vectors rotated by ``(..., 4)`` unit quaternions: ``q v conj(q)``."""
    qv = np.concatenate([np.zeros((*v.shape[:-1], 1)), v], axis=-1)
    return product(product(q, qv), conjugate(q))[..., 1:]


def log(q: NDArray[np.float64]) -> NDArray[np.float64]:
    """The rotation vector, twice the quaternion logarithm (axis times angle, rad), of
    ``(..., 4)`` unit quaternions, the short way round (an angle of at most pi).
    """
    q = np.where(q[..., :1] < 0, -q, q)
    v = q[..., 1:]
    norm = np.linalg.norm(v, axis=-1)
    angle_ = 2 * portable.arctan2(norm, q[..., 0])
    scale = np.where(norm > 1e-12, angle_ / np.maximum(norm, 1e-300), 2.0)
    return v * scale[..., None]


def exp(r: NDArray[np.float64]) -> NDArray[np.float64]:
    """The quaternion of the rotation vector ``r`` (``(..., 3)``, rad), the inverse of :func:`log`:
    ``(cos(|r| / 2), sin(|r| / 2) r / |r|)``, unit to rounding (not renormalized, so that a
    product with it can be normalized once).
    """
    theta = np.linalg.norm(r, axis=-1)
    scale = np.where(theta > 1e-12, portable.sin(theta / 2) / np.maximum(theta, 1e-300), 0.5)
    return np.concatenate([portable.cos(theta / 2)[..., None], r * scale[..., None]], axis=-1)


def angle(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """The angle (rad) of the rotation between unit quaternions ``a`` and ``b``, either sign."""
    theta: NDArray[np.float64] = 2.0 * portable.arccos(np.minimum(1.0, np.abs(np.sum(a * b, axis=-1))))
    return theta


def slerp(q0: NDArray[np.float64], q1: NDArray[np.float64], s: NDArray[np.float64]) -> NDArray[np.float64]:
    """Spherical linear interpolation between rows of ``(M, 4)`` unit quaternions at fractions
    ``s`` (M,), the short way round.
    """
    dot = np.sum(q0 * q1, axis=-1)
    q1 = np.where(dot[:, None] < 0, -q1, q1)
    dot = np.abs(dot).clip(-1.0, 1.0)
    theta = portable.arccos(dot)
    small = theta < 1e-9
    sin = np.where(small, 1.0, portable.sin(theta))
    w0 = np.where(small, 1.0 - s, portable.sin((1.0 - s) * theta) / sin)
    w1 = np.where(small, s, portable.sin(s * theta) / sin)
    out = w0[:, None] * q0 + w1[:, None] * q1
    unit: NDArray[np.float64] = out / np.linalg.norm(out, axis=1, keepdims=True)
    return unit


def continuous(q: NDArray[np.float64]) -> NDArray[np.float64]:
    """``(T, 4)`` quaternions with signs flipped so that consecutive ones are on the same
    hemisphere (a flip between samples would look like a jump of 2 pi to a derivative).
    """
    out = q.copy()
    for j in range(1, len(out)):
        if np.sum(out[j] * out[j - 1]) < 0:
            out[j] = -out[j]
    return out


def check_unit(q: NDArray[np.float64], name: str, normalize: bool = False) -> NDArray[np.float64]:
    """``q`` (T, 4) checked to be unit quaternions: the zero quaternion is refused, and so is a
    norm off by more than :data:`UNIT_TOLERANCE` unless ``normalize`` (then every row is scaled
    to unit norm). Raises naming the first offending sample.
    """
    norms = np.linalg.norm(q, axis=1)
    zero = norms == 0.0
    off = zero if normalize else np.abs(norms - 1.0) > UNIT_TOLERANCE
    if off.any():
        j = int(np.argmax(off))
        why = (
            "the zero quaternion is not a rotation and cannot be normalized" if zero[j] else
            f"orientations must be unit quaternions (|norm - 1| <= {UNIT_TOLERANCE:g}); pass normalize=True to "
            "scale them"
        )
        raise InvalidInputError(
            f"{name}[{j}] has the quaternion (w, x, y, z) = {q[j].tolist()} of norm {norms[j]}: {why}"
        )
    return q / norms[:, None] if normalize else q
