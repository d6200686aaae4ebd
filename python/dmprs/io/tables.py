"""Demonstrations from CSV and npz files, and the small tables that give each one its query.

* CSV: a header row, then one row per sample: a time column (``t`` by default, in s) and one
  column per degree of freedom.
* npz: arrays ``t`` (T,) and ``y`` (T,) or (T, D), optionally ``yd`` and ``ydd``; any other
  scalar arrays (say ``bottle_volume``) become the demonstration's labels.
* Query tables, CSV or JSON, one row per demonstration: a ``demo`` column naming it and one
  column per query dimension, whose header may carry its unit in brackets
  (``bottle_volume [l]``). In JSON: a list of ``{"demo": ..., "bottle_volume": 0.3}`` records,
  or ``{"units": {"bottle_volume": "l"}, "demos": [...]}``.
"""

from __future__ import annotations

import csv
import json
import re
import zipfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from dmprs.errors import DmprsError, InvalidInputError
from dmprs.trajectory import Trajectory

__all__ = ["QueryTable", "read_csv_trajectory", "read_npz_trajectory", "read_query_table"]

_HEADER_UNIT = re.compile(r"^\s*(?P<name>[^\[\]]+?)\s*(\[(?P<unit>[^\[\]]*)\])?\s*$")


def _rows(path: Path) -> tuple[list[str], list[list[str]]]:
    try:
        with open(path, newline="", encoding="utf-8") as f:
            rows = [r for r in csv.reader(f) if r and any(c.strip() for c in r)]
    except OSError as exc:
        raise InvalidInputError(f"{path}: cannot read ({exc.strerror or exc})") from None
    if len(rows) < 2:
        raise InvalidInputError(f"{path}: expected a header row and at least one data row")
    return [c.strip() for c in rows[0]], rows[1:]


def _number(text: str, path: Path, line: int, column: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise InvalidInputError(f"{path}, line {line}, column {column!r}: {text!r} is not a number") from None


def read_csv_trajectory(path: str | Path, time_column: str = "t",
                        columns: Sequence[str] | None = None) -> tuple[Trajectory, tuple[str, ...]]:
    """The trajectory in a CSV file and the names of its columns (default: all but the time)."""
    p = Path(path)
    header, rows = _rows(p)
    if time_column not in header:
        raise InvalidInputError(f"{p}: no time column {time_column!r}; the columns are {', '.join(header)}")
    names = tuple(c for c in header if c != time_column) if columns is None else tuple(columns)
    missing = [c for c in names if c not in header]
    if missing:
        raise InvalidInputError(
            f"{p}: no column {', '.join(map(repr, missing))}; the columns are {', '.join(header)}")
    index = [header.index(c) for c in (time_column, *names)]
    data = np.empty((len(rows), len(index)))
    for i, row in enumerate(rows):
        if len(row) != len(header):
            raise InvalidInputError(f"{p}, line {i + 2}: {len(row)} fields, the header has {len(header)}")
        data[i] = [_number(row[j], p, i + 2, header[j]) for j in index]
    try:
        return Trajectory(data[:, 0], data[:, 1:]), names
    except DmprsError as exc:
        raise InvalidInputError(f"{p}: {exc}") from None


def read_npz_trajectory(path: str | Path) -> tuple[Trajectory, dict[str, float]]:
    """The trajectory in an npz file and its scalar labels."""
    p = Path(path)
    try:
        with np.load(p, allow_pickle=False) as npz:
            arrays = {k: npz[k] for k in npz.files}
    except (OSError, ValueError, zipfile.BadZipFile) as exc:
        raise InvalidInputError(f"{p}: not a readable npz file ({exc})") from None
    for key in ("t", "y"):
        if key not in arrays:
            raise InvalidInputError(f"{p}: no array {key!r}; it has {', '.join(sorted(arrays)) or 'none'}")
    labels = {k: float(v) for k, v in arrays.items()
              if k not in ("t", "y", "yd", "ydd") and v.ndim == 0 and v.dtype.kind in "fiu"}
    try:
        return Trajectory(arrays["t"], arrays["y"], arrays.get("yd"), arrays.get("ydd")), labels
    except DmprsError as exc:
        raise InvalidInputError(f"{p}: {exc}") from None


@dataclass(frozen=True)
class QueryTable:
    """Queries by demonstration name, with the names and units of the query dimensions."""

    names: tuple[str, ...]
    units: tuple[str, ...]
    queries: dict[str, tuple[float, ...]]


def _split_unit(header: str) -> tuple[str, str]:
    m = _HEADER_UNIT.match(header)
    return (m["name"], m["unit"] or "") if m else (header.strip(), "")


def read_query_table(path: str | Path) -> QueryTable:
    """A query table (CSV or JSON, see the module docs)."""
    p = Path(path)
    if p.suffix.lower() == ".json":
        return _json_table(p)
    header, rows = _rows(p)
    if "demo" not in header:
        raise InvalidInputError(f"{p}: no 'demo' column naming each demonstration; the columns are {', '.join(header)}")
    cols = [i for i, h in enumerate(header) if h != "demo"]
    if not cols:
        raise InvalidInputError(f"{p}: no query column besides 'demo'")
    names, units = zip(*(_split_unit(header[i]) for i in cols))
    d = header.index("demo")
    queries: dict[str, tuple[float, ...]] = {}
    for k, row in enumerate(rows):
        if len(row) != len(header):
            raise InvalidInputError(f"{p}, line {k + 2}: {len(row)} fields, the header has {len(header)}")
        _add(queries, row[d].strip(), tuple(_number(row[i], p, k + 2, header[i]) for i in cols), p)
    return QueryTable(tuple(names), tuple(units), queries)


def _add(queries: dict[str, tuple[float, ...]], demo: str, q: tuple[float, ...], path: Path) -> None:
    if demo in queries:
        raise InvalidInputError(f"{path}: demonstration {demo!r} appears twice")
    queries[demo] = q


def _json_table(p: Path) -> QueryTable:
    try:
        data: Any = json.loads(p.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise InvalidInputError(f"{p}: cannot read it as JSON ({exc})") from None
    units_map = data.get("units", {}) if isinstance(data, dict) else {}
    records = data.get("demos") if isinstance(data, dict) else data
    if not isinstance(records, list) or not records or not all(isinstance(r, dict) for r in records):
        raise InvalidInputError(f"{p}: expected a list of {{\"demo\": ..., <query>: <value>}} records")
    names = tuple(k for k in records[0] if k != "demo")
    if not names:
        raise InvalidInputError(f"{p}: the records have no query field besides 'demo'")
    queries: dict[str, tuple[float, ...]] = {}
    for k, r in enumerate(records):
        if "demo" not in r or set(r) - {"demo"} != set(names):
            raise InvalidInputError(f"{p}: record {k} must have 'demo' and exactly the fields {names}")
        values = []
        for n in names:
            v = r[n]
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                raise InvalidInputError(f"{p}: record {k}, {n!r} = {v!r} is not a number")
            values.append(float(v))
        _add(queries, str(r["demo"]), tuple(values), p)
    return QueryTable(names, tuple(str(units_map.get(n, "")) for n in names), queries)
