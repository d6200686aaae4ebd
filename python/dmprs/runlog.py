"""The trial log of a learning run: one directory per run.

``run.json``      what was run (task, desired query, learner, limits), written atomically once
``trials.jsonl``  one line per finished trial, appended, flushed and fsynced before the learner
                  sees the trial, so a crash or Ctrl-C loses no finished trial
``trial_NNNN.npz`` the trial's commanded and executed trajectories and array signals

A run can be resumed from its log; a last line cut mid-write is reported and dropped.
"""

from __future__ import annotations

import json
import os
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from dmprs._io import (
    MiB,
    append_jsonl,
    create_empty,
    float_from_json,
    read_json,
    read_jsonl,
    regular_files,
    strict_json,
    truncate_cut_line,
    write_atomic,
    write_npz_atomic,
)
from dmprs.adapters import Outcome, Status
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
        """The trial's line of ``trials.jsonl`` (its arrays go to ``npz_name``)."""
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
    def from_json(cls, d: dict[str, Any], where: str = "trial record", n_query: int | None = None,
                  n_eps: int | None = None) -> TrialRecord:
        """The record a log line holds, every field checked (types, finite numbers, an error for
        every ok trial); a bad field raises :class:`RunLogError` naming ``where`` and the field.
        ``n_query``, ``n_eps``: the lengths the query and the error must have (any when None).
        """
        index = d.get("trial")
        if type(index) is not int or index < 0:
            raise RunLogError(f"{where}: 'trial' is {_shown(index)}, expected a trial number (an integer >= 0)")
        status = d.get("status")
        if status not in _STATUSES:
            raise RunLogError(f"{where}: 'status' is {_shown(status)}, expected one of {', '.join(_STATUSES)}")
        query = _numbers(d.get("query", _MISSING), "query", where, n_query)
        eps = d.get("eps")
        if eps is not None or status == Status.OK.value:
            eps = _numbers(eps, "eps", where, n_eps)
        success = d.get("success", False)
        message = d.get("message", "")
        signals = d.get("signals", {})
        if type(success) is not bool:
            raise RunLogError(f"{where}: 'success' is {_shown(success)}, expected true or false")
        if not isinstance(message, str):
            raise RunLogError(f"{where}: 'message' is {_shown(message)}, expected a string")
        if not isinstance(signals, dict) or not all(
                isinstance(v, (str, int, float)) or v is None for v in signals.values()):
            raise RunLogError(f"{where}: 'signals' is {_shown(signals)}, expected an object of numbers and strings")
        return cls(index=index, query=query, status=status, eps=eps, success=success,
                   signals={k: float_from_json(v) for k, v in signals.items()}, message=message)


_MISSING = object()
_STATUSES = tuple(s.value for s in Status)


def _shown(value: Any) -> str:
    return "missing" if value is _MISSING else f"{value!r:.60}"


def _numbers(value: Any, name: str, where: str, n: int | None) -> np.ndarray:
    """A logged list of ``n`` finite numbers, or a RunLogError naming the field (NaN and
    infinities are logged as strings, see ``_io.strict_json``: they are read, then refused).
    """
    if isinstance(value, list):
        value = [float_from_json(v) for v in value]
    if not isinstance(value, list) or not all(
            isinstance(v, (int, float)) and not isinstance(v, bool) for v in value):
        raise RunLogError(f"{where}: {name!r} is {_shown(value)}, expected a list of numbers")
    arr = np.asarray(value, dtype=float)
    if n is not None and arr.shape != (n,):
        raise RunLogError(f"{where}: {name!r} has {arr.size} value(s), expected {n} (one per query dimension)")
    if not np.isfinite(arr).all():
        raise RunLogError(f"{where}: {name!r} is {value!r:.60}: not finite")
    return arr


class RunLog:
    """Reads and appends the trial log of one run directory."""

    def __init__(self, directory: str | Path) -> None:
        self.directory = Path(directory)
        self.trials_path = self.directory / "trials.jsonl"
        self.meta_path = self.directory / "run.json"

    @classmethod
    def create(cls, directory: str | Path, meta: dict[str, Any]) -> RunLog:
        """Starts the log of a new run in ``directory`` (a new or empty one) with its description ``meta``."""
        log = cls(directory)
        try:
            log.directory.mkdir(parents=True, exist_ok=True)
            if log.trials_path.is_file() and log.trials_path.stat().st_size > 0:
                raise RunLogError(
                    f"{log.trials_path} already holds trials: resume the run or choose another log_dir")
            # Anything but the regular files of a run (a link, a FIFO, a folder) is not ours: a run
            # never writes through or into one.
            regular = set(regular_files(log.directory))
            foreign = sorted(p.name for p in log.directory.iterdir()
                             if not (_RUN_FILE.match(p.name) and p.name in regular))
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
            create_empty(log.trials_path)
        except OSError as exc:
            raise RunLogError(f"cannot write the run log in {log.directory}: {exc}") from exc
        return log

    def meta(self) -> dict[str, Any]:
        """The run description (``run.json``), checked to be one."""
        try:
            data = read_json(self.meta_path, what="run description", error=RunLogError, limit=META_MAX_BYTES)
        except RunLogError as exc:
            why = str(exc).removeprefix(f"{self.meta_path}: ")
            raise RunLogError(f"{self.meta_path} is not a readable run description: {why}") from None
        if not isinstance(data, dict) or "schema_version" not in data:
            raise RunLogError(f"{self.meta_path}: not a dmprs run description (a JSON object with a schema_version)")
        version = data["schema_version"]
        if type(version) is not int or version < 1:
            raise RunLogError(f"{self.meta_path}: schema_version is {version!r:.60}, expected a positive integer")
        if version > LOG_SCHEMA_VERSION:
            raise RunLogError(
                f"{self.meta_path} has schema version {version}; this dmprs reads "
                f"up to {LOG_SCHEMA_VERSION}: upgrade dmprs")
        names = data.get("query_names")
        if names is not None and not (isinstance(names, list) and names and all(isinstance(n, str) for n in names)):
            raise RunLogError(f"{self.meta_path}: 'query_names' is {names!r:.60}, expected a list of strings")
        return data

    def read(self) -> tuple[list[TrialRecord], str | None]:
        """The complete trials, and a note if the last line was cut mid-write. Every record is
        checked (see :meth:`TrialRecord.from_json`); queries and errors must have one value per
        query dimension of ``run.json`` when it names them (a learning run), else as many as the
        first trial's (a baseline's weights and error).
        """
        if not self.directory.is_dir():
            raise RunLogError(f"{self.directory} is not a run directory")
        names = self.meta().get("query_names") if os.path.lexists(self.meta_path) else None
        n_query = n_eps = None if names is None else len(names)
        raw, cut = read_jsonl(self.trials_path, what="trial log", error=RunLogError)
        trials = []
        for i, r in enumerate(raw):
            record = TrialRecord.from_json(r, f"{self.trials_path}, trial {i}", n_query, n_eps)
            if record.index != i:
                raise RunLogError(f"{self.trials_path}: record {i + 1} is numbered {record.index}, expected {i} "
                                  "(a trial is missing or repeated)")
            name = r.get("file")
            if name is not None and not (isinstance(name, str) and _TRIAL_FILE.match(name)):
                raise RunLogError(f"{self.trials_path}, trial {i}: 'file' is {name!r:.60}, expected trial_NNNN.npz")
            n_query = len(record.query)
            n_eps = n_eps if record.eps is None else len(record.eps)
            trials.append(record)
        self._check_trial_files(raw)
        return trials, cut

    def _check_trial_files(self, raw: list[dict[str, Any]]) -> None:
        """Damage that would otherwise pass in silence: a trial file the log lists but the
        directory lacks, or trial files beyond the log (an emptied or cut trials.jsonl; only the
        next trial's file may exist, written just before a crash and before its line).
        """
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
        try:
            truncate_cut_line(self.trials_path)
        except OSError as exc:
            raise RunLogError(f"cannot repair {self.trials_path}: {exc}") from None

    def append(
        self, record: TrialRecord, command: Trajectory | CartesianTrajectory | None, outcome: Outcome | None
    ) -> None:
        """Writes the trial's arrays, then its line: the line is the commit point."""
        arrays: dict[str, Any] = {"query": record.query}
        if command is not None:
            arrays.update(command.to_arrays("cmd_"))
        if outcome is not None:
            if outcome.executed is not None:
                arrays.update(outcome.executed.to_arrays("exe_"))
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
_TRIAL_FILE = re.compile(r"^trial_\d{4,}\.npz$")
#: run.json is a few hundred bytes; anything near this is not one
META_MAX_BYTES = 16 * MiB


def _jsonable(value: Any) -> Any:
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, Path):
        return str(value)
    return repr(value)

