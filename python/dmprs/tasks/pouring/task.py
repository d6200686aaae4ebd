"""Scoring the pouring task: the poured volume against the target (docs/method.md §9.2)."""

from __future__ import annotations

import os
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from dmprs._arrays import as_count
from dmprs.dmp import DMP
from dmprs.tasks.liquid import TARGET_VOLUME, PouringTask
from dmprs.tasks.pouring.adapter import CAPACITY, SUCCESS_TOLERANCE, PouringAdapter
from dmprs.tasks.pouring.demonstrator import demonstration
from dmprs.trajectory import Trajectory

if TYPE_CHECKING:
    from dmprs.generalize import GeneralizedDMP
    from dmprs.trajectory import AnyTrajectory


class Pouring(PouringTask):
    """Pour ``target_volume`` (0.2 l) from a bottle holding ``bottle_volume`` (l) in the 2-D
    simulation; scored as :class:`~dmprs.tasks.liquid.PouringTask` (success within 10 ml).
    Adapter options (``liquid_seed``, ``reseed_liquid``, ``hold``, ``noise``) are passed to
    :class:`PouringAdapter`.

    ``rollout_substeps`` k > 1 integrates the DMP at ``CONTROL_PERIOD / k`` and commands every
    k-th sample: explicit Euler at the 5 ms control period is far enough off the DMP's solution
    that a success stored in a growing database refits to a DMP that pours more (docs/growing.md).
    Default 1, the plain rollout.
    """

    adapter: PouringAdapter
    name = "pouring"
    capacity = CAPACITY

    def __init__(self, bottle_volume: float = 0.5, target_volume: float = TARGET_VOLUME,
                 tol: float = SUCCESS_TOLERANCE, *, rollout_substeps: int = 1, **adapter_options: Any) -> None:
        adapter = PouringAdapter(bottle_volume, **adapter_options)
        super().__init__(adapter, adapter.bottle_volume, target_volume, tol)
        self.rollout_substeps = as_count(rollout_substeps, "rollout_substeps", 1)

    def trajectory(self, dmp: GeneralizedDMP) -> AnyTrajectory:
        """The tilt to execute: the DMP's rollout at the control period, finer when ``rollout_substeps`` asks."""
        k = self.rollout_substeps
        if k == 1 or not isinstance(dmp, DMP):
            return super().trajectory(dmp)
        fine = dmp.rollout(dt=self.adapter.spec.control_period / k)
        assert fine.yd is not None and fine.ydd is not None  # a rollout has its derivatives
        return Trajectory(fine.t[::k], fine.y[::k], fine.yd[::k], fine.ydd[::k])

    def demonstration(self, bottle_volume: float, *, cache_dir: str | os.PathLike[str] | None = None,
                      ) -> tuple[NDArray[np.float64], Trajectory]:
        """A scripted demonstration for a bottle of ``bottle_volume`` l, with this task's target
        and liquid: (query, tilt trajectory).
        """
        q, traj, _ = demonstration(bottle_volume, self.target_volume,
                                   liquid_seed=self.adapter.liquid.liquid_seed, cache_dir=cache_dir)
        return q, traj
