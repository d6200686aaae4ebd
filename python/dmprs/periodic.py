"""Periodic Dynamic Movement Primitives: a rhythm (wiping, stirring, bouncing a ball) about a
baseline, in joint space or as a full pose, fitted in batch or online and rolled out by the Rust
core (docs/method.md §12).
"""

from __future__ import annotations

from typing import Any, Self

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dmprs import _core
from dmprs._arrays import as_count, as_float_array, as_scalar
from dmprs.cartesian import derivative_array, pose_array
from dmprs.dmp import demonstration_arrays
from dmprs.errors import InvalidInputError
from dmprs.periodic_stepper import PeriodicStepper
from dmprs.primitive import Primitive, spring
from dmprs.trajectory import CartesianTrajectory, Trajectory

__all__ = ["PeriodicCartesianDMP", "PeriodicDMP", "PeriodicOnlineFit"]


def _vector(value: ArrayLike, name: str) -> NDArray[np.float64]:
    return np.atleast_1d(as_float_array(value, name, (0, 1)))


def _per_dof(value: ArrayLike, name: str, n_dof: int) -> NDArray[np.float64]:
    arr = _vector(value, name)
    if arr.shape != (n_dof,):
        raise InvalidInputError(f"{name} has {arr.shape[0]} entries, expected {n_dof} (one per DOF)")
    return arr


def _phase(value: Any) -> float:
    return as_scalar(value, "phase")


class _Rhythm(Primitive):
    """What both periodic primitives add to :class:`dmprs.primitive.Primitive`: the amplitude,
    the period and the von Mises kernels' concentration, a rollout from a phase, and
    ``with_amplitude``.
    """

    __slots__ = ()
    _core: _core.PeriodicDmp | _core.PeriodicCartesianDmp
    _PARAMETERS = ("tau", "goal", "amplitude", "start", "weights")

    @property
    def amplitude(self) -> NDArray[np.float64]:
        """The amplitude r per coordinate: the forcing term's scale (P4), so the rhythm's size
        about the baseline.
        """
        return self._core.amplitude

    @property
    def period(self) -> float:
        """``2 pi tau`` (s)."""
        return 2.0 * np.pi * self.tau

    @property
    def h(self) -> float:
        """The von Mises kernels' shared concentration."""
        return self._core.h

    def _rollout(self, dt: float, duration: float | None, phase: float) -> Any:
        dt_ = as_scalar(dt, "dt", positive=True)
        d = None if duration is None else as_scalar(duration, "duration", positive=True)
        return self._core.rollout(dt_, d, _phase(phase))

    def with_amplitude(self, amplitude: ArrayLike) -> Self:
        """The same rhythm scaled about its baseline: r multiplies the forcing term (P4)."""
        return self._wrap(self._core.with_amplitude(_per_dof(amplitude, "amplitude", self.n_dof)))


class PeriodicDMP(_Rhythm):
    r"""A periodic Dynamic Movement Primitive with D degrees of freedom sharing one phase.

    The equations (Ijspeert, Nakanishi, Hoffmann, Pastor, Schaal 2013; Ude et al. 2010), per DOF::

        tau * dz/dt   = alpha_z * (beta_z * (g - y) - z) + f(phi)    (P1)
        tau * dy/dt   = z                                            (P2)
        tau * dphi/dt = 1,  phi mod 2 pi                             (P3)
        f(phi) = r * sum_i psi_i(phi) w_i / sum_i psi_i(phi)         (P4)
        psi_i(phi) = exp(h * (cos(phi - c_i) - 1)),  c_i = 2 pi i / N

    ``g`` is the baseline the rhythm oscillates about, ``r`` its amplitude (per DOF) and the
    period ``2 pi tau``; each can be changed on its own. The spring's constants are the discrete
    DMP's (``alpha_z = 48``, ``beta_z = alpha_z / 4``); ``h = width_factor / (1 - cos(2 pi / N))``
    so that a kernel falls to ``exp(-width_factor)`` at its neighbours' centres.

    Build one with :meth:`fit` from a demonstration of one or more periods, with
    :class:`PeriodicOnlineFit` from a stream, or from its parameters::

        PeriodicDMP(weights, goal, start, tau, amplitude=...)  # weights (D, N), goal (D,), start (D,)

    Periodic DMPs are immutable; ``with_goal``, ``with_amplitude``, ``with_start`` and
    ``with_tau`` return new ones.
    """

    __slots__ = ()
    _core: _core.PeriodicDmp
    _DICT_TYPE = "dmprs.PeriodicDMP"

    def __init__(
        self,
        weights: ArrayLike,
        goal: ArrayLike,
        start: ArrayLike,
        tau: float,
        *,
        amplitude: ArrayLike | None = None,
        alpha_z: float = 48.0,
        beta_z: float | None = None,
        width_factor: float = 2.0,
    ) -> None:
        w = as_float_array(weights, "weights", (1, 2))
        w = w.reshape(1, -1) if w.ndim == 1 else w
        n_dof = w.shape[0]
        as_count(w.shape[1], "n_basis (columns of weights)", 3)
        g = _per_dof(goal, "goal", n_dof)
        s = _per_dof(start, "start", n_dof)
        r = np.ones(n_dof) if amplitude is None else _per_dof(amplitude, "amplitude", n_dof)
        core = _core.PeriodicDmp(w, g, r, s, as_scalar(tau, "tau", positive=True),
                                 spring(alpha_z, beta_z, width_factor))
        object.__setattr__(self, "_core", core)

    @classmethod
    def fit(
        cls,
        t: ArrayLike,
        y: ArrayLike,
        period: float | None = None,
        n_basis: int = 25,
        yd: ArrayLike | None = None,
        ydd: ArrayLike | None = None,
        *,
        alpha_z: float = 48.0,
        beta_z: float | None = None,
        width_factor: float = 2.0,
    ) -> PeriodicDMP:
        """Fits a periodic DMP to a demonstration of one or more whole periods by batch least
        squares (docs/method.md §12.2).

        ``tau = period / (2 pi)``, the phase ``phi_j = (t_j - t_0) / tau``, the baseline
        ``g = (min y + max y) / 2`` and the amplitude ``r = (max y - min y) / 2`` per DOF (1 for a
        DOF that does not move), the start ``y[0]``; with
        ``F_j = tau^2 ydd_j - alpha_z (beta_z (g - y_j) - tau yd_j)`` the weights solve
        ``min |A w - F / r|^2``, ``A_ji = psi_i(phi_j) / sum_k psi_k(phi_j)``.

        Args:
            t: sample times (T,), strictly increasing; T >= 3.
            y: positions (T,) or (T, D).
            period: the rhythm's period (s), at most the demonstration's duration; by default
                the duration (the demonstration is exactly one period).
            n_basis: kernels N >= 3 on the circle.
            yd: measured velocities, shaped like y; when omitted, second-order finite
                differences as :meth:`dmprs.DMP.fit`. A demonstration of exactly one period is
                best given its derivatives, or several periods: the differences are one-sided
                at the ends.
            ydd: measured accelerations, shaped like y; when omitted, the same scheme on ``yd``.
            alpha_z: the spring's gain (P1).
            beta_z: its damping, ``alpha_z / 4`` (critical damping) when None.
            width_factor: the kernels' width relative to their spacing (§12.1).
        """
        tt, yy, *derivs = demonstration_arrays(t, y, yd, ydd)
        p = None if period is None else as_scalar(period, "period", positive=True)
        core = _core.PeriodicDmp.fit(tt, yy, derivs[0], derivs[1], p, as_count(n_basis, "n_basis", 3),
                                     spring(alpha_z, beta_z, width_factor))
        return cls._wrap(core)

    # --- parameters -------------------------------------------------------------------------
    # --- behaviour --------------------------------------------------------------------------
    def rollout(self, dt: float = 0.001, duration: float | None = None, *, phase: float = 0.0) -> Trajectory:
        """Integrates eqs. P1-P3 with semi-implicit Euler at step ``dt`` (s) from the start at rest
        (``z = 0``) at ``phase`` (rad).

        Returns a :class:`Trajectory` sampled at ``t_j = j * dt`` up to ``duration`` (default one
        period; rounded up to a whole step). From rest the spring settles within about
        ``8 tau / alpha_z`` into the steady rhythm.
        """
        return Trajectory._trusted(*self._rollout(dt, duration, phase))

    def stepper(self, dt: float = 0.001, **options: Any) -> PeriodicStepper:
        """An online stepper for a control loop of period ``dt`` (s): one ``step(measured)`` per
        period, fading in and (after ``stop()``) out, with filtered changes of baseline,
        amplitude and frequency, phase stopping and limits; ``options`` as
        :class:`dmprs.periodic_stepper.PeriodicStepper` (``phase``, ``ramp``, ``change_filter``,
        ``alpha_e``, ``velocity_max``, ``acceleration_max``, ...).
        """
        return PeriodicStepper(self, dt, **options)

    def with_goal(self, goal: ArrayLike) -> PeriodicDMP:
        """The same rhythm about a new baseline g."""
        return self._wrap(self._core.with_goal(_per_dof(goal, "goal", self.n_dof)))

    def with_start(self, start: ArrayLike) -> PeriodicDMP:
        """The same rhythm started (at rest) from a new position."""
        return self._wrap(self._core.with_start(_per_dof(start, "start", self.n_dof)))

    def __repr__(self) -> str:
        return (f"PeriodicDMP(n_dof={self.n_dof}, n_basis={self.n_basis}, period={self.period:.6g}, "
                f"goal={np.array2string(self.goal, precision=4)}, "
                f"amplitude={np.array2string(self.amplitude, precision=4)})")


class PeriodicCartesianDMP(_Rhythm):
    r"""A periodic DMP of an end-effector pose: position (m) and orientation (a unit quaternion
    ``(w, x, y, z)``) on one periodic phase, one basis and one tau.

    The position follows :class:`PeriodicDMP`; the orientation its quaternion counterpart
    (Abu-Dakka, Saveriano, Kyrki 2021)::

        tau * d(eta)/dt = alpha_z * (beta_z * 2 log(g_o * conj(q)) - eta) + r_o * f_o(phi)
        tau * dq/dt     = 1/2 * eta * q

    with ``eta = tau * omega`` (world frame), ``g_o`` the baseline orientation the rhythm turns
    about and ``r_o`` the amplitude per axis; the rollout turns ``q`` by ``exp(h / (2 tau) eta)``
    each step, so it stays a unit quaternion. For a rotation about one fixed axis it is exactly
    the :class:`PeriodicDMP` of the angle.

    Poses are ``(7,)`` arrays ``x, y, z, qw, qx, qy, qz``; ``amplitude`` is ``(6,)`` (x, y, z,
    then the three axes of rotation); weights ``(6, N)``::

        PeriodicCartesianDMP(weights, goal, start, tau, amplitude=...)   # goal: the baseline pose

    Immutable; ``with_goal``, ``with_amplitude``, ``with_start`` and ``with_tau`` return new ones.
    """

    __slots__ = ()
    _core: _core.PeriodicCartesianDmp
    _DICT_TYPE = "dmprs.PeriodicCartesianDMP"

    def __init__(
        self,
        weights: ArrayLike,
        goal: ArrayLike,
        start: ArrayLike,
        tau: float,
        *,
        amplitude: ArrayLike | None = None,
        alpha_z: float = 48.0,
        beta_z: float | None = None,
        width_factor: float = 2.0,
    ) -> None:
        w = as_float_array(weights, "weights", 2)
        if w.shape[0] != 6:
            raise InvalidInputError(
                f"weights has shape {w.shape}, expected (6, N): x, y, z, then 3 orientation rows")
        as_count(w.shape[1], "n_basis (columns of weights)", 3)
        r = np.ones(6) if amplitude is None else _per_dof(amplitude, "amplitude", 6)
        core = _core.PeriodicCartesianDmp(w, pose_array(goal, "goal"), r, pose_array(start, "start"),
                                          as_scalar(tau, "tau", positive=True),
                                          spring(alpha_z, beta_z, width_factor))
        object.__setattr__(self, "_core", core)

    @classmethod
    def fit(
        cls,
        t: ArrayLike,
        pose: ArrayLike,
        period: float | None = None,
        n_basis: int = 25,
        *,
        velocity: ArrayLike | None = None,
        angular_velocity: ArrayLike | None = None,
        acceleration: ArrayLike | None = None,
        angular_acceleration: ArrayLike | None = None,
        normalize: bool = False,
        alpha_z: float = 48.0,
        beta_z: float | None = None,
        width_factor: float = 2.0,
    ) -> PeriodicCartesianDMP:
        """Fits a rhythmic pose to a demonstration of one or more whole periods (docs/method.md
        §12.4).

        The position as :meth:`PeriodicDMP.fit`; the baseline orientation is the middle of the
        demonstration's range of rotation (component-wise, in rotation vectors relative to the
        first sample), the amplitude per axis the half range about it, and the orientation's
        forcing target ``tau^2 omegadot - alpha_z (beta_z 2 log(g_o * conj(q)) - tau omega)``.

        Args:
            t: sample times (T,), strictly increasing; T >= 3.
            pose: (T, 7) ``x, y, z, qw, qx, qy, qz``; quaternions unit to 1e-6.
            period: the rhythm's period (s), at most the duration; by default the duration.
            n_basis: kernels N >= 3 on the circle.
            velocity: measured linear velocity (T, 3); finite differences when omitted.
            angular_velocity: measured, world frame (T, 3); when omitted, as
                :meth:`dmprs.CartesianDMP.fit` computes it.
            acceleration: measured linear acceleration (T, 3).
            angular_acceleration: measured, world frame (T, 3).
            normalize: scale every quaternion to unit norm instead of refusing one whose norm is
                off by more than 1e-6.
            alpha_z: the spring's gain.
            beta_z: its damping, ``alpha_z / 4`` when None.
            width_factor: the kernels' width relative to their spacing.
        """
        derivatives = {
            "velocity": derivative_array(velocity, "velocity"),
            "acceleration": derivative_array(acceleration, "acceleration"),
            "angular_velocity": derivative_array(angular_velocity, "angular_velocity"),
            "angular_acceleration": derivative_array(angular_acceleration, "angular_acceleration"),
        }
        p = None if period is None else as_scalar(period, "period", positive=True)
        core = _core.PeriodicCartesianDmp.fit(
            as_float_array(t, "t", 1), as_float_array(pose, "pose", 2), derivatives, bool(normalize), p,
            as_count(n_basis, "n_basis", 3), spring(alpha_z, beta_z, width_factor))
        return cls._wrap(core)

    def rollout(self, dt: float = 0.001, duration: float | None = None, *,
                phase: float = 0.0) -> CartesianTrajectory:
        """Integrates position and orientation with semi-implicit Euler at step ``dt`` (s) from
        the start pose at rest at ``phase`` (rad); a :class:`~dmprs.CartesianTrajectory` up to
        ``duration`` (default one period).
        """
        return CartesianTrajectory._trusted(*self._rollout(dt, duration, phase))

    def with_goal(self, pose: ArrayLike) -> PeriodicCartesianDMP:
        """The same rhythm about a new baseline pose (7,)."""
        return self._wrap(self._core.with_goal(pose_array(pose, "goal")))

    def with_start(self, pose: ArrayLike) -> PeriodicCartesianDMP:
        """The same rhythm started (at rest) from a new pose (7,)."""
        return self._wrap(self._core.with_start(pose_array(pose, "start")))


class PeriodicOnlineFit:
    """Learns a periodic DMP's weights from a stream of samples by recursive least squares with
    a forgetting factor (docs/method.md §12.3): one :meth:`update` per sample, the weights ready
    at any time, so a rhythm can be learned while it is demonstrated.

    ``forgetting`` (lambda, in [0.5, 1]) weighs a sample k updates old by ``lambda^k``: 1 keeps
    every sample (the batch least squares), 0.995 remembers about 200 samples. ``delta`` sets
    the initial covariance ``P_0 = I / delta``. ``n_dof`` is from 1 to 10,000 and ``n_basis``
    from 3 to 1000.
    """

    __slots__ = ("_constants", "_core")

    def __init__(
        self,
        n_dof: int,
        n_basis: int = 25,
        *,
        forgetting: float = 0.995,
        delta: float = 1e-6,
        alpha_z: float = 48.0,
        beta_z: float | None = None,
        width_factor: float = 2.0,
    ) -> None:
        self._constants = spring(alpha_z, beta_z, width_factor)
        self._core = _core.PeriodicOnlineFit(as_count(n_dof, "n_dof", 1), as_count(n_basis, "n_basis", 3),
                                             self._constants, as_scalar(forgetting, "forgetting", positive=True),
                                             as_scalar(delta, "delta", positive=True))

    @property
    def n_dof(self) -> int:
        """Coordinates D."""
        return int(self.weights.shape[0])

    @property
    def weights(self) -> NDArray[np.float64]:
        """The weights so far, ``(D, N)``."""
        return self._core.weights

    @property
    def samples(self) -> int:
        """Samples taken so far."""
        return self._core.samples

    def update(
        self,
        phase: float,
        tau: float,
        y: ArrayLike,
        yd: ArrayLike,
        ydd: ArrayLike,
        goal: ArrayLike,
        amplitude: ArrayLike,
    ) -> None:
        """Takes one sample ``(y, yd, ydd)`` (each ``(D,)``) at ``phase`` (rad) of a rhythm with
        time constant ``tau`` (its period over 2 pi), baseline ``goal`` and ``amplitude``. A
        sample that would make the fit non-finite is refused, naming it, and changes nothing.
        """
        n = self.n_dof
        self._core.update(_phase(phase), as_scalar(tau, "tau", positive=True), _per_dof(y, "y", n),
                          _per_dof(yd, "yd", n), _per_dof(ydd, "ydd", n), _per_dof(goal, "goal", n),
                          _per_dof(amplitude, "amplitude", n))

    def dmp(self, goal: ArrayLike, start: ArrayLike, tau: float, *,
            amplitude: ArrayLike | None = None) -> PeriodicDMP:
        """The periodic DMP of the weights so far, with these parameters and the fit's constants."""
        return PeriodicDMP(self.weights, goal, start, tau, amplitude=amplitude, **self._constants)
