"""What an adapter declares about itself: degrees of freedom, control period, limits and the
outcome signals it measures."""

from __future__ import annotations

import enum
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from dmprs.errors import InvalidInputError
from dmprs.trajectory import Trajectory


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

    def __post_init__(self) -> None:
        n = len(self.dof_names)
        if n == 0:
            raise InvalidInputError(f"{self.name}: an adapter needs at least one DOF")
        if len(self.dof_units) != n:
            raise InvalidInputError(f"{self.name}: {n} dof_names but {len(self.dof_units)} dof_units")
        if not (np.isfinite(self.control_period) and self.control_period > 0):
            raise InvalidInputError(f"{self.name}: control_period = {self.control_period} must be > 0")
        for name in ("position_min", "position_max", "velocity_max", "acceleration_max", "start_pose"):
            value = getattr(self, name)
            if value is not None and len(value) != n:
                raise InvalidInputError(f"{self.name}: {name} has {len(value)} entries for {n} DOFs")
        names = [s.name for s in self.signals]
        if len(set(names)) != len(names):
            raise InvalidInputError(f"{self.name}: duplicate signal names in {names}")

    @property
    def n_dof(self) -> int:
        return len(self.dof_names)

    def check(self, trajectory: Trajectory) -> list[str]:
        """Every way ``trajectory`` breaks this spec, as readable sentences; empty if none.

        Pure: it only reads the trajectory. Position limits apply to y, velocity limits to yd and
        acceleration limits to ydd (derived by finite differences when the trajectory lacks them).
        """
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
        if self.max_duration is not None and trajectory.duration > self.max_duration + 1e-12:
            problems.append(f"duration {trajectory.duration:.4g} s exceeds the limit {self.max_duration:.4g} s")
        yd = trajectory.yd if trajectory.yd is not None else _derivative(t, y)
        ydd = trajectory.ydd if trajectory.ydd is not None else _derivative(t, yd)
        self._check_bounds(problems, t, "position", y, self.position_min, self.position_max)
        if self.velocity_max is not None:
            self._check_bounds(problems, t, "velocity", np.abs(yd), None, self.velocity_max)
        if self.acceleration_max is not None:
            self._check_bounds(problems, t, "acceleration", np.abs(ydd), None, self.acceleration_max)
        if self.start_pose is not None:
            off = np.abs(y[0] - np.asarray(self.start_pose))
            for d in np.flatnonzero(off > self.start_tolerance):
                problems.append(
                    f"{self.dof_names[d]} starts at {y[0, d]:.6g} {self.dof_units[d]}, "
                    f"{off[d]:.3g} from the start pose {self.start_pose[d]:.6g} "
                    f"(tolerance {self.start_tolerance:.3g})"
                )
        return problems

    def signal_problems(self, signals: Any) -> list[str]:
        """Every way measured ``signals`` break this spec (empty when they are fine): not a
        mapping, a declared signal missing, an undeclared one, a value that is not a real number
        or array of them (a string, None, a bool), or a NaN or infinity."""
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
    ended as it did.
    """

    status: Status
    signals: Mapping[str, Any] = field(default_factory=dict)
    executed: Trajectory | None = None
    message: str = ""

    @property
    def ok(self) -> bool:
        return self.status is Status.OK
