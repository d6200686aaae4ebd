"""Online DMPs: execute a :class:`dmprs.DMP` or :class:`dmprs.CartesianDMP` inside a control
loop, one control period per :meth:`~JointStepper.step` (Rust core:
``crates/dmp-core/src/stepper.rs``, ``cartesian_stepper.rs``; docs/method.md §2.5).

Open loop and without coupling, the k-th call of ``step()`` returns sample k of the DMP's
``rollout(dt)`` (t = k dt) bit for bit: the rollout is this stepper run open loop. Online, the
stepper adds:

* **phase stopping** (Ijspeert et al. 2002, 2013): ``step(measured)`` with the robot's position
  slows the clock by ``1 + sum_d alpha_e[d] (measured[d] - y[d])^2`` (``y`` the last command),
  the phase and the transformation system alike, from the next sample on, so a held robot waits
  at one phase and resumes; without ``acceleration_max`` the clock follows the measurement at
  once (a measurement that jumps jumps the velocity), with it as fast as the limit allows;
* **a goal filter**: :meth:`~JointStepper.set_goal` moves the attractor as
  ``tau dg/dt = goal_filter (g_new - g)`` (the orientation along the geodesic), so a goal jump
  does not jump the acceleration; ``goal_filter=None`` switches to the goal at once;
* **limits by temporal coupling** (Dahlin & Karayiannidis, IEEE RA-L 2021): ``velocity_max`` and
  ``acceleration_max`` slow the clock (tau grows) instead of clipping the command, so the path
  stays the DMP's; velocities are never exceeded, accelerations whenever feasible, and
  :meth:`~JointStepper.over_limit` says when they are not (docs/method.md §2.5.4);
* **coupling terms** added to ``tau dz/dt`` (eq. 1): a repulsion from ``position_min`` /
  ``position_max``; for a Cartesian DMP, sphere ``obstacles`` (Park et al. 2008's dynamic
  potential field); and the caller's ``step(coupling=...)``. A command that they hold at rest
  short of its goal is never ``done()`` but ``blocked()``.

``step()`` returns three read-only arrays that the **next call overwrites** (so that a call costs
no allocation): copy them to keep them. Each step knows the time scale of the next, so the
returned acceleration is the change of the returned velocity to the next sample's:
``yd[k+1] == yd[k] + ydd[k] * dt`` to rounding with one sub-step. ``copy.copy`` and
``copy.deepcopy`` give an independent stepper in the same state, whose steps are this one's
bit for bit.

Example::

    stepper = dmp.stepper(0.001, velocity_max=1.0)
    while not stepper.done():
        y, yd, ydd = stepper.step(robot.position())
        robot.command(y, yd, ydd)
"""

from __future__ import annotations

from typing import Any, Self

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dmprs import _core
from dmprs._arrays import as_count, as_float_array, as_scalar, check_finite
from dmprs.errors import InvalidInputError

__all__ = ["CartesianStepper", "JointStepper"]

# The defaults live in the Rust core (StepperOptions::new and its parts).
_DEFAULTS = _core.Stepper.DEFAULTS
_COORDINATES = "x, y, z, then the 3 of the orientation"


def _core_of(dmp: Any, core_type: type, expected: str) -> Any:
    core = getattr(dmp, "_core", None)
    if not isinstance(core, core_type):
        raise InvalidInputError(f"dmp is a {type(dmp).__name__}; expected a {expected}")
    return core


def _per_coordinate(value: Any, name: str, n: int, what: str) -> NDArray[np.float64]:
    """A scalar for every coordinate, or one value each; no NaN (infinities are the caller's
    to allow).
    """
    arr = as_float_array(value, name, (0, 1))
    if np.ndim(value) == 0:  # a scalar is every coordinate's; a list of one is one coordinate's
        arr = np.repeat(arr, n)
    if arr.shape != (n,):
        raise InvalidInputError(f"{name} has shape {arr.shape}, expected a scalar or ({n},): one per {what}")
    if np.isnan(arr).any():
        check_finite(arr, name)
    return arr


def _refuse(arr: NDArray[np.float64], bad: NDArray[np.bool_], name: str, rule: str) -> None:
    if bad.any():
        i = int(np.argmax(bad))
        raise InvalidInputError(f"{name}[{i}] = {arr[i]:g} is invalid: {rule}")


def _gains(value: Any, name: str, n: int, what: str) -> list[float]:
    arr = _per_coordinate(value, name, n, what)
    check_finite(arr, name)
    _refuse(arr, arr < 0, name, "must be >= 0")
    return _floats(arr)


def _limits(value: Any, name: str, n: int, what: str) -> list[float] | None:
    """Speed or acceleration limits: > 0, ``inf`` for none."""
    if value is None:
        return None
    arr = _per_coordinate(value, name, n, what)
    _refuse(arr, ~(arr > 0), name, "must be > 0 (inf for no limit)")
    return _floats(arr)


def _positions(value: Any, name: str, n: int) -> list[float] | None:
    """Position limits: any number, ``-inf`` / ``inf`` for none."""
    return None if value is None else _floats(_per_coordinate(value, name, n, "position coordinate"))


def _margins(value: Any, n: int) -> list[float] | None:
    if value is None:
        return None
    arr = _per_coordinate(value, "limit_margin", n, "position coordinate")
    check_finite(arr, "limit_margin")
    _refuse(arr, arr <= 0, "limit_margin", "must be > 0")
    return _floats(arr)


def _floats(arr: NDArray[np.float64]) -> list[float]:
    """The array as the list of floats the core's options take."""
    values: list[float] = arr.tolist()
    return values


def _options(
    n: int,
    n_position: int,
    what: str,
    dt: Any,
    substeps: Any,
    alpha_e: Any,
    goal_filter: Any,
    velocity_max: Any,
    acceleration_max: Any,
    position_min: Any,
    position_max: Any,
    limit_margin: Any,
    limit_gain: Any,
    gamma_nominal: Any,
    gamma_a: Any,
    eps: Any,
    rest_tol: Any,
) -> tuple[float, _core._StepperOptions]:
    """The options both steppers share, validated: ``n`` coordinates, ``n_position`` of them
    positions (the ones position limits act on).
    """
    return as_scalar(dt, "dt", positive=True), {
        "substeps": None if substeps is None else as_count(substeps, "substeps", 1),
        "alpha_e": _gains(alpha_e, "alpha_e", n, what),
        "goal_filter": None if goal_filter is None else as_scalar(goal_filter, "goal_filter", positive=True),
        "velocity_max": _limits(velocity_max, "velocity_max", n, what),
        "acceleration_max": _limits(acceleration_max, "acceleration_max", n, what),
        "position_min": _positions(position_min, "position_min", n_position),
        "position_max": _positions(position_max, "position_max", n_position),
        "limit_margin": _margins(limit_margin, n_position),
        "limit_gain": as_scalar(limit_gain, "limit_gain", positive=True),
        "gamma_nominal": as_scalar(gamma_nominal, "gamma_nominal", positive=True),
        "gamma_a": _nonnegative(gamma_a, "gamma_a"),
        "eps": as_scalar(eps, "eps", positive=True),
        "rest_tol": as_scalar(rest_tol, "rest_tol", positive=True),
    }


def _nonnegative(value: Any, name: str) -> float:
    x = as_scalar(value, name)
    if x < 0:
        raise InvalidInputError(f"{name} = {x:g} is invalid: must be >= 0")
    return x


def _obstacles(value: Any) -> NDArray[np.float64] | None:
    """(M, 4) rows ``x, y, z, radius``; a single (4,) row is accepted."""
    if value is None:
        return None
    arr = as_float_array(value, "obstacles", (1, 2))
    arr = arr.reshape(1, -1) if arr.ndim == 1 else arr
    if arr.shape[1] != 4:
        raise InvalidInputError(f"obstacles has shape {arr.shape}, expected (M, 4): x, y, z, radius per sphere")
    check_finite(arr, "obstacles")
    if (arr[:, 3] < 0).any():
        i = int(np.argmax(arr[:, 3] < 0))
        raise InvalidInputError(f"obstacles[{i}] has radius {arr[i, 3]:g}: radii must be >= 0")
    return np.ascontiguousarray(arr)


class JointStepper(_core.Stepper):
    """Executes a :class:`dmprs.DMP` one control period at a time (module docs).

    Args:
        dmp: the DMP.
        dt: the control period (s).
        substeps: Euler sub-steps per period; default the fewest stable ones, the rollout's
            rule (1 for any ``dt`` within explicit Euler's stability limit).
        alpha_e: phase-stopping gain(s) in 1/(units of y)^2, scalar or one per DOF: a tracking
            error of ``1/sqrt(alpha_e)`` halves the clock's speed (default 1e4: 0.01 rad or m).
            Used only when ``step`` is given ``measured``; 0 switches it off.
        goal_filter: ``alpha_g`` of the goal filter (default 24 = alpha_z / 2); None: a new
            goal acts at once.
        velocity_max, acceleration_max: limits per DOF (scalar or (D,), ``inf`` for none), met
            by temporal coupling (the clock slows; the path is kept).
        position_min, position_max: position limits per DOF (``-inf`` / ``inf`` for none); the
            command is repelled inside a band of ``limit_margin`` (default 5 % of the range) next
            to each.
        limit_gain: the repulsion's gain kappa: at half the band from a limit it pushes as hard
            as the DMP's spring over ``kappa`` bands.
        gamma_nominal, gamma_a, eps: the temporal coupling's gains (the rate back to the nominal
            tau, the weight and floor of the acceleration potential; Dahlin & Karayiannidis'
            values 1, 0.5, 1e-3).
        rest_tol: tolerance of :meth:`done` (units of y), the rollout's ``rest_tol``.
    """

    __slots__ = ()

    def __new__(
        cls,
        dmp: Any,
        dt: float,
        *,
        substeps: int | None = None,
        alpha_e: float | ArrayLike = _DEFAULTS["alpha_e"],
        goal_filter: float | None = _DEFAULTS["goal_filter"],
        velocity_max: float | ArrayLike | None = None,
        acceleration_max: float | ArrayLike | None = None,
        position_min: float | ArrayLike | None = None,
        position_max: float | ArrayLike | None = None,
        limit_margin: float | ArrayLike | None = None,
        limit_gain: float = _DEFAULTS["limit_gain"],
        gamma_nominal: float = _DEFAULTS["gamma_nominal"],
        gamma_a: float = _DEFAULTS["gamma_a"],
        eps: float = _DEFAULTS["eps"],
        rest_tol: float = _DEFAULTS["rest_tol"],
    ) -> Self:
        """A stepper for ``dmp`` at control period ``dt`` (s); options as the class docs."""
        core = _core_of(dmp, _core.Dmp, "dmprs.DMP")
        n = core.n_dof
        period, opts = _options(
            n, n, "DOF", dt, substeps, alpha_e, goal_filter, velocity_max, acceleration_max,
            position_min, position_max, limit_margin, limit_gain, gamma_nominal, gamma_a, eps, rest_tol,
        )
        return super().__new__(cls, core, period, opts)


def _obstacle_options(obstacles: ArrayLike | None, gain: float, beta: float) -> tuple[Any, float, float]:
    """The obstacles, ``obstacle_gain`` and ``obstacle_beta`` validated, as the core takes them."""
    beta = as_scalar(beta, "obstacle_beta")
    if beta < 1:
        raise InvalidInputError(f"obstacle_beta = {beta:g} is invalid: must be >= 1")
    return _obstacles(obstacles), as_scalar(gain, "obstacle_gain", positive=True), beta


class CartesianStepper(_core.CartesianStepper):
    """Executes a :class:`dmprs.CartesianDMP` one control period at a time (module docs).

    ``step(measured=None, coupling=None)`` returns ``(pose, velocity, acceleration)``: pose
    ``(7,)`` ``x, y, z, qw, qx, qy, qz``; velocity ``(6,)`` the linear then the angular velocity
    (world frame, rad/s); acceleration ``(6,)`` likewise. ``measured`` is the robot's pose (7,),
    ``coupling`` 6 values added to ``tau dz/dt`` (position, then orientation).

    Per-coordinate options (``alpha_e``, ``velocity_max``, ``acceleration_max``) are a scalar or 6
    values: x, y, z (units of position), then the three orientation coordinates (rad): phase
    stopping weighs the rotation angle of the measured orientation in rad. Position limits
    (``position_min``, ``position_max``, ``limit_margin``: scalar or 3 values) bound the
    position in a box. ``obstacles`` are spheres, an ``(M, 4)`` array of ``x, y, z, radius``
    (radius 0: a point), avoided with Park et al.'s dynamic potential field of gain
    ``obstacle_gain`` (lambda, units of position squared) and ``obstacle_beta``; replace them
    while running with :meth:`set_obstacles`. The field's push is bounded (at most
    ``16 alpha_z |z|``, and it never lengthens ``z`` by more than half the DMP's damping), a
    start, goal or current position inside a sphere (or on its surface) is refused naming the
    argument that brought it, and a sphere exactly ahead is passed on a fixed side
    (docs/method.md §2.5.5). :meth:`blocked` says when the movement came to rest away from its
    goal (held by an obstacle, a limit or a coupling term). Other options as
    :class:`JointStepper`.
    """

    __slots__ = ()

    def __new__(
        cls,
        dmp: Any,
        dt: float,
        *,
        substeps: int | None = None,
        alpha_e: float | ArrayLike = _DEFAULTS["alpha_e"],
        goal_filter: float | None = _DEFAULTS["goal_filter"],
        velocity_max: float | ArrayLike | None = None,
        acceleration_max: float | ArrayLike | None = None,
        position_min: float | ArrayLike | None = None,
        position_max: float | ArrayLike | None = None,
        limit_margin: float | ArrayLike | None = None,
        limit_gain: float = _DEFAULTS["limit_gain"],
        gamma_nominal: float = _DEFAULTS["gamma_nominal"],
        gamma_a: float = _DEFAULTS["gamma_a"],
        eps: float = _DEFAULTS["eps"],
        rest_tol: float = _DEFAULTS["rest_tol"],
        obstacles: ArrayLike | None = None,
        obstacle_gain: float = _DEFAULTS["obstacle_gain"],
        obstacle_beta: float = _DEFAULTS["obstacle_beta"],
    ) -> Self:
        """A stepper for ``dmp`` at control period ``dt`` (s); options as the class docs."""
        core = _core_of(dmp, _core.CartesianDmp, "dmprs.CartesianDMP")
        period, opts = _options(
            6, 3, _COORDINATES, dt, substeps, alpha_e, goal_filter, velocity_max, acceleration_max,
            position_min, position_max, limit_margin, limit_gain, gamma_nominal, gamma_a, eps, rest_tol,
        )
        return super().__new__(cls, core, period, opts, *_obstacle_options(obstacles, obstacle_gain, obstacle_beta))

    def set_obstacles(self, obstacles: ArrayLike | None) -> None:
        """Replaces the sphere obstacles, ``(M, 4)`` rows ``x, y, z, radius`` (None: none); a
        sphere holding the goal or the current position is refused, the obstacles unchanged.
        """
        super().set_obstacles(_obstacles(obstacles))
