"""Online periodic DMPs: a :class:`dmprs.PeriodicDMP` executed in a control loop, one control
period per :meth:`~PeriodicStepper.step` (Rust core: ``crates/dmp-core/src/periodic_stepper.rs``;
docs/method.md §12.6).

With ``ramp=0`` and nothing changed, measured or limited, the k-th call of ``step()`` returns
sample k of the DMP's ``rollout(dt, phase=...)``, bit for bit. Online, the stepper adds:

* **a start and a stop at rest**: the rhythm fades in over ``ramp`` periods while the baseline
  moves from the start to ``g``, and :meth:`~PeriodicStepper.stop` fades it out over as many and
  brings it to rest at the baseline (or ``rest``); :meth:`~PeriodicStepper.done` once it is;
* **filtered changes**: :meth:`~PeriodicStepper.set_goal`, :meth:`~PeriodicStepper.set_amplitude`
  and :meth:`~PeriodicStepper.set_tau` are approached as ``tau dv/dt = change_filter (v* - v)``
  (the frequency ``1/tau`` for ``set_tau``), so no change jumps the command;
* **phase stopping**: ``step(measured)`` slows the clock by ``1 + sum_d alpha_e[d] (measured[d] -
  y[d])^2``, so the rhythm waits for a held robot;
* **limits by temporal coupling**: ``velocity_max`` and ``acceleration_max`` slow the clock
  instead of clipping (as :class:`dmprs.JointStepper`); :meth:`~PeriodicStepper.over_limit` says
  when an acceleration limit could not be met.

``step()`` returns three read-only arrays that the next call overwrites. The returned
acceleration is the change of the returned velocity to the next sample's and the position
follows the semi-implicit step: ``yd[k+1] == yd[k] + ydd[k] * dt`` and ``y[k+1] == y[k] +
yd[k+1] * dt`` to rounding.

Example::

    stepper = rhythm.stepper(0.002, ramp=1.0, velocity_max=2.0)
    for _ in range(5000):
        y, yd, ydd = stepper.step(robot.position())
        robot.command(y, yd, ydd)
    stepper.stop()
    while not stepper.done():
        robot.command(*stepper.step(robot.position()))
"""

from __future__ import annotations

from typing import Any, Self

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dmprs import _core
from dmprs._arrays import as_float_array, as_scalar
from dmprs.errors import InvalidInputError
from dmprs.stepper import _core_of, _gains, _limits

__all__ = ["PeriodicStepper"]

_DEFAULTS = _core.Stepper.DEFAULTS


def _vector(value: ArrayLike, name: str, n: int) -> NDArray[np.float64]:
    arr = np.atleast_1d(as_float_array(value, name, (0, 1)))
    if arr.shape != (n,):
        raise InvalidInputError(f"{name} has shape {arr.shape}, expected ({n},): one per DOF")
    return np.ascontiguousarray(arr)


class PeriodicStepper(_core.PeriodicStepper):
    """A :class:`dmprs.PeriodicDMP` stepped online at control period ``dt`` (s).

    Args:
        dmp: the periodic DMP.
        dt: the control period (s); too coarse for the spring, it is integrated in the
            rollout's sub-steps; ``dt * change_filter`` must not exceed tau (refused, naming it).
        phase: the phase to start at (rad).
        ramp: periods over which the rhythm fades in and, after ``stop()``, out (0: it starts
            at full amplitude, as the rollout, and stops by the spring alone).
        change_filter: ``alpha_c`` of the filter for baseline, amplitude and frequency changes
            (per radian of phase: 1 settles a change in about three quarters of a period).
        alpha_e: phase-stopping gains, a scalar or one per DOF (0: off).
        velocity_max, acceleration_max: limits, a scalar or one per DOF (``inf``: none).
        gamma_nominal, gamma_a, eps: the temporal coupling's gains (as :class:`dmprs.JointStepper`).
    """

    __slots__ = ()

    def __new__(
        cls,
        dmp: Any,
        dt: float = 0.001,
        *,
        phase: float = 0.0,
        ramp: float = 1.0,
        change_filter: float = 1.0,
        alpha_e: Any = _DEFAULTS["alpha_e"],
        velocity_max: Any = None,
        acceleration_max: Any = None,
        gamma_nominal: float = _DEFAULTS["gamma_nominal"],
        gamma_a: float = _DEFAULTS["gamma_a"],
        eps: float = _DEFAULTS["eps"],
    ) -> Self:
        """A stepper for ``dmp`` at control period ``dt`` (s); options as the class docs."""
        core = _core_of(dmp, _core.PeriodicDmp, "dmprs.PeriodicDMP")
        n = core.n_dof
        ramp_ = as_scalar(ramp, "ramp")
        if ramp_ < 0:
            raise InvalidInputError(f"ramp must be >= 0 (periods; 0: no fade in or out); got {ramp_:g}")
        options: _core._PeriodicStepperOptions = {
            "phase": as_scalar(phase, "phase"),
            "ramp": ramp_,
            "change_filter": as_scalar(change_filter, "change_filter", positive=True),
            "alpha_e": _gains(alpha_e, "alpha_e", n, "DOF"),
            "velocity_max": _limits(velocity_max, "velocity_max", n, "DOF"),
            "acceleration_max": _limits(acceleration_max, "acceleration_max", n, "DOF"),
            "gamma_nominal": as_scalar(gamma_nominal, "gamma_nominal", positive=True),
            "gamma_a": as_scalar(gamma_a, "gamma_a"),
            "eps": as_scalar(eps, "eps", positive=True),
        }
        return super().__new__(cls, core, as_scalar(dt, "dt", positive=True), options)

    def stop(self, rest: ArrayLike | None = None) -> None:
        """Fades the rhythm out over ``ramp`` periods and brings it to rest at ``rest`` (by
        default the baseline); :meth:`done` once it is there, at rest.
        """
        super().stop(None if rest is None else _vector(rest, "rest", self.n_dof))

    def set_goal(self, goal: ArrayLike) -> None:
        """A new baseline, approached through the change filter."""
        super().set_goal(_vector(goal, "goal", self.n_dof))

    def set_amplitude(self, amplitude: ArrayLike) -> None:
        """A new amplitude per DOF, approached through the change filter."""
        super().set_amplitude(_vector(amplitude, "amplitude", self.n_dof))

    def set_tau(self, tau: float) -> None:
        """A new period ``2 pi tau``, its frequency approached through the change filter."""
        super().set_tau(as_scalar(tau, "tau", positive=True))

    def __copy__(self) -> PeriodicStepper:
        # the core's constructor given this stepper: a copy in its state, of the caller's class
        twin: PeriodicStepper = _core.PeriodicStepper.__new__(type(self), self)
        return twin

    def __deepcopy__(self, memo: dict[int, Any]) -> PeriodicStepper:
        return self.__copy__()
