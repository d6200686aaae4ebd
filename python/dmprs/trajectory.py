"""Sampled trajectories, time-major."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dmprs import quaternion as quaternion_
from dmprs._arrays import as_float_array, check_finite, check_increasing
from dmprs.errors import InvalidInputError

_JOINT_FIELDS = ("t", "y", "yd", "ydd")


class _Samples:
    """What a joint-space and a pose trajectory share, read from the fields the subclass
    declares (``_FIELDS``, ``t`` first): the sample count, the duration, the dict of arrays,
    equality and freezing the validated arrays.
    """

    _FIELDS: ClassVar[tuple[str, ...]]
    t: NDArray[np.float64]

    def _freeze(self, fields: dict[str, NDArray[np.float64] | None]) -> None:
        """Stores read-only copies of the validated ``fields``."""
        for name, value in fields.items():
            owned = None if value is None else value.copy()  # never alias the caller's array
            if owned is not None:
                owned.setflags(write=False)
            object.__setattr__(self, name, owned)

    @property
    def n_samples(self) -> int:
        """The number of samples T."""
        return int(self.t.shape[0])

    @property
    def duration(self) -> float:
        """``t[-1] - t[0]`` (s)."""
        return float(self.t[-1] - self.t[0])

    def __len__(self) -> int:
        return self.n_samples

    def _known(self) -> list[str]:
        """The fields that hold an array, in declaration order."""
        return [name for name in self._FIELDS if getattr(self, name) is not None]

    def to_arrays(self, prefix: str = "") -> dict[str, NDArray[np.float64]]:
        """Its arrays by field name (``t``, the positions and the known derivatives), each name
        prefixed: what the database, the run logs and the recordings store (:func:`from_arrays`
        reads it).
        """
        return {f"{prefix}{name}": getattr(self, name) for name in self._known()}

    def __eq__(self, other: object) -> bool:
        # a joint-space and a pose trajectory never compare equal (NotImplemented both ways)
        if not isinstance(other, _Samples) or other._FIELDS != self._FIELDS:
            return NotImplemented
        for name in self._FIELDS:
            a, b = getattr(self, name), getattr(other, name)
            if (a is None) != (b is None):
                return False
            if a is not None and (a.shape != b.shape or not np.array_equal(a, b)):
                return False
        return True

    __hash__ = None  # type: ignore[assignment]


@dataclass(frozen=True, eq=False)
class Trajectory(_Samples):
    """Positions ``y`` (T, D) at times ``t`` (T,), with velocities ``yd`` and accelerations
    ``ydd`` (T, D) when known. SI units; arrays are read-only float64.

    A 1-D ``y`` is taken as one degree of freedom. Construction validates: finite values,
    strictly increasing (possibly non-uniform) ``t``, matching shapes.
    """

    t: NDArray[np.float64]
    y: NDArray[np.float64]
    yd: NDArray[np.float64] | None = None
    ydd: NDArray[np.float64] | None = None
    _FIELDS = _JOINT_FIELDS

    def __post_init__(self) -> None:
        t = as_float_array(self.t, "t", 1)
        check_increasing(t)
        fields: dict[str, NDArray[np.float64] | None] = {"t": t}
        y = as_float_array(self.y, "y", (1, 2))
        y = y.reshape(-1, 1) if y.ndim == 1 else y
        if y.shape[0] != t.shape[0]:
            raise InvalidInputError(f"y has {y.shape[0]} samples but t has {t.shape[0]}")
        if y.shape[1] == 0:
            raise InvalidInputError("y has no degrees of freedom (shape (T, 0))")
        check_finite(y, "y")
        fields["y"] = y
        for name in ("yd", "ydd"):
            value = getattr(self, name)
            if value is None:
                fields[name] = None
                continue
            arr = as_float_array(value, name, (1, 2))
            arr = arr.reshape(-1, 1) if arr.ndim == 1 else arr
            if arr.shape != y.shape:
                raise InvalidInputError(f"{name} has shape {arr.shape}, expected {y.shape} like y")
            check_finite(arr, name)
            fields[name] = arr
        self._freeze(fields)

    @classmethod
    def _trusted(cls, t: Any, y: Any, yd: Any, ydd: Any) -> Trajectory:
        """Wraps arrays fresh from the core (already valid) without re-checking them."""
        self = object.__new__(cls)
        for name, arr in (("t", t), ("y", y), ("yd", yd), ("ydd", ydd)):
            if arr is not None:
                arr.setflags(write=False)
            object.__setattr__(self, name, arr)
        return self

    @property
    def n_dof(self) -> int:
        """The number of degrees of freedom D."""
        return int(self.y.shape[1])

    def __repr__(self) -> str:
        return (
            f"Trajectory(n_samples={self.n_samples}, n_dof={self.n_dof}, "
            f"duration={self.duration:.6g} s, fields={'+'.join(self._known())})"
        )


_CARTESIAN_FIELDS = (
    "t", "position", "quaternion", "velocity", "angular_velocity", "acceleration", "angular_acceleration",
)


@dataclass(frozen=True, eq=False)
class CartesianTrajectory(_Samples):
    """A pose trajectory at times ``t`` (T,): ``position`` (T, 3) in m and ``quaternion`` (T, 4),
    scalar first ``(w, x, y, z)`` and unit norm, with the linear ``velocity``, ``acceleration``
    and the world-frame ``angular_velocity``, ``angular_acceleration`` (T, 3) when known. SI
    units (m, rad, s); arrays are read-only float64.

    :attr:`pose` is the (T, 7) array ``x, y, z, qw, qx, qy, qz`` of pytransform3d and
    movement_primitives; :meth:`from_pose` builds one from it. Construction validates: finite
    values, strictly increasing ``t``, matching shapes, and unit quaternions (to 1e-6).
    Quaternions are kept as given, signs included (a fit makes them sign-continuous).
    """

    t: NDArray[np.float64]
    position: NDArray[np.float64]
    quaternion: NDArray[np.float64]
    velocity: NDArray[np.float64] | None = None
    angular_velocity: NDArray[np.float64] | None = None
    acceleration: NDArray[np.float64] | None = None
    angular_acceleration: NDArray[np.float64] | None = None
    _FIELDS = _CARTESIAN_FIELDS

    def __post_init__(self) -> None:
        t = as_float_array(self.t, "t", 1)
        check_increasing(t)
        fields: dict[str, NDArray[np.float64] | None] = {"t": t}
        for name in _CARTESIAN_FIELDS[1:]:
            value = getattr(self, name)
            if value is None and name not in ("position", "quaternion"):
                fields[name] = None
                continue
            width = 4 if name == "quaternion" else 3
            arr = as_float_array(value, name, 2)
            if arr.shape != (t.shape[0], width):
                raise InvalidInputError(
                    f"{name} has shape {arr.shape}, expected ({t.shape[0]}, {width}): one row per entry of t"
                )
            check_finite(arr, name)
            fields[name] = arr
        quaternion = fields["quaternion"]
        assert quaternion is not None
        quaternion_.check_unit(quaternion, "quaternion")
        self._freeze(fields)

    @classmethod
    def from_pose(
        cls,
        t: Any,
        pose: Any,
        *,
        normalize: bool = False,
        velocity: Any = None,
        angular_velocity: Any = None,
        acceleration: Any = None,
        angular_acceleration: Any = None,
    ) -> CartesianTrajectory:
        """From a (T, 7) ``pose`` array ``x, y, z, qw, qx, qy, qz``; ``normalize=True`` scales
        each quaternion to unit norm instead of refusing one off by more than 1e-6.
        """
        p = as_float_array(pose, "pose", 2)
        if p.shape[1] != 7:
            raise InvalidInputError(
                f"pose has shape {p.shape}, expected (T, 7): x, y, z, qw, qx, qy, qz per sample"
            )
        check_finite(p, "pose")
        q = quaternion_.check_unit(p[:, 3:], "pose", normalize)
        return cls(t, p[:, :3], q, velocity, angular_velocity, acceleration, angular_acceleration)

    @classmethod
    def unchecked(cls, t: Any, pose: Any) -> CartesianTrajectory:
        """A pose trajectory from ``t`` and ``pose`` (T, 7) built without any check, for testing
        what its consumers refuse (a NaN, a non-unit quaternion, a start elsewhere); never for
        data. Every consumer checks it with :func:`dmprs.adapters.spec.pose_problems`.
        """
        t = np.asarray(t, dtype=np.float64)
        pose = np.asarray(pose, dtype=np.float64)
        return cls._trusted(t, pose[:, :3], pose[:, 3:], None, None, None, None)

    @classmethod
    def _trusted(cls, *arrays: Any) -> CartesianTrajectory:
        """Wraps arrays fresh from the core (already valid and read-only) without re-checking
        them.
        """
        self = object.__new__(cls)
        self.__dict__.update(zip(_CARTESIAN_FIELDS, arrays, strict=True))  # one call: rollouts are hot
        return self

    @property
    def pose(self) -> NDArray[np.float64]:
        """(T, 7): ``x, y, z, qw, qx, qy, qz``."""
        out = np.hstack([self.position, self.quaternion])
        out.setflags(write=False)
        return out

    @property
    def n_dof(self) -> int:
        """6: three translations and three rotations."""
        return 6

    def __repr__(self) -> str:
        return (
            f"CartesianTrajectory(n_samples={self.n_samples}, duration={self.duration:.6g} s, "
            f"fields={'+'.join(self._known())})"
        )


#: What an adapter executes: joint-space samples, or poses of a Cartesian DMP's rollout.
AnyTrajectory = Trajectory | CartesianTrajectory


def from_arrays(arrays: Mapping[str, NDArray[np.float64]], prefix: str = "") -> AnyTrajectory | None:
    """The trajectory :meth:`Trajectory.to_arrays` or :meth:`CartesianTrajectory.to_arrays` wrote
    under ``prefix`` (a pose trajectory when there is a ``position``), validated as on
    construction; None when there is no ``t``. Any other name under the prefix is an error.
    """
    fields = {name[len(prefix):]: arr for name, arr in arrays.items() if name.startswith(prefix)}
    if "t" not in fields:
        return None
    pose = "position" in fields
    allowed, required = (_CARTESIAN_FIELDS, ("t", "position", "quaternion")) if pose else (_JOINT_FIELDS, ("t", "y"))
    missing = [f"{prefix}{n}" for n in required if n not in fields]
    extra = sorted(f"{prefix}{n}" for n in fields if n not in allowed)
    if missing or extra:
        raise InvalidInputError(
            f"arrays {sorted(prefix + n for n in fields)} are not a {'pose ' if pose else ''}trajectory: "
            + "; ".join(([f"missing {', '.join(missing)}"] if missing else [])
                        + ([f"unknown {', '.join(extra)}"] if extra else [])))
    if pose:
        return CartesianTrajectory(**fields)
    return Trajectory(**fields)


def nanoseconds(t: ArrayLike) -> NDArray[np.int64]:
    """Times (s) in whole nanoseconds, as ROS 2's ``builtin_interfaces`` carry them."""
    return np.round(np.asarray(t, dtype=float) * 1e9).astype(np.int64)


def controller_times(t: NDArray[np.float64]) -> NDArray[np.float64]:
    """``t`` from its first sample, rounded to whole nanoseconds: the times a robot's trajectory
    controller receives over ROS 2 (a ``Duration`` per point). The arm scenes execute these, so
    that a trajectory sent to a served scene through ROS 2 is the same command, bit for bit, as
    one executed in this process.
    """
    t = np.asarray(t, dtype=float)
    out: NDArray[np.float64] = nanoseconds(t - t[0]) / 1e9
    return out
