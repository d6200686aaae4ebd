"""Counts what the fuzz targets of ``tests/fuzz_targets.py`` do, each example in a forked child so
that a panic, an abort or a hang is counted instead of ending the run. From the repository's root,
with dmprs installed (editable or as a wheel; the source tree is not put on the path, so an
installed wheel's built extension is the one imported):

    python3 -m tests.fuzz_tally [examples per target] [target name part ...]

e.g. ``python3 -m tests.fuzz_tally 300 "database" "run logs"``; with no name, every target and
the reliability issue's examples. Prints one row per target and a total: inputs tried, clear
errors (DmprsError), ok, panics (pyo3 PanicException), aborts (the child killed by a signal),
leaked exception types (anything else, and refusals whose message does not name the file),
hangs (no answer within 5 s, or the target's ``HANG_TIMEOUTS``), non-finite outputs, and garbage
accepted (``AcceptedGarbage``: a write outside the directory given or through a link, a foreign
file overwritten, files left behind, an action or target taken that must be refused).
"""

from __future__ import annotations

import collections
import multiprocessing as mp
import sys
import traceback
from typing import Any

from hypothesis import HealthCheck, given, settings

from tests.fuzz_targets import HANG_TIMEOUTS, TARGETS, WARMUPS, AcceptedGarbage, non_finite

COLUMNS = ["inputs", "clear errors", "ok", "panics", "aborts", "leaked types", "hangs", "non-finite",
           "garbage accepted"]
# "non-finite" also counts garbage returned without an error (see the issue examples below).
HANG_S = 5.0


def _issue_examples() -> list[Any]:
    """The inputs the reliability issue reports, as calls (the learners' PI2 ones included: they
    belong to the learner configuration, not to these fixes, and show what is left).
    """
    import numpy as np

    import dmprs
    from dmprs.learners import PI2, ErrorLearning, PolicyGradient, PoWER

    t50 = np.linspace(0, 1, 50)
    t11 = np.linspace(0, 0.01, 11)

    def fit() -> Any:
        return dmprs.DMP.fit(t50, np.sin(t50))

    def stiff() -> Any:
        return dmprs.DMP.fit(t11, np.sin(50 * t11))

    return [
        lambda: dmprs.DMP.fit(t50, np.sin(t50), alpha_x=20),
        lambda: dmprs.DMP.fit(t50, np.sin(t50), n_basis=10000),
        lambda: dmprs.GaussianProcess(n_restarts=10**6).fit(t50, np.sin(t50)),
        lambda: stiff().rollout(),
        lambda: stiff().rollout(duration=2),
        lambda: dmprs.DMP.fit(t50, np.sin(t50), alpha_z=1e4).rollout(),
        lambda: fit().with_goal([1e308]).rollout(),
        lambda: fit().with_tau(1e-3).rollout(duration=1),
        lambda: dmprs.rollout_batch([fit().with_goal([1e308])]),
        lambda: dmprs.DMP.fit(t50, np.sin(t50), n_basis=2**70),
        lambda: fit().rollout(dt=2**2000),
        lambda: dmprs.DMP.from_dict({**fit().to_dict(), "tau": 10**400}),
        lambda: ErrorLearning(0.0, max_trials=2**70),
        lambda: dmprs.GaussianProcess(max_iter=2**64).fit(t50, np.sin(t50)),
        lambda: dmprs.rollout_batch(None),
        lambda: fit().rollout(until_rest="no"),
        lambda: fit().rollout(dt="0.01"),
        lambda: fit().with_tau("1"),
        lambda: dmprs.DMP.from_dict({**fit().to_dict(), "extra": 1}),
        lambda: dmprs.DMP.from_dict({**fit().to_dict(), "beta_z": None}),
        lambda: dmprs.DMP.from_dict({**fit().to_dict(), "version": True}),
        lambda: dmprs.GaussianProcess(signal_var_bounds=(2, 1)).fit(t50, t50, optimize=False),
        lambda: PoWER(np.zeros(3), 1e200).ask(),
        lambda: PolicyGradient(np.zeros(2), delta=1e300).ask(),
        lambda: ErrorLearning(np.zeros(1), gain=1e308).ask(),
        lambda: PI2(np.zeros(5), 0.1, n_steps=10**9),
        lambda: PI2(np.zeros(5), 0.1, n_steps=2**40),
    ]


# Garbage accepted silently counts as a non-finite/garbage output in the tally.
_GARBAGE_IF_ACCEPTED = set(range(15, 22))


def _child(name: str, args: Any, conn: Any) -> None:
    from dmprs.errors import DmprsError

    try:
        if name == "issue examples":
            out = _issue_examples()[args]()
            if args == 3 and abs(out.y[-1, 0] - 0.4794) > 0.5:  # the stiff rollout that ended at -16.3
                conn.send(("non-finite", f"example 3 ended at {out.y[-1, 0]:g}, not near the goal 0.479"))
                return
            if args in _GARBAGE_IF_ACCEPTED:
                conn.send(("non-finite", f"example {args} accepted garbage"))
                return
            conn.send(("non-finite", f"example {args}") if non_finite(out) else ("ok", ""))
            return
        out = TARGETS[name][1](args)
        conn.send(("non-finite", non_finite(out)) if non_finite(out) else ("ok", ""))
    except DmprsError:
        conn.send(("clear errors", ""))
    except AcceptedGarbage as exc:
        conn.send(("garbage accepted", str(exc)[:200]))
    except BaseException as exc:  # noqa: BLE001 - classifying is the point
        kind = "panics" if type(exc).__name__ == "PanicException" else "leaked types"
        conn.send((kind, f"{type(exc).__name__}: {str(exc)[:120]} @ {traceback.format_exc(limit=-1)[-200:]}"))


def _one(name: str, args: Any) -> tuple[str, str]:
    parent, child = mp.Pipe(duplex=False)
    proc = mp.get_context("fork").Process(target=_child, args=(name, args, child))
    proc.start()
    if parent.poll(HANG_TIMEOUTS.get(name, HANG_S)):
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


def main(examples: int, names: list[str]) -> None:
    chosen = {n: t for n, t in TARGETS.items() if not names or any(p.lower() in n.lower() for p in names)}
    if examples == 0:  # only the issue's examples
        chosen.clear()
    total: collections.Counter[str] = collections.Counter()
    print("| target | " + " | ".join(COLUMNS) + " |")
    print("|---" * (len(COLUMNS) + 1) + "|")
    notes: list[str] = []
    for name, (strategy, _) in chosen.items():
        if name in WARMUPS:
            WARMUPS[name]()  # once, in the parent: every forked child inherits it
        counts: collections.Counter[str] = collections.Counter()

        _tally(name, strategy, examples, counts, notes)
        total.update(counts)
        print(f"| {name} | " + " | ".join(str(counts[c]) for c in COLUMNS) + " |", flush=True)
    if not names:
        counts = collections.Counter()
        for k in range(len(_issue_examples())):
            kind, detail = _one("issue examples", k)
            counts["inputs"] += 1
            counts[kind] += 1
            if kind not in ("ok", "clear errors"):
                notes.append(f"issue example {k}: {kind}: {detail}")
        total.update(counts)
        print("| the issue's examples | " + " | ".join(str(counts[c]) for c in COLUMNS) + " |", flush=True)
    print("| **total** | " + " | ".join(str(total[c]) for c in COLUMNS) + " |")
    print("\n".join(notes), file=sys.stderr)


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 300, sys.argv[2:])
