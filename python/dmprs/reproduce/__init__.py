"""``dmprs reproduce``: the paper's experiments in simulation, and the baselines, as one job.

Parts (paper figure in brackets):

1. Matchbox, demos flipped back + flipped over, every query learner (Fig. 4; paper: 4 trials).
2. Matchbox, both demos flipped back: pi/2 outside the demos (Fig. 7; paper: succeeds).
3. Pouring 0.2 l from bottles of 0.4, 0.5, 0.7 l and 0.25 l (outside the demos' 0.3-1.0 l)
   with golden section, fixed-gain error learning and the root finder (Fig. 9; no count given).
4. Baselines (not in the paper): PoWER and PI² in the full DMP weight space over seeds and
   exploration levels, and the constrained-domain policy gradient, from the same first trial.

Every run goes through :func:`dmprs.parallel.pmap` (local processes by default, or Ray). The
job writes ``report.md``, ``report.json`` and PNG figures into ``out``.
"""

from __future__ import annotations

import dataclasses
import json
import os
import time
from collections import Counter
from collections.abc import Callable
from pathlib import Path
from typing import Any

from dmprs._io import strict_json
from dmprs.parallel import pmap
from dmprs.reproduce.figures import write_figures
from dmprs.reproduce.plan import LearnSpec, plan, skipped
from dmprs.reproduce.report import PAPER, markdown, summarize
from dmprs.reproduce.run import (
    dispatch,
    longest_first,
    part_of,
    pinned_numerics,
    prepare_pouring,
    run_learning,
    seconds_left,
)


@dataclasses.dataclass
class PartTime:
    """Where a part's time went: its runs, their summed wall-clock seconds (in the workers), and
    the job's elapsed seconds when its last run finished.
    """

    part: str
    runs: int
    seconds: float = 0.0
    finished_at: float | None = None


__all__ = ["PAPER", "LearnSpec", "PartTime", "dispatch", "markdown", "plan", "reproduce", "run_learning", "skipped",
           "summarize", "write_figures"]


def reproduce(out: str | Path = "out", *, quick: bool = False, backend: str = "local",
              workers: int | None = None,
              progress: Callable[[int, int, dict[str, Any]], None] | None = None,
              part_done: Callable[[PartTime, float, float], None] | None = None) -> dict[str, Any]:
    """Runs the whole job; writes figures and the report into ``out``; returns the report.

    ``progress(done, total, result)`` follows every run; ``part_done(part, elapsed, remaining)``
    every part as its last run finishes, with the job's elapsed seconds and an estimate of the
    seconds left (:func:`~dmprs.reproduce.run.seconds_left`). The report keeps each part's time
    (``timing``: its runs, their summed run time, when it finished).
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    cache = out / ".cache"
    cache.mkdir(exist_ok=True)
    specs = plan(quick)
    start = time.perf_counter()
    # Workers inherit the environment: they read the pouring calibration from this disk cache.
    saved = os.environ.get("DMPRS_CACHE_DIR")
    os.environ["DMPRS_CACHE_DIR"] = saved or str(cache.resolve())
    done = [0]
    parts = {name: PartTime(name, runs) for name, runs in Counter(part_of(s) for s in specs).items()}
    left = Counter(part_of(s) for s in specs)

    def on_result(i: int, r: dict[str, Any]) -> None:
        done[0] += 1
        part = part_of(specs[i])
        parts[part].seconds += float(r.get("seconds", 0.0))
        left[part] -= 1
        elapsed = time.perf_counter() - start
        if left[part] == 0:
            parts[part].finished_at = round(elapsed, 1)
            if part_done:
                measured = {name: p.seconds for name, p in parts.items()}
                finished = {name: p.runs - left[name] for name, p in parts.items()}
                part_done(parts[part], elapsed, seconds_left(elapsed, measured, finished, left))
        if progress:
            progress(done[0], len(specs), r)

    try:
        with pinned_numerics():
            prepare_pouring(specs, Path(os.environ["DMPRS_CACHE_DIR"]), backend=backend, workers=workers)
            results = pmap(dispatch, specs, backend=backend, workers=workers, on_result=on_result,
                           order=longest_first(specs))
        report = summarize(results)
        report.update(quick=quick, backend=backend, seconds=round(time.perf_counter() - start, 1),
                      skipped=skipped(quick),
                      timing=[dataclasses.asdict(p) for p in sorted(parts.values(), key=lambda p: -p.seconds)])
        text = json.dumps(strict_json({"summary": report, "runs": results}), indent=1, default=str, allow_nan=False)
        (out / "report.json").write_text(text)
        figures = write_figures(results, out)  # the arm's frame strip reads the cached calibration
    finally:
        if saved is None:
            del os.environ["DMPRS_CACHE_DIR"]
    (out / "report.md").write_text(markdown(report, figures))
    return report
