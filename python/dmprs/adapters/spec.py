"""What an adapter declares about itself: degrees of freedom, control period, limits and the
outcome signals it measures.
"""

from __future__ import annotations

import enum
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from dmprs import quaternion
from dmprs.errors import InvalidInputError
from dmprs.portable import norm
from dmprs.trajectory import AnyTrajectory, CartesianTrajectory, Trajectory


@dataclass(frozen=True)
class SignalSpec:
    """One measured outcome signal: a name, its SI unit, and what it means.

    ``kind`` is ``"real"`` (a finite number or array of them) or ``"label"`` (a string, e.g. a
    regime name). ``nan_if_absent`` declares that NaN means "did not happen" for this signal
    (e.g. the time a box never reached); otherwise a NaN or infinity is a broken measurement.
    """

    name: str
    unit: str
    description: str = ""
    kind: str = "real"
    nan_if_absent: bool = False

    def __post_init__(self) -> None:
        if self.kind not in ("real", "label"):
            raise InvalidInputError(f"signal {self.name!r}: kind = {self.kind!r} is invalid: use 'real' or 'label'")


@dataclass(frozen=True)
class AdapterSpec:
    """Everything a caller must know before sending a trajectory.

    Limits are per DOF; ``None`` means unlimited. ``start_pose`` (if given) is where every
    trajectory must begin, within ``start_tolerance`` (units of the DOFs). A trajectory that
    breaks a limit is rejected, never clipped: clipping would execute a different movement than
    the one the learner chose.

    ``pose=True`` declares an end-effector adapter that takes :class:`~dmprs.CartesianTrajectory`
    commands: ``dof_names`` are then the three position coordinates (m), to which the position,
    velocity and acceleration limits apply, and the orientation is a unit quaternion, checked
    for unit norm (to 1e-6), for the norm of the angular velocity (``angular_velocity_max``,
    rad/s) and of the angular acceleration (``angular_acceleration_max``, rad/s^2). Its
    ``start_pose`` is a pose ``(x, y, z, qw, qx, qy, qz)``; ``start_tolerance`` is in m for the
    position and rad for the orientation.
    """

    name: str
    dof_names: tuple[str, ...]
    dof_units: tuple[str, ...]
    control_period: float
    signals: tuple[SignalSpec, ...]
    position_min: tuple[float, ...] | None = None
    position_max: tuple[float, ...] | None = None
    velocity_max: tuple[float, ...] | None = None
    acceleration_max: tuple[float, ...] | None = None
    start_pose: tuple[float, ...] | None = None
    start_tolerance: float = 1e-3
    max_duration: float | None = None
    min_samples: int = 2
    pose: bool = False
    angular_velocity_max: float | None = None
    angular_acceleration_max: float | None = None

    def __post_init__(self) -> None:
        n = len(self.dof_names)
        if self.pose and n != 3:
            raise InvalidInputError(
                f"{self.name}: a pose adapter has 3 position DOFs (x, y, z); got {n} dof_names"
            )
        if not self.pose and (self.angular_velocity_max is not None or self.angular_acceleration_max is not None):
            raise InvalidInputError(f"{self.name}: angular limits need pose=True")
        for name in ("angular_velocity_max", "angular_acceleration_max"):
            value = getattr(self, name)
            if value is not None and not (np.isfinite(value) and value > 0):
                raise InvalidInputError(f"{self.name}: {name} = {value} must be > 0")
        if n == 0:
            raise InvalidInputError(f"{self.name}: an adapter needs at least one DOF")
        if len(self.dof_units) != n:
            raise InvalidInputError(f"{self.name}: {n} dof_names but {len(self.dof_units)} dof_units")
        if not (np.isfinite(self.control_period) and self.control_period > 0):
            raise InvalidInputError(f"{self.name}: control_period = {self.control_period} must be > 0")
        for name in ("position_min", "position_max", "velocity_max", "acceleration_max", "start_pose"):
            value = getattr(self, name)
            want = 7 if (self.pose and name == "start_pose") else n
            if value is not None and len(value) != want:
                raise InvalidInputError(f"{self.name}: {name} has {len(value)} entries, expected {want}")
        names = [s.name for s in self.signals]
        if len(set(names)) != len(names):
            raise InvalidInputError(f"{self.name}: duplicate signal names in {names}")

    @property
    def n_dof(self) -> int:
        """Number of degrees of freedom (the length of ``dof_names``)."""
        return len(self.dof_names)

    def check(self, trajectory: AnyTrajectory) -> list[str]:
        """Every way ``trajectory`` breaks this spec, as readable sentences; empty if none.

        Pure: it only reads the trajectory. Position limits apply to y, velocity limits to yd and
        acceleration limits to ydd (derived by finite differences when the trajectory lacks them).
        """
        if self.pose:
            if not isinstance(trajectory, CartesianTrajectory):
                return [f"{self.name} takes poses: expected a dmprs.CartesianTrajectory, got {type(trajectory).__name__}"]
            return self._check_pose(trajectory)
        if not isinstance(trajectory, Trajectory):
            return [f"expected a dmprs.Trajectory, got {type(trajectory).__name__}"]
        problems: list[str] = []
        t, y = trajectory.t, trajectory.y
        if y.shape[1] != self.n_dof:
            return [f"trajectory has {y.shape[1]} DOFs; {self.name} has {self.n_dof} ({', '.join(self.dof_names)})"]
        if len(t) < self.min_samples:
            problems.append(f"trajectory has {len(t)} samples; at least {self.min_samples} are needed")
            return problems
        arrays = {"y": y, "yd": trajectory.yd, "ydd": trajectory.ydd}
        for name, arr in arrays.items():
            if arr is not None and not np.isfinite(arr).all():
                j, d = np.argwhere(~np.isfinite(arr))[0]
                problems.append(f"{name}[{j}, {d}] ({self.dof_names[d]}) is not finite")
        if problems:
            return problems
        self._check_motion(problems, trajectory.duration, t, y, trajectory.yd, trajectory.ydd)
        if self.start_pose is not None:
            off = np.abs(y[0] - np.asarray(self.start_pose))
            # `not <=`: a start the robot reports as NaN is away from every trajectory
            for d in np.flatnonzero(~(off <= self.start_tolerance)):
                problems.append(
                    f"{self.dof_names[d]} starts at {y[0, d]:.6g} {self.dof_units[d]}, "
                    f"{off[d]:.3g} from the start pose {self.start_pose[d]:.6g} "
                    f"(tolerance {self.start_tolerance:.3g})"
                )
        return problems

    def signal_problems(self, signals: Any) -> list[str]:
        """Every way measured ``signals`` break this spec (empty when they are fine): not a
        mapping, a declared signal missing, an undeclared one, a value that is not a real number
        or array of them (a string, None, a bool), or a NaN or infinity.
        """
        if not isinstance(signals, Mapping):
            return [f"signals is a {type(signals).__name__}, not a mapping of signal names to values"]
        declared = [s.name for s in self.signals]
        problems = [f"declared signal {name!r} is missing" for name in declared if name not in signals]
        problems += [f"signal {name!r} is not declared in the spec" for name in signals if name not in declared]
        for sig in self.signals:
            if sig.name not in signals:
                continue
            value = signals[sig.name]
            if sig.kind == "label":
                if not isinstance(value, str):
                    problems.append(f"signal {sig.name!r} is {type(value).__name__} {value!r:.60}, not a label (str)")
                continue
            try:
                arr = np.asarray(value)
            except Exception:  # noqa: BLE001 - ragged or exotic values are simply the wrong type
                arr = np.asarray(None)
            if isinstance(value, (bool, np.bool_)) or arr.dtype.kind not in "fiu":
                problems.append(
                    f"signal {sig.name!r} is {type(value).__name__} {value!r:.60}, not a real number or array")
            elif np.isinf(arr).any() or (np.isnan(arr).any() and not sig.nan_if_absent):
                problems.append(f"signal {sig.name!r} has non-finite values: {value!r:.60}")
        return problems

    def _check_pose(self, tr: CartesianTrajectory) -> list[str]:
        problems = pose_problems(tr, min_samples=self.min_samples)
        if problems:
            return problems
        t = tr.t
        self._check_motion(problems, tr.duration, t, tr.position, tr.velocity, tr.acceleration)
        w = tr.angular_velocity if tr.angular_velocity is not None else _angular_velocity(t, tr.quaternion)
        for what, values, limit, unit in (
            ("angular velocity", w, self.angular_velocity_max, "rad/s"),
            ("angular acceleration", None, self.angular_acceleration_max, "rad/s^2"),
        ):
            if limit is None:
                continue
            if values is None:
                values = tr.angular_acceleration if tr.angular_acceleration is not None else _derivative(t, w)
            speed = np.linalg.norm(values, axis=1)
            j = int(np.argmax(speed))
            if speed[j] > limit:
                problems.append(f"{what} is {speed[j]:.6g} {unit} at t = {t[j]:.4g} s, above the maximum {limit:.6g}")
        if self.start_pose is not None:
            problems += start_problems(tr, self.start_pose, self.start_tolerance)
        return problems

    def _check_motion(self, problems, duration, t, y, yd, ydd) -> None:
        """The duration, position, velocity and acceleration limits, for joints and for the
        position of a pose alike; a derivative not measured is taken by finite differences.
        """
        if self.max_duration is not None and duration > self.max_duration + 1e-12:
            problems.append(f"duration {duration:.4g} s exceeds the limit {self.max_duration:.4g} s")
        yd = yd if yd is not None else _derivative(t, y)
        ydd = ydd if ydd is not None else _derivative(t, yd)
        self._check_bounds(problems, t, "position", y, self.position_min, self.position_max)
        if self.velocity_max is not None:
            self._check_bounds(problems, t, "velocity", np.abs(yd), None, self.velocity_max)
        if self.acceleration_max is not None:
            self._check_bounds(problems, t, "acceleration", np.abs(ydd), None, self.acceleration_max)

    def _check_bounds(self, problems, t, what, values, low, high) -> None:
        for bound, sign in ((low, -1.0), (high, 1.0)):
            if bound is None:
                continue
            b = np.asarray(bound, dtype=float)
            excess = sign * (values - b)
            for d in range(self.n_dof):
                bad = np.flatnonzero(excess[:, d] > 0)
                if len(bad):
                    j = bad[np.argmax(excess[bad, d])]
                    word = "above the maximum" if sign > 0 else "below the minimum"
                    problems.append(
                        f"{what} of {self.dof_names[d]} is {values[j, d]:.6g} {self._unit(d, what)} "
                        f"at t = {t[j]:.4g} s, {word} {b[d]:.6g}"
                    )

    def _unit(self, d: int, what: str) -> str:
        base = self.dof_units[d]
        return {"position": base, "velocity": f"{base}/s", "acceleration": f"{base}/s^2"}[what]


def _derivative(t: np.ndarray, y: np.ndarray) -> np.ndarray:
    return np.gradient(y, t, axis=0, edge_order=2 if len(t) >= 3 else 1)


def _angular_velocity(t: np.ndarray, q: np.ndarray) -> np.ndarray:
    """World-frame angular velocity (T, 3) of sampled unit quaternions, by finite differences of
    consecutive rotations: ``2 log(q_{j+1} conj(q_j)) / dt`` at the midpoints, interpolated.
    """
    if len(t) < 2:
        return np.zeros((len(t), 3))
    mid = quaternion.log(quaternion.product(q[1:], quaternion.conjugate(q[:-1]))) / np.diff(t)[:, None]
    tm = 0.5 * (t[1:] + t[:-1])
    return np.stack([np.interp(t, tm, mid[:, d]) for d in range(3)], axis=1)


def pose_problems(tr: CartesianTrajectory, *, min_samples: int) -> list[str]:
    """What makes a pose trajectory unusable, as every consumer checks it before anything else
    (an adapter's spec, an adapter that turns poses into joints): too few samples, arrays of the
    wrong width, a value that is not finite, times that do not increase, a quaternion that is not
    unit. A validated
    :class:`~dmprs.CartesianTrajectory` can only have too few samples; one built
    :meth:`~dmprs.CartesianTrajectory.unchecked` may break any. Empty when none.
    """
    t = tr.t
    if len(t) < min_samples:
        return [f"trajectory has {len(t)} samples; at least {min_samples} are needed"]
    widths = {name: (3 if name != "quaternion" else 4) for name in _POSE_FIELDS}
    problems = [f"{name} has {arr.shape[1]} columns per sample, a pose has {widths[name]}"
                for name in _POSE_FIELDS if (arr := getattr(tr, name)) is not None and arr.shape[1:] != (widths[name],)]
    if problems:
        return problems
    for name in ("t", *_POSE_FIELDS):
        arr = getattr(tr, name)
        if arr is not None and not np.isfinite(arr).all():
            where = ", ".join(str(int(i)) for i in np.argwhere(~np.isfinite(arr))[0])
            problems.append(f"{name}[{where}] is not finite")
    if problems:
        return problems
    if (np.diff(t) <= 0).any():
        j = int(np.argmax(np.diff(t) <= 0)) + 1
        return [f"t must be strictly increasing; t[{j}] = {t[j]:.6g} s is not"]
    norm_error = np.abs(np.linalg.norm(tr.quaternion, axis=1) - 1.0)
    if norm_error.max() > quaternion.UNIT_TOLERANCE:
        j = int(np.argmax(norm_error))
        return [(f"the quaternion at t = {t[j]:.4g} s has norm {1 + norm_error[j]:.9g}, not a unit quaternion "
                f"(tolerance {quaternion.UNIT_TOLERANCE:g})")]
    return []


def start_problems(tr: CartesianTrajectory, start_pose: tuple[float, ...], tolerance: float) -> list[str]:
    """Where a usable pose trajectory (:func:`pose_problems`) starts away from ``start_pose``
    (x, y, z, qw, qx, qy, qz): beyond ``tolerance`` m in position or ``tolerance`` rad in
    orientation. Empty when it starts there.
    """
    start = np.asarray(start_pose, dtype=float)
    if start.shape != (7,) or not np.isfinite(start).all():
        return [f"the start pose {start.tolist()} is not a finite pose (x, y, z, qw, qx, qy, qz)"]
    q_norm = norm(start[3:])
    if not q_norm > 0.5:  # a reported orientation must be a quaternion, not zeros or a scaled one
        return [f"the start pose's quaternion {start[3:].tolist()} has norm {q_norm:.3g}, not a unit quaternion"]
    problems = []
    off = norm(tr.position[0] - start[:3])
    if not off <= tolerance:
        problems.append(f"the position starts {off * 1000:.3g} mm from the start pose's {start[:3].tolist()} m "
                        f"(tolerance {tolerance * 1000:.3g} mm)")
    turn = float(quaternion.angle(tr.quaternion[0], start[3:] / q_norm))
    if not turn <= tolerance:
        problems.append(f"the orientation starts {turn:.3g} rad from the start pose's (tolerance {tolerance:.3g} rad)")
    return problems


_POSE_FIELDS = ("position", "quaternion", "velocity", "angular_velocity", "acceleration", "angular_acceleration")


class Status(str, enum.Enum):
    """How a trial ended. Only ``OK`` outcomes carry a measurement a learner may use."""

    OK = "ok"
    DRY_RUN = "dry_run"
    REJECTED = "rejected"
    ABORTED = "aborted"
    TIMEOUT = "timeout"
    STOPPED = "stopped"
    ERROR = "error"


@dataclass(frozen=True)
class Outcome:
    """The result of one ``execute`` call.

    ``signals`` maps the adapter's signal names to measured values (floats or arrays);
    ``executed`` is what the robot or simulation actually did, which may differ from the
    commanded trajectory (tracking error, early stop). ``message`` says why a non-ok trial
    ended as it did, or what an ok one left out (samples no robot could have sent).
    """

    status: Status
    signals: Mapping[str, Any] = field(default_factory=dict)
    executed: AnyTrajectory | None = None
    message: str = ""

    @property
    def ok(self) -> bool:
        """Whether the execution ran to its end (status OK)."""
        return self.status is Status.OK
