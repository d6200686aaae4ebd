"""Whether a reproduction reproduces a stored summary: bit for bit, timings aside.

The simulators and the learners give the same bits on every machine of the project's kind
(:mod:`dmprs.portable`), so a summary stored beside the docs is a reference any run of the same
plan must match exactly; the first value that differs is named by its path in the summary.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from dmprs._io import strict_json
from dmprs.errors import DmprsError

#: keys whose values are wall-clock times, which differ from run to run
TIMING_KEYS = frozenset({"seconds", "timing"})


class ReproductionMismatchError(DmprsError):
    """A reproduction's summary differs from the stored one it was checked against."""


def _plain(summary: dict[str, Any]) -> Any:
    """The summary as JSON would store it (tuples as lists, non-finite values as strings)."""
    return json.loads(json.dumps(strict_json(summary), default=str, allow_nan=False))


def without_timings(value: Any) -> Any:
    """``value`` with every entry under :data:`TIMING_KEYS` left out, at any depth."""
    if isinstance(value, dict):
        return {k: without_timings(v) for k, v in value.items() if k not in TIMING_KEYS}
    if isinstance(value, list):
        return [without_timings(v) for v in value]
    return value


def first_difference(expected: Any, actual: Any, path: str = "summary") -> str | None:
    """Where ``actual`` first differs from ``expected`` (``path[key][index]: expected ... got
    ...``), or None if they agree, values under :data:`TIMING_KEYS` aside.
    """
    if isinstance(expected, dict) and isinstance(actual, dict):
        for key in sorted(set(expected) | set(actual) - TIMING_KEYS, key=str):
            if key in TIMING_KEYS:
                continue
            if key not in actual or key not in expected:
                return f"{path}[{key!r}]: {'missing' if key not in actual else 'not in the reference'}"
            if (found := first_difference(expected[key], actual[key], f"{path}[{key!r}]")) is not None:
                return found
        return None
    if isinstance(expected, list) and isinstance(actual, list):
        for i, (e, a) in enumerate(zip(expected, actual, strict=False)):
            if (found := first_difference(e, a, f"{path}[{i}]")) is not None:
                return found
        if len(expected) != len(actual):
            return f"{path}: {len(actual)} entries, the reference has {len(expected)}"
        return None
    if type(expected) is not type(actual) or expected != actual:
        return f"{path}: the reference has {expected!r}, this run {actual!r}"
    return None


def check_summary(summary: dict[str, Any], reference: str | Path) -> None:
    """Raises :class:`ReproductionMismatchError` naming the first value of ``summary`` that
    differs from the summary stored at ``reference`` (timings aside).
    """
    path = Path(reference)
    try:
        stored = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise ReproductionMismatchError(f"cannot read the reference summary {path}: {exc}") from None
    if (found := first_difference(stored, _plain(summary))) is not None:
        raise ReproductionMismatchError(f"this run does not reproduce {path}: first difference at {found}")
