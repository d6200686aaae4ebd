"""A task is an adapter plus scoring: what the desired outcome is, how far an outcome is from it,
and when a trial counts as a success.
"""

from __future__ import annotations

import abc
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dmprs._arrays import as_query
from dmprs.adapters import Adapter, Outcome
from dmprs.errors import InvalidInputError

if TYPE_CHECKING:
    from dmprs.generalize import GeneralizedDMP
    from dmprs.trajectory import AnyTrajectory


class Task(abc.ABC):
    """Scoring for one kind of trial, on top of an adapter.

    The signed error follows one convention for every learner (docs/method.md §5.3): **eps > 0
    means the query must increase**. With a measured outcome ``y`` (from :meth:`measure`), its
    target ``y*`` for the desired query (from :meth:`target`) and the task's ``sign``
    ``s = sign(dy/dq)``::

        eps = s * (y* - y)

    When the query is in outcome units (the matchbox) ``s = +1`` and this is eq. 13,
    ``eps = q0 - q_a``. When a larger query gives less outcome (pouring: a larger assumed volume
    tilts less) ``s = -1``.
    """

    #: registry name, e.g. "matchbox"
    name: str = ""
    #: names and units of the query's components
    query_names: tuple[str, ...] = ()
    query_units: tuple[str, ...] = ()
    #: s in eps = s (y* - y)
    sign: float = 1.0
    #: a trial succeeds when |eps| < tol (in the units of the outcome), unless success() says otherwise
    tol: float = 0.0

    def __init__(self, adapter: Adapter) -> None:
        self.adapter = adapter

    @property
    def n_query(self) -> int:
        """The dimension of the query."""
        return len(self.query_names)

    def validate_query(self, query: ArrayLike, name: str = "desired_query") -> NDArray[np.float64]:
        """``query`` as one finite value per query dimension, or a clear error naming ``name``."""
        return as_query(query, name, self.query_names)

    def trajectory(self, dmp: GeneralizedDMP) -> AnyTrajectory:
        """The trajectory to execute for a generalized DMP (any kind of primitive): by default
        its rollout at the adapter's control period, up to tau (a pose trajectory for a
        Cartesian DMP, one period for a periodic one).
        """
        return dmp.rollout(dt=self.adapter.spec.control_period)

    @abc.abstractmethod
    def measure(self, outcome: Outcome) -> NDArray[np.float64]:
        """The outcome y of an ok trial, in the units of :meth:`target`."""

    def target(self, desired_query: NDArray[np.float64]) -> NDArray[np.float64]:
        """y* for a desired query; the query itself when it is in outcome units."""
        return desired_query

    def error(self, desired_query: ArrayLike, outcome: Outcome) -> NDArray[np.float64]:
        """eps = s (y* - y), positive when the query must increase."""
        q = self.validate_query(desired_query)
        if not outcome.ok:
            raise InvalidInputError(
                f"cannot score a trial whose status is {outcome.status.value}: {outcome.message}"
            )
        return self.sign * (self.target(q) - self.measure(outcome))

    def success(self, desired_query: ArrayLike, outcome: Outcome) -> bool:
        """Whether the trial achieved the desired query."""
        return bool(np.all(np.abs(self.error(desired_query, outcome)) < self.tol))
