"""Running the specs of the plan, each in a worker, as plain data for the report."""

from __future__ import annotations

import contextlib
import importlib
import os
import time
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from dmprs import experiments
from dmprs.baselines import BaselineSpec, run_baseline
from dmprs.experiments import arm_pouring
from dmprs.reproduce.parts import BY_KIND
from dmprs.reproduce.plan import SEED_KEYS, LearnSpec
from dmprs.tasks import pouring
from dmprs.tasks.arm_pouring import DEMO_VOLUMES as ARM_DEMO_VOLUMES

#: OpenBLAS's kernel for the x86-64 baseline (SSE3), which every x86-64 CPU can run
PORTABLE_BLAS_KERNEL = "Prescott"
#: s: roughly how long one run of a part takes (the report's "Where the time went"), so that the
#: longest runs go to the workers first and no worker is left with a long one at the end; a part
#: not listed counts as one second. Only the order of the runs depends on it, never a result.
RUN_SECONDS = {"arm_pouring": 30.0, "growing": 17.0, "pouring": 5.0, "versus": 5.0, "arm-sequence": 5.0,
               "online": 2.0, "noisy": 1.0, "baselines": 0.5}


def _numpy_dispatch_targets() -> str:
    """numpy's run-time dispatch targets that this CPU has (empty if numpy does not say)."""
    try:
        m = importlib.import_module("numpy._core._multiarray_umath")  # numpy's record of its dispatch
        features: dict[str, bool] = m.__cpu_features__
        return " ".join(f for f in m.__cpu_dispatch__ if features.get(f))
    except (ImportError, AttributeError):
        return ""


@contextlib.contextmanager
def pinned_numerics() -> Iterator[None]:
    """Local workers started inside run the same BLAS kernel and numpy loops on every machine.

    dmprs's own numerics do not depend on the CPU (:mod:`dmprs.portable`), but the baselines'
    packages do: scikit-learn's GP (Bayesian optimization) factors with LAPACK and takes numpy's
    ``exp``, CMA-ES decomposes its covariance. OpenBLAS and numpy read their choice from the
    environment when they load, so the workers (spawned, so they load afresh) are started with
    OpenBLAS's baseline kernel, one thread, and numpy's dispatch beyond its baseline disabled.
    This process keeps what it has; the variables are restored on leaving.
    """
    pins = {"OPENBLAS_CORETYPE": PORTABLE_BLAS_KERNEL, "OPENBLAS_NUM_THREADS": "1"}
    if targets := _numpy_dispatch_targets():
        pins["NPY_DISABLE_CPU_FEATURES"] = targets
    saved = {k: os.environ.get(k) for k in pins}
    os.environ.update(pins)
    try:
        yield
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def run_learning(spec: LearnSpec) -> dict[str, Any]:
    """Runs one learning experiment; returns its trials as plain data."""
    r = experiments.run(spec.experiment, learner=spec.learner, max_trials=spec.max_trials,
                        **dict(spec.setup))
    trials = [{
        "query": t.query.tolist(), "status": t.status,
        "eps": None if t.eps is None else t.eps.tolist(), "success": t.success,
        "signals": {k: v for k, v in t.signals.items() if isinstance(v, (int, float, str))},
    } for t in r.trials]
    return {"kind": "learn", "part": spec.part, "experiment": spec.experiment,
            "setup": dict(spec.setup), "learner": spec.learner, "converged": r.converged,
            "trials_to_success": r.trials_to_success, "n_trials": r.n_trials,
            "stop_reason": r.stop_reason,
            "learned_query": None if r.learned_query is None else r.learned_query.tolist(),
            "trials": trials}


def _baseline(spec: BaselineSpec) -> dict[str, Any]:
    out = run_baseline(spec)
    out.update(kind="baseline", part="baselines", setup=dict(spec.setup))
    return out


def part_of(spec: Any) -> str:
    """The part of the report a spec's run belongs to (its result's ``part``)."""
    if isinstance(spec, LearnSpec):
        return spec.part
    if isinstance(spec, BaselineSpec):
        return "baselines"
    return str(spec.kind)


def experiment_of(result: dict[str, Any]) -> str:
    """The experiment a run's ``result`` belongs to within its part: its experiment and setting
    (a learning run's bottle volume, a comparison's setting), or its part where it names none.
    """
    if "name" in result:  # a comparison's setting
        return str(result["name"])
    if "experiment" in result:
        setting = {k: v for k, v in result.get("setup", {}).items() if k not in SEED_KEYS}
        return f"{result['experiment']} ({', '.join(f'{k} {v}' for k, v in setting.items())})" if setting \
            else str(result["experiment"])
    return str(result["part"])


def longest_first(specs: list[Any]) -> list[int]:
    """The specs' indices, the longest runs first (:data:`RUN_SECONDS`), in plan order otherwise."""
    return sorted(range(len(specs)), key=lambda i: -RUN_SECONDS.get(part_of(specs[i]), 1.0))


def seconds_left(elapsed: float, measured: Mapping[str, float], finished: Mapping[str, int],
                 left: Mapping[str, int]) -> float:
    """Wall-clock seconds the runs ``left`` (per part) should still take, after ``elapsed``
    seconds in which each part's ``finished`` runs took ``measured`` seconds in the workers.

    A run left is expected to take its part's mean so far, or :data:`RUN_SECONDS` while none
    of its part's has finished; the elapsed time per worker-second so far turns that into
    wall-clock time. The runs go longest first, so a count of runs alone would take the first,
    slowest ones as the pace of all the rest.
    """
    def mean(part: str) -> float:
        n = finished.get(part, 0)
        return measured.get(part, 0.0) / n if n else RUN_SECONDS.get(part, 1.0)

    done = sum(measured.values())
    if done <= 0.0:
        return 0.0
    return elapsed / done * sum(n * mean(part) for part, n in left.items() if n > 0)


def dispatch(spec: Any) -> dict[str, Any]:
    """Runs one spec of the plan: a paper experiment, a baseline, or a run of another part; its
    result carries the run's wall-clock ``seconds`` and the ``cpu_seconds`` of its process.
    """
    start, cpu = time.perf_counter(), time.process_time()
    if isinstance(spec, LearnSpec):
        result = run_learning(spec)
    elif isinstance(spec, CalibrationSpec):
        result = _calibrate(spec)
    elif isinstance(spec, BaselineSpec):
        result = _baseline(spec)
    else:
        result = BY_KIND[spec.kind].run(spec)
        result.update(kind=spec.kind, part=spec.kind)
    result["seconds"] = round(time.perf_counter() - start, 2)
    result["cpu_seconds"] = round(time.process_time() - cpu, 2)
    return result


@dataclass(frozen=True)
class CalibrationSpec:
    """Calibrating the pouring demonstration of ``experiment`` for a bottle of ``volume`` l into
    the disk cache ``cache_dir``, which the runs of that experiment then read.
    """

    experiment: str
    volume: float
    cache_dir: str
    kind: str = "calibration"

    @property
    def label(self) -> str:
        """The job's name in progress lines and errors."""
        return f"calibrating the {self.experiment} demonstration from {self.volume:g} l"


def _calibrate(spec: CalibrationSpec) -> dict[str, Any]:
    if spec.experiment == "pouring":
        pouring.demonstration(spec.volume, cache_dir=spec.cache_dir)
    else:
        arm_pouring.demonstration(spec.volume, cache_dir=spec.cache_dir)
    return {"kind": spec.kind, "part": spec.kind}


#: the experiments whose runs read calibrated demonstrations, and their demonstrations' bottles
CALIBRATED = {"pouring": pouring.DEMO_VOLUMES, "arm-pouring": ARM_DEMO_VOLUMES}


def schedule(specs: list[Any], cache_dir: Path) -> tuple[list[Any], list[int], dict[int, list[int]]]:
    """The job's items, the order they are handed out in and what each waits for
    (:func:`dmprs.parallel.pmap`'s ``items``, ``order`` and ``after``): first the calibrations
    of the demonstrations the runs share, each once, the arm's and the fuller bottle's (the most
    simulated) first; then ``specs``, :func:`longest_first`. A run that reads calibrated
    demonstrations waits for its experiment's calibrations; every other run may go at once.
    """
    poured = {getattr(s, "experiment", "") for s in specs}
    calibrations = sorted((CalibrationSpec(e, v, str(cache_dir)) for e, volumes in CALIBRATED.items()
                           if e in poured for v in volumes),
                          key=lambda c: (c.experiment != "arm-pouring", -c.volume))
    first = len(calibrations)
    after = {first + k: [j for j, c in enumerate(calibrations) if c.experiment == getattr(s, "experiment", "")]
             for k, s in enumerate(specs)}
    after = {i: before for i, before in after.items() if before}
    return [*calibrations, *specs], [*range(first), *(first + i for i in longest_first(specs))], after
