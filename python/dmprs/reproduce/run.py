"""Running the specs of the plan, each in a worker, as plain data for the report."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from dmprs import experiments
from dmprs.baselines import BaselineSpec, run_baseline
from dmprs.experiments.arm_pouring import demonstrations
from dmprs.reproduce.parts import BY_KIND
from dmprs.reproduce.plan import LearnSpec
from dmprs.tasks.pouring import DEMO_VOLUMES, demonstration


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


def dispatch(spec: Any) -> dict[str, Any]:
    """Runs one spec of the plan: a paper experiment, a baseline, or a run of another part."""
    if isinstance(spec, LearnSpec):
        return run_learning(spec)
    if isinstance(spec, BaselineSpec):
        return _baseline(spec)
    result = BY_KIND[spec.kind].run(spec)
    result.update(kind=spec.kind, part=spec.kind)
    return result


def _prepare_pouring(specs: list[Any], cache_dir: Path) -> None:
    """Calibrates the pouring demonstrations once, before workers start, into the disk cache."""
    experiments = {getattr(s, "experiment", "") for s in specs}
    if "pouring" in experiments:

        for v in DEMO_VOLUMES:
            demonstration(v, cache_dir=str(cache_dir))
    if "arm-pouring" in experiments:

        demonstrations(cache_dir=str(cache_dir))
