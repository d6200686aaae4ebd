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
import io
import re
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from dmprs._io import MiB, load_npz, read_json, read_text
from dmprs.errors import DmprsError, InvalidInputError
from dmprs.io.segment import MIN_SAMPLES
from dmprs.trajectory import Trajectory

__all__ = ["CSV_MAX_BYTES", "NPZ_MAX_BYTES", "TABLE_MAX_BYTES", "QueryTable", "read_csv_trajectory",
           "read_npz_trajectory", "read_query_table"]

#: A CSV demonstration may be at most this large (its values, parsed, take at most 4 x as much).
CSV_MAX_BYTES = 128 * MiB
#: The arrays of an npz demonstration may hold at most this many bytes (checked from the npy
#: headers before anything is read or inflated).
NPZ_MAX_BYTES = 1024 * MiB
#: A query table (one row per demonstration) may be at most this large.
TABLE_MAX_BYTES = 16 * MiB

_HEADER_UNIT = re.compile(r"^\s*(?P<name>[^\[\]]+?)\s*(\[(?P<unit>[^\[\]]*)\])?\s*$")


def _rows(path: Path, limit: int, what: str) -> tuple[list[str], Iterator[tuple[int, list[str]]]]:
    """The header of a CSV file (read whole, within ``limit`` bytes, as UTF-8) and its non-blank
    rows with their line numbers; a malformed row is an error naming the line.
    """
    text = read_text(path, limit=limit, what=what)
    reader = csv.reader(io.StringIO(text, newline=""))

    def rows() -> Iterator[tuple[int, list[str]]]:
        while True:
            try:
                row = next(reader)
            except StopIteration:
                return
            except csv.Error as exc:
                raise InvalidInputError(f"{path}, line {reader.line_num}: not valid CSV ({exc})") from None
            if row and any(c.strip() for c in row):
                yield reader.line_num, row

    it = rows()
    first = next(it, None)
    if first is None:
        raise InvalidInputError(f"{path}: empty; expected a header row and data rows")
    header = [c.strip() for c in first[1]]
    dup = next((c for c in header if header.count(c) > 1), None)
    if dup is not None:
        raise InvalidInputError(f"{path}, line {first[0]}: column {dup!r} appears twice in the header")
    return header, it


def _number(text: str, path: Path, line: int, column: str) -> float:
    try:
        x = float(text)
    except ValueError:
        raise InvalidInputError(f"{path}, line {line}, column {column!r}: {text[:40]!r} is not a number") from None
    if not np.isfinite(x):
        raise InvalidInputError(f"{path}, line {line}, column {column!r}: {text.strip()!r}; every value must be finite")
    return x


def _columns(header: Sequence[str], most: int = 20) -> str:
    """The header's names for a message: unprintable ones quoted with their escapes, at most
    ``most`` of them.
    """
    names = [h if h.isprintable() else repr(h) for h in header[:most]]
    more = f" and {len(header) - most} more" if len(header) > most else ""
    return ", ".join(names) + more


def read_csv_trajectory(path: str | Path, time_column: str = "t",
                        columns: Sequence[str] | None = None) -> tuple[Trajectory, tuple[str, ...]]:
    """The trajectory in a CSV file and the names of its columns (default: all but the time)."""
    p = Path(path)
    header, rows = _rows(p, CSV_MAX_BYTES, "CSV file")
    if time_column not in header:
        raise InvalidInputError(f"{p}: no time column {time_column!r}; the columns are {_columns(header)}")
    names = tuple(c for c in header if c != time_column) if columns is None else tuple(columns)
    if not names:
        raise InvalidInputError(f"{p}: no column besides the time {time_column!r}")
    missing = [c for c in names if c not in header]
    if missing:
        raise InvalidInputError(
            f"{p}: no column {', '.join(map(repr, missing))}; the columns are {_columns(header)}")
    index = [header.index(c) for c in (time_column, *names)]
    data, lines = np.empty((64, len(index))), np.empty(64, dtype=np.int64)
    n = 0
    for line, row in rows:
        if len(row) != len(header):
            raise InvalidInputError(f"{p}, line {line}: {len(row)} fields, the header has {len(header)}")
        if n == len(data):  # grows by doubling: each row costs at least a byte per field
            data, lines = np.concatenate([data, np.empty_like(data)]), np.concatenate([lines, lines])
        data[n] = [_number(row[j], p, line, header[j]) for j in index]
        lines[n] = line
        n += 1
    if n < MIN_SAMPLES:
        raise InvalidInputError(f"{p}: {n} data rows; a demonstration needs at least {MIN_SAMPLES} "
                                "(DMP.fit differentiates twice)")
    t = data[:n, 0]
    back = np.flatnonzero(np.diff(t) <= 0)
    if len(back):
        j = int(back[0]) + 1
        raise InvalidInputError(f"{p}, line {lines[j]}: time {float(t[j])!r} does not exceed {float(t[j - 1])!r} on line "
                                f"{lines[j - 1]}; times must increase")
    return Trajectory(t, data[:n, 1:]), names


def read_npz_trajectory(path: str | Path) -> tuple[Trajectory, dict[str, float]]:
    """The trajectory in an npz file and its scalar labels."""
    p = Path(path)
    arrays = load_npz(p, str(p), limit=NPZ_MAX_BYTES)
    for key in ("t", "y"):
        if key not in arrays:
            raise InvalidInputError(f"{p}: no array {key!r}; it has {', '.join(sorted(arrays)) or 'none'}")
    labels = {}
    for k, v in arrays.items():
        if k not in ("t", "y", "yd", "ydd") and v.ndim == 0 and v.dtype.kind in "fiu":
            x = float(v)
            if not np.isfinite(x):
                raise InvalidInputError(f"{p}: label {k!r} is {x}; every value must be finite")
            labels[k] = x
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
    header, rows = _rows(p, TABLE_MAX_BYTES, "query table")
    if "demo" not in header:
        raise InvalidInputError(f"{p}: no 'demo' column naming each demonstration; the columns are {_columns(header)}")
    cols = [i for i, h in enumerate(header) if h != "demo"]
    if not cols:
        raise InvalidInputError(f"{p}: no query column besides 'demo'")
    names, units = zip(*(_split_unit(header[i]) for i in cols), strict=True)
    d = header.index("demo")
    queries: dict[str, tuple[float, ...]] = {}
    for line, row in rows:
        if len(row) != len(header):
            raise InvalidInputError(f"{p}, line {line}: {len(row)} fields, the header has {len(header)}")
        _add(queries, row[d].strip(), tuple(_number(row[i], p, line, header[i]) for i in cols), f"{p}, line {line}")
    if not queries:
        raise InvalidInputError(f"{p}: expected a header row and at least one data row")
    return QueryTable(tuple(names), tuple(units), queries)


def _add(queries: dict[str, tuple[float, ...]], demo: str, q: tuple[float, ...], where: str) -> None:
    if not demo:
        raise InvalidInputError(f"{where}: the demonstration's name is empty")
    if demo in queries:
        raise InvalidInputError(f"{where}: demonstration {demo!r} appears twice")
    queries[demo] = q


def _json_table(p: Path) -> QueryTable:
    data: Any = read_json(p, what="query table", limit=TABLE_MAX_BYTES)
    units_map = data.get("units", {}) if isinstance(data, dict) else {}
    if not isinstance(units_map, dict):
        raise InvalidInputError(f"{p}: 'units' must map query names to units")
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
                raise InvalidInputError(f"{p}: record {k}, {n!r} = {str(v)[:40]!r} is not a number")
            values.append(float(v))
        _add(queries, str(r["demo"]).strip(), tuple(values), f"{p}, record {k}")
    return QueryTable(names, tuple(str(units_map.get(n, "")) for n in names), queries)
