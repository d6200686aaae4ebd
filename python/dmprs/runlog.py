"""The trial log of a learning run: one directory per run.

``run.json``      what was run (task, desired query, learner, limits), written atomically once
``trials.jsonl``  one line per finished trial, appended, flushed and fsynced before the learner
                  sees the trial, so a crash or Ctrl-C loses no finished trial
``trial_NNNN.npz`` the trial's commanded and executed trajectories and array signals

A run can be resumed from its log; a last line cut mid-write is reported and dropped.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from dmprs._io import (
    append_jsonl,
    float_from_json,
    read_jsonl,
    strict_json,
    truncate_cut_line,
    write_atomic,
    write_npz_atomic,
)
from dmprs.adapters import Outcome
from dmprs.errors import RunLogError
from dmprs.trajectory import CartesianTrajectory, Trajectory

LOG_SCHEMA_VERSION = 1


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
            query=_floats(d["query"]),
            status=str(d["status"]),
            eps=None if d.get("eps") is None else _floats(d["eps"]),
            success=bool(d.get("success", False)),
            signals={k: float_from_json(v) for k, v in dict(d.get("signals", {})).items()},
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
            foreign = sorted(p.name for p in log.directory.iterdir() if not _RUN_FILE.match(p.name))
            if foreign:
                raise RunLogError(
                    f"{log.directory} is a non-empty directory that is not a dmprs run (it holds "
                    f"{', '.join(foreign[:3])}{', ...' if len(foreign) > 3 else ''}); choose another log_dir")
            if any(p.name.startswith("trial_") for p in log.directory.iterdir()):
                raise RunLogError(
                    f"{log.directory} holds trial files but {log.trials_path.name} lists none: the log "
                    "was damaged; choose another log_dir rather than overwrite them")
            data = {"schema_version": LOG_SCHEMA_VERSION, **meta}
            text = json.dumps(strict_json(data), indent=2, default=_jsonable, allow_nan=False)
            write_atomic(log.meta_path, text.encode())
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
        version = data["schema_version"]
        if type(version) is not int or version < 1:
            raise RunLogError(f"{self.meta_path}: schema_version is {version!r}, expected a positive integer")
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
        self._check_trial_files(raw)
        return trials, cut

    def _check_trial_files(self, raw: list[dict[str, Any]]) -> None:
        """Damage that would otherwise pass in silence: a trial file the log lists but the
        directory lacks, or trial files beyond the log (an emptied or cut trials.jsonl; only the
        next trial's file may exist, written just before a crash and before its line)."""
        for r in raw:
            name = r.get("file")
            if isinstance(name, str) and not (self.directory / name).is_file():
                raise RunLogError(
                    f"{self.directory / name} is missing: trial {r['trial']} of {self.trials_path} "
                    "lost its arrays (deleted or moved)")
        beyond = sorted(
            p.name for p in self.directory.glob("trial_*.npz")
            if p.stem[6:].isdigit() and int(p.stem[6:]) > len(raw)
        )
        if beyond:
            raise RunLogError(
                f"{self.trials_path} lists {len(raw)} trial(s) but the directory also holds {beyond[0]}"
                f"{' and more' if len(beyond) > 1 else ''}: the log was emptied or cut; restore it "
                "rather than resume over those trials")

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


# Files a run directory may hold (and the temporary files of their atomic writes).
_RUN_FILE = re.compile(r"^(run\.json|trials\.jsonl|trial_\d{4,}\.npz|learning\.png|\..*\.tmp)$")


def _floats(values: Any) -> np.ndarray:
    """A logged list of numbers, NaN and infinities written as strings (see ``_io.strict_json``)."""
    items = values if isinstance(values, list) else [values]
    return np.asarray([float_from_json(v) for v in items], dtype=float)


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
