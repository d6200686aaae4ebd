"""An analytic task: no physics, a smooth monotone outcome map, optional measurement noise.

It exists so that the learning loop, the CLI and the logs can be exercised end to end in
milliseconds, and so that learners can be compared on a map whose answer is known.

The "robot" executes a 1-DOF go-and-return movement; the outcome is a nonlinear function of its
peak, ``y = peak + 0.3 sin(peak)`` (monotone: its slope is between 0.7 and 1.3), plus Gaussian
noise of standard deviation ``noise`` drawn from the seed given to ``reset``; ``execution_noise``
adds a tracking error (:class:`dmprs.tasks.noise.Noise`) to the executed movement. Demonstrations are
minimum-jerk bumps labelled with their measured outcome, so the query is in outcome units
(``s = +1``, eps = q0 - y) and K = I is the natural gain, as for the matchbox.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from dmprs.adapters import AdapterSpec, BaseAdapter, Outcome, SignalSpec, Status
from dmprs.errors import InvalidInputError
from dmprs.portable import sin
from dmprs.profiles import min_jerk
from dmprs.tasks.base import Task
from dmprs.tasks.noise import Noise
from dmprs.trajectory import Trajectory

DURATION = 1.0
CONTROL_PERIOD = 0.002


def outcome_map(peak: float | NDArray[np.float64]) -> float | NDArray[np.float64]:
    """The true, unknown-to-the-learner map from movement peak to outcome."""
    s = sin(peak)
    return peak + 0.3 * (float(s) if np.ndim(peak) == 0 else s)


def bump(amplitude: float, n: int = 501, duration: float = DURATION) -> Trajectory:
    """A minimum-jerk go-and-return movement peaking at ``amplitude`` halfway."""
    t = np.linspace(0.0, duration, n)
    s = np.minimum(t / (duration / 2), 2 - t / (duration / 2))
    y = amplitude * min_jerk(s)[0]
    return Trajectory(t, y)


class AnalyticAdapter(BaseAdapter):
    """Executes a trajectory by reading its peak; measures ``outcome_map(peak) + noise``.

    ``noise``: the measurement noise's standard deviation, or a whole
    :class:`~dmprs.tasks.noise.Noise` (then ``execution_noise`` must be 0).
    """

    def __init__(self, noise: float | Noise = 0.0, execution_noise: float = 0.0) -> None:
        super().__init__(AdapterSpec(
            name="analytic",
            dof_names=("x",),
            dof_units=("m",),
            control_period=CONTROL_PERIOD,
            signals=(SignalSpec("outcome", "m", "peak + 0.3 sin(peak), plus noise"),
                     SignalSpec("peak", "m", "largest position reached")),
            position_min=(-5.0,),
            position_max=(5.0,),
            velocity_max=(50.0,),
            start_pose=(0.0,),
            start_tolerance=1e-6,
            max_duration=10.0,
            min_samples=3,
        ))
        if isinstance(noise, Noise):
            if execution_noise:
                raise InvalidInputError("give the execution noise inside noise=Noise(...), not beside it")
            self.tracking = noise
        else:
            self.tracking = Noise(execution=execution_noise, measurement=float(noise))
        self.noise = self.tracking.measurement
        self._rng = np.random.default_rng(0)

    def _reset(self, seed: int | None) -> None:
        self._rng = np.random.default_rng(seed)

    def _execute(self, trajectory: Trajectory) -> Outcome:
        trajectory = self.tracking.track(trajectory, self._rng)
        peak = float(trajectory.y[:, 0].max())
        value = self.tracking.measure(float(outcome_map(peak)), self._rng)
        return Outcome(Status.OK, signals={"outcome": value, "peak": peak}, executed=trajectory)




class AnalyticTask(Task):
    """Reach a desired outcome value (m) with the analytic adapter; success within ``tol``."""

    name = "analytic"
    query_names = ("outcome",)
    query_units = ("m",)
    sign = 1.0

    def __init__(self, noise: float | Noise = 0.0, tol: float = 0.01, execution_noise: float = 0.0) -> None:
        super().__init__(AnalyticAdapter(noise=noise, execution_noise=execution_noise))
        self.tol = float(tol)

    def measure(self, outcome: Outcome) -> NDArray[np.float64]:
        """The measured outcome value (m)."""
        return np.array([outcome.signals["outcome"]])

    def demonstration(self, amplitude: float) -> tuple[NDArray[np.float64], Trajectory]:
        """A scripted demonstration and its label: the outcome it measurably produced."""
        traj = bump(amplitude)
        with self.adapter:
            self.adapter.reset(seed=0)
            outcome = self.adapter.execute(traj)
        return self.measure(outcome), traj
