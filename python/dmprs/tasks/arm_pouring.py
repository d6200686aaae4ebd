"""The paper's pouring (section 5) on a 7-DOF arm in MuJoCo: a KUKA LBR iiwa 14 (the LWR's
successor) holds a bottle of granular "liquid" and must pour **0.2 l** into a glass, whatever the
bottle holds (:mod:`dmprs.sim.arm_scene`, model in :mod:`dmprs.sim.arm_model`, docs/arm.md).

* :class:`ArmPouringAdapter` executes either a joint-space :class:`~dmprs.Trajectory` (7 DOFs,
  rad) or a Cartesian pose trajectory of the bottle's mouth (any object with ``.t`` (T,) and
  ``.pose`` (T, 7) = x, y, z, qw, qx, qy, qz, such as a ``CartesianDMP`` rollout), which it turns
  into joints by damped-least-squares differential IK (:mod:`dmprs.sim.arm_ik`). ``check`` does
  that IK pass dry and lists every reason to refuse: non-finite or non-unit poses, a start away
  from the home pose, unreachable poses, joint position and velocity limits, the arm or bottle
  touching the table or the glass; each names the time. A simulation that diverges becomes an
  ``error`` outcome.
* :class:`ArmPouring` scores it like the 2-D :class:`~dmprs.tasks.pouring.Pouring`: query = the
  (assumed) bottle volume in l, ``eps = V_poured - V*`` (``sign = -1``).
* :func:`pour_poses` is the scripted "kinesthetic" demonstrator: reach over the glass, tilt about
  the mouth, hold, tilt back, as a pose trajectory; :func:`calibrate_peak_tilt` finds the peak
  tilt that pours a given volume with the library's Illinois root finder.
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
import os
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dmprs._arrays import as_float_array, check_increasing
from dmprs._io import write_atomic
from dmprs.adapters import AdapterSpec, BaseAdapter, Outcome, SignalSpec, Status
from dmprs.errors import InvalidInputError, NumericalError
from dmprs.tasks.base import Task
from dmprs.trajectory import Trajectory

#: litres per sphere (the same 2 ml as the 2-D scene)
PARTICLE_VOLUME = 0.002
#: the most the simulated bottle holds (l): 500 spheres
CAPACITY = 1.0
TARGET_VOLUME = 0.2  #: l, the paper's task
DEMO_VOLUMES = (0.3, 1.0)  #: l, the demonstrations' bottles (method.md §9.1)
#: s: command sample period of a trajectory (the servo interpolates it to 1 kHz)
CONTROL_PERIOD = 0.002
MAX_DURATION = 8.0  #: s
#: a pose trajectory must start at the home pose within these (m, rad)
START_POSITION_TOL = 1e-3
START_ORIENTATION_TOL = 1e-3
#: an IK residual above these at any sample makes the pose unreachable (m, rad)
REACH_POSITION_TOL = 1e-3
REACH_ORIENTATION_TOL = 5e-3
#: quaternions must be unit to this (a CartesianDMP rollout is to 1e-12)
UNIT_TOL = 1e-6
#: s between the samples the collision check looks at
COLLISION_CHECK_PERIOD = 0.01
#: the scripted demonstration (s): reach over the glass, tilt up, hold, tilt back (method.md §9.3)
DEMO_TIMING = (0.5, 1.5, 0.7, 1.5)
#: the mouth's pose while pouring: over the glass's near edge, upright (see docs/arm.md)
POUR_POSITION = (0.75, -0.175, 0.32)


class PoseTrajectoryLike(Protocol):
    """What the adapter needs of a Cartesian trajectory (``CartesianTrajectory`` has it)."""

    @property
    def t(self) -> NDArray[np.float64]: ...
    @property
    def pose(self) -> NDArray[np.float64]: ...


@dataclass(frozen=True, eq=False)
class PoseTrajectory:
    """Poses of the bottle's mouth ``pose`` (T, 7: x, y, z in m, then a scalar-first unit
    quaternion) at times ``t`` (T,): the scripted demonstrations, validated on construction."""

    t: NDArray[np.float64]
    pose: NDArray[np.float64]

    def __post_init__(self) -> None:
        t = as_float_array(self.t, "t", 1)
        check_increasing(t)
        pose = as_float_array(self.pose, "pose", 2)
        if pose.shape != (len(t), 7):
            raise InvalidInputError(f"pose has shape {pose.shape}; expected ({len(t)}, 7)")
        for arr in (t, pose):
            arr.setflags(write=False)
        object.__setattr__(self, "t", t)
        object.__setattr__(self, "pose", pose)


    @property
    def y(self) -> NDArray[np.float64]:
        """The poses, under the name run logs store a command's samples by."""
        return self.pose


def _quat_mul(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """Row-wise Hamilton product of scalar-first quaternions (T, 4)."""
    w1, x1, y1, z1 = a.T
    w2, x2, y2, z2 = b.T
    return np.stack([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2], axis=1)


def pose_to_tangent(pose: NDArray[np.float64], reference: NDArray[np.float64]) -> NDArray[np.float64]:
    """Poses (T, 7) as (T, 6): the position, then the rotation vector ``2 log(q * conj(r))`` of each
    orientation relative to the unit quaternion ``reference`` r (world frame). For rotations of
    less than pi from r this is one-to-one and smooth, so a per-coordinate DMP of it is a pose DMP
    in the tangent space at r: for a rotation about one fixed axis it is exactly the discrete DMP
    of the angle, as the orientation DMP of Ude et al. 2014 is (docs/arm.md)."""
    pose = np.asarray(pose, dtype=float)
    conj = np.asarray(reference, dtype=float) * np.array([1.0, -1.0, -1.0, -1.0])
    rel = _quat_mul(pose[:, 3:], np.broadcast_to(conj, (len(pose), 4)))
    rel *= np.where(rel[:, :1] < 0, -1.0, 1.0)  # the short way round
    v = rel[:, 1:]
    norm = np.linalg.norm(v, axis=1)
    angle = 2 * np.arctan2(norm, rel[:, 0])
    scale = np.where(norm > 1e-12, angle / np.maximum(norm, 1e-300), 2.0)
    return np.hstack([pose[:, :3], v * scale[:, None]])


def tangent_to_pose(y: NDArray[np.float64], reference: NDArray[np.float64]) -> NDArray[np.float64]:
    """The inverse of :func:`pose_to_tangent`: (T, 6) -> poses (T, 7) with unit quaternions."""
    y = np.asarray(y, dtype=float)
    r = y[:, 3:]
    angle = np.linalg.norm(r, axis=1)
    axis_scale = np.where(angle > 1e-12, np.sin(angle / 2) / np.maximum(angle, 1e-300), 0.5)
    rel = np.hstack([np.cos(angle / 2)[:, None], r * axis_scale[:, None]])
    quat = _quat_mul(rel, np.broadcast_to(np.asarray(reference, dtype=float), (len(y), 4)))
    return np.hstack([y[:, :3], quat / np.linalg.norm(quat, axis=1, keepdims=True)])


def _is_pose_trajectory(trajectory: Any) -> bool:
    return not isinstance(trajectory, Trajectory) and hasattr(trajectory, "pose") and hasattr(trajectory, "t")


def _check_volume(value: Any, name: str, capacity: float = CAPACITY) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InvalidInputError(f"{name} = {value!r} must be a number of litres") from None
    if isinstance(value, bool) or not math.isfinite(v) or v <= 0:
        raise InvalidInputError(f"{name} = {value!r} must be a finite number of litres > 0")
    if v > capacity + 1e-12:
        raise InvalidInputError(f"{name} = {v:g} l exceeds the simulated bottle's capacity of {capacity:g} l")
    if round(v / PARTICLE_VOLUME) < 1:
        raise InvalidInputError(f"{name} = {v:g} l is less than one sphere ({PARTICLE_VOLUME * 1000:g} ml)")
    return v


def _tilt(quat: NDArray[np.float64]) -> NDArray[np.float64]:
    """The angle (rad) between the bottle's axis (the mouth frame's z) and the vertical."""
    _w, x, y = quat[:, 0], quat[:, 1], quat[:, 2]
    zz = 1 - 2 * (x * x + y * y)  # the z component of the rotated z axis
    return np.arccos(np.clip(zz / np.sum(quat * quat, axis=1), -1.0, 1.0))


@functools.lru_cache(maxsize=1)
def _kinematics() -> Any:
    from dmprs.sim.arm_ik import ArmKinematics

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
        from dmprs.sim import arm_model as am
        from dmprs.sim.arm_scene import home_configuration

        v = _check_volume(bottle_volume, "bottle_volume")
        self.n_particles = round(v / PARTICLE_VOLUME)
        self.bottle_volume = self.n_particles * PARTICLE_VOLUME
        if not (isinstance(liquid_seed, (int, np.integer)) and not isinstance(liquid_seed, bool)
                and liquid_seed >= 0):
            raise InvalidInputError(f"liquid_seed = {liquid_seed!r} must be a non-negative integer")
        hold_s = float(hold)
        if not (math.isfinite(hold_s) and 0 <= hold_s <= 10):
            raise InvalidInputError(f"hold = {hold!r} s must be between 0 and 10")
        self.home = home_configuration()
        super().__init__(AdapterSpec(
            name="arm-pouring",
            dof_names=am.JOINT_NAMES,
            dof_units=("rad",) * 7,
            control_period=CONTROL_PERIOD,
            signals=(
                SignalSpec("poured_volume", "l", "liquid in the glass, counted `hold` s after the trajectory ends"),
                SignalSpec("remaining_volume", "l", "liquid still in the bottle at the end"),
                SignalSpec("spilled_volume", "l", "liquid neither in the bottle nor in the glass"),
                SignalSpec("initial_volume", "l", "liquid in the bottle before the trial"),
                SignalSpec("poured_particles", "1", "spheres in the glass (2 ml each)"),
                SignalSpec("remaining_particles", "1", "spheres in the bottle"),
                SignalSpec("spilled_particles", "1", "spheres elsewhere"),
                SignalSpec("particles", "1", "spheres in the scene (constant)"),
                SignalSpec("tracking_error", "rad", "largest joint tracking error while moving"),
                SignalSpec("ik_position_error", "m", "largest IK position residual (0 for joint trajectories)"),
                SignalSpec("ik_orientation_error", "rad", "largest IK orientation residual"),
                SignalSpec("max_tilt", "rad", "largest executed tilt of the bottle from upright"),
                SignalSpec("poured_volume_curve", "l", "liquid in the glass over time"),
                SignalSpec("poured_volume_time", "s", "sample times of poured_volume_curve"),
            ),
            position_min=tuple(-x for x in am.JOINT_LIMITS),
            position_max=am.JOINT_LIMITS,
            velocity_max=am.VELOCITY_LIMITS,
            start_pose=tuple(float(x) for x in self.home),
            start_tolerance=1e-3,
            max_duration=MAX_DURATION,
            min_samples=3,
        ))
        self.liquid_seed = int(liquid_seed)
        self.reseed_liquid = bool(reseed_liquid)
        self.hold = hold_s
        self._seed = self.liquid_seed
        self._planned: tuple[Any, Trajectory, float, float] | None = None

    def _reset(self, seed: int | None) -> None:
        if self.reseed_liquid:
            self._seed = self.liquid_seed if seed is None else int(seed)

    # --- the dry pass: IK, limits, collisions ----------------------------------------------------

    def plan(self, trajectory: Any) -> tuple[Trajectory | None, float, float, list[str]]:
        """The joint trajectory that executes ``trajectory`` (itself if it is a joint trajectory;
        the IK's solution for a pose trajectory), its largest IK residuals (m, rad), and every
        problem found before the limit and collision checks."""
        if not _is_pose_trajectory(trajectory):
            return (trajectory if isinstance(trajectory, Trajectory) else None), 0.0, 0.0, []
        from dmprs.sim.arm_scene import HOME_POSE

        t = np.asarray(trajectory.t, dtype=float)
        pose = np.asarray(trajectory.pose, dtype=float)
        if t.ndim != 1 or pose.shape != (len(t), 7):
            return None, 0.0, 0.0, [f"a pose trajectory needs t (T,) and pose (T, 7); got {t.shape} and {pose.shape}"]
        if len(t) < 3:
            return None, 0.0, 0.0, [f"trajectory has {len(t)} samples; at least 3 are needed"]
        for name, arr in (("t", t), ("pose", pose)):
            if not np.isfinite(arr).all():
                idx = tuple(int(i) for i in np.argwhere(~np.isfinite(arr))[0])
                return None, 0.0, 0.0, [f"{name}{list(idx)} is not finite"]
        if (np.diff(t) <= 0).any():
            j = int(np.argmax(np.diff(t) <= 0)) + 1
            return None, 0.0, 0.0, [f"t must be strictly increasing; t[{j}] = {t[j]:.6g} s is not"]
        norm = np.linalg.norm(pose[:, 3:], axis=1)
        off = np.abs(norm - 1)
        if (off > UNIT_TOL).any():
            j = int(np.argmax(off))
            return None, 0.0, 0.0, [(f"the quaternion at t = {t[j]:.4g} s has norm {norm[j]:.9g}, not 1 "
                                    f"(tolerance {UNIT_TOL:g})")]
        home = np.asarray(HOME_POSE)
        problems = []
        dp = float(np.linalg.norm(pose[0, :3] - home[:3]))
        dr = 2 * math.acos(min(1.0, abs(float(np.dot(pose[0, 3:] / norm[0], home[3:])))))
        if dp > START_POSITION_TOL or dr > START_ORIENTATION_TOL:
            problems.append(f"the pose trajectory starts {dp * 1000:.3g} mm and {dr:.3g} rad from the home pose "
                            f"{HOME_POSE} (tolerances {START_POSITION_TOL * 1000:g} mm, {START_ORIENTATION_TOL:g} rad)")
            return None, 0.0, 0.0, problems
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
        joints, _, _, problems = self.plan(trajectory)
        if problems:
            return problems
        if joints is None:
            return [(f"expected a dmprs.Trajectory (7 joints) or a pose trajectory (.t, .pose), got "
                    f"{type(trajectory).__name__}")]
        problems = self.spec.check(joints)
        if _is_pose_trajectory(trajectory):
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
        rows = list(range(0, joints.n_samples, step)) + [joints.n_samples - 1]
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
        from dmprs.sim import arm_scene as scene

        joints, pe, re, problems = self.plan(trajectory)
        if problems or joints is None:  # execute() checked already; a changed trajectory is refused
            return Outcome(Status.REJECTED, message="; ".join(problems) or "not a trajectory")
        liquid = scene.settled_liquid(self.n_particles, self._seed)
        qd = joints.yd if joints.yd is not None else np.gradient(joints.y, joints.t, axis=0)
        result = scene.simulate_pour(joints.t, joints.y, qd, liquid, hold=self.hold,
                                     should_stop=self._interrupted)
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
        n = result.n_particles
        signals = {
            "poured_volume": result.n_glass * PARTICLE_VOLUME,
            "remaining_volume": result.n_bottle * PARTICLE_VOLUME,
            "spilled_volume": result.n_spilled * PARTICLE_VOLUME,
            "initial_volume": n * PARTICLE_VOLUME,
            "poured_particles": result.n_glass,
            "remaining_particles": result.n_bottle,
            "spilled_particles": result.n_spilled,
            "particles": n,
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


# --- the scripted demonstrator ------------------------------------------------------------------

def _min_jerk(s: NDArray[np.float64]) -> NDArray[np.float64]:
    s = np.clip(s, 0.0, 1.0)
    return 10 * s**3 - 15 * s**4 + 6 * s**5


def pour_poses(peak_tilt: float, timing: tuple[float, float, float, float] = DEMO_TIMING,
               dt: float = CONTROL_PERIOD) -> PoseTrajectory:
    """The scripted demonstration as poses of the mouth: minimum-jerk reach from the home pose to
    :data:`POUR_POSITION` (upright), minimum-jerk tilt about the mouth by ``peak_tilt`` rad toward
    the glass (a rotation about the world's x axis, which turns the mouth toward -y), hold, and
    minimum-jerk tilt back to upright; the mouth stays still while the bottle tilts."""
    from dmprs.sim.arm_scene import HOME_POSE

    peak = float(peak_tilt)
    if not math.isfinite(peak):
        raise InvalidInputError(f"peak_tilt = {peak_tilt!r} must be a finite angle in rad")
    reach, up, hold, down = (float(x) for x in timing)
    if min(reach, up, down) <= 0 or hold < 0:
        raise InvalidInputError(f"timing = {timing!r}: reach, up and down must be > 0 s, hold >= 0 s")
    total = reach + up + hold + down
    t = np.linspace(0.0, total, round(total / dt) + 1)
    start, goal = np.asarray(HOME_POSE[:3]), np.asarray(POUR_POSITION)
    position = start + _min_jerk(t / reach)[:, None] * (goal - start)
    angle = peak * (_min_jerk((t - reach) / up) - _min_jerk((t - reach - up - hold) / down))
    quat = np.stack([np.cos(angle / 2), np.sin(angle / 2), np.zeros_like(t), np.zeros_like(t)], axis=1)
    return PoseTrajectory(t, np.hstack([position, quat]))


@dataclass(frozen=True)
class Calibration:
    """A demonstration's peak tilt and what it pours, with every search evaluation."""

    bottle_volume: float
    target_volume: float
    liquid_seed: int
    peak_tilt: float  #: rad
    poured_volume: float  #: l
    evaluations: tuple[tuple[float, float], ...]  #: (peak tilt rad, poured l), in order


def poured_volume(bottle_volume: float, trajectory: Any, liquid_seed: int = 0) -> float:
    """What ``trajectory`` pours from a bottle holding ``bottle_volume`` l (one simulated trial)."""
    adapter = ArmPouringAdapter(bottle_volume, liquid_seed=liquid_seed)
    with adapter:
        adapter.reset(seed=liquid_seed)
        outcome = adapter.execute(trajectory)
    if not outcome.ok:
        raise NumericalError(f"a pour from {bottle_volume:g} l was {outcome.status.value}: {outcome.message}")
    return float(outcome.signals["poured_volume"])


def _cache_path(cache_dir: str, params: dict[str, Any]) -> Path:
    """The disk-cache file of a calibration: keyed by its parameters, the whole scene (its MJCF,
    the liquid's and the demonstrator's constants) and the MuJoCo version."""
    import mujoco

    from dmprs.sim import arm_model, arm_scene, granular

    blob = json.dumps({"params": params, "mjcf": arm_model.scene_xml(), "mujoco": mujoco.__version__,
                       "home": arm_scene.HOME_POSE, "settle": arm_scene.SETTLE_TIME,
                       "spawn": (granular.SPAWN_GAP, granular.MAX_PARTICLES), "timing": DEMO_TIMING,
                       "pour": POUR_POSITION, "period": CONTROL_PERIOD, "schema": 1}, sort_keys=True, default=str)
    return Path(cache_dir) / f"arm-pouring-demo-{hashlib.sha256(blob.encode()).hexdigest()[:24]}.json"


def calibrate_peak_tilt(bottle_volume: float, target_volume: float = TARGET_VOLUME, *, liquid_seed: int = 0,
                        tol: float = 0.004, max_evaluations: int = 10, bracket: tuple[float, float] = (1.2, 2.4),
                        cache_dir: str | os.PathLike[str] | None = None) -> Calibration:
    """The peak tilt of :func:`pour_poses` that pours ``target_volume`` from a bottle holding
    ``bottle_volume`` l, found by the library's Illinois root finder
    (:class:`dmprs.learners.IllinoisRootFinder`) on ``poured(peak) - target`` over ``bracket``
    (rad), stopping at ``|error| <= tol`` l or after ``max_evaluations`` pours (then the best).

    Cached per process; with ``cache_dir`` (default: ``$DMPRS_CACHE_DIR`` if set) also on disk
    (see :func:`_cache_path`)."""
    if cache_dir is None and os.environ.get("DMPRS_CACHE_DIR"):
        cache_dir = os.environ["DMPRS_CACHE_DIR"]
    return _calibrate(float(bottle_volume), float(target_volume), int(liquid_seed), float(tol),
                      int(max_evaluations), (float(bracket[0]), float(bracket[1])),
                      None if cache_dir is None else str(cache_dir))


@functools.lru_cache(maxsize=16)
def _calibrate(bottle_volume: float, target_volume: float, liquid_seed: int, tol: float, max_evaluations: int,
               bracket: tuple[float, float], cache_dir: str | None) -> Calibration:
    from dmprs.learners import IllinoisRootFinder

    v = _check_volume(bottle_volume, "bottle_volume")
    target = _check_volume(target_volume, "target_volume", capacity=v)
    lo, hi = bracket
    path = None
    if cache_dir is not None:
        path = _cache_path(cache_dir, {"v": v, "target": target, "seed": liquid_seed, "tol": tol,
                                       "max": max_evaluations, "bracket": bracket})
        try:
            d = json.loads(path.read_text())
            return Calibration(**{**d, "evaluations": tuple(tuple(e) for e in d["evaluations"])})
        except (OSError, ValueError, TypeError):
            pass  # absent or damaged: computed and (re)written
    # The root finder searches q with eps > 0 meaning "increase q": more tilt pours more, so
    # eps = target - poured (method.md §5.3).
    finder = IllinoisRootFinder(0.5 * (lo + hi), lo, hi, tol=tol, max_trials=max_evaluations)
    evals: list[tuple[float, float]] = []
    while len(evals) < max_evaluations and not finder.converged:
        peak = float(np.atleast_1d(finder.ask())[0])
        poured = poured_volume(v, pour_poses(peak), liquid_seed)
        evals.append((peak, poured))
        if abs(poured - target) <= tol:
            break
        finder.tell(peak, target - poured)
    peak, poured = min(evals, key=lambda e: (abs(e[1] - target), e[0]))
    cal = Calibration(v, target, int(liquid_seed), peak, poured, tuple(evals))
    if path is not None:
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            write_atomic(path, json.dumps(asdict(cal)).encode())
        except OSError:
            pass  # the disk cache is an optimization only
    return cal


def demonstration_tangent(peak_tilt: float) -> Trajectory:
    """The scripted demonstration of :func:`pour_poses` as a 6-D trajectory of the position and the
    rotation vector from the upright home orientation (:func:`pose_to_tangent`), with its exact
    sampling, for encoding as DMPs with the library's generalizer."""
    from dmprs.sim.arm_scene import HOME_POSE

    poses = pour_poses(peak_tilt)
    return Trajectory(poses.t, pose_to_tangent(poses.pose, np.asarray(HOME_POSE[3:])))


# --- the task -----------------------------------------------------------------------------------

class ArmPouring(Task):
    """Pour ``target_volume`` (0.2 l) with the arm from a bottle holding ``bottle_volume`` l.

    Query: the assumed bottle volume (l); ``eps = V_poured - V*`` (``sign = -1``); success when
    ``|eps| < tol`` (l; the default is set from the measured noise floor, docs/arm.md). Adapter
    options go to :class:`ArmPouringAdapter`.
    """

    name = "arm-pouring"
    query_names = ("bottle_volume",)
    query_units = ("l",)
    sign = -1.0

    def __init__(self, bottle_volume: float = 0.5, target_volume: float = TARGET_VOLUME,
                 tol: float = 0.010, **adapter_options: Any) -> None:
        adapter = ArmPouringAdapter(bottle_volume, **adapter_options)
        super().__init__(adapter)
        self.bottle_volume = adapter.bottle_volume
        self.target_volume = _check_volume(target_volume, "target_volume", capacity=self.bottle_volume)
        tol_f = float(tol)
        if not (math.isfinite(tol_f) and tol_f > 0):
            raise InvalidInputError(f"tol = {tol!r} must be > 0 l")
        self.tol = tol_f

    def validate_query(self, query: ArrayLike, name: str = "desired_query") -> NDArray[np.float64]:
        q = super().validate_query(query, name)
        if q[0] <= 0:
            raise InvalidInputError(f"{name} = {q[0]:g} l: a bottle volume must be > 0")
        return q

    def trajectory(self, dmp: Any) -> Any:
        """The pose trajectory of a generalized DMP, rolled out at the adapter's control period: a
        ``CartesianDMP``'s rollout as it is, or a 6-D DMP of :func:`demonstration_tangent`'s
        coordinates (position, rotation vector from upright) turned back into poses."""
        out = dmp.rollout(dt=self.adapter.spec.control_period)
        if hasattr(out, "pose"):
            return out
        from dmprs.sim.arm_scene import HOME_POSE

        return PoseTrajectory(out.t, tangent_to_pose(out.y, np.asarray(HOME_POSE[3:])))

    def measure(self, outcome: Outcome) -> NDArray[np.float64]:
        return np.array([float(outcome.signals["poured_volume"])])

    def target(self, desired_query: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.array([self.target_volume])
