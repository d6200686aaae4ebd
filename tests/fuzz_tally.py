"""Counts what the fuzz targets of ``tests/fuzz_targets.py`` do, each example in a forked child so
that a panic, an abort or a hang is counted instead of ending the run:

    PYTHONPATH=python python3 -m tests.fuzz_tally [examples per target]

Prints one row per target and a total: inputs tried, clear errors (DmprsError), panics
(pyo3 PanicException), aborts (the child killed by a signal), leaked exception types (anything
else), hangs (no answer within 5 s), non-finite outputs.
"""

from __future__ import annotations

import collections
import multiprocessing as mp
import sys
import traceback
from typing import Any

from hypothesis import HealthCheck, given, settings

from tests.fuzz_targets import TARGETS, non_finite

COLUMNS = ["inputs", "clear errors", "ok", "panics", "aborts", "leaked types", "hangs", "non-finite"]
HANG_S = 5.0


def _child(name: str, args: Any, conn: Any) -> None:
    from dmprs.errors import DmprsError

    try:
        out = TARGETS[name][1](args)
        conn.send(("non-finite", non_finite(out)) if non_finite(out) else ("ok", ""))
    except DmprsError:
        conn.send(("clear errors", ""))
    except BaseException as exc:  # noqa: BLE001 - classifying is the point
        kind = "panics" if type(exc).__name__ == "PanicException" else "leaked types"
        conn.send((kind, f"{type(exc).__name__}: {str(exc)[:120]} @ {traceback.format_exc(limit=-1)[-200:]}"))


def _one(name: str, args: Any) -> tuple[str, str]:
    parent, child = mp.Pipe(duplex=False)
    proc = mp.get_context("fork").Process(target=_child, args=(name, args, child))
    proc.start()
    if parent.poll(HANG_S):
        result = parent.recv()
        proc.join()
        return result
    proc.join(0.2)
    if proc.exitcode is None:
        proc.kill()
        proc.join()
        return "hangs", repr(args)[:200]
    return "aborts", f"exit code {proc.exitcode}: {repr(args)[:200]}"


def _tally(name: str, strategy: Any, examples: int, counts: Any, notes: list[str]) -> None:
    @settings(max_examples=examples, deadline=None, derandomize=True, database=None,
              suppress_health_check=list(HealthCheck))
    @given(strategy)
    def tally(args: Any) -> None:
        kind, detail = _one(name, args)
        counts["inputs"] += 1
        counts[kind] += 1
        if kind not in ("ok", "clear errors") and len(notes) < 80:
            notes.append(f"{name}: {kind}: {detail}")

    tally()


def main(examples: int) -> None:
    total: collections.Counter[str] = collections.Counter()
    print("| target | " + " | ".join(COLUMNS) + " |")
    print("|---" * (len(COLUMNS) + 1) + "|")
    notes: list[str] = []
    for name, (strategy, _) in TARGETS.items():
        counts: collections.Counter[str] = collections.Counter()

        _tally(name, strategy, examples, counts, notes)
        total.update(counts)
        print(f"| {name} | " + " | ".join(str(counts[c]) for c in COLUMNS) + " |", flush=True)
    print("| **total** | " + " | ".join(str(total[c]) for c in COLUMNS) + " |")
    print("\n".join(notes), file=sys.stderr)


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 300)
