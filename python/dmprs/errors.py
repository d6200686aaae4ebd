"""The exceptions of dmprs.

Everything dmprs raises on purpose derives from :class:`DmprsError`. Errors caused by the
caller's input also derive from :class:`ValueError`, so ``except ValueError`` keeps working.
Every exception class of the package lives here. The Rust core raises these same classes
(``crates/py-bindings/src/errors.rs``).
"""

from __future__ import annotations

__all__ = [
    "AdapterConformanceError",
    "AdapterError",
    "DatabaseError",
    "DmprsError",
    "ExtrapolationError",
    "InvalidInputError",
    "LearnerStateError",
    "NumericalError",
    "ParallelError",
    "RunLogError",
]


class DmprsError(Exception):
    """Base class of every error dmprs raises on purpose."""


class InvalidInputError(DmprsError, ValueError):
    """An argument is malformed: wrong shape or dtype, NaN or inf, non-increasing time, a
    parameter outside its domain. The message says what and where.
    """


class NumericalError(DmprsError, ArithmeticError):
    """The input was valid but a computation failed (e.g. a matrix that is not positive
    definite, a rollout that does not come to rest).
    """


class LearnerStateError(DmprsError, RuntimeError):
    """A learner was driven out of order: ``tell`` without a pending ``ask``, ``tell`` of a query
    other than the one ``ask`` returned, or ``ask`` after the learner stopped (see its
    ``status``).
    """


class ExtrapolationError(InvalidInputError):
    """A query too far from the demonstrations: its generalized DMP would be invalid (e.g. tau
    would leave (0.2 x the shortest, 5 x the longest demonstration's duration); docs/method.md §3.3).
    The message names the query and the tau it would get.
    """


class DatabaseError(DmprsError):
    """A movement database on disk that cannot be read or written: a missing, corrupted,
    truncated or foreign file, or one written by a newer dmprs. The message names the file.
    """


class RunLogError(DmprsError, OSError):
    """A run directory that cannot be read or written; the message names the file."""


class AdapterError(DmprsError, RuntimeError):
    """An adapter was used out of order (e.g. execute before connect)."""


class AdapterConformanceError(DmprsError, AssertionError):
    """An adapter broke the adapter contract (:func:`dmprs.adapters.check_adapter`); the message
    lists every failed check.
    """


class ParallelError(DmprsError, RuntimeError):
    """A run inside :func:`dmprs.parallel.pmap` failed; the message names the item."""
