"""The episodic hardware-adapter interface: one call executes one whole trajectory.

Simulations and real robots implement :class:`Adapter`. Subclass :class:`BaseAdapter` and
write ``_execute``: it gets the shared pre-execution check, dry runs, error capture, stop and
context-manager handling for free.
"""

from __future__ import annotations

import abc
import threading
import time
import traceback
from types import TracebackType
from typing import Generic, Self, TypeVar

from dmprs._arrays import as_scalar
from dmprs.adapters.spec import AdapterSpec, Outcome, Status
from dmprs.errors import AdapterError, InvalidInputError
from dmprs.trajectory import AnyTrajectory

#: The trajectories an adapter executes: joint-space samples, poses, or either.
TrajectoryT = TypeVar("TrajectoryT", bound=AnyTrajectory)


class Adapter(abc.ABC, Generic[TrajectoryT]):
    """The protocol every adapter follows.

    ``spec`` describes the DOFs, limits and outcome signals. ``connect``/``disconnect`` (or a
    ``with`` block) bracket a session. ``reset(seed=...)`` puts the world back in its initial
    state. ``check`` lists every reason a trajectory would be rejected, without moving anything.
    ``execute`` runs one trajectory and returns an :class:`Outcome`. ``stop`` halts motion at once
    and may be called at any time, from any thread, any number of times.
    """

    spec: AdapterSpec

    @abc.abstractmethod
    def connect(self) -> None:
        """Opens the session with the robot or simulation; idempotent."""

    @abc.abstractmethod
    def disconnect(self) -> None:
        """Closes the session; idempotent."""

    @abc.abstractmethod
    def reset(self, seed: int | None = None) -> None:
        """Puts the world back in its initial state, drawing anything random from ``seed``."""

    @abc.abstractmethod
    def check(self, trajectory: TrajectoryT) -> list[str]:
        """Every reason ``trajectory`` would be rejected, as sentences; empty if none. Moves nothing."""

    @abc.abstractmethod
    def execute(
        self, trajectory: TrajectoryT, dry_run: bool = False, timeout_s: float | None = None
    ) -> Outcome:
        """Runs ``trajectory`` once (or only checks it, with ``dry_run``) and returns its outcome."""

    @abc.abstractmethod
    def stop(self) -> None:
        """Halts motion at once; safe from any thread, any number of times."""

    def __enter__(self) -> Self:
        self.connect()
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        try:
            self.stop()
        finally:
            self.disconnect()


class BaseAdapter(Adapter[TrajectoryT]):
    """Shared behaviour; subclasses implement :meth:`_execute` (and usually :meth:`_reset`).

    ``execute`` checks the trajectory against the spec (rejecting, never clipping), honours
    ``dry_run``, and turns anything ``_execute`` raises into an ``error`` outcome with the
    traceback in the message, so one failing trial cannot lose the run. ``_execute`` should call
    :meth:`_interrupted` between control steps: it becomes true after :meth:`stop` or when the
    deadline of ``timeout_s`` has passed, and ``_execute`` should then return early with
    :meth:`_interrupted_outcome`.
    """

    def __init__(self, spec: AdapterSpec) -> None:
        self.spec = spec
        self._connected = False
        self._stop = threading.Event()
        self._deadline: float | None = None

    @property
    def connected(self) -> bool:
        """Whether a session is open."""
        return self._connected

    def connect(self) -> None:
        """Opens the session."""
        self._connected = True

    def disconnect(self) -> None:
        """Closes the session."""
        self._connected = False

    def reset(self, seed: int | None = None) -> None:
        """Clears a stop and restores the initial state through :meth:`_reset`."""
        self._stop.clear()
        self._reset(seed)

    def _reset(self, seed: int | None) -> None:
        """Hook: restore the initial state. Simulations re-seed here."""

    def check(self, trajectory: TrajectoryT) -> list[str]:
        """The spec's checks, then the adapter's own (:meth:`_extra_checks`)."""
        return self.spec.check(trajectory) + self._extra_checks(trajectory)

    def _extra_checks(self, trajectory: TrajectoryT) -> list[str]:
        """Hook: adapter-specific checks (workspace, collisions) on an in-limits trajectory."""
        return []

    def stop(self) -> None:
        """Asks :meth:`_execute` to return at its next poll of :meth:`_interrupted`."""
        self._stop.set()

    def _interrupted(self) -> bool:
        return self._stop.is_set() or (
            self._deadline is not None and time.monotonic() > self._deadline
        )

    def _interrupted_outcome(self, executed: AnyTrajectory | None = None) -> Outcome:
        if self._stop.is_set():
            return Outcome(Status.STOPPED, executed=executed, message="stop() was called")
        return Outcome(Status.TIMEOUT, executed=executed, message="the trial exceeded timeout_s")

    def execute(
        self, trajectory: TrajectoryT, dry_run: bool = False, timeout_s: float | None = None
    ) -> Outcome:
        """Checks, then runs :meth:`_execute` under ``timeout_s``; anything it raises becomes an ``error`` outcome."""
        if not self._connected:
            raise AdapterError(f"{self.spec.name}: execute() before connect()")
        problems = self.check(trajectory)
        if problems:
            return Outcome(Status.REJECTED, message="; ".join(problems))
        if dry_run:
            return Outcome(Status.DRY_RUN, message="checked, not executed")
        limit = None if timeout_s is None else as_scalar(timeout_s, "timeout_s")
        if limit is not None and limit < 0:
            raise InvalidInputError(f"timeout_s = {limit:g} is invalid: must be >= 0 (or None for no limit)")
        self._stop.clear()
        deadline = None if limit is None else time.monotonic() + limit
        self._deadline = deadline
        try:
            outcome = self._execute(trajectory)
        except Exception as exc:  # noqa: BLE001 - any failure of one trial becomes its outcome
            self.stop()
            tb = "".join(traceback.format_exception_only(type(exc), exc)).strip()
            return Outcome(Status.ERROR, message=f"{self.spec.name} raised during the trial: {tb}")
        finally:
            self._deadline = None
        # Enforced here, not left to _execute: an adapter that never polls _interrupted() and
        # overruns is a timeout whatever it returned (its signals were measured too late).
        overran = deadline is not None and time.monotonic() > deadline
        if self._stop.is_set() and outcome.status is Status.OK:
            return self._interrupted_outcome(outcome.executed)
        if overran and outcome.status not in (Status.TIMEOUT, Status.ERROR, Status.STOPPED):
            return Outcome(
                Status.TIMEOUT, executed=outcome.executed,
                message=f"the trial overran timeout_s = {limit:g} s (_execute returned {outcome.status.value})",
            )
        return outcome

    @abc.abstractmethod
    def _execute(self, trajectory: TrajectoryT) -> Outcome:
        """Runs a checked trajectory and measures the outcome signals."""
