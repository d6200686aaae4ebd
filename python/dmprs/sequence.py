"""Sequences: joint DMPs joined end to start without stopping, with continuous position,
velocity and acceleration at every join (Rust core: ``crates/dmp-core/src/sequence.rs``;
docs/method.md §2.9, after Nemec and Ude, "Action sequencing using dynamic movement
primitives", Robotica 2012).

Each movement runs until its phase has run out (``t = tau`` of its own clock, later when phase
stopping held it); the next starts where it has arrived, with its velocity, and a term added to
its eq. 1 makes its first acceleration the one the movement before would have commanded next,
then fades at the spring's own rate. By the end of a movement the term has faded and the
movement ends where its DMP's own rollout from rest at the same start ends. A later movement's
``start`` is not used: it starts where the one before hands over. A DMP with a final velocity
(docs/method.md §2.8) hands over in motion: a hit followed by a movement that stops.

A sequence is one object with a :meth:`~Sequence.rollout` and a :meth:`~Sequence.stepper`; the
rollout steps the stepper (one integrator for both), so the stepper's open-loop samples are the
rollout's, bit for bit. A sequence of one DMP is that DMP: its rollout is the DMP's rollout and
its stepper the DMP's stepper, bit for bit.

Example::

    reach_and_back = dmprs.Sequence([reach, place, retreat])
    trajectory = reach_and_back.rollout(0.001)
    stepper = reach_and_back.stepper(0.001)
    while not stepper.done():
        y, yd, ydd = stepper.step(robot.position())
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from typing import Any, Self

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dmprs import _core
from dmprs._arrays import short
from dmprs.dmp import DMP
from dmprs.errors import InvalidInputError
from dmprs.primitive import rollout_options
from dmprs.stepper import _DEFAULTS, _options
from dmprs.trajectory import Trajectory

__all__ = ["Sequence", "SequenceStepper"]


def _movements(dmps: Any) -> tuple[DMP, ...]:
    """``dmps`` validated: a non-empty iterable of :class:`dmprs.DMP` with one number of DOFs."""
    if isinstance(dmps, DMP) or not isinstance(dmps, Iterable) or isinstance(dmps, str | bytes):
        raise InvalidInputError(f"dmps must be a list of dmprs.DMP; got {short(dmps)}")
    items = tuple(dmps)
    if not items:
        raise InvalidInputError("dmps is empty: a sequence needs at least one dmprs.DMP")
    for i, d in enumerate(items):
        if not isinstance(d, DMP):
            raise InvalidInputError(f"dmps[{i}] is a {type(d).__name__}, not a dmprs.DMP (a sequence joins "
                                    "joint DMPs; Cartesian sequences are not supported yet)")
        if d.n_dof != items[0].n_dof:
            raise InvalidInputError(f"dmps[{i}] has {d.n_dof} DOFs, but dmps[0] has {items[0].n_dof}: the "
                                    "movements of a sequence share their DOFs")
    return items


class Sequence:
    """Joint DMPs joined end to start (module docs): ``Sequence([dmp_a, dmp_b, ...])``.

    Immutable; compares equal to a sequence of equal DMPs, and pickles.
    """

    __slots__ = ("_dmps",)
    _dmps: tuple[DMP, ...]

    def __init__(self, dmps: Iterable[DMP]) -> None:
        """A sequence of ``dmps`` (at least one :class:`dmprs.DMP`, all with the same DOFs),
        run in their order.
        """
        object.__setattr__(self, "_dmps", _movements(dmps))

    def __setattr__(self, name: str, value: Any) -> None:
        raise AttributeError("Sequence is immutable; build a new one from its dmps")

    @property
    def dmps(self) -> tuple[DMP, ...]:
        """The movements, in their order."""
        return self._dmps

    @property
    def n_dof(self) -> int:
        """Degrees of freedom D, every movement's."""
        return self._dmps[0].n_dof

    @property
    def tau(self) -> float:
        """The nominal duration (s): the sum of the movements' taus."""
        return float(sum(d.tau for d in self._dmps))

    @property
    def start(self) -> NDArray[np.float64]:
        """Where the sequence starts: the first movement's start."""
        return self._dmps[0].start

    @property
    def goal(self) -> NDArray[np.float64]:
        """Where it ends: the last movement's goal."""
        return self._dmps[-1].goal

    def __len__(self) -> int:
        return len(self._dmps)

    def __iter__(self) -> Iterator[DMP]:
        return iter(self._dmps)

    def __getitem__(self, index: int) -> DMP:
        return self._dmps[index]

    def __eq__(self, other: object) -> bool:
        if type(other) is not type(self):
            return NotImplemented
        assert isinstance(other, Sequence)
        return self._dmps == other._dmps

    __hash__ = None  # type: ignore[assignment]

    def __reduce__(self) -> tuple[Any, ...]:
        return (type(self), (list(self._dmps),))

    def __repr__(self) -> str:
        taus = ", ".join(f"{d.tau:.6g}" for d in self._dmps)
        return f"Sequence(n_movements={len(self)}, n_dof={self.n_dof}, taus=[{taus}])"

    def rollout(
        self,
        dt: float = 0.001,
        duration: float | None = None,
        *,
        until_rest: bool = False,
        rest_tol: float = 1e-4,
    ) -> Trajectory:
        """The sequence open loop from the first movement's start at rest, sampled at
        ``t_j = j * dt`` until the last movement has run its tau (the movements hand over at
        their taus: ``sum(tau) / dt`` steps when each tau is a whole number of steps), or for
        ``duration`` (s); with ``until_rest=True`` on until the last movement rests at its goal
        (refused when the last DMP has a final velocity: it never rests). Options as
        :meth:`dmprs.DMP.rollout`; a sequence of one DMP gives that DMP's rollout.
        """
        opts = rollout_options(dt, duration, until_rest, rest_tol)
        return Trajectory._trusted(*_core.sequence_rollout([d._core for d in self._dmps], **opts))

    def stepper(self, dt: float = 0.001, **options: Any) -> SequenceStepper:
        """An online stepper for a control loop of period ``dt`` (s), with the surface of
        :class:`dmprs.JointStepper`; ``options`` as :class:`SequenceStepper`.
        """
        return SequenceStepper(self, dt, **options)


class SequenceStepper(_core.SequenceStepper):
    """Executes a :class:`Sequence` one control period at a time, with the methods of
    :class:`dmprs.JointStepper` (``step``, ``reset``, ``set_goal``, ``set_tau``, ``done``,
    ``blocked``, ``output``, ``phase``, ...) and :attr:`active`, the movement that runs.

    ``step(measured=None, coupling=None)`` hands over to the next movement first when the one
    that runs has run its tau, then returns ``(y, yd, ydd)`` in read-only arrays that the next
    call overwrites. Phase stopping (``measured``) slows the movement that runs, and so delays
    its hand-over. ``set_goal`` and ``set_tau`` act on the movement that runs; ``phase``,
    ``tau``, ``nominal_tau``, ``goal`` and ``substeps`` are its own; ``steps`` counts from the
    sequence's start. ``done()`` and ``blocked()`` speak of the last movement only (an earlier
    one hands over when its phase runs out, held or not); ``reset(start)`` goes back to the
    first movement. ``over_limit()`` is always False.

    Options as :class:`dmprs.JointStepper`, except ``velocity_max`` and ``acceleration_max``,
    which are refused: their temporal coupling assumes a movement that starts at rest, and the
    movements after the first start in motion.
    """

    __slots__ = ()
    #: the options' defaults, :class:`dmprs.JointStepper`'s
    DEFAULTS = _DEFAULTS

    def __new__(
        cls,
        sequence: Sequence,
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
        """A stepper for ``sequence`` at control period ``dt`` (s); options as the class docs."""
        if not isinstance(sequence, Sequence):
            raise InvalidInputError(f"sequence must be a dmprs.Sequence; got {short(sequence)}")
        for name, value in (("velocity_max", velocity_max), ("acceleration_max", acceleration_max)):
            if value is not None:
                raise InvalidInputError(
                    f"{name} is not taken by a sequence: temporal coupling's time scale assumes a "
                    "movement that starts at rest, and the movements after the first start in motion")
        n = sequence.n_dof
        period, opts = _options(
            n, n, "DOF", dt, substeps, alpha_e, goal_filter, None, None,
            position_min, position_max, limit_margin, limit_gain, gamma_nominal, gamma_a, eps, rest_tol,
        )
        return super().__new__(cls, [d._core for d in sequence.dmps], period, opts)
