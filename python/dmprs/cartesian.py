"""Cartesian-space DMPs: position and orientation (unit quaternion) on one phase, fitted and rolled
out by the Rust core (``crates/dmp-core/src/cartesian.rs``; docs/cartesian.md).
"""

from __future__ import annotations

from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dmprs import _core
from dmprs._arrays import as_count, as_float_array
from dmprs.errors import InvalidInputError
from dmprs.primitive import DiscretePrimitive, Parameters, constants, rollout_options
from dmprs.stepper import CartesianStepper
from dmprs.trajectory import CartesianTrajectory

__all__ = ["CartesianDMP"]

def pose_array(value: ArrayLike, name: str) -> NDArray[np.float64]:
    """A pose ``(7,)``, ``x, y, z, qw, qx, qy, qz``, validated (the core checks the quaternion)."""
    p = as_float_array(value, name, 1)
    if p.shape != (7,):
        raise InvalidInputError(f"{name} has shape {p.shape}, expected (7,): x, y, z, qw, qx, qy, qz")
    return p


def derivative_array(value: ArrayLike | None, name: str) -> NDArray[np.float64] | None:
    """A pose demonstration's measured derivative ``(T, 3)``, or None."""
    return None if value is None else as_float_array(value, name, 2)


def twist_array(value: ArrayLike) -> NDArray[np.float64]:
    """A final velocity ``(6,)``: ``vx, vy, vz`` (m/s), then ``wx, wy, wz`` (rad/s, world frame)."""
    v = as_float_array(value, "final_velocity", 1)
    if v.shape != (6,):
        raise InvalidInputError(
            f"final_velocity has shape {v.shape}, expected (6,): vx, vy, vz (m/s), then wx, wy, wz (rad/s)"
        )
    return v


class CartesianDMP(DiscretePrimitive):
    r"""A DMP of an end-effector pose: position ``p`` (m) and orientation ``q``, a unit
    quaternion ``(w, x, y, z)``, sharing one phase, one basis and one tau.

    The position follows the discrete DMP of paper eqs. 1-4 (as :class:`dmprs.DMP`); the
    orientation follows the quaternion DMP of Ude, Nemec, Petrič, Morimoto (ICRA 2014)::

        tau * d(eta)/dt = alpha_z * (beta_z * 2 log(g_o * conj(q)) - eta) + f_o(x)
        tau * dq/dt     = 1/2 * eta * q
        f_o(x) = sum_k w_k Psi_k(x) / sum_k Psi_k(x) * x        (w_k in R^3, eq. 4)

    with ``eta = tau * omega`` (``omega`` the angular velocity in the world frame), ``*`` the
    quaternion product and ``log(q) = arccos(w) v / |v|`` (half the rotation vector). The rollout
    integrates ``q <- exp(dt / (2 tau) * eta) * q``, so q stays a unit quaternion. For a rotation
    about one fixed axis this is exactly the discrete DMP of the angle. Constants as
    :class:`dmprs.DMP`: ``alpha_z = 48``, ``beta_z = alpha_z / 4``, ``alpha_x = 2``.

    Poses are ``(7,)`` arrays ``x, y, z, qw, qx, qy, qz``, the layout of pytransform3d and
    movement_primitives. Build one with :meth:`fit`, or from its parameters::

        CartesianDMP(weights, goal, start, tau)   # weights (6, N): x, y, z, then 3 orientation rows

    ``final_velocity`` ``(6,)``, ``vx, vy, vz`` (m/s) then ``wx, wy, wz`` (rad/s, world frame),
    makes it reach the goal pose moving at that linear and angular velocity at ``t = tau``
    (docs/cartesian.md, "A final velocity"; None: zero, the DMP above).

    Immutable; :meth:`with_goal`, :meth:`with_start` and :meth:`with_tau` return new ones.
    See docs/cartesian.md for the equations of the fit and the decisions behind them.
    """

    __slots__ = ()
    _CORE = _core.CartesianDmp
    _core: _core.CartesianDmp
    _DICT_TYPE = "dmprs.CartesianDMP"
    _OPTIONAL = ("final_velocity",)

    def __init__(self, *args: Any, final_velocity: ArrayLike | None = None, **kwargs: Any) -> None:
        """As :class:`~dmprs.primitive.DiscretePrimitive` (weights, goal, start, tau and the
        constants), and the final velocity ``(6,)`` it reaches its goal pose with (None: zero).
        """
        super().__init__(*args, **kwargs)
        if final_velocity is not None:
            object.__setattr__(self, "_core", self._core.with_final_velocity(twist_array(final_velocity)))

    @property
    def final_velocity(self) -> NDArray[np.float64]:
        """The velocity ``(6,)`` the movement reaches its goal pose with at ``t = tau``: ``vx, vy,
        vz`` (m/s), then ``wx, wy, wz`` (rad/s, world frame); zeros for the DMP without one.
        """
        v = self._core.final_velocity
        return np.zeros(6) if v is None else v

    def _optional_parameters(self) -> dict[str, Any]:
        v = self._core.final_velocity
        return {} if v is None else {"final_velocity": v.tolist()}

    @staticmethod
    def _parameters(weights: ArrayLike, goal: ArrayLike, start: ArrayLike) -> Parameters:
        w = as_float_array(weights, "weights", 2)
        if w.shape[0] != 6:
            raise InvalidInputError(
                f"weights has shape {w.shape}, expected (6, N): x, y, z, then 3 orientation rows"
            )
        as_count(w.shape[1], "n_basis (columns of weights)", 2)
        return w, pose_array(goal, "goal"), pose_array(start, "start")

    @classmethod
    def fit(
        cls,
        t: ArrayLike,
        pose: ArrayLike,
        n_basis: int = 25,
        *,
        velocity: ArrayLike | None = None,
        angular_velocity: ArrayLike | None = None,
        acceleration: ArrayLike | None = None,
        angular_acceleration: ArrayLike | None = None,
        normalize: bool = False,
        alpha_z: float = 48.0,
        beta_z: float | None = None,
        alpha_x: float = 2.0,
        width_factor: float = 2.0,
        final_velocity: ArrayLike | Literal["demo"] | None = None,
    ) -> CartesianDMP:
        """Fits position and orientation to one pose demonstration by batch least squares.

        ``tau = t[-1] - t[0]``, goal = the last pose, start = the first. The position is fitted
        as :meth:`dmprs.DMP.fit`; the orientation on the target
        ``F_j = tau^2 omegadot_j - alpha_z (beta_z 2 log(g_o * conj(q_j)) - tau omega_j)`` with
        the same design matrix. Quaternion sign flips between samples (q and -q are the same
        rotation) are removed first.

        Args:
            t: sample times (T,), strictly increasing, possibly non-uniform; T >= 3.
            pose: (T, 7) ``x, y, z, qw, qx, qy, qz``; quaternions unit to 1e-6.
            n_basis: kernels N >= 2.
            velocity: measured linear velocity (T, 3); computed with second-order finite
                differences when omitted (as :meth:`dmprs.DMP.fit`).
            angular_velocity: measured, world frame (T, 3). When omitted, ``omega_j`` is the
                same second-order scheme applied in the tangent space at sample j
                (``sum_i c_ji 2 log(q_i * conj(q_j))``).
            acceleration: measured linear acceleration (T, 3); when omitted, the scheme on the
                velocity.
            angular_acceleration: measured, world frame (T, 3); when omitted, the scheme on
                ``omega``.
            normalize: scale every quaternion to unit norm instead of refusing one whose norm is
                off by more than 1e-6 (the zero quaternion is refused either way).
            alpha_z: the transformation system's gain, as :meth:`dmprs.DMP.fit`.
            beta_z: its damping, ``alpha_z / 4`` when None.
            alpha_x: the phase decay, at most ln 1e8.
            width_factor: kernel width relative to the spacing of the kernel centres.
            final_velocity: the velocity ``(6,)`` the DMP reaches its goal pose with at
                ``t = tau``, ``vx, vy, vz`` (m/s) then ``wx, wy, wz`` (rad/s, world frame);
                ``"demo"`` for the demonstration's last linear and angular velocity; None for
                zero. With one, both parts are fitted against their moving goals
                (docs/cartesian.md, "A final velocity").
        """
        from_demo = isinstance(final_velocity, str)
        if from_demo and final_velocity != "demo":
            raise InvalidInputError(f"final_velocity must be an array, 'demo' or None; got {final_velocity!r}")
        given = None if final_velocity is None or from_demo else twist_array(final_velocity)
        derivatives = {
            "velocity": derivative_array(velocity, "velocity"),
            "acceleration": derivative_array(acceleration, "acceleration"),
            "angular_velocity": derivative_array(angular_velocity, "angular_velocity"),
            "angular_acceleration": derivative_array(angular_acceleration, "angular_acceleration"),
        }
        core = _core.CartesianDmp.fit(as_float_array(t, "t", 1), as_float_array(pose, "pose", 2), derivatives,
                                      bool(normalize), as_count(n_basis, "n_basis", 2),
                                      constants(alpha_z, beta_z, alpha_x, width_factor), given, from_demo)
        return cls._wrap(core)

    @classmethod
    def fit_trajectory(cls, trajectory: CartesianTrajectory, n_basis: int = 25, **options: Any) -> CartesianDMP:
        """:meth:`fit` to a :class:`~dmprs.CartesianTrajectory`, with its measured derivatives."""
        if not isinstance(trajectory, CartesianTrajectory):
            raise InvalidInputError(
                f"trajectory is a {type(trajectory).__name__}; expected a dmprs.CartesianTrajectory"
            )
        tr = trajectory
        return cls.fit(
            tr.t, tr.pose, n_basis, velocity=tr.velocity, angular_velocity=tr.angular_velocity,
            acceleration=tr.acceleration, angular_acceleration=tr.angular_acceleration, **options,
        )

    # --- behaviour --------------------------------------------------------------------------
    def rollout(
        self,
        dt: float = 0.001,
        duration: float | None = None,
        *,
        until_rest: bool = False,
        rest_tol: float = 1e-4,
    ) -> CartesianTrajectory:
        """Integrates position and orientation with explicit Euler at step ``dt`` (s) from rest
        at the start pose, ``q <- exp(dt / (2 tau) eta) * q``.

        Returns a :class:`~dmprs.CartesianTrajectory` sampled at ``t_j = j * dt`` up to
        ``duration`` (default tau), with velocities and accelerations. ``until_rest=True`` goes
        on until the position is within ``rest_tol`` (m) and the orientation within ``rest_tol``
        (rad) of the goal, at rest, and no longer driven by the forcing term. A DMP with a final
        velocity moves on at it past tau and never rests: ``until_rest`` is refused for it.
        """
        opts = rollout_options(dt, duration, until_rest, rest_tol)
        return CartesianTrajectory._trusted(*self._core.rollout(**opts))

    def stepper(self, dt: float = 0.001, **options: Any) -> CartesianStepper:
        """An online stepper for a control loop of period ``dt`` (s): one ``step(measured)`` per
        period returning ``(pose, velocity, acceleration)``, with phase stopping, goal changes,
        limits, position limits and sphere ``obstacles``; ``options`` as
        :class:`dmprs.stepper.CartesianStepper`. A DMP with a final velocity moves on at it past
        tau, so its stepper is never ``done()``: stop at the phase ``exp(-alpha_x)`` (``t = tau``)
        or hand over to the next primitive.
        """
        return CartesianStepper(self, dt, **options)

    def with_final_velocity(self, final_velocity: ArrayLike) -> CartesianDMP:
        """The same movement reaching its goal pose with ``final_velocity`` ``(6,)`` at ``t = tau``:
        ``vx, vy, vz`` (m/s), then ``wx, wy, wz`` (rad/s, world frame). Position and orientation
        pull to goals moving at those velocities that arrive at the goal pose at tau. Zeros give
        the DMP without one, bit for bit.
        """
        return CartesianDMP._wrap(self._core.with_final_velocity(twist_array(final_velocity)))

    def with_goal(self, pose: ArrayLike) -> CartesianDMP:
        """The same movement towards a new goal pose (7,). The quaternion's sign is taken on the
        side of the current goal, so ``q`` and ``-q`` give the same movement.
        """
        return CartesianDMP._wrap(self._core.with_goal(pose_array(pose, "goal")))

    def with_start(self, pose: ArrayLike) -> CartesianDMP:
        """The same movement from a new start pose (7,) (sign on the side of the current start)."""
        return CartesianDMP._wrap(self._core.with_start(pose_array(pose, "start")))
