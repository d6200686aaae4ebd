"""Dynamic Movement Primitives: the discrete DMP of paper eqs. 1-4, fitted and rolled out by the
Rust core."""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import TYPE_CHECKING, Any, overload

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dmprs import _core
from dmprs._arrays import as_count, as_flag, as_float_array, as_scalar, short
from dmprs._core import Dmp as _CoreDmp
from dmprs.errors import InvalidInputError
from dmprs.stepper import JointStepper
from dmprs.trajectory import CartesianTrajectory, Trajectory

if TYPE_CHECKING:
    from dmprs.cartesian import CartesianDMP

__all__ = ["DMP", "rollout_batch"]

_DICT_TYPE = "dmprs.DMP"
_DICT_VERSION = 1


def _constants(alpha_z: Any, beta_z: Any, alpha_x: Any, width_factor: Any) -> dict[str, float]:
    az = as_scalar(alpha_z, "alpha_z", positive=True)
    bz = az / 4.0 if beta_z is None else as_scalar(beta_z, "beta_z", positive=True)
    return {
        "alpha_z": az,
        "beta_z": bz,
        "alpha_x": as_scalar(alpha_x, "alpha_x", positive=True),
        "width_factor": as_scalar(width_factor, "width_factor", positive=True),
    }


def _rollout_options(dt: Any, duration: Any, until_rest: bool, rest_tol: Any) -> dict[str, Any]:
    return {
        "dt": as_scalar(dt, "dt", positive=True),
        "duration": None if duration is None else as_scalar(duration, "duration", positive=True),
        "until_rest": as_flag(until_rest, "until_rest"),
        "rest_tol": as_scalar(rest_tol, "rest_tol", positive=True),
    }


class DMP:
    r"""A discrete Dynamic Movement Primitive with D degrees of freedom sharing one phase.

    The equations (Nemec, Vuga, Ude 2013, eqs. 1-4; Ijspeert/Schaal), per DOF::

        tau * dz/dt = alpha_z * (beta_z * (g - y) - z) + f(x)      (1)
        tau * dy/dt = z                                            (2)
        tau * dx/dt = -alpha_x * x                                 (3)
        f(x) = sum_k w_k Psi_k(x) / sum_k Psi_k(x) * x             (4)
        Psi_k(x) = exp(-h_k (x - c_k)^2)

    There is **no (g - y0) amplitude factor** in f: the weights are in the units of y, so they
    can be interpolated between demonstrations with different goals. Constants default to the
    JSI lab's: ``alpha_z = 48``, ``beta_z = alpha_z / 4`` (critically damped), ``alpha_x = 2``;
    centres ``c_k = exp(-alpha_x (k-1)/(N-1))`` and widths ``h_k = width_factor /
    (c_{k+1} - c_k)^2`` with ``width_factor = 2`` and ``h_N = h_{N-1}``.

    Build one with :meth:`fit` from a demonstration, or from its parameters::

        DMP(weights, goal, y0, tau)   # weights (D, N), goal (D,), y0 (D,), tau > 0 (s)

    DMPs are immutable; :meth:`with_goal`, :meth:`with_start` and :meth:`with_tau` return new ones.
    """

    __slots__ = ("_core",)
    _core: _core.Dmp

    def __init__(
        self,
        weights: ArrayLike,
        goal: ArrayLike,
        y0: ArrayLike,
        tau: float,
        *,
        alpha_z: float = 48.0,
        beta_z: float | None = None,
        alpha_x: float = 2.0,
        width_factor: float = 2.0,
    ) -> None:
        w = as_float_array(weights, "weights", (1, 2))
        w = w.reshape(1, -1) if w.ndim == 1 else w
        g = np.atleast_1d(as_float_array(goal, "goal", (0, 1)))
        s = np.atleast_1d(as_float_array(y0, "y0", (0, 1)))
        if w.shape[0] != g.shape[0]:
            raise InvalidInputError(
                f"weights has {w.shape[0]} rows (DOFs) but goal has {g.shape[0]} entries"
            )
        as_count(w.shape[1], "n_basis (columns of weights)", 2)
        core = _core.Dmp(
            w, g, s, as_scalar(tau, "tau", positive=True),
            **_constants(alpha_z, beta_z, alpha_x, width_factor),
        )
        object.__setattr__(self, "_core", core)

    @classmethod
    def _wrap(cls, core: _CoreDmp) -> DMP:
        self = object.__new__(cls)
        object.__setattr__(self, "_core", core)
        return self

    def __setattr__(self, name: str, value: Any) -> None:
        raise AttributeError("DMP is immutable; use with_goal, with_start or with_tau")

    @classmethod
    def fit(
        cls,
        t: ArrayLike,
        y: ArrayLike,
        n_basis: int = 25,
        yd: ArrayLike | None = None,
        ydd: ArrayLike | None = None,
        *,
        alpha_z: float = 48.0,
        beta_z: float | None = None,
        alpha_x: float = 2.0,
        width_factor: float = 2.0,
    ) -> DMP:
        """Fits a DMP to one demonstration by batch least squares (docs/method.md §2.3).

        ``tau = t[-1] - t[0]``, ``g = y[-1]``, ``y0 = y[0]``; with
        ``x_j = exp(-alpha_x (t_j - t_0) / tau)`` and
        ``F_j = tau^2 ydd_j - alpha_z (beta_z (g - y_j) - tau yd_j)``, the weights solve
        ``min |A w - F|^2`` where ``A_jk = Psi_k(x_j) x_j / sum_i Psi_i(x_j)`` (entries below
        1e-8 set to 0, a ridge of 1e-10 x the mean diagonal for kernels no sample reaches).

        Args:
            t: sample times (T,), strictly increasing, possibly non-uniform; T >= 3.
            y: positions (T,) or (T, D).
            n_basis: number of kernels N >= 2 (25 for short strikes, 40 for a 3 s profile).
            yd, ydd: measured velocities and accelerations, shaped like y. When omitted they are
                computed with second-order finite differences on the (non-uniform) grid, exactly
                the scheme of ``numpy.gradient(y, t, edge_order=2)``, applied twice. Smooth noisy
                data first: differentiation amplifies noise.
        """
        tt = as_float_array(t, "t", 1)
        yy = as_float_array(y, "y", (1, 2))
        yy = yy.reshape(-1, 1) if yy.ndim == 1 else yy
        derivs: list[NDArray[np.float64] | None] = []
        for name, value in (("yd", yd), ("ydd", ydd)):
            if value is None:
                derivs.append(None)
                continue
            arr = as_float_array(value, name, (1, 2))
            derivs.append(arr.reshape(-1, 1) if arr.ndim == 1 else arr)
        core = _core.Dmp.fit(
            tt, yy, derivs[0], derivs[1],
            n_basis=as_count(n_basis, "n_basis", 2),
            **_constants(alpha_z, beta_z, alpha_x, width_factor),
        )
        return cls._wrap(core)

    # --- parameters -------------------------------------------------------------------------
    @property
    def weights(self) -> NDArray[np.float64]:
        """Shape weights, (D, N), in the units of y (times s^-2 s^2: see eq. 1)."""
        return self._core.weights

    @property
    def goal(self) -> NDArray[np.float64]:
        """Goal g, (D,)."""
        return self._core.goal

    @property
    def y0(self) -> NDArray[np.float64]:
        """Start position, (D,)."""
        return self._core.y0

    @property
    def tau(self) -> float:
        """Temporal scaling (s); the duration of the demonstration it was fitted to."""
        return self._core.tau

    @property
    def n_dof(self) -> int:
        return self._core.n_dof

    @property
    def n_basis(self) -> int:
        return self._core.n_basis

    @property
    def alpha_z(self) -> float:
        return self._core.alpha_z

    @property
    def beta_z(self) -> float:
        return self._core.beta_z

    @property
    def alpha_x(self) -> float:
        return self._core.alpha_x

    @property
    def width_factor(self) -> float:
        return self._core.width_factor

    @property
    def centers(self) -> NDArray[np.float64]:
        """Kernel centres c_k on the phase, (N,)."""
        return self._core.centers

    @property
    def widths(self) -> NDArray[np.float64]:
        """Kernel widths h_k, (N,)."""
        return self._core.widths

    # --- behaviour --------------------------------------------------------------------------
    def rollout(
        self,
        dt: float = 0.001,
        duration: float | None = None,
        *,
        until_rest: bool = False,
        rest_tol: float = 1e-4,
    ) -> Trajectory:
        """Integrates eqs. 1-3 with explicit Euler at step ``dt`` (s) from x = 1, y = y0, z = 0.

        Returns a :class:`Trajectory` sampled at ``t_j = j * dt`` up to ``duration`` (default
        tau; rounded up to a whole step). The phase is still e^-2 = 0.135 at tau; pass
        ``until_rest=True`` to go on until every DOF is within ``rest_tol`` of its goal, at rest,
        and no longer driven by the forcing term.
        """
        opts = _rollout_options(dt, duration, until_rest, rest_tol)
        return Trajectory._trusted(*self._core.rollout(**opts))

    def stepper(self, dt: float = 0.001, **options: Any) -> JointStepper:
        """An online stepper for a control loop of period ``dt`` (s): one ``step(measured)`` per
        period, with phase stopping, goal changes, limits and coupling terms; ``options`` as
        :class:`dmprs.stepper.JointStepper` (``substeps``, ``alpha_e``, ``goal_filter``,
        ``velocity_max``, ``acceleration_max``, ``position_min``, ``position_max``, ...)."""
        return JointStepper(self, dt, **options)

    def with_goal(self, goal: ArrayLike) -> DMP:
        """The same movement towards a new goal (weights and tau unchanged)."""
        return DMP._wrap(self._core.with_goal(np.atleast_1d(as_float_array(goal, "goal", (0, 1)))))

    def with_start(self, y0: ArrayLike) -> DMP:
        """The same movement from a new start position."""
        return DMP._wrap(self._core.with_start(np.atleast_1d(as_float_array(y0, "y0", (0, 1)))))

    def with_tau(self, tau: float) -> DMP:
        """The same path at another speed: scaling tau by k stretches time by k, nothing else."""
        return DMP._wrap(self._core.with_tau(as_scalar(tau, "tau", positive=True)))

    # --- serialization ----------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """A JSON-safe dict of plain floats and lists; :meth:`from_dict` restores it exactly."""
        return {
            "type": _DICT_TYPE,
            "version": _DICT_VERSION,
            "tau": self.tau,
            "goal": self.goal.tolist(),
            "y0": self.y0.tolist(),
            "weights": self.weights.tolist(),
            "alpha_z": self.alpha_z,
            "beta_z": self.beta_z,
            "alpha_x": self.alpha_x,
            "width_factor": self.width_factor,
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> DMP:
        """Inverse of :meth:`to_dict`."""
        if not isinstance(data, Mapping):
            raise InvalidInputError(f"expected a dict from DMP.to_dict(); got {type(data).__name__}")
        if data.get("type") != _DICT_TYPE:
            raise InvalidInputError(f"not a DMP dict: 'type' is {data.get('type')!r}, expected {_DICT_TYPE!r}")
        version = data.get("version")
        if type(version) is not int or version > _DICT_VERSION or version < 1:
            raise InvalidInputError(
                f"DMP dict version {short(version)} is not supported (this dmprs reads version {_DICT_VERSION})"
            )
        required = ("tau", "goal", "y0", "weights", "alpha_z", "beta_z", "alpha_x", "width_factor")
        missing = [k for k in required if k not in data]
        if missing:
            raise InvalidInputError(f"DMP dict is missing {', '.join(missing)}")
        unknown = sorted(set(data) - set(required) - {"type", "version"}, key=str)
        if unknown:
            raise InvalidInputError(f"DMP dict has unknown keys {', '.join(map(short, unknown))}")
        if data["beta_z"] is None:
            raise InvalidInputError("DMP dict has beta_z = None; to_dict() always writes a number")
        return cls(
            data["weights"], data["goal"], data["y0"], data["tau"],
            alpha_z=data["alpha_z"], beta_z=data["beta_z"],
            alpha_x=data["alpha_x"], width_factor=data["width_factor"],
        )

    def __reduce__(self) -> tuple[Any, ...]:
        return (DMP.from_dict, (self.to_dict(),))

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, DMP):
            return NotImplemented
        return self.to_dict() == other.to_dict()

    __hash__ = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        return (
            f"DMP(n_dof={self.n_dof}, n_basis={self.n_basis}, tau={self.tau:.6g}, "
            f"goal={np.array2string(self.goal, precision=4)})"
        )


@overload
def rollout_batch(
    dmps: Iterable[DMP], dt: float = ..., duration: float | None = ..., *,
    until_rest: bool = ..., rest_tol: float = ...,
) -> list[Trajectory]: ...
@overload
def rollout_batch(
    dmps: Iterable[CartesianDMP], dt: float = ..., duration: float | None = ..., *,
    until_rest: bool = ..., rest_tol: float = ...,
) -> list[CartesianTrajectory]: ...
@overload
def rollout_batch(
    dmps: Iterable[DMP | CartesianDMP], dt: float = ..., duration: float | None = ..., *,
    until_rest: bool = ..., rest_tol: float = ...,
) -> list[Trajectory | CartesianTrajectory]: ...
def rollout_batch(
    dmps: Iterable[DMP | CartesianDMP],
    dt: float = 0.001,
    duration: float | None = None,
    *,
    until_rest: bool = False,
    rest_tol: float = 1e-4,
) -> list[Trajectory] | list[CartesianTrajectory] | list[Trajectory | CartesianTrajectory]:
    """Rolls out many DMPs in one call, in parallel on all cores with the GIL released.

    The result equals ``[d.rollout(dt, duration, ...) for d in dmps]`` bit for bit. Each DMP
    keeps its own tau, so with ``duration=None`` the trajectories may differ in length.
    :class:`dmprs.CartesianDMP` s (which give :class:`dmprs.CartesianTrajectory` s) may be mixed in.
    """
    from dmprs.cartesian import CartesianDMP  # cartesian builds on this module

    if isinstance(dmps, DMP) or not isinstance(dmps, Iterable):
        raise InvalidInputError(f"dmps must be an iterable of dmprs.DMP or dmprs.CartesianDMP; got {short(dmps)}")
    items = list(dmps)
    for i, d in enumerate(items):
        if not isinstance(d, (DMP, CartesianDMP)):
            raise InvalidInputError(f"dmps[{i}] is a {type(d).__name__}, not a dmprs.DMP or dmprs.CartesianDMP")
    opts = _rollout_options(dt, duration, until_rest, rest_tol)
    joint = [(i, d) for i, d in enumerate(items) if isinstance(d, DMP)]
    pose = [(i, d) for i, d in enumerate(items) if isinstance(d, CartesianDMP)]
    out: list[Any] = [None] * len(items)
    if joint:
        arrays = _core.rollout_batch([d._core for _, d in joint], **opts)
        for (i, _), a in zip(joint, arrays, strict=True):
            out[i] = Trajectory._trusted(*a)
    if pose:
        cartesian = _core.rollout_batch_cartesian([d._core for _, d in pose], **opts)
        for (i, _), c in zip(pose, cartesian, strict=True):
            out[i] = CartesianTrajectory._trusted(*c)
    return out
