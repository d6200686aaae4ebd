"""One parallel map for every many-run job (seeds, baselines, sweeps).

``pmap(fn, items)`` runs ``fn(item)`` for each item and returns the results in order. Backends:

* ``"local"`` (default): worker processes on this machine (``spawn`` start method: the Rust
  core's thread pools do not survive ``fork``);
* ``"ray"``: tasks on a Ray cluster (``pip install 'dmprs[ray]'``); connects to the cluster of
  ``RAY_ADDRESS`` or starts a local one;
* ``"serial"``: in this process, one by one (debugging, tiny jobs).

``fn`` must be a module-level function and items picklable. Results do not depend on the
backend or the number of workers: each run gets its own seed from its item, never from a shared
random state.
"""

from __future__ import annotations

import multiprocessing
import os
from collections.abc import Callable, Collection, Iterable, Mapping, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from typing import Any, TypeVar

from dmprs.errors import DmprsError, InvalidInputError, ParallelError

T = TypeVar("T")
R = TypeVar("R")

BACKENDS = ("local", "ray", "serial")


def pmap(
    fn: Callable[[T], R],
    items: Iterable[T],
    *,
    backend: str = "local",
    workers: int | None = None,
    on_result: Callable[[int, R], None] | None = None,
    order: Sequence[int] | None = None,
    after: Mapping[int, Collection[int]] | None = None,
) -> list[R]:
    """``[fn(x) for x in items]``, in parallel; ``on_result(index, result)`` as each finishes.

    ``order`` (a permutation of the items' indices) is the order in which they are handed to
    the workers, longest first keeping every worker busy to the end; the results are in the
    items' order whatever it is. ``after[i]`` names the items that must have finished before
    item ``i`` is handed out (what it reads from their work, e.g. a shared disk cache); until
    then the next item in ``order`` that may go goes.
    """
    jobs: Sequence[T] = list(items)
    if order is None:
        order = range(len(jobs))
    elif sorted(order) != list(range(len(jobs))):
        raise InvalidInputError(f"order must be a permutation of the {len(jobs)} items' indices")
    needs = _prerequisites(after or {}, len(jobs))
    if backend not in BACKENDS:
        raise InvalidInputError(f"unknown backend {backend!r}; choose from {', '.join(BACKENDS)}")
    if workers is not None and (not isinstance(workers, int) or workers < 1):
        raise InvalidInputError(f"workers = {workers!r} must be a positive integer")
    n = workers or os.cpu_count() or 1
    queue = _Queue(order, needs)
    if backend == "serial" or not jobs:
        return _serial(fn, jobs, on_result, queue)
    if backend == "ray":
        return _ray(fn, jobs, n, on_result, queue)
    return _local(fn, jobs, n, on_result, queue)


def _prerequisites(after: Mapping[int, Collection[int]], n: int) -> dict[int, frozenset[int]]:
    """``after`` checked: item indices, and no item waiting, directly or not, on itself."""
    needs = {}
    for i, before in after.items():
        if not (isinstance(i, int) and 0 <= i < n) or any(not (isinstance(j, int) and 0 <= j < n) for j in before):
            raise InvalidInputError(f"after must map the {n} items' indices to collections of their indices")
        needs[i] = frozenset(before)
    resolved = set(range(n)) - set(needs)
    waiting = dict(needs)
    while waiting:
        free = [i for i, before in waiting.items() if before <= resolved]
        if not free:
            raise InvalidInputError(f"after makes items wait on each other in a cycle (items {sorted(waiting)})")
        for i in free:
            del waiting[i]
            resolved.add(i)
    return needs


class _Queue:
    """The items not yet handed out, in ``order``; :meth:`take` hands out the first whose
    prerequisites have all finished.
    """

    def __init__(self, order: Sequence[int], needs: Mapping[int, frozenset[int]]) -> None:
        self.waiting = list(order)
        self.needs = needs
        self.finished: set[int] = set()
        self.position = {i: k for k, i in enumerate(order)}

    def take(self) -> int | None:
        for k, i in enumerate(self.waiting):
            if self.needs.get(i, frozenset()) <= self.finished:
                return self.waiting.pop(k)
        return None


def _serial(fn, jobs, on_result, queue):
    out: list[Any] = [None] * len(jobs)
    while (i := queue.take()) is not None:
        try:
            out[i] = fn(jobs[i])
        except Exception as exc:
            raise ParallelError(f"run {i} ({jobs[i]!r}) failed: {type(exc).__name__}: {exc}") from exc
        queue.finished.add(i)
        if on_result:
            on_result(i, out[i])
    return out


def _local(fn, jobs, n, on_result, queue):
    results: list[Any] = [None] * len(jobs)
    ctx = multiprocessing.get_context("spawn")
    workers = min(n, len(jobs))
    with ProcessPoolExecutor(max_workers=workers, mp_context=ctx) as pool:
        running: dict[Any, int] = {}
        while True:
            # one run per worker in flight: the next one is chosen when a worker is free
            while len(running) < workers and (i := queue.take()) is not None:
                running[pool.submit(fn, jobs[i])] = i
            if not running:
                return results
            done, _ = wait(running, return_when=FIRST_COMPLETED)
            # runs that finished together are told in the order they were handed out
            for f in sorted(done, key=lambda f: queue.position[running[f]]):
                i = running.pop(f)
                try:
                    results[i] = f.result()
                except Exception as exc:
                    for p in running:
                        p.cancel()
                    raise ParallelError(f"run {i} ({jobs[i]!r}) failed: {type(exc).__name__}: {exc}") from exc
                queue.finished.add(i)
                if on_result:
                    on_result(i, results[i])


def _ray(fn, jobs, n, on_result, queue):
    try:
        import ray
    except ImportError:
        raise DmprsError("the ray backend needs Ray: pip install 'dmprs[ray]'") from None
    if not ray.is_initialized():
        if os.environ.get("RAY_ADDRESS"):
            ray.init(address=os.environ["RAY_ADDRESS"], log_to_driver=False)
        else:
            ray.init(num_cpus=n, include_dashboard=False, log_to_driver=False)
    remote = ray.remote(fn)
    results: list[Any] = [None] * len(jobs)
    running: dict[Any, int] = {}
    while True:
        # items whose prerequisites have finished go to the cluster, which schedules them in turn
        while (i := queue.take()) is not None:
            running[remote.remote(jobs[i])] = i
        if not running:
            return results
        done, _ = ray.wait(list(running), num_returns=1)
        i = running.pop(done[0])
        try:
            results[i] = ray.get(done[0])
        except Exception as exc:
            raise ParallelError(f"run {i} ({jobs[i]!r}) failed: {type(exc).__name__}: {exc}") from exc
        queue.finished.add(i)
        if on_result:
            on_result(i, results[i])
