"""Writing an adapter for your robot, and checking it before it moves anything.

    python examples/write_an_adapter.py

``PlanarArmAdapter`` stands in for your robot's SDK: a two-joint arm whose joints follow the
commanded positions through a critically damped servo (natural frequency 30 rad/s), simulated at
the control period. It reports where the fingertip ended up. Replace the body of ``_execute``
with your SDK's streaming loop (see docs/adapters.md); keep the spec honest about the limits.

``check_adapter`` is the conformance suite (like Gymnasium's ``check_env``): first without
moving anything (``execute=False``, as you would on the real arm), then with executions. A
broken variant that forgets to declare one of its signals shows what a failure report looks like.
"""

from __future__ import annotations

import numpy as np

import dmprs
from dmprs.adapters import (
    AdapterConformanceError,
    AdapterSpec,
    BaseAdapter,
    Outcome,
    SignalSpec,
    Status,
    check_adapter,
)

L1, L2 = 0.4, 0.3
DT = 0.002
START = (0.3, 1.6)


class PlanarArmAdapter(BaseAdapter):
    def __init__(self, servo_frequency: float = 30.0) -> None:
        super().__init__(AdapterSpec(
            name="planar_arm",
            dof_names=("shoulder", "elbow"),
            dof_units=("rad", "rad"),
            control_period=DT,
            signals=(SignalSpec("fingertip_x", "m", "final fingertip x"),
                     SignalSpec("fingertip_y", "m", "final fingertip y"),
                     SignalSpec("tracking_error", "rad", "largest |commanded - executed| joint angle")),
            position_min=(-np.pi, 0.0), position_max=(np.pi, 2.8),
            velocity_max=(3.0, 3.0), acceleration_max=(40.0, 40.0),
            start_pose=START, start_tolerance=0.01, max_duration=5.0, min_samples=3,
        ))
        self.omega = float(servo_frequency)

    def _execute(self, trajectory: dmprs.Trajectory) -> Outcome:
        q = np.array(trajectory.y[0], dtype=float)
        qd = np.zeros_like(q)
        executed = np.empty_like(trajectory.y)
        for j, target in enumerate(trajectory.y):
            if self._interrupted():  # stop() or the timeout: halt and say so
                return self._interrupted_outcome()
            # one control period of the servo: qdd = w^2 (target - q) - 2 w qd, semi-implicit Euler
            qd += DT * (self.omega**2 * (target - q) - 2 * self.omega * qd)
            q += DT * qd
            executed[j] = q
        a, b = q[0], q[0] + q[1]
        tip = (L1 * np.cos(a) + L2 * np.cos(b), L1 * np.sin(a) + L2 * np.sin(b))
        return Outcome(Status.OK, executed=dmprs.Trajectory(trajectory.t, executed), signals={
            "fingertip_x": float(tip[0]), "fingertip_y": float(tip[1]),
            "tracking_error": float(np.abs(executed - trajectory.y).max())})


class ForgetfulAdapter(PlanarArmAdapter):
    """Measures a signal it does not declare: check_adapter catches it."""

    def _execute(self, trajectory: dmprs.Trajectory) -> Outcome:
        out = super()._execute(trajectory)
        return Outcome(out.status, {**out.signals, "gripper": 0.0}, out.executed)


def a_valid_trajectory() -> dmprs.Trajectory:
    t = np.arange(0.0, 1.0 + DT / 2, DT)
    s = t / t[-1]
    m = 10 * s**3 - 15 * s**4 + 6 * s**5
    return dmprs.Trajectory(t, np.array(START) + np.outer(m, [0.5, -0.6]))


def main() -> dict:
    traj = a_valid_trajectory()
    dry = check_adapter(PlanarArmAdapter(), traj, execute=False)
    print(f"without moving: {len(dry)} checks passed")
    full = check_adapter(PlanarArmAdapter(), traj)
    print(f"with executions: {len(full)} checks passed")
    arm = PlanarArmAdapter()
    with arm:
        arm.reset(seed=0)
        outcome = arm.execute(traj)
        too_fast = arm.execute(dmprs.Trajectory(traj.t / 4, traj.y))  # rejected, never clipped
    print(f"one strike: fingertip at ({outcome.signals['fingertip_x']:.3f}, {outcome.signals['fingertip_y']:.3f}) m, "
          f"tracking error {outcome.signals['tracking_error'] * 1e3:.1f} mrad")
    print(f"four times faster: {too_fast.status.value}: {too_fast.message[:100]}...")
    try:
        check_adapter(ForgetfulAdapter(), traj)
        caught = ""
    except AdapterConformanceError as exc:
        caught = str(exc)
        print(f"the broken adapter is caught: {caught}")
    return {"dry": dry, "full": full, "outcome": outcome, "too_fast": too_fast, "caught": caught}


if __name__ == "__main__":
    main()
