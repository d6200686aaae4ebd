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
from collections.abc import Callable, Iterable, Sequence
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
) -> list[R]:
    """``[fn(x) for x in items]``, in parallel; ``on_result(index, result)`` as each finishes.

    ``order`` (a permutation of the items' indices) is the order in which they are handed to
    the workers, longest first keeping every worker busy to the end; the results are in the
    items' order whatever it is.
    """
    jobs: Sequence[T] = list(items)
    if order is None:
        order = range(len(jobs))
    elif sorted(order) != list(range(len(jobs))):
        raise InvalidInputError(f"order must be a permutation of the {len(jobs)} items' indices")
    if backend not in BACKENDS:
        raise InvalidInputError(f"unknown backend {backend!r}; choose from {', '.join(BACKENDS)}")
    if workers is not None and (not isinstance(workers, int) or workers < 1):
        raise InvalidInputError(f"workers = {workers!r} must be a positive integer")
    n = workers or os.cpu_count() or 1
    if backend == "serial" or not jobs:
        return _serial(fn, jobs, on_result, order)
    if backend == "ray":
        return _ray(fn, jobs, n, on_result, order)
    return _local(fn, jobs, n, on_result, order)


def _serial(fn, jobs, on_result, order):
    out: list[Any] = [None] * len(jobs)
    for i in order:
        try:
            out[i] = fn(jobs[i])
        except Exception as exc:
            raise ParallelError(f"run {i} ({jobs[i]!r}) failed: {type(exc).__name__}: {exc}") from exc
        if on_result:
            on_result(i, out[i])
    return out


def _local(fn, jobs, n, on_result, order):
    results: list[Any] = [None] * len(jobs)
    ctx = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(max_workers=min(n, len(jobs)), mp_context=ctx) as pool:
        futures = {pool.submit(fn, jobs[i]): i for i in order}
        handed = {f: position for position, f in enumerate(futures)}
        pending = set(futures)
        while pending:
            done, pending = wait(pending, return_when=FIRST_COMPLETED)
            # runs that finished together are told in the order they were handed out
            for f in sorted(done, key=handed.__getitem__):
                i = futures[f]
                try:
                    results[i] = f.result()
                except Exception as exc:
                    for p in pending:
                        p.cancel()
                    raise ParallelError(f"run {i} ({jobs[i]!r}) failed: {type(exc).__name__}: {exc}") from exc
                if on_result:
                    on_result(i, results[i])
    return results


def _ray(fn, jobs, n, on_result, order):
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
    index = {remote.remote(jobs[i]): i for i in order}
    refs = list(index)
    results: list[Any] = [None] * len(jobs)
    pending = list(refs)
    while pending:
        done, pending = ray.wait(pending, num_returns=1)
        i = index[done[0]]
        try:
            results[i] = ray.get(done[0])
        except Exception as exc:
            raise ParallelError(f"run {i} ({jobs[i]!r}) failed: {type(exc).__name__}: {exc}") from exc
        if on_result:
            on_result(i, results[i])
    return results
