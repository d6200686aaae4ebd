"""Sampled trajectories, time-major."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dmprs._arrays import as_float_array, check_finite, check_increasing
from dmprs.errors import InvalidInputError


@dataclass(frozen=True, eq=False)
class Trajectory:
    """Positions ``y`` (T, D) at times ``t`` (T,), with velocities ``yd`` and accelerations
    ``ydd`` (T, D) when known. SI units; arrays are read-only float64.

    A 1-D ``y`` is taken as one degree of freedom. Construction validates: finite values,
    strictly increasing (possibly non-uniform) ``t``, matching shapes.
    """

    t: NDArray[np.float64]
    y: NDArray[np.float64]
    yd: NDArray[np.float64] | None = None
    ydd: NDArray[np.float64] | None = None

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
        for name, arr in fields.items():
            if arr is not None:
                arr = arr.copy()  # never alias the caller's array
                arr.setflags(write=False)
            object.__setattr__(self, name, arr)

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
    def n_samples(self) -> int:
        return int(self.t.shape[0])

    @property
    def n_dof(self) -> int:
        return int(self.y.shape[1])

    @property
    def duration(self) -> float:
        return float(self.t[-1] - self.t[0])

    def __len__(self) -> int:
        return self.n_samples

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Trajectory):
            return NotImplemented
        return all(
            (a is None and b is None)
            or (a is not None and b is not None and a.shape == b.shape and bool(np.array_equal(a, b)))
            for a, b in (
                (self.t, other.t), (self.y, other.y), (self.yd, other.yd), (self.ydd, other.ydd)
            )
        )

    __hash__ = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        parts = ["y"] + [n for n in ("yd", "ydd") if getattr(self, n) is not None]
        return (
            f"Trajectory(n_samples={self.n_samples}, n_dof={self.n_dof}, "
            f"duration={self.duration:.6g} s, fields={'+'.join(['t', *parts])})"
        )
