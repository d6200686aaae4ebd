"""Trials to success over several runs of one setting: the median, the range and the success count
the reproduction reports for every setting.
"""

from __future__ import annotations

import statistics
from typing import Any


def trial_stats(values: list[int | None], budget: int | None = None) -> dict[str, Any]:
    """Of the trials to success of some runs (None: the run never succeeded): how many runs, how
    many succeeded, the median (a failed run counts as infinitely many trials when some succeeded),
    the range of the successful ones, and the trial cap ``budget``.
    """
    ok = [v for v in values if v is not None]
    return {"runs": len(values), "successes": len(ok),
            "median": statistics.median(ok) if len(ok) == len(values) and ok else
            (statistics.median(ok + [float("inf")] * (len(values) - len(ok))) if ok else None),
            "min": min(ok) if ok else None, "max": max(ok) if ok else None, "budget": budget}
