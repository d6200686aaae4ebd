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
import shutil
import tempfile
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
    experiment_of,
    part_of,
    pinned_numerics,
    run_learning,
    schedule,
    seconds_left,
)
from dmprs.sim import pour_memo


@dataclasses.dataclass
class PartTime:
    """Where a part's time went: its runs, their summed wall-clock and CPU seconds (in the
    workers), the job's elapsed seconds when its last run finished, and per experiment of the
    part (:func:`~dmprs.reproduce.run.experiment_of`) its runs and their wall-clock seconds.
    """

    part: str
    runs: int
    seconds: float = 0.0
    cpu_seconds: float = 0.0
    finished_at: float | None = None
    experiments: dict[str, list[float]] = dataclasses.field(default_factory=dict)

    def add(self, result: dict[str, Any]) -> None:
        """Counts a finished run of the part."""
        seconds = float(result.get("seconds", 0.0))
        self.seconds += seconds
        self.cpu_seconds += float(result.get("cpu_seconds", 0.0))
        runs_seconds = self.experiments.setdefault(experiment_of(result), [0, 0.0])
        runs_seconds[0] += 1
        runs_seconds[1] += seconds


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
    (``timing``: :class:`PartTime`, the slowest part first).
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    cache = out / ".cache"
    cache.mkdir(exist_ok=True)
    specs = plan(quick)
    start = time.perf_counter()
    # Workers inherit the environment: they read the pouring calibration from this disk cache,
    # and each pour another run of this job has simulated from the job's memo.
    saved = os.environ.get("DMPRS_CACHE_DIR")
    os.environ["DMPRS_CACHE_DIR"] = saved or str(cache.resolve())
    memo = Path(tempfile.mkdtemp(prefix="pours-", dir=cache)).resolve()
    saved_memo = os.environ.get(pour_memo.MEMO_DIR)
    os.environ[pour_memo.MEMO_DIR] = str(memo)
    done = [0]
    parts = {name: PartTime(name, runs) for name, runs in Counter(part_of(s) for s in specs).items()}
    left = Counter(part_of(s) for s in specs)

    def on_result(i: int, r: dict[str, Any]) -> None:
        done[0] += 1
        part = part_of(specs[i])
        parts[part].add(r)
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
            items, order, after = schedule(specs, Path(os.environ["DMPRS_CACHE_DIR"]))
            first = len(items) - len(specs)  # the calibrations come first; on_result tells the runs
            results = pmap(dispatch, items, backend=backend, workers=workers, order=order, after=after,
                           on_result=lambda i, r: on_result(i - first, r) if i >= first else None)[first:]
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
        if saved_memo is None:
            del os.environ[pour_memo.MEMO_DIR]
        else:
            os.environ[pour_memo.MEMO_DIR] = saved_memo
        shutil.rmtree(memo, ignore_errors=True)
    (out / "report.md").write_text(markdown(report, figures))
    return report
