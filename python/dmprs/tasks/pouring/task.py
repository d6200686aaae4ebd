"""Scoring the pouring task: the poured volume against the target (docs/method.md §9.2)."""

from __future__ import annotations

import math
import os
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dmprs._arrays import as_count
from dmprs.adapters import Outcome
from dmprs.dmp import DMP
from dmprs.errors import InvalidInputError
from dmprs.tasks.base import Task
from dmprs.tasks.pouring.adapter import SUCCESS_TOLERANCE, TARGET_VOLUME, PouringAdapter, _check_volume
from dmprs.tasks.pouring.demonstrator import demonstration
from dmprs.trajectory import Trajectory

if TYPE_CHECKING:
    from dmprs.cartesian import CartesianDMP
    from dmprs.trajectory import AnyTrajectory


class Pouring(Task):
    """Pour ``target_volume`` (0.2 l) from a bottle holding ``bottle_volume`` (l).

    Query: the bottle volume (l) fed to the generalizer, i.e. the *assumed* volume; the
    physical bottle always holds ``bottle_volume``. ``eps = V_poured - V*`` (``sign = -1``),
    success when ``|eps| < tol`` (10 ml). Adapter options (``liquid_seed``, ``reseed_liquid``,
    ``hold``) are passed to :class:`PouringAdapter`.

    ``rollout_substeps`` k > 1 integrates the DMP at ``CONTROL_PERIOD / k`` and commands every
    k-th sample: explicit Euler at the 5 ms control period is 12 mrad off the DMP's solution, so a
    success stored in a growing database refits to a DMP that pours ~4 ml more (measured; k = 25:
    0.4 mrad). Default 1, the plain rollout.
    """

    adapter: PouringAdapter
    name = "pouring"
    query_names = ("bottle_volume",)
    query_units = ("l",)
    sign = -1.0

    def __init__(self, bottle_volume: float = 0.5, target_volume: float = TARGET_VOLUME,
                 tol: float = SUCCESS_TOLERANCE, *, rollout_substeps: int = 1, **adapter_options: Any) -> None:
        adapter = PouringAdapter(bottle_volume, **adapter_options)
        super().__init__(adapter)
        self.bottle_volume = adapter.bottle_volume
        self.target_volume = _check_volume(target_volume, "target_volume", capacity=self.bottle_volume)
        tol_f = float(tol)
        if not (math.isfinite(tol_f) and tol_f > 0):
            raise InvalidInputError(f"tol = {tol!r} must be > 0 l")
        self.tol = tol_f
        self.rollout_substeps = as_count(rollout_substeps, "rollout_substeps", 1)

    def trajectory(self, dmp: DMP | CartesianDMP) -> AnyTrajectory:
        k = self.rollout_substeps
        if k == 1 or not isinstance(dmp, DMP):
            return super().trajectory(dmp)
        fine = dmp.rollout(dt=self.adapter.spec.control_period / k)
        assert fine.yd is not None and fine.ydd is not None  # a rollout has its derivatives
        return Trajectory(fine.t[::k], fine.y[::k], fine.yd[::k], fine.ydd[::k])

    def validate_query(self, query: ArrayLike, name: str = "desired_query") -> NDArray[np.float64]:
        q = super().validate_query(query, name)
        if q[0] <= 0:
            raise InvalidInputError(f"{name} = {q[0]:g} l: a bottle volume must be > 0")
        return q

    def measure(self, outcome: Outcome) -> NDArray[np.float64]:
        return np.array([float(outcome.signals["poured_volume"])])

    def target(self, desired_query: NDArray[np.float64]) -> NDArray[np.float64]:
        # Whatever the bottle holds, the task is to pour the same amount (docs/method.md §9.1).
        return np.array([self.target_volume])

    def demonstration(self, bottle_volume: float, *, cache_dir: str | os.PathLike[str] | None = None,
                      ) -> tuple[NDArray[np.float64], Trajectory]:
        """A scripted demonstration for a bottle of ``bottle_volume`` l, with this task's target
        and liquid: (query, tilt trajectory)."""
        q, traj, _ = demonstration(bottle_volume, self.target_volume,
                                   liquid_seed=self.adapter.liquid_seed, cache_dir=cache_dir)
        return q, traj
