"""A noisy robot (the paper's real-robot runs of Figs. 6 and 11): execution noise
and measurement noise, drawn from the seed the trial runner gives ``adapter.reset`` (seed + trial
index), so a noisy run is still reproducible bit for bit.

* Execution (joint tracking) noise: the robot follows ``y(t) + e(t)`` instead of the command,
  ``e(t) = a sin(pi s) + b sin(2 pi s)`` per DOF with ``s`` the normalized time and ``a, b ~
  N(0, execution^2)`` (DOF units): a smooth tracking error that vanishes at the start and the
  end, so the command's start pose and final pose are kept.
* Contact noise (the matchbox): the friction and restitution of the trial are multiplied by
  ``1 + contact x N(0, 1)`` (clipped at 0.05).
* Measurement noise: ``N(0, measurement^2)`` added to the measured outcome signal; and
  outliers, readings gone wrong (a misdetection, a scale read while it settles): with
  probability ``outliers`` a reading also gets ``N(0, outlier_scale^2)``, which gives it the
  wrong sign about half the time when the scale dwarfs the error.

Off (all zero, the default) nothing is drawn and the tasks behave exactly as without it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dmprs._arrays import as_scalar
from dmprs.errors import InvalidInputError
from dmprs.portable import sin
from dmprs.trajectory import Trajectory


@dataclass(frozen=True)
class Noise:
    """Standard deviations of the execution, contact and measurement noise (0: off)."""

    execution: float = 0.0
    measurement: float = 0.0
    contact: float = 0.0
    outliers: float = 0.0  # probability per reading
    outlier_scale: float = 0.0

    def __post_init__(self) -> None:
        for name in ("execution", "measurement", "contact", "outliers", "outlier_scale"):
            if as_scalar(getattr(self, name), f"noise.{name}") < 0:
                raise InvalidInputError(f"noise.{name} = {getattr(self, name)} must be >= 0")
        if self.outliers > 1:
            raise InvalidInputError(f"noise.outliers = {self.outliers} is a probability: it must be <= 1")
        if (self.outliers > 0) != (self.outlier_scale > 0):
            raise InvalidInputError(
                f"noise.outliers = {self.outliers} and noise.outlier_scale = {self.outlier_scale}: "
                "give both (> 0) or neither")

    @property
    def off(self) -> bool:
        """Whether every noise level is zero (then nothing is drawn)."""
        return not self.measures and self.execution == 0 and self.contact == 0

    @property
    def measures(self) -> bool:
        """Whether a reading is noisy at all (measurement noise or outliers)."""
        return self.measurement > 0 or self.outliers > 0

    @staticmethod
    def rng(seed: int | None) -> np.random.Generator:
        """The generator of one trial's noise, from the seed the trial runner passes to ``reset``."""
        return np.random.default_rng(seed)

    def track(self, trajectory: Trajectory, rng: np.random.Generator) -> Trajectory:
        """The trajectory as the noisy robot executes it (the command itself when off)."""
        if self.execution == 0:
            return trajectory
        t = trajectory.t
        s = (t - t[0]) / (t[-1] - t[0])
        a, b = self.execution * rng.standard_normal((2, trajectory.n_dof))
        e = sin(np.pi * s)[:, None] * a + sin(2 * np.pi * s)[:, None] * b
        return Trajectory(t, trajectory.y + e)

    def factor(self, rng: np.random.Generator) -> float:
        """A contact parameter's multiplier for one trial."""
        return 1.0 if self.contact == 0 else max(0.05, 1.0 + self.contact * float(rng.standard_normal()))

    def measure(self, value: float, rng: np.random.Generator) -> float:
        """``value`` read with the measurement noise (itself when there is none)."""
        if self.measurement > 0:
            value += self.measurement * float(rng.standard_normal())
        if self.outliers > 0 and rng.random() < self.outliers:  # drawn only when on: streams unchanged
            value += self.outlier_scale * float(rng.standard_normal())
        return value
