"""The trial log of a learning run: one directory per run.

``run.json``      what was run (task, desired query, learner, limits), written atomically once
``trials.jsonl``  one line per finished trial, appended, flushed and fsynced before the learner
                  sees the trial, so a crash or Ctrl-C loses no finished trial
``trial_NNNN.npz`` the trial's commanded and executed trajectories and array signals

A run can be resumed from its log; a last line cut mid-write is reported and dropped.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from dmprs._io import append_jsonl, read_jsonl, truncate_cut_line, write_atomic, write_npz_atomic
from dmprs.adapters import Outcome
from dmprs.errors import DmprsError
from dmprs.trajectory import CartesianTrajectory, Trajectory

LOG_SCHEMA_VERSION = 1


class RunLogError(DmprsError, OSError):
    """A run directory that cannot be read or written; the message names the file."""


@dataclass(frozen=True)
class TrialRecord:
    """One trial: the query executed, how it ended, and its signed error if it was scored."""

    index: int
    query: np.ndarray
    status: str
    eps: np.ndarray | None = None
    success: bool = False
    signals: dict[str, Any] = field(default_factory=dict)
    message: str = ""

    def to_json(self, npz_name: str | None) -> dict[str, Any]:
        return {
            "trial": self.index,
            "query": self.query.tolist(),
            "status": self.status,
            "eps": None if self.eps is None else self.eps.tolist(),
            "success": self.success,
            "signals": {k: v for k, v in self.signals.items() if np.ndim(v) == 0},
            "message": self.message,
            "file": npz_name,
        }

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> TrialRecord:
        return cls(
            index=int(d["trial"]),
            query=np.asarray(d["query"], dtype=float),
            status=str(d["status"]),
            eps=None if d.get("eps") is None else np.asarray(d["eps"], dtype=float),
            success=bool(d.get("success", False)),
            signals=dict(d.get("signals", {})),
            message=str(d.get("message", "")),
        )


class RunLog:
    """Reads and appends the trial log of one run directory."""

    def __init__(self, directory: str | Path) -> None:
        self.directory = Path(directory)
        self.trials_path = self.directory / "trials.jsonl"
        self.meta_path = self.directory / "run.json"

    @classmethod
    def create(cls, directory: str | Path, meta: dict[str, Any]) -> RunLog:
        log = cls(directory)
        try:
            log.directory.mkdir(parents=True, exist_ok=True)
            if log.trials_path.exists() and log.trials_path.stat().st_size > 0:
                raise RunLogError(
                    f"{log.trials_path} already holds trials: resume the run or choose another log_dir")
            data = {"schema_version": LOG_SCHEMA_VERSION, **meta}
            write_atomic(log.meta_path, json.dumps(data, indent=2, default=_jsonable).encode())
            log.trials_path.touch()
        except OSError as exc:
            raise RunLogError(f"cannot write the run log in {log.directory}: {exc}") from exc
        return log

    def meta(self) -> dict[str, Any]:
        try:
            data = json.loads(self.meta_path.read_text(encoding="utf-8"))
        except (OSError, ValueError) as exc:
            raise RunLogError(f"{self.meta_path} is not a readable run description: {exc}") from None
        if not isinstance(data, dict) or "schema_version" not in data:
            raise RunLogError(f"{self.meta_path} is not a dmprs run description")
        if data["schema_version"] > LOG_SCHEMA_VERSION:
            raise RunLogError(
                f"{self.meta_path} has schema version {data['schema_version']}; this dmprs reads "
                f"up to {LOG_SCHEMA_VERSION}: upgrade dmprs")
        return data

    def read(self) -> tuple[list[TrialRecord], str | None]:
        """The complete trials, and a note if the last line was cut mid-write."""
        if not self.directory.is_dir():
            raise RunLogError(f"{self.directory} is not a run directory")
        try:
            raw, cut = read_jsonl(self.trials_path)
            trials = [TrialRecord.from_json(r) for r in raw]
        except (OSError, ValueError, KeyError, TypeError) as exc:
            raise RunLogError(f"{self.trials_path} cannot be read: {exc}") from None
        for i, tr in enumerate(trials):
            if tr.index != i:
                raise RunLogError(f"{self.trials_path}: record {i + 1} is numbered {tr.index}")
        return trials, cut

    def repair(self) -> None:
        """Drops a cut last line before appending to a resumed run."""
        truncate_cut_line(self.trials_path)

    def append(
        self, record: TrialRecord, command: Trajectory | CartesianTrajectory | None, outcome: Outcome | None
    ) -> None:
        """Writes the trial's arrays, then its line: the line is the commit point."""
        arrays: dict[str, Any] = {"query": record.query}
        if command is not None:
            arrays.update(cmd_t=command.t, cmd_y=_samples(command))
        if outcome is not None:
            if outcome.executed is not None:
                arrays.update(exe_t=outcome.executed.t, exe_y=_samples(outcome.executed))
            for k, v in outcome.signals.items():
                arrays[f"sig_{k}"] = np.asarray(v)
        name = f"trial_{record.index:04d}.npz"
        try:
            write_npz_atomic(self.directory / name, arrays)
            append_jsonl(self.trials_path, record.to_json(name))
        except OSError as exc:
            raise RunLogError(f"cannot append trial {record.index} to {self.trials_path}: {exc}") from exc


def _jsonable(value: Any) -> Any:
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, Path):
        return str(value)
    return repr(value)


def _samples(tr: Trajectory | CartesianTrajectory) -> np.ndarray:
    """The samples a log keeps: y, or the (T, 7) pose of a pose trajectory."""
    return tr.pose if isinstance(tr, CartesianTrajectory) else tr.y
