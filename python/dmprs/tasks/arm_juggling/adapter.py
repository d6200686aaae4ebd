"""The MuJoCo juggling scene behind the adapter interface: joint trajectories of the 7-DOF arm
holding a paddle, the iiwa's limits, and the apex of the bouncing ball as the outcome.
"""

from __future__ import annotations

import numpy as np

from dmprs._arrays import as_count
from dmprs.adapters import BaseAdapter, Outcome, SignalSpec, Status
from dmprs.sim.juggle_scene import Drop, home, paddle_heights, plan_release, rhythm_of, simulate_juggle
from dmprs.tasks import iiwa
from dmprs.trajectory import Trajectory, controller_times

#: s: command sample period of a trajectory (the servo interpolates it to 1 kHz)
CONTROL_PERIOD = 0.002
MAX_DURATION = 20.0  #: s
#: the apex is the mean over the last this many flights within the rhythm's full-amplitude periods
MEASURED_FLIGHTS = 6
#: and the ball must have flown at least this many there (the first ones settle the bouncing)
MIN_FLIGHTS = 10
#: m: a flight lower than this is chattering on the paddle, not bouncing
MIN_APEX = 0.02


class ArmJugglingAdapter(BaseAdapter):
    """The MuJoCo juggling scene (:mod:`dmprs.sim.juggle_scene`) behind the adapter interface.

    Seven DOFs ``a1..a7`` (rad) with the iiwa 14's position and velocity limits (a trajectory
    that breaks one is rejected, naming the joint, the value and the time); every trajectory
    must start at :func:`~dmprs.sim.juggle_scene.home` (within 1 mrad), the paddle level at
    rest. The hand drops the ball into the trajectory's rhythm as the :class:`Drop` of ``seed``
    says (a seed is a physically different start and ball: drop phase, height and restitution).

    Signals: ``apex`` (m, the mean apex of the ball's lowest point above the paddle's face at
    rest over the last :data:`MEASURED_FLIGHTS` flights within the rhythm's full-amplitude
    periods: the measurement), ``apex_spread`` (m, their range), ``flight_time`` (s, their mean
    duration), ``flights`` (how many there were in those periods), ``rhythm_period`` (s, of the
    commanded paddle), ``release_time`` (s), ``tracking_error`` (rad). A trajectory without a
    paddle rhythm, a ball that falls past the paddle, or one that stops bouncing (fewer than
    :data:`MIN_FLIGHTS` flights, or one of the measured lower than :data:`MIN_APEX`) ends the
    trial as ``aborted`` with the reason.
    """

    def __init__(self, seed: int = 0) -> None:
        self.seed = as_count(seed, "seed", 0)
        self.drop = Drop.of_seed(self.seed)
        super().__init__(iiwa.spec(
            "arm-juggling", home=home(), control_period=CONTROL_PERIOD, max_duration=MAX_DURATION,
            signals=(
                SignalSpec("apex", "m", "mean apex of the ball above the paddle at rest, last flights"),
                SignalSpec("apex_spread", "m", "range of those apexes"),
                SignalSpec("flight_time", "s", "mean duration of those flights"),
                SignalSpec("flights", "", "flights within the rhythm's full-amplitude periods"),
                SignalSpec("rhythm_period", "s", "period of the commanded paddle rhythm"),
                SignalSpec("release_time", "s", "when the hand let the ball go, from the start"),
                iiwa.TRACKING_ERROR,
            ),
        ))

    def _execute(self, trajectory: Trajectory) -> Outcome:
        t = controller_times(trajectory.t)
        qd = np.gradient(trajectory.y, t, axis=0, edge_order=2) if trajectory.yd is None else trajectory.yd
        z = paddle_heights(trajectory.y)
        rhythm = rhythm_of(t, z)
        if rhythm is None:
            return Outcome(Status.ABORTED, message="the paddle does not move in a rhythm to drop the ball into "
                           "(no full upward swing, or none of 5 mm or more)")
        release = plan_release(t, z, rhythm, self.drop)
        if release.time < 0:
            return Outcome(Status.ABORTED, message=f"the rhythm is at full amplitude too early to drop the ball into "
                           f"(it would be let go at t = {release.time:.3f} s)")
        r = simulate_juggle(t, trajectory.y, qd, release, self.drop.damping_ratio, should_stop=self._interrupted)
        done = Trajectory(trajectory.t[0] + r.times, r.q) if len(r.times) >= 2 else None
        if r.interrupted:
            return self._interrupted_outcome(done)
        if r.fell:
            return Outcome(Status.ABORTED, executed=done, message="the ball fell past the paddle")
        inside = (r.takeoff_time >= release.time) & (r.landing_time <= rhythm.end)
        apexes, flights = r.apex[inside], r.landing_time[inside] - r.takeoff_time[inside]
        last = apexes[-MEASURED_FLIGHTS:]
        if len(apexes) < MIN_FLIGHTS or last.min() < MIN_APEX:
            low = "" if len(apexes) == 0 else f", the lowest of the last {len(last)} {last.min() * 100:.1f} cm"
            return Outcome(Status.ABORTED, executed=done, message=f"the ball did not keep bouncing: {len(apexes)} "
                           f"flights in the rhythm's full-amplitude periods{low}")
        return Outcome(Status.OK, executed=done, signals={
            "apex": float(last.mean()), "apex_spread": float(last.max() - last.min()),
            "flight_time": float(flights[-MEASURED_FLIGHTS:].mean()), "flights": float(len(apexes)),
            "rhythm_period": rhythm.period, "release_time": release.time,
            "tracking_error": float(np.abs(r.q - r.q_ref).max()),
        })
