"""Sequences: DMPs joined end to start without stopping, with continuous position, velocity
and acceleration at every join (Rust core: ``crates/dmp-core/src/sequence.rs``,
``cartesian_sequence.rs`` and the ``chain.rs`` they share; docs/method.md §2.9, after Nemec and
Ude, "Action sequencing using dynamic movement primitives", Robotica 2012).

A sequence joins joint DMPs (:class:`dmprs.DMP`, all with the same DOFs) or Cartesian DMPs
(:class:`dmprs.CartesianDMP`): for a pose, the orientation is handed over with the quaternion's
sign and the angular velocity (``eta = tau omega``), and the join's term is added to the
orientation's ``tau d(eta)/dt`` too, so the angular acceleration is continuous as well
(docs/cartesian.md).

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

    poses = dmprs.Sequence([reach_pose, pour_pose, return_pose])   # CartesianDMPs
    pose, velocity, acceleration = poses.stepper(0.001).step()
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from typing import Any, Generic, Self, TypeVar, overload

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dmprs import _core
from dmprs._arrays import short
from dmprs.cartesian import CartesianDMP
from dmprs.dmp import DMP
from dmprs.errors import InvalidInputError
from dmprs.primitive import rollout_options
from dmprs.stepper import _COORDINATES, _DEFAULTS, _obstacle_options, _options
from dmprs.trajectory import CartesianTrajectory, Trajectory

__all__ = ["CartesianSequenceStepper", "Sequence", "SequenceStepper"]

#: the movements of a sequence: joint or Cartesian DMPs, one kind in a sequence
P = TypeVar("P", DMP, CartesianDMP)
_KINDS = (DMP, CartesianDMP)


def _movements(dmps: Any) -> tuple[Any, ...]:
    """``dmps`` validated: a non-empty iterable of :class:`dmprs.DMP` with one number of DOFs,
    or of :class:`dmprs.CartesianDMP`.
    """
    if isinstance(dmps, _KINDS) or not isinstance(dmps, Iterable) or isinstance(dmps, str | bytes):
        raise InvalidInputError(f"dmps must be a list of dmprs.DMP or of dmprs.CartesianDMP; got {short(dmps)}")
    items = tuple(dmps)
    if not items:
        raise InvalidInputError("dmps is empty: a sequence needs at least one dmprs.DMP or dmprs.CartesianDMP")
    kind = type(items[0]) if isinstance(items[0], _KINDS) else None
    for i, d in enumerate(items):
        if not isinstance(d, _KINDS):
            raise InvalidInputError(f"dmps[{i}] is a {type(d).__name__}, not a dmprs.DMP or dmprs.CartesianDMP")
        if kind is not None and not isinstance(d, kind):
            raise InvalidInputError(f"dmps[{i}] is a {type(d).__name__}, but dmps[0] is a {kind.__name__}: a "
                                    "sequence joins movements of one kind, joint or Cartesian")
        if isinstance(d, DMP) and d.n_dof != items[0].n_dof:
            raise InvalidInputError(f"dmps[{i}] has {d.n_dof} DOFs, but dmps[0] has {items[0].n_dof}: the "
                                    "movements of a sequence share their DOFs")
    return items


class Sequence(Generic[P]):
    """DMPs joined end to start (module docs): ``Sequence([dmp_a, dmp_b, ...])``, joint or
    Cartesian.

    Immutable; compares equal to a sequence of equal DMPs, and pickles.
    """

    __slots__ = ("_dmps",)
    _dmps: tuple[P, ...]

    def __init__(self, dmps: Iterable[P]) -> None:
        """A sequence of ``dmps`` (at least one :class:`dmprs.DMP`, all with the same DOFs, or
        at least one :class:`dmprs.CartesianDMP`), run in their order.
        """
        object.__setattr__(self, "_dmps", _movements(dmps))

    def __setattr__(self, name: str, value: Any) -> None:
        raise AttributeError("Sequence is immutable; build a new one from its dmps")

    @property
    def dmps(self) -> tuple[P, ...]:
        """The movements, in their order."""
        return self._dmps

    @property
    def cartesian(self) -> bool:
        """Whether the movements are :class:`dmprs.CartesianDMP`."""
        return isinstance(self._dmps[0], CartesianDMP)

    @property
    def n_dof(self) -> int:
        """Degrees of freedom D, every movement's (a Cartesian DMP's: its own)."""
        return self._dmps[0].n_dof

    @property
    def tau(self) -> float:
        """The nominal duration (s): the sum of the movements' taus."""
        return float(sum(d.tau for d in self._dmps))

    @property
    def start(self) -> NDArray[np.float64]:
        """Where the sequence starts: the first movement's start (a pose if Cartesian)."""
        return self._dmps[0].start

    @property
    def goal(self) -> NDArray[np.float64]:
        """Where it ends: the last movement's goal (a pose if Cartesian)."""
        return self._dmps[-1].goal

    def __len__(self) -> int:
        return len(self._dmps)

    def __iter__(self) -> Iterator[P]:
        return iter(self._dmps)

    def __getitem__(self, index: int) -> P:
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
        kind = "cartesian=True" if self.cartesian else f"n_dof={self.n_dof}"
        return f"Sequence(n_movements={len(self)}, {kind}, taus=[{taus}])"

    @overload
    def rollout(
        self: Sequence[DMP], dt: float = ..., duration: float | None = ..., *, until_rest: bool = ...,
        rest_tol: float = ...,
    ) -> Trajectory: ...
    @overload
    def rollout(
        self: Sequence[CartesianDMP], dt: float = ..., duration: float | None = ..., *, until_rest: bool = ...,
        rest_tol: float = ...,
    ) -> CartesianTrajectory: ...
    def rollout(
        self,
        dt: float = 0.001,
        duration: float | None = None,
        *,
        until_rest: bool = False,
        rest_tol: float = 1e-4,
    ) -> Trajectory | CartesianTrajectory:
        """The sequence open loop from the first movement's start at rest, sampled at
        ``t_j = j * dt`` until the last movement has run its tau (the movements hand over at
        their taus: ``sum(tau) / dt`` steps when each tau is a whole number of steps), or for
        ``duration`` (s); with ``until_rest=True`` on until the last movement rests at its goal
        (refused when the last DMP has a final velocity: it never rests). Options as
        :meth:`dmprs.DMP.rollout`; a sequence of one DMP gives that DMP's rollout. Cartesian
        DMPs give a :class:`dmprs.CartesianTrajectory`.
        """
        opts = rollout_options(dt, duration, until_rest, rest_tol)
        # One kind per sequence (checked in __init__); mypy sees each constraint of P apart.
        cores: list[Any] = [d._core for d in self._dmps]
        if self.cartesian:
            return CartesianTrajectory._trusted(*_core.cartesian_sequence_rollout(cores, **opts))
        return Trajectory._trusted(*_core.sequence_rollout(cores, **opts))

    @overload
    def stepper(self: Sequence[DMP], dt: float = ..., **options: Any) -> SequenceStepper: ...
    @overload
    def stepper(self: Sequence[CartesianDMP], dt: float = ..., **options: Any) -> CartesianSequenceStepper: ...
    def stepper(self, dt: float = 0.001, **options: Any) -> SequenceStepper | CartesianSequenceStepper:
        """An online stepper for a control loop of period ``dt`` (s), with the surface of
        :class:`dmprs.JointStepper` (:class:`dmprs.CartesianStepper` for Cartesian DMPs);
        ``options`` as :class:`SequenceStepper` (:class:`CartesianSequenceStepper`).
        """
        this: Any = self  # as in rollout
        if self.cartesian:
            return CartesianSequenceStepper(this, dt, **options)
        return SequenceStepper(this, dt, **options)


def _refuse_limits(velocity_max: Any, acceleration_max: Any) -> None:
    """Velocity and acceleration limits refused, by name (:class:`SequenceStepper`)."""
    for name, value in (("velocity_max", velocity_max), ("acceleration_max", acceleration_max)):
        if value is not None:
            raise InvalidInputError(
                f"{name} is not taken by a sequence: temporal coupling's time scale assumes a "
                "movement that starts at rest, and the movements after the first start in motion")


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
        if not isinstance(sequence, Sequence) or sequence.cartesian:
            raise InvalidInputError(f"sequence must be a dmprs.Sequence of dmprs.DMP; got {short(sequence)}")
        _refuse_limits(velocity_max, acceleration_max)
        n = sequence.n_dof
        period, opts = _options(
            n, n, "DOF", dt, substeps, alpha_e, goal_filter, None, None,
            position_min, position_max, limit_margin, limit_gain, gamma_nominal, gamma_a, eps, rest_tol,
        )
        return super().__new__(cls, [d._core for d in sequence.dmps], period, opts)


class CartesianSequenceStepper(_core.CartesianSequenceStepper):
    """Executes a :class:`Sequence` of :class:`dmprs.CartesianDMP` one control period at a time,
    with the methods of :class:`dmprs.CartesianStepper` (``step``, ``reset``, ``set_goal``,
    ``set_tau``, ``done``, ``blocked``, ``output``, ``phase``, ``obstacles``, ...) and
    :attr:`active`, the movement that runs; as :class:`SequenceStepper` otherwise.

    ``step(measured=None, coupling=None)`` returns ``(pose, velocity, acceleration)`` as
    :meth:`dmprs.CartesianStepper.step` does. Options as :class:`dmprs.CartesianStepper` (the
    obstacles hold for every movement; there is no ``set_obstacles``), except ``velocity_max``
    and ``acceleration_max``, which are refused as by :class:`SequenceStepper`.
    """

    __slots__ = ()
    #: the options' defaults, :class:`dmprs.CartesianStepper`'s
    DEFAULTS = _DEFAULTS

    def __new__(
        cls,
        sequence: Sequence[CartesianDMP],
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
        """A stepper for ``sequence`` at control period ``dt`` (s); options as the class docs."""
        if not isinstance(sequence, Sequence) or not sequence.cartesian:
            raise InvalidInputError(f"sequence must be a dmprs.Sequence of dmprs.CartesianDMP; got {short(sequence)}")
        _refuse_limits(velocity_max, acceleration_max)
        period, opts = _options(
            6, 3, _COORDINATES, dt, substeps, alpha_e, goal_filter, None, None,
            position_min, position_max, limit_margin, limit_gain, gamma_nominal, gamma_a, eps, rest_tol,
        )
        cores = [d._core for d in sequence.dmps]
        return super().__new__(cls, cores, period, opts, *_obstacle_options(obstacles, obstacle_gain, obstacle_beta))
