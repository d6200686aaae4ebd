"""The MuJoCo arm-pouring scene behind the adapter interface: joint or pose trajectories, the dry
IK pass, limits, collisions, and the outcome signals.
"""

from __future__ import annotations

import functools
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dmprs.adapters import BaseAdapter, Outcome, SignalSpec, Status
from dmprs.adapters.spec import pose_problems, start_problems
from dmprs.portable import arccos
from dmprs.sim import arm_scene as scene
from dmprs.sim import pour_memo
from dmprs.sim.arm_ik import ArmKinematics
from dmprs.sim.arm_scene import HOME_POSE, home_configuration
from dmprs.tasks import iiwa
from dmprs.tasks.liquid import CURVE_SIGNALS, PARTICLE_VOLUME, Liquid, check_volume, counts
from dmprs.tasks.liquid import signals as liquid_signals
from dmprs.trajectory import CartesianTrajectory, Trajectory, controller_times

#: the most the simulated bottle holds (l): 500 spheres of 2 ml
CAPACITY = 1.0
#: s: command sample period of a trajectory (the servo interpolates it to 1 kHz)
CONTROL_PERIOD = 0.002
MAX_DURATION = 8.0  #: s
#: a pose trajectory must start at the home pose within this, in m and in rad
START_TOLERANCE = 1e-3
#: an IK residual above these at any sample makes the pose unreachable (m, rad)
REACH_POSITION_TOL = 1e-3
REACH_ORIENTATION_TOL = 5e-3
#: s between the samples the collision check looks at
COLLISION_CHECK_PERIOD = 0.01


def _tilt(quat: NDArray[np.float64]) -> NDArray[np.float64]:
    """The angle (rad) between the bottle's axis (the mouth frame's z) and the vertical."""
    _w, x, y = quat[:, 0], quat[:, 1], quat[:, 2]
    zz = 1 - 2 * (x * x + y * y)  # the z component of the rotated z axis
    return arccos(np.clip(zz / np.sum(quat * quat, axis=1), -1.0, 1.0))


@functools.lru_cache(maxsize=1)
def _kinematics() -> Any:

    return ArmKinematics()


class ArmPouringAdapter(BaseAdapter):
    """The MuJoCo arm-pouring scene behind the adapter interface.

    Seven DOFs ``a1..a7`` (rad) with the iiwa 14's position and velocity limits; a joint
    trajectory must start at :func:`home_configuration` (within 1 mrad), a pose trajectory at
    :data:`~dmprs.sim.arm_scene.HOME_POSE` (1 mm, 1 mrad). After the trajectory the arm holds its
    last sample for ``hold`` s and the spheres are counted.

    Signals: ``poured_volume`` (l, in the glass: the measurement), ``remaining_volume``,
    ``spilled_volume``, ``initial_volume`` (l) and the same as sphere counts
    (``poured_particles``, ``remaining_particles``, ``spilled_particles``, ``particles``; the three
    add up to ``particles``); ``tracking_error`` (rad, the largest |q - q*| of any joint while
    moving); ``ik_position_error`` (m) and ``ik_orientation_error`` (rad), the largest IK
    residuals (0 for a joint trajectory); ``max_tilt`` (rad, of the bottle's axis from the
    vertical); ``poured_volume_curve`` (l) at ``poured_volume_time`` (s) every 20 ms.
    """

    def __init__(self, bottle_volume: float = 0.5, *, liquid_seed: int = 0, reseed_liquid: bool = False,
                 hold: float = 0.5) -> None:

        v = check_volume(bottle_volume, "bottle_volume", capacity=CAPACITY)
        self.n_particles = round(v / PARTICLE_VOLUME)
        self.bottle_volume = self.n_particles * PARTICLE_VOLUME
        self.liquid = Liquid(liquid_seed, reseed_liquid, hold)
        self.home = home_configuration()
        super().__init__(iiwa.spec(
            "arm-pouring", home=self.home, control_period=CONTROL_PERIOD, max_duration=MAX_DURATION,
            signals=(
                *liquid_signals("spheres"),
                iiwa.TRACKING_ERROR,
                SignalSpec("ik_position_error", "m", "largest IK position residual (0 for joint trajectories)"),
                SignalSpec("ik_orientation_error", "rad", "largest IK orientation residual"),
                SignalSpec("max_tilt", "rad", "largest executed tilt of the bottle from upright"),
                *CURVE_SIGNALS,
            ),
        ))
        self._planned: tuple[Any, Trajectory, float, float] | None = None

    def _reset(self, seed: int | None) -> None:
        self.liquid.reset(seed)

    # --- the dry pass: IK, limits, collisions ----------------------------------------------------

    def plan(self, trajectory: Any) -> tuple[Trajectory | None, float, float, list[str]]:
        """The joint trajectory that executes ``trajectory`` (itself if it is a joint trajectory;
        the IK's solution for a pose trajectory), its largest IK residuals (m, rad), and every
        problem found before the limit and collision checks.
        """
        if not isinstance(trajectory, CartesianTrajectory):
            return (trajectory if isinstance(trajectory, Trajectory) else None), 0.0, 0.0, []

        problems = pose_problems(trajectory, min_samples=self.spec.min_samples) or start_problems(
            trajectory, HOME_POSE, START_TOLERANCE)
        if problems:
            return None, 0.0, 0.0, problems
        t, pose = trajectory.t, trajectory.pose
        # Unit to rounding; the whole pose is divided by the norms as it was when the arm's numbers
        # were measured (the granular outcome turns any change of rounding into another pour).
        norm = np.linalg.norm(pose[:, 3:], axis=1)
        if trajectory is not None and self._planned is not None and self._planned[0] is trajectory:
            _, joints, pe, re = self._planned
            return joints, pe, re, []
        ik = _kinematics().track(t, pose / norm[:, None] if norm.size else pose, self.home)
        bad_p = np.flatnonzero(ik.position_error > REACH_POSITION_TOL)
        bad_r = np.flatnonzero(ik.orientation_error > REACH_ORIENTATION_TOL)
        if len(bad_p) or len(bad_r):
            j = int(min(bad_p[:1].tolist() + bad_r[:1].tolist()))
            problems.append(
                f"the pose at t = {t[j]:.4g} s is unreachable: the IK is left {ik.position_error[j] * 1000:.3g} mm "
                f"and {ik.orientation_error[j]:.3g} rad away (tolerances {REACH_POSITION_TOL * 1000:g} mm, "
                f"{REACH_ORIENTATION_TOL:g} rad); position {np.round(pose[j, :3], 4).tolist()} m")
            return None, 0.0, 0.0, problems
        qd = np.gradient(ik.q, t, axis=0, edge_order=2)
        joints = Trajectory(t, ik.q, qd)
        pe, re = float(ik.position_error.max()), float(ik.orientation_error.max())
        self._planned = (trajectory, joints, pe, re)
        return joints, pe, re, []

    def check(self, trajectory: Any) -> list[str]:
        """Every problem of the IK pass, then the limits of the joint solution, then the first collision."""
        joints, _, _, problems = self.plan(trajectory)
        if problems:
            return problems
        if joints is None:
            return [(f"expected a dmprs.Trajectory (7 joints) or a dmprs.CartesianTrajectory (the mouth's poses), "
                    f"got {type(trajectory).__name__}")]
        problems = self.spec.check(joints)
        if isinstance(trajectory, CartesianTrajectory):
            problems = [f"the IK solution: {p}" for p in problems]
        return problems or self._collisions(joints)

    def _collisions(self, joints: Trajectory) -> list[str]:
        """The first contact of the arm or the bottle with the table or the glass, if any."""
        import mujoco

        kin = _kinematics()
        m, d = kin.model, kin.data
        table = m.geom("table").id
        glassware = {g for g in range(m.ngeom) if m.geom(g).name.startswith("glass")}
        step = max(1, round(COLLISION_CHECK_PERIOD / max(float(np.median(np.diff(joints.t))), 1e-9)))
        rows = [*range(0, joints.n_samples, step), joints.n_samples - 1]
        for k in rows:
            d.qpos[:7] = joints.y[k]
            mujoco.mj_fwdPosition(m, d)
            for c in d.contact[: d.ncon]:
                if c.dist >= 0:
                    continue
                names = sorted((m.geom(c.geom1).name, m.geom(c.geom2).name))
                hit = {c.geom1, c.geom2}
                if table in hit or hit & glassware:
                    return [(f"at t = {joints.t[k] - joints.t[0]:.4g} s {names[0]} and {names[1]} collide "
                            f"({-c.dist * 1000:.3g} mm of penetration)")]
        return []

    # --- execution -------------------------------------------------------------------------------

    def _execute(self, trajectory: Any) -> Outcome:

        joints, pe, re, problems = self.plan(trajectory)
        if problems or joints is None:  # execute() checked already; a changed trajectory is refused
            return Outcome(Status.REJECTED, message="; ".join(problems) or "not a trajectory")
        t = controller_times(joints.t)
        qd = joints.yd if joints.yd is not None else np.gradient(joints.y, t, axis=0)
        n, seed, hold = self.n_particles, self.liquid.seed, self.liquid.hold

        def pour() -> scene.ArmPourResult | None:
            liquid = scene.settle_liquid(n, seed, should_stop=self._interrupted)
            if liquid is None:
                return None
            return scene.simulate_pour(t, joints.y, qd, liquid, hold=hold, should_stop=self._interrupted)

        result = pour_memo.memoized("arm-pouring", (n, seed, hold, t, joints.y, qd), pour)
        if result is None:  # stopped or timed out while the liquid settled
            return self._interrupted_outcome()
        t_rel = joints.t - joints.t[0]
        reached = t_rel <= result.times[-1] + 1e-12
        executed = None
        if reached.sum() >= 2:
            executed = Trajectory(joints.t[reached], np.stack(
                [np.interp(t_rel[reached], result.times, result.q[:, j]) for j in range(7)], axis=1))
        if result.interrupted:
            return self._interrupted_outcome(executed)
        moving = result.times <= t_rel[-1] + 1e-12
        tracking = float(np.abs(result.q[moving] - result.q_ref[moving]).max())
        tilt = float(_tilt(self._mouth_quaternions(result.q[::10])).max())
        signals = {
            **counts(result.n_glass, result.n_bottle, result.n_spilled, result.n_particles,
                     result.n_glass * PARTICLE_VOLUME),
            "tracking_error": tracking,
            "ik_position_error": pe,
            "ik_orientation_error": re,
            "max_tilt": tilt,
            "poured_volume_curve": result.glass_counts * PARTICLE_VOLUME,
            "poured_volume_time": result.sample_times,
        }
        return Outcome(Status.OK, signals=signals, executed=executed)

    @staticmethod
    def _mouth_quaternions(q: NDArray[np.float64]) -> NDArray[np.float64]:
        kin = _kinematics()
        return np.array([kin.pose(row)[3:] for row in q])

