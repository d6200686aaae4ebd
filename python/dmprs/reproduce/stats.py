"""Trials to success over several runs of one setting: the median, the range and the success count
the reproduction reports for every setting, and their one way of being written in a table.
"""

from __future__ import annotations

import math
import statistics
from typing import Any


def trial_stats(values: list[int | None], budget: int | None = None) -> dict[str, Any]:
    """Of the trials to success of some runs (None: the run never succeeded): how many runs, how
    many succeeded, the median, the range of the successful ones, and the trial cap ``budget``.

    A failed run counts as more trials than any success, so the median is None when at least
    half the runs failed (it lies beyond the cap). None, not infinity: the summary is stored as
    JSON, which has no infinity.
    """
    ok = sorted(v for v in values if v is not None)
    failed = len(values) - len(ok)
    median = statistics.median(ok + [math.inf] * failed) if ok else None
    return {"runs": len(values), "successes": len(ok),
            "median": median if median is not None and math.isfinite(median) else None,
            "min": min(ok) if ok else None, "max": max(ok) if ok else None, "budget": budget}


def cell(row: dict[str, Any]) -> str:
    """Trials to success of one row: the count of a single run, else ``median [min-max]`` and,
    where some runs failed, how many succeeded.
    """
    if row["successes"] == 0:
        if row.get("stop_reason"):
            return f"not solved: {row['stop_reason']}"
        return f"none within {row['budget'] or 'the cap'}"
    med = row["median"]
    med_s = f">{row['budget']}" if med is None else f"{med:g}"
    if row["runs"] == 1:
        return med_s
    ok = "" if row["successes"] == row["runs"] else f", {row['successes']}/{row['runs']} succeeded"
    return f"{med_s} [{row['min']}-{row['max']}]{ok}"
