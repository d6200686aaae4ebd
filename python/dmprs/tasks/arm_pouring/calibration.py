"""Calibrating a demonstration: the peak tilt whose pour gives the target volume, found with the
library's Illinois root finder and cached (per process, and on disk with ``cache_dir``).
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
from pathlib import Path
from typing import Any

import numpy as np

from dmprs.errors import NumericalError
from dmprs.learners import IllinoisRootFinder
from dmprs.sim import arm_model, arm_scene, granular
from dmprs.tasks.arm_pouring.adapter import CAPACITY, CONTROL_PERIOD, ArmPouringAdapter
from dmprs.tasks.arm_pouring.demonstrator import DEMO_TIMING, POUR_POSITION, pour_poses
from dmprs.tasks.liquid import TARGET_VOLUME, check_volume
from dmprs.tasks.pouring.calibration import Calibration  # the same record as the 2-D pouring's


def poured_volume(bottle_volume: float, trajectory: Any, liquid_seed: int = 0) -> float:
    """What ``trajectory`` pours from a bottle holding ``bottle_volume`` l (one simulated trial)."""
    adapter = ArmPouringAdapter(bottle_volume, liquid_seed=liquid_seed)
    with adapter:
        adapter.reset(seed=liquid_seed)
        outcome = adapter.execute(trajectory)
    if not outcome.ok:
        raise NumericalError(f"a pour from {bottle_volume:g} l was {outcome.status.value}: {outcome.message}")
    return float(outcome.signals["poured_volume"])


def _cache_path(cache_dir: str, params: dict[str, Any]) -> Path:
    """The disk-cache file of a calibration: keyed by its parameters, the whole scene (its MJCF,
    the liquid's and the demonstrator's constants) and the MuJoCo version.
    """
    import mujoco


    blob = json.dumps({"params": params, "mjcf": arm_model.scene_xml(), "mujoco": mujoco.__version__,
                       "home": arm_scene.HOME_POSE, "settle": arm_scene.SETTLE_TIME,
                       "spawn": (granular.SPAWN_GAP, granular.MAX_PARTICLES), "timing": DEMO_TIMING,
                       "pour": POUR_POSITION, "period": CONTROL_PERIOD, "schema": 2}, sort_keys=True, default=str)
    return Path(cache_dir) / f"arm-pouring-demo-{hashlib.sha256(blob.encode()).hexdigest()[:24]}.json"


def calibrate_peak_tilt(bottle_volume: float, target_volume: float = TARGET_VOLUME, *, liquid_seed: int = 0,
                        tol: float = 0.004, max_evaluations: int = 10, bracket: tuple[float, float] = (1.2, 2.4),
                        cache_dir: str | os.PathLike[str] | None = None) -> Calibration:
    """The peak tilt of :func:`pour_poses` that pours ``target_volume`` from a bottle holding
    ``bottle_volume`` l, found by the library's Illinois root finder
    (:class:`dmprs.learners.IllinoisRootFinder`) on ``poured(peak) - target`` over ``bracket``
    (rad), stopping at ``|error| <= tol`` l or after ``max_evaluations`` pours (then the best).

    Cached per process; with ``cache_dir`` (default: ``$DMPRS_CACHE_DIR`` if set) also on disk
    (see :func:`_cache_path`).
    """
    if cache_dir is None and os.environ.get("DMPRS_CACHE_DIR"):
        cache_dir = os.environ["DMPRS_CACHE_DIR"]
    return _calibrate(float(bottle_volume), float(target_volume), int(liquid_seed), float(tol),
                      int(max_evaluations), (float(bracket[0]), float(bracket[1])),
                      None if cache_dir is None else str(cache_dir))


@functools.lru_cache(maxsize=16)
def _calibrate(bottle_volume: float, target_volume: float, liquid_seed: int, tol: float, max_evaluations: int,
               bracket: tuple[float, float], cache_dir: str | None) -> Calibration:

    v = check_volume(bottle_volume, "bottle_volume", capacity=CAPACITY)
    target = check_volume(target_volume, "target_volume", capacity=v)
    lo, hi = bracket
    path = None
    if cache_dir is not None:
        path = _cache_path(cache_dir, {"v": v, "target": target, "seed": liquid_seed, "tol": tol,
                                       "max": max_evaluations, "bracket": bracket})
        if (cached := Calibration.load(path)) is not None:
            return cached
    # The root finder searches q with eps > 0 meaning "increase q": more tilt pours more, so
    # eps = target - poured (docs/method.md §5.3).
    finder = IllinoisRootFinder(0.5 * (lo + hi), low=lo, high=hi, tol=tol, max_trials=max_evaluations)
    evals: list[tuple[float, float]] = []
    while len(evals) < max_evaluations and not (finder.converged or finder.done):
        peak = float(np.atleast_1d(finder.ask())[0])
        poured = poured_volume(v, pour_poses(peak), liquid_seed)
        evals.append((peak, poured))
        if abs(poured - target) <= tol:
            break
        finder.tell(peak, target - poured)
    peak, poured = min(evals, key=lambda e: (abs(e[1] - target), e[0]))
    cal = Calibration(v, target, int(liquid_seed), peak, poured, tuple(evals))
    if path is not None:
        cal.save(path)
    return cal

