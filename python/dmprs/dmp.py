"""Dynamic Movement Primitives: the discrete DMP of paper eqs. 1-4, fitted and rolled out by the
Rust core.
"""

from __future__ import annotations

from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dmprs import _core
from dmprs._arrays import as_count, as_float_array, as_scalar
from dmprs.errors import InvalidInputError
from dmprs.primitive import DiscretePrimitive, Parameters, constants, rollout_options
from dmprs.stepper import JointStepper
from dmprs.trajectory import Trajectory

__all__ = ["DMP", "demonstration_arrays"]


def demonstration_arrays(
    t: ArrayLike, y: ArrayLike, yd: ArrayLike | None, ydd: ArrayLike | None
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64] | None, NDArray[np.float64] | None]:
    """A joint demonstration validated as the core's fits take it: ``t`` (T,), then ``y``, ``yd``
    and ``ydd`` as (T, D) columns (a (T,) array is one DOF; a derivative may be None).
    """
    def columns(value: ArrayLike, name: str) -> NDArray[np.float64]:
        arr = as_float_array(value, name, (1, 2))
        return arr.reshape(-1, 1) if arr.ndim == 1 else arr

    return (as_float_array(t, "t", 1), columns(y, "y"), None if yd is None else columns(yd, "yd"),
            None if ydd is None else columns(ydd, "ydd"))


class DMP(DiscretePrimitive):
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

        DMP(weights, goal, start, tau)   # weights (D, N), goal (D,), start (D,), tau > 0 (s)

    DMPs are immutable; :meth:`with_goal`, :meth:`with_start` and :meth:`with_tau` return new ones.
    """

    __slots__ = ()
    _CORE = _core.Dmp
    _core: _core.Dmp
    _DICT_TYPE = "dmprs.DMP"
    _OPTIONAL = ("final_velocity",)

    def __init__(self, *args: Any, final_velocity: ArrayLike | None = None, **kwargs: Any) -> None:
        """As :class:`~dmprs.primitive.DiscretePrimitive` (weights, goal, start, tau and the
        constants), and the velocity ``(D,)`` it reaches its goal with (docs/method.md §2.8;
        None: zero, the DMP of eqs. 1-4).
        """
        super().__init__(*args, **kwargs)
        if final_velocity is not None:
            object.__setattr__(self, "_core", self._core.with_final_velocity(self._velocity(final_velocity)))

    def _velocity(self, value: ArrayLike) -> NDArray[np.float64]:
        """A final velocity as the core takes it: ``(D,)``, a scalar for a one-DOF DMP."""
        v = np.atleast_1d(as_float_array(value, "final_velocity", (0, 1)))
        if v.shape != (self.n_dof,):
            raise InvalidInputError(f"final_velocity has shape {v.shape}, expected ({self.n_dof},): one entry per DOF")
        return v

    @property
    def final_velocity(self) -> NDArray[np.float64]:
        """The velocity ``(D,)`` the movement reaches its goal with at ``t = tau`` (docs/method.md
        §2.8); zeros for the DMP of eqs. 1-4.
        """
        v = self._core.final_velocity
        return np.zeros(self.n_dof) if v is None else v

    def _optional_parameters(self) -> dict[str, Any]:
        v = self._core.final_velocity
        return {} if v is None else {"final_velocity": v.tolist()}

    @staticmethod
    def _parameters(weights: ArrayLike, goal: ArrayLike, start: ArrayLike) -> Parameters:
        w = as_float_array(weights, "weights", (1, 2))
        w = w.reshape(1, -1) if w.ndim == 1 else w
        g = np.atleast_1d(as_float_array(goal, "goal", (0, 1)))
        s = np.atleast_1d(as_float_array(start, "start", (0, 1)))
        if w.shape[0] != g.shape[0]:
            raise InvalidInputError(
                f"weights has {w.shape[0]} rows (DOFs) but goal has {g.shape[0]} entries"
            )
        as_count(w.shape[1], "n_basis (columns of weights)", 2)
        return w, g, s

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
        final_velocity: ArrayLike | Literal["demo"] | None = None,
    ) -> DMP:
        """Fits a DMP to one demonstration by batch least squares (docs/method.md §2.3).

        ``tau = t[-1] - t[0]``, ``g = y[-1]``, the start ``y[0]``; with
        ``x_j = exp(-alpha_x (t_j - t_0) / tau)`` and
        ``F_j = tau^2 ydd_j - alpha_z (beta_z (g - y_j) - tau yd_j)``, the weights solve
        ``min |A w - F|^2`` where ``A_jk = Psi_k(x_j) x_j / sum_i Psi_i(x_j)`` (entries below
        1e-8 set to 0, a ridge of 1e-10 x the mean diagonal for kernels no sample reaches).

        Args:
            t: sample times (T,), strictly increasing, possibly non-uniform; T >= 3.
            y: positions (T,) or (T, D).
            n_basis: number of kernels N >= 2 (25 for short strikes, 40 for a 3 s profile).
            yd: measured velocities, shaped like y. When omitted they are computed with
                second-order finite differences on the (non-uniform) grid, exactly the scheme of
                ``numpy.gradient(y, t, edge_order=2)``. Smooth noisy data first: differentiation
                amplifies noise.
            ydd: measured accelerations, shaped like y; when omitted, the same scheme applied
                to ``yd``.
            alpha_z: the transformation system's gain (eq. 1).
            beta_z: its damping, ``alpha_z / 4`` (critical damping) when None.
            alpha_x: the phase decay (eq. 3); at most ln 1e8, beyond which the phase underflows
                the basis functions and the fit is refused.
            width_factor: kernel width relative to the spacing of the kernel centres.
            final_velocity: the velocity ``(D,)`` the DMP reaches its goal with at ``t = tau``
                (docs/method.md §2.8), ``"demo"`` for the demonstration's last velocity, or None
                for zero (eqs. 1-4). With one, the targets are
                ``F_j = tau^2 ydd_j - alpha_z (beta_z (g - gd (tau - t_j) - y_j) + tau (gd - yd_j))``.
        """
        tt, yy, *derivs = demonstration_arrays(t, y, yd, ydd)
        from_demo = isinstance(final_velocity, str)
        if from_demo and final_velocity != "demo":
            raise InvalidInputError(f"final_velocity must be an array, 'demo' or None; got {final_velocity!r}")
        given = None if final_velocity is None or from_demo else np.atleast_1d(
            as_float_array(final_velocity, "final_velocity", (0, 1)))
        core = _core.Dmp.fit(tt, yy, derivs[0], derivs[1], as_count(n_basis, "n_basis", 2),
                             constants(alpha_z, beta_z, alpha_x, width_factor), given, from_demo)
        return cls._wrap(core)

    # --- behaviour --------------------------------------------------------------------------
    def rollout(
        self,
        dt: float = 0.001,
        duration: float | None = None,
        *,
        until_rest: bool = False,
        rest_tol: float = 1e-4,
    ) -> Trajectory:
        """Integrates eqs. 1-3 with explicit Euler at step ``dt`` (s) from x = 1, y = start, z = 0.

        Returns a :class:`Trajectory` sampled at ``t_j = j * dt`` up to ``duration`` (default
        tau; rounded up to a whole step). The phase is still e^-2 = 0.135 at tau; pass
        ``until_rest=True`` to go on until every DOF is within ``rest_tol`` of its goal, at rest,
        and no longer driven by the forcing term. A DMP with a final velocity moves on at it past
        tau and never rests (docs/method.md §2.8): ``until_rest`` is refused for it.
        """
        opts = rollout_options(dt, duration, until_rest, rest_tol)
        return Trajectory._trusted(*self._core.rollout(**opts))

    def stepper(self, dt: float = 0.001, **options: Any) -> JointStepper:
        """An online stepper for a control loop of period ``dt`` (s): one ``step(measured)`` per
        period, with phase stopping, goal changes, limits and coupling terms; ``options`` as
        :class:`dmprs.stepper.JointStepper` (``substeps``, ``alpha_e``, ``goal_filter``,
        ``velocity_max``, ``acceleration_max``, ``position_min``, ``position_max``, ...). A DMP
        with a final velocity moves on at it past tau, so its stepper is never ``done()``: stop
        at the phase ``exp(-alpha_x)`` (``t = tau``) or hand over to the next primitive
        (:class:`dmprs.Sequence` does).
        """
        return JointStepper(self, dt, **options)

    def with_final_velocity(self, final_velocity: ArrayLike) -> DMP:
        """The same movement reaching its goal with velocity ``final_velocity`` ``(D,)`` at
        ``t = tau`` (docs/method.md §2.8): the spring pulls to a goal moving at that velocity that
        arrives at ``goal`` at tau. Zeros give the DMP of eqs. 1-4, bit for bit.
        """
        return DMP._wrap(self._core.with_final_velocity(self._velocity(final_velocity)))

    def with_goal(self, goal: ArrayLike) -> DMP:
        """The same movement towards a new goal (weights and tau unchanged)."""
        return DMP._wrap(self._core.with_goal(np.atleast_1d(as_float_array(goal, "goal", (0, 1)))))

    def with_start(self, start: ArrayLike) -> DMP:
        """The same movement from a new start position."""
        return DMP._wrap(self._core.with_start(np.atleast_1d(as_float_array(start, "start", (0, 1)))))

    def with_via_points(self, times: ArrayLike, positions: ArrayLike, dt: float = 0.001) -> DMP:
        """The same movement made to pass ``positions`` at ``times`` (s), with its weights changed
        as little as possible (least norm per DOF; docs/method.md §2.6).

        The rollout is linear in the weights, so the via-points are met exactly (to rounding) by
        ``rollout(dt)`` at the samples nearest ``times``, and to the integrator's order at another
        ``dt``. A via-point already on the rollout changes nothing.

        Args:
            times: ``(V,)`` times after the start (s), on different samples of the rollout at
                ``dt``, early enough that the forcing term still acts.
            positions: ``(V, D)`` positions, or ``(V,)`` for a one-DOF DMP.
            dt: the rollout step the via-points are met at.
        """
        tt = np.atleast_1d(as_float_array(times, "times", (0, 1)))
        pp = as_float_array(positions, "positions", (1, 2))
        pp = pp.reshape(-1, 1) if pp.ndim == 1 and self.n_dof == 1 else np.atleast_2d(pp)
        if pp.shape != (tt.shape[0], self.n_dof):
            raise InvalidInputError(f"positions has shape {pp.shape}, expected ({tt.shape[0]}, {self.n_dof}): "
                                    "one row per time, one column per DOF")
        return DMP._wrap(self._core.with_via_points(tt, pp, as_scalar(dt, "dt", positive=True)))
