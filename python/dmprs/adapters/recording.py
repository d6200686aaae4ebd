"""Adapters that record trials and serve recorded trials again."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from dmprs._io import MiB, append_jsonl, load_npz, read_jsonl, write_npz_atomic
from dmprs.adapters.base import Adapter
from dmprs.adapters.spec import AdapterSpec, Outcome, Status
from dmprs.errors import AdapterError, DmprsError, InvalidInputError
from dmprs.trajectory import AnyTrajectory, CartesianTrajectory, Trajectory, from_arrays

_INDEX = "recording.jsonl"
_TRIAL_FILE = re.compile(r"^trial_\d{4,}\.npz$")
#: a recorded trial's arrays: a few MB even for long trajectories
_TRIAL_MAX_BYTES = 1024 * MiB


def _samples(tr: AnyTrajectory) -> np.ndarray:
    """The positions of a joint trajectory, the poses of a Cartesian one."""
    return tr.pose if isinstance(tr, CartesianTrajectory) else tr.y


class RecordingAdapter(Adapter):
    """Wraps another adapter and records every trial that passes through it: the commanded
    trajectory, the outcome's status, message and signals, and the executed trajectory.

    Each trial is one line of ``recording.jsonl`` plus ``trial_NNNN.npz``, both forced to disk
    before ``execute`` returns. A :class:`ReplayAdapter` serves them again.
    """

    def __init__(self, inner: Adapter, directory: str | Path) -> None:
        self.inner = inner
        self.spec = inner.spec
        self.directory = Path(directory)
        self.directory.mkdir(parents=True, exist_ok=True)
        index = self.directory / _INDEX
        self._n = len(read_jsonl(index)[0]) if index.exists() else 0

    def connect(self) -> None:
        """Connects the wrapped adapter."""
        self.inner.connect()

    def disconnect(self) -> None:
        """Disconnects the wrapped adapter."""
        self.inner.disconnect()

    def reset(self, seed: int | None = None) -> None:
        """Resets the wrapped adapter."""
        self.inner.reset(seed=seed)

    def check(self, trajectory: Trajectory) -> list[str]:
        """The wrapped adapter's checks."""
        return self.inner.check(trajectory)

    def stop(self) -> None:
        """Stops the wrapped adapter."""
        self.inner.stop()

    def execute(
        self, trajectory: Trajectory, dry_run: bool = False, timeout_s: float | None = None
    ) -> Outcome:
        """Executes through the wrapped adapter and records the trial before returning its outcome."""
        outcome = self.inner.execute(trajectory, dry_run=dry_run, timeout_s=timeout_s)
        name = f"trial_{self._n:04d}.npz"
        arrays = {**trajectory.to_arrays("cmd_"), **({} if outcome.executed is None else outcome.executed.to_arrays("exe_"))}
        arrays.update({f"sig_{k}": np.asarray(v) for k, v in outcome.signals.items()})
        write_npz_atomic(self.directory / name, arrays)
        append_jsonl(self.directory / _INDEX, {
            "trial": self._n, "file": name, "status": outcome.status.value,
            "message": outcome.message, "dry_run": dry_run, "signals": sorted(outcome.signals),
        })
        self._n += 1
        return outcome


class ReplayAdapter(Adapter):
    """Serves the outcomes of a recording, in order, without any robot or simulation.

    With ``strict=True`` (default) each trajectory must equal the recorded command to within
    ``atol``; a different one gets an ``error`` outcome naming the first mismatch, because
    replaying another trial's outcome would be a lie. The spec is that of the recorded adapter
    and must be given (recordings store data, not code).
    """

    def __init__(self, directory: str | Path, spec: AdapterSpec, strict: bool = True,
                 atol: float = 1e-9) -> None:
        self.spec = spec
        self.directory = Path(directory)
        index = self.directory / _INDEX
        if not index.exists():
            raise InvalidInputError(f"{index} does not exist: not a dmprs recording")
        self._records, _ = read_jsonl(index)
        self.strict, self.atol = strict, atol
        self._next = 0
        self._connected = False

    def __len__(self) -> int:
        return len(self._records)

    def connect(self) -> None:
        """Opens the replay."""
        self._connected = True

    def disconnect(self) -> None:
        """Closes the replay."""
        self._connected = False

    def reset(self, seed: int | None = None) -> None:
        """Rewinds to the first recorded trial."""
        self._next = 0

    def check(self, trajectory: Trajectory) -> list[str]:
        """The recorded adapter's spec's checks."""
        return self.spec.check(trajectory)

    def stop(self) -> None:
        """Nothing moves in a replay: nothing to stop."""

    def execute(
        self, trajectory: Trajectory, dry_run: bool = False, timeout_s: float | None = None
    ) -> Outcome:
        """The next recorded outcome, if ``trajectory`` is the one recorded for it."""
        if not self._connected:
            raise AdapterError("ReplayAdapter: execute() before connect()")
        if dry_run:
            problems = self.check(trajectory)
            status = Status.REJECTED if problems else Status.DRY_RUN
            return Outcome(status, message="; ".join(problems) or "checked, not executed")
        problems = self.check(trajectory)
        if problems:
            # The recorded adapter rejected it too; skip its record if it is the next one.
            if self._next < len(self._records) and self._records[self._next]["status"] == Status.REJECTED.value:
                self._next += 1
            return Outcome(Status.REJECTED, message="; ".join(problems))
        if self._next >= len(self._records):
            return Outcome(Status.ERROR, message=f"the recording has only {len(self._records)} trials")
        record = self._records[self._next]
        self._next += 1
        name = record.get("file")
        if not (isinstance(name, str) and _TRIAL_FILE.match(name)):
            return Outcome(Status.ERROR, message=f"{self.directory / _INDEX}: trial {self._next - 1} names the file "
                                                 f"{name!r:.60}, not a recorded trial_NNNN.npz")
        path = self.directory / name
        try:  # a regular file of bounded size, headers read before data (labels are strings)
            arrays = load_npz(path, str(path), limit=_TRIAL_MAX_BYTES, kinds="fiubU")
            command = from_arrays(arrays, "cmd_")
            executed = from_arrays(arrays, "exe_")
        except DmprsError as exc:
            return Outcome(Status.ERROR, message=f"cannot replay {path}: {exc}")
        signals = {k[4:]: (v.item() if v.ndim == 0 else v) for k, v in arrays.items() if k.startswith("sig_")}
        if self.strict and command is not None:
            recorded, asked = _samples(command), _samples(trajectory)
            same = recorded.shape == asked.shape and np.allclose(
                recorded, asked, rtol=0, atol=self.atol) and np.allclose(
                command.t, trajectory.t, rtol=0, atol=self.atol)
            if not same:
                return Outcome(Status.ERROR, message=(
                    f"trajectory differs from the one recorded in {path.name}; "
                    "replaying its outcome would be wrong"))
        status = Status(record["status"])
        return Outcome(status, signals=signals, executed=executed, message=record.get("message", ""))
