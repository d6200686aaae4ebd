"""What the two pouring tasks share (the 2-D pymunk scene and the MuJoCo arm): the paper's target,
the volume check, the liquid's outcome signals and options, and the scoring (docs/method.md §9).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dmprs._arrays import as_flag, as_scalar, short
from dmprs.adapters import Adapter, Outcome, SignalSpec
from dmprs.errors import InvalidInputError
from dmprs.tasks.base import Task

#: l: the paper's task, whatever the bottle holds (docs/method.md §9.1)
TARGET_VOLUME = 0.2
#: l per particle: a 2 ml disc in 2-D, a 2 ml sphere on the arm (docs/method.md §9.3)
PARTICLE_VOLUME = 0.002
#: s: the longest the bottle may be held still after a trajectory before the liquid is counted
MAX_HOLD = 10.0


def check_volume(value: Any, name: str, *, capacity: float) -> float:
    """A volume in litres: a finite number, > 0, within ``capacity`` and at least one particle."""
    v = as_scalar(value, name)
    if v <= 0:
        raise InvalidInputError(f"{name} = {v:g} l must be > 0")
    if v > capacity + 1e-12:
        raise InvalidInputError(f"{name} = {v:g} l exceeds the simulated bottle's capacity of {capacity:g} l")
    if round(v / PARTICLE_VOLUME) < 1:
        raise InvalidInputError(f"{name} = {v:g} l is less than one particle ({PARTICLE_VOLUME * 1000:g} ml)")
    return v


def signals(particle: str) -> tuple[SignalSpec, ...]:
    """The eight signals every pour measures: the volumes (l) in the glass (the measurement), in
    the bottle, spilled and at the start, and the same as whole ``particle`` counts (they add up
    to ``particles``; the volumes are the counts times :data:`PARTICLE_VOLUME`).
    """
    return (
        SignalSpec("poured_volume", "l", "liquid in the glass, counted `hold` s after the trajectory ends"),
        SignalSpec("remaining_volume", "l", "liquid still in the bottle at the end"),
        SignalSpec("spilled_volume", "l", "liquid neither in the bottle nor in the glass"),
        SignalSpec("initial_volume", "l", "liquid in the bottle before the trial"),
        SignalSpec("poured_particles", "1", f"{particle} in the glass (2 ml each)"),
        SignalSpec("remaining_particles", "1", f"{particle} in the bottle"),
        SignalSpec("spilled_particles", "1", f"{particle} elsewhere"),
        SignalSpec("particles", "1", f"{particle} in the scene (constant)"),
    )


#: the poured volume over a pour, and its sample times
CURVE_SIGNALS = (
    SignalSpec("poured_volume_curve", "l", "liquid in the glass over time"),
    SignalSpec("poured_volume_time", "s", "sample times of poured_volume_curve"),
)


def counts(n_glass: int, n_bottle: int, n_spilled: int, n: int, poured_volume: float) -> dict[str, Any]:
    """The eight signals of :func:`signals` from the particle counts; ``poured_volume`` is the
    reading of the glass (the exact count times the particle volume, or a noisy reading of it).
    """
    return {
        "poured_volume": poured_volume,
        "remaining_volume": n_bottle * PARTICLE_VOLUME,
        "spilled_volume": n_spilled * PARTICLE_VOLUME,
        "initial_volume": n * PARTICLE_VOLUME,
        "poured_particles": n_glass,
        "remaining_particles": n_bottle,
        "spilled_particles": n_spilled,
        "particles": n,
    }


class Liquid:
    """The liquid's options of a pouring adapter: ``liquid_seed`` draws the particles (their
    sizes, hence the settled packing) and, with ``reseed_liquid``, ``reset(seed)`` draws a new
    liquid from ``seed`` for every trial (trial-to-trial variation); ``hold`` (s) is how long the
    bottle rests after the trajectory before the liquid is counted.
    """

    def __init__(self, liquid_seed: Any, reseed_liquid: Any, hold: Any) -> None:
        if not (isinstance(liquid_seed, (int, np.integer)) and not isinstance(liquid_seed, (bool, np.bool_))
                and liquid_seed >= 0):
            raise InvalidInputError(f"liquid_seed = {short(liquid_seed)} must be a non-negative integer")
        self.liquid_seed = int(liquid_seed)
        self.reseed_liquid = as_flag(reseed_liquid, "reseed_liquid")
        self.hold = as_scalar(hold, "hold")
        if not 0 <= self.hold <= MAX_HOLD:
            raise InvalidInputError(f"hold = {self.hold:g} s must be between 0 and {MAX_HOLD:g}")
        self.seed = self.liquid_seed

    def reset(self, seed: int | None) -> None:
        """The liquid of the next trial: a new one drawn from ``seed`` when reseeding."""
        if self.reseed_liquid:
            self.seed = self.liquid_seed if seed is None else int(seed)


class PouringTask(Task):
    """Pour ``target_volume`` from a bottle holding ``bottle_volume`` (l), the adapter's.

    Query: the assumed bottle volume (l), fed to the generalizer; the physical bottle always
    holds ``bottle_volume``. ``eps = V_poured - V*`` (``sign = -1``: poured too much means the
    assumed volume must increase, which tilts less; docs/method.md §5.3, §9.2); success when
    ``|eps| < tol``.
    """

    query_names = ("bottle_volume",)
    query_units = ("l",)
    sign = -1.0
    #: the most the simulated bottle holds (l)
    capacity: float

    def __init__(self, adapter: Adapter[Any], bottle_volume: float, target_volume: float, tol: float) -> None:
        super().__init__(adapter)
        self.bottle_volume = bottle_volume
        self.target_volume = check_volume(target_volume, "target_volume", capacity=bottle_volume)
        self.tol = as_scalar(tol, "tol", positive=True)

    def validate_query(self, query: ArrayLike, name: str = "desired_query") -> NDArray[np.float64]:
        """A bottle volume the simulation can hold, or a clear error naming ``name``."""
        q = super().validate_query(query, name)
        if not 0 < q[0] <= self.capacity:
            raise InvalidInputError(f"{name} = {q[0]:g} l: a bottle volume must be > 0 and at most the simulated "
                                    f"bottle's capacity of {self.capacity:g} l")
        return q

    def measure(self, outcome: Outcome) -> NDArray[np.float64]:
        """The poured volume (l)."""
        return np.array([float(outcome.signals["poured_volume"])])

    def target(self, desired_query: NDArray[np.float64]) -> NDArray[np.float64]:
        # Whatever the bottle holds, the task is to pour the same amount (docs/method.md §9.1).
        """The target volume, whatever the bottle holds."""
        return np.array([self.target_volume])
