"""The MuJoCo throwing scene behind the adapter interface: joint trajectories of the 7-DOF arm,
the iiwa's limits, and the landing point as the outcome.
"""

from __future__ import annotations

import numpy as np

from dmprs.adapters import BaseAdapter, Outcome, SignalSpec, Status
from dmprs.errors import InvalidInputError
from dmprs.portable import norm
from dmprs.sim.throw_scene import HOME, simulate_throw
from dmprs.tasks import iiwa
from dmprs.tasks.noise import Noise
from dmprs.trajectory import Trajectory, controller_times

#: s: command sample period of a trajectory (the servo interpolates it to 1 kHz)
CONTROL_PERIOD = 0.002
MAX_DURATION = 4.0  #: s


class ArmThrowingAdapter(BaseAdapter):
    """The MuJoCo throwing scene (:mod:`dmprs.sim.throw_scene`) behind the adapter interface.

    Seven DOFs ``a1..a7`` (rad) with the iiwa 14's position and velocity limits (a trajectory
    that breaks one is rejected, naming the joint, the value and the time); every trajectory
    must start at :data:`~dmprs.sim.throw_scene.HOME` (within 1 mrad), where the ball rests in
    the cup. After the trajectory the arm holds its last sample until the ball lands.

    Signals: ``landing_x``, ``landing_y`` (m, where the ball first touched the floor: the
    measurement), ``landing_time`` and ``release_time`` (s from the start), ``release_speed``
    (m/s), ``tracking_error`` (rad, the largest |q - q*| of any joint while moving). A ball that
    never leaves the cup, does not land in time or hits the pedestal first ends the trial as
    ``aborted`` with the reason.

    ``noise`` (:class:`dmprs.tasks.noise.Noise`, default off): joint tracking error (rad,
    ``execution``) and the landing point measured with ``measurement`` m of noise per
    coordinate, drawn from the seed of :meth:`reset` (the trial runner's ``seed + trial``).
    """

    def __init__(self, noise: Noise | None = None) -> None:

        if noise is not None and not isinstance(noise, Noise):
            raise InvalidInputError(f"noise is a {type(noise).__name__}; expected a dmprs.tasks.noise.Noise")
        if noise is not None and noise.contact:
            raise InvalidInputError(f"noise.contact = {noise.contact}: the throwing scene has no contact "
                                    "parameters to perturb (the cup is frictionless); use execution or measurement")
        self.noise = noise or Noise()
        self._rng = Noise.rng(0)
        self.home = np.asarray(HOME, dtype=float)
        super().__init__(iiwa.spec(
            "arm-throwing", home=HOME, control_period=CONTROL_PERIOD, max_duration=MAX_DURATION,
            signals=(
                SignalSpec("landing_x", "m", "x where the ball first touched the floor"),
                SignalSpec("landing_y", "m", "y where the ball first touched the floor"),
                SignalSpec("landing_time", "s", "when it touched the floor, from the start"),
                SignalSpec("release_time", "s", "when the ball left the cup, from the start"),
                SignalSpec("release_speed", "m/s", "the ball's speed when it left the cup"),
                iiwa.TRACKING_ERROR,
            ),
        ))

    def _reset(self, seed: int | None) -> None:
        self._rng = Noise.rng(seed)

    def _execute(self, trajectory: Trajectory) -> Outcome:

        executed = self.noise.track(trajectory, self._rng)
        t = controller_times(executed.t)
        qd = np.gradient(executed.y, t, axis=0, edge_order=2) if (
            executed is not trajectory or trajectory.yd is None) else trajectory.yd
        r = simulate_throw(t, executed.y, qd, should_stop=self._interrupted)
        done = Trajectory(executed.t[0] + r.times, r.q) if len(r.times) >= 2 else None
        if r.interrupted:
            return self._interrupted_outcome(done)
        if not np.isfinite(r.release_time):
            return Outcome(Status.ABORTED, executed=done, message="the ball never left the cup")
        if r.hit:
            return Outcome(Status.ABORTED, executed=done,
                           message=f"the ball hit the {r.hit} at t = {r.release_time:.3f} s or later, before the floor")
        if not r.landed:
            return Outcome(Status.ABORTED, executed=done, message="the ball did not reach the floor in time")
        x, y = (self.noise.measure(float(v), self._rng) for v in r.landing)
        return Outcome(Status.OK, executed=done, signals={
            "landing_x": x, "landing_y": y, "landing_time": r.landing_time, "release_time": r.release_time,
            "release_speed": norm(r.release_velocity),
            "tracking_error": float(np.abs(r.q - r.q_ref).max()),
        })
