"""What every movement primitive shares (the spring's constants, the parameters, immutability,
equality, pickling and the dict form), and what the discrete ones (:class:`dmprs.DMP`,
:class:`dmprs.CartesianDMP`) add: the decaying phase.

The discrete primitives follow paper eqs. 1-4 on one phase with the same constants
(``alpha_z = 48``, ``beta_z = alpha_z / 4``, ``alpha_x = 2``, ``width_factor = 2``;
docs/method.md §2.2); :class:`dmprs.PeriodicDMP` shares the spring on a periodic phase (§11).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, ClassVar, Self

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dmprs import _core
from dmprs._arrays import as_flag, as_scalar, short
from dmprs.errors import InvalidInputError

__all__ = ["DiscretePrimitive", "Primitive", "constants", "rollout_options", "spring"]

#: A primitive's weights, goal and start, validated as its core takes them.
Parameters = tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]

def spring(alpha_z: Any, beta_z: Any, width_factor: Any) -> dict[str, float]:
    """The constants every primitive has, validated, as the core takes them (``beta_z=None``:
    ``alpha_z / 4``, critically damped).
    """
    az = as_scalar(alpha_z, "alpha_z", positive=True)
    bz = az / 4.0 if beta_z is None else as_scalar(beta_z, "beta_z", positive=True)
    return {"alpha_z": az, "beta_z": bz, "width_factor": as_scalar(width_factor, "width_factor", positive=True)}


def constants(alpha_z: Any, beta_z: Any, alpha_x: Any, width_factor: Any) -> dict[str, float]:
    """A discrete primitive's constants, validated, as the core takes them."""
    return {**spring(alpha_z, beta_z, width_factor), "alpha_x": as_scalar(alpha_x, "alpha_x", positive=True)}


def rollout_options(dt: Any, duration: Any, until_rest: Any, rest_tol: Any) -> dict[str, Any]:
    """A rollout's options, validated, as the core takes them."""
    return {
        "dt": as_scalar(dt, "dt", positive=True),
        "duration": None if duration is None else as_scalar(duration, "duration", positive=True),
        "until_rest": as_flag(until_rest, "until_rest"),
        "rest_tol": as_scalar(rest_tol, "rest_tol", positive=True),
    }


_DICT_VERSION = 2
#: keys that version 1 of the dict form named otherwise (a DMP's start was "y0")
_RENAMED_IN_2 = {"y0": "start"}


class Primitive:
    """What every primitive shares: an immutable wrapper of the Rust core's primitive
    (``_core``), its parameters, ``with_tau``, ``==``, pickling and :meth:`to_dict` /
    :meth:`from_dict`. Subclasses add how to build, fit and roll out, and how a goal and a start
    are given.
    """

    __slots__ = ("_core",)
    _core: _core.Dmp | _core.CartesianDmp | _core.PeriodicDmp | _core.PeriodicCartesianDmp
    #: the ``type`` of the dict form
    _DICT_TYPE: ClassVar[str]
    #: the parameters' names, in the order of the dict form; the constructor takes each by name
    _PARAMETERS: ClassVar[tuple[str, ...]] = ("tau", "goal", "start", "weights")
    #: the constants' names, in the order of the dict form; the constructor takes each by name
    _CONSTANTS: ClassVar[tuple[str, ...]] = ("alpha_z", "beta_z", "width_factor")
    #: parameters the dict form holds only when they are not their default (so a primitive
    #: without them writes the dict it always did); the constructor takes each by name
    _OPTIONAL: ClassVar[tuple[str, ...]] = ()

    @classmethod
    def _wrap(cls, core: Any) -> Self:
        self = object.__new__(cls)
        object.__setattr__(self, "_core", core)
        return self

    def __setattr__(self, name: str, value: Any) -> None:
        raise AttributeError(f"{type(self).__name__} is immutable; use with_goal, with_start or with_tau")

    # --- parameters -------------------------------------------------------------------------
    @property
    def weights(self) -> NDArray[np.float64]:
        """Shape weights ``(D, N)``, one row per coordinate, in its units (no (g - y0) factor in
        eq. 4, so weights of demonstrations with different goals can be interpolated).
        """
        return self._core.weights

    @property
    def goal(self) -> NDArray[np.float64]:
        """The goal: ``(D,)``, or the pose ``(7,)`` of a Cartesian DMP."""
        return self._core.goal

    @property
    def start(self) -> NDArray[np.float64]:
        """The start (the paper's y0): ``(D,)``, or the pose ``(7,)`` of a Cartesian DMP."""
        return self._core.start

    @property
    def tau(self) -> float:
        """Temporal scaling (s); the duration of the demonstration it was fitted to."""
        return self._core.tau

    @property
    def n_dof(self) -> int:
        """Coordinates D (a Cartesian DMP has 6: three translations and three rotations)."""
        return self._core.n_dof

    @property
    def n_basis(self) -> int:
        """Kernels N."""
        return self._core.n_basis

    @property
    def alpha_z(self) -> float:
        """The spring's gain in eq. 1."""
        return self._core.alpha_z

    @property
    def beta_z(self) -> float:
        """The spring's stiffness ratio in eq. 1 (``alpha_z / 4``: critically damped)."""
        return self._core.beta_z

    @property
    def width_factor(self) -> float:
        """How wide the kernels are relative to their spacing."""
        return self._core.width_factor

    @property
    def centers(self) -> NDArray[np.float64]:
        """Kernel centres c_k on the phase, (N,)."""
        return self._core.centers

    def _constants(self) -> dict[str, float]:
        return {name: getattr(self, name) for name in self._CONSTANTS}

    def _optional_parameters(self) -> dict[str, Any]:
        """The :attr:`_OPTIONAL` parameters that are not their default, as the dict form holds them."""
        return {}

    # --- behaviour --------------------------------------------------------------------------
    def with_tau(self, tau: float) -> Self:
        """The same path at another speed: scaling tau by k stretches time by k, nothing else."""
        return self._wrap(self._core.with_tau(as_scalar(tau, "tau", positive=True)))

    # --- serialization ----------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """A JSON-safe dict of plain floats and lists; :meth:`from_dict` restores it exactly."""
        parameters = {name: getattr(self, name) for name in self._PARAMETERS}
        return {
            "type": self._DICT_TYPE,
            "version": _DICT_VERSION,
            **{k: v.tolist() if isinstance(v, np.ndarray) else v for k, v in parameters.items()},
            **self._constants(),
            **self._optional_parameters(),
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Self:
        """Inverse of :meth:`to_dict` (also reads version 1, whose DMPs named the start y0)."""
        kind = cls._DICT_TYPE.removeprefix("dmprs.")
        if not isinstance(data, Mapping):
            raise InvalidInputError(f"expected a dict from {kind}.to_dict(); got {type(data).__name__}")
        if data.get("type") != cls._DICT_TYPE:
            raise InvalidInputError(
                f"not a {kind} dict: 'type' is {short(data.get('type'))}, expected {cls._DICT_TYPE!r}")
        version = data.get("version")
        if type(version) is not int or not 1 <= version <= _DICT_VERSION:
            raise InvalidInputError(f"{kind} dict version {short(version)} is not supported (this dmprs reads "
                                    f"versions 1 to {_DICT_VERSION})")
        fields = {(_RENAMED_IN_2.get(k, k) if version == 1 else k): v for k, v in data.items()}
        required = (*cls._PARAMETERS, *cls._CONSTANTS)
        missing = [k for k in required if k not in fields]
        if missing:
            raise InvalidInputError(f"{kind} dict is missing {', '.join(missing)}")
        unknown = sorted(set(fields) - set(required) - set(cls._OPTIONAL) - {"type", "version"}, key=str)
        if unknown:
            raise InvalidInputError(f"{kind} dict has unknown keys {', '.join(map(short, unknown))}")
        if fields["beta_z"] is None:
            raise InvalidInputError(f"{kind} dict has beta_z = None; to_dict() always writes a number")
        optional = {name: fields[name] for name in cls._OPTIONAL if name in fields}
        return cls(**{name: fields[name] for name in required}, **optional)

    def __reduce__(self) -> tuple[Any, ...]:
        return (type(self).from_dict, (self.to_dict(),))

    def __eq__(self, other: object) -> bool:
        if type(other) is not type(self):
            return NotImplemented
        assert isinstance(other, Primitive)
        return self.to_dict() == other.to_dict()

    __hash__ = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        return (f"{type(self).__name__}(n_dof={self.n_dof}, n_basis={self.n_basis}, tau={self.tau:.6g}, "
                f"goal={np.array2string(self.goal, precision=4)})")


class DiscretePrimitive(Primitive):
    """What :class:`dmprs.DMP` and :class:`dmprs.CartesianDMP` add to :class:`Primitive`: the
    decaying phase of eq. 3 and its constant ``alpha_x``, and kernels of their own widths.
    """

    __slots__ = ()
    #: the core's class the constructor builds
    _CORE: ClassVar[type[_core.Dmp | _core.CartesianDmp]]
    _core: _core.Dmp | _core.CartesianDmp
    _CONSTANTS = ("alpha_z", "beta_z", "alpha_x", "width_factor")

    def __init__(
        self,
        weights: ArrayLike,
        goal: ArrayLike,
        start: ArrayLike,
        tau: float,
        *,
        alpha_z: float = 48.0,
        beta_z: float | None = None,
        alpha_x: float = 2.0,
        width_factor: float = 2.0,
    ) -> None:
        w, g, s = self._parameters(weights, goal, start)
        core = self._CORE(w, g, s, as_scalar(tau, "tau", positive=True),
                          constants(alpha_z, beta_z, alpha_x, width_factor))
        object.__setattr__(self, "_core", core)

    @staticmethod
    def _parameters(weights: ArrayLike, goal: ArrayLike, start: ArrayLike) -> Parameters:
        """The weights, goal and start validated as the subclass's core takes them."""
        raise NotImplementedError

    @property
    def alpha_x(self) -> float:
        """The phase's decay in eq. 3."""
        return self._core.alpha_x

    @property
    def widths(self) -> NDArray[np.float64]:
        """Kernel widths ``h_k = width_factor / (c_{k+1} - c_k)^2``, (N,)."""
        return self._core.widths
