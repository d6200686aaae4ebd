"""Calibrating a demonstration: the peak tilt whose pour gives the target volume, found in the
simulation and cached (per process, and on disk with ``cache_dir``).
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
import os
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from dmprs._io import write_atomic
from dmprs.errors import InvalidInputError, NumericalError
from dmprs.sim import pouring_scene as scene
from dmprs.tasks.liquid import TARGET_VOLUME, check_volume
from dmprs.tasks.pouring.adapter import CAPACITY, CONTROL_PERIOD, MAX_TILT, PouringAdapter
from dmprs.tasks.pouring.profile import DEMO_TIMING, tilt_profile


@dataclass(frozen=True)
class Calibration:
    """A scripted demonstration's peak tilt and what it pours, with every search evaluation."""

    bottle_volume: float
    target_volume: float
    liquid_seed: int
    peak_tilt: float  #: rad
    poured_volume: float  #: l
    evaluations: tuple[tuple[float, float], ...]  #: (peak tilt rad, poured l), in order

    @classmethod
    def load(cls, path: Path) -> Calibration | None:
        """The calibration cached at ``path``; None if it is absent or damaged (then it is
        computed and rewritten).
        """
        try:
            d = json.loads(path.read_text())
            return cls(**{**d, "evaluations": tuple(tuple(e) for e in d["evaluations"])})
        except (OSError, ValueError, TypeError):
            return None

    def save(self, path: Path) -> None:
        """Caches this calibration at ``path`` (atomically); a disk that refuses is ignored,
        the cache being an optimization only.
        """
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            write_atomic(path, json.dumps(asdict(self)).encode())
        except OSError:
            pass


def _poured(bottle_volume: float, peak: float, liquid_seed: int) -> float:
    adapter = PouringAdapter(bottle_volume, liquid_seed=liquid_seed)
    with adapter:
        adapter.reset(seed=liquid_seed)
        outcome = adapter.execute(tilt_profile(peak))
    if not outcome.ok:
        raise NumericalError(f"a demonstration pour with peak {peak:.4f} rad was {outcome.status.value}: {outcome.message}")
    return float(outcome.signals["poured_volume"])


def _cache_key(**params: Any) -> str:
    import pymunk


    consts = {k: getattr(scene, k) for k in dir(scene) if k.isupper() and isinstance(getattr(scene, k), (int, float, tuple))}
    blob = json.dumps({"params": params, "scene": consts, "pymunk": pymunk.version,
                       "demo_timing": DEMO_TIMING, "control_period": CONTROL_PERIOD,
                       "schema": 1}, sort_keys=True, default=str)
    return hashlib.sha256(blob.encode()).hexdigest()[:24]


def calibrate_peak_tilt(bottle_volume: float, target_volume: float = TARGET_VOLUME, *,
                        liquid_seed: int = 0, tol: float = 0.004, max_evaluations: int = 10,
                        bracket: tuple[float, float] = (1.3, 1.95),
                        cache_dir: str | os.PathLike[str] | None = None) -> Calibration:
    """The peak tilt of :func:`tilt_profile` that pours ``target_volume`` from a bottle holding
    ``bottle_volume`` (both l), found by regula falsi with the Illinois modification on
    ``poured(peak) - target`` over ``bracket`` (rad), stopping at ``|error| <= tol`` (l) or after
    ``max_evaluations`` pours (returning the best one). Poured volume comes in whole discs and
    the disc "liquid" is granular, so the map is a noisy staircase: 2 ml (one disc) is the
    finest meaningful ``tol``.

    Cached per process; with ``cache_dir`` (default: ``$DMPRS_CACHE_DIR`` if set) also on disk,
    keyed by a hash of the parameters, the scene's constants and the pymunk version.
    """
    v = check_volume(bottle_volume, "bottle_volume", capacity=CAPACITY)
    target = check_volume(target_volume, "target_volume", capacity=v)
    if not (isinstance(max_evaluations, int) and max_evaluations >= 2):
        raise InvalidInputError(f"max_evaluations = {max_evaluations!r} must be an integer >= 2")
    lo, hi = (float(b) for b in bracket)
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo < hi <= MAX_TILT):
        raise InvalidInputError(f"bracket = {bracket!r} must satisfy 0 < low < high <= {MAX_TILT} rad")
    if not (math.isfinite(tol) and tol > 0):
        raise InvalidInputError(f"tol = {tol!r} must be > 0 l")
    if cache_dir is None and os.environ.get("DMPRS_CACHE_DIR"):
        cache_dir = os.environ["DMPRS_CACHE_DIR"]
    return _calibrate(v, target, int(liquid_seed), float(tol), max_evaluations, lo, hi,
                      None if cache_dir is None else str(cache_dir))


@functools.lru_cache(maxsize=32)
def _calibrate(v: float, target: float, seed: int, tol: float, max_evals: int, lo: float, hi: float,
               cache_dir: str | None) -> Calibration:
    params = {"bottle_volume": v, "target_volume": target, "liquid_seed": seed, "tol": tol,
              "max_evaluations": max_evals, "bracket": (lo, hi)}
    path = None
    if cache_dir is not None:
        path = Path(cache_dir) / f"pouring-demo-{_cache_key(**params)}.json"
        if (cached := Calibration.load(path)) is not None:
            return cached

    evals: list[tuple[float, float]] = []

    def f(peak: float) -> float:
        poured = _poured(v, peak, seed)
        evals.append((peak, poured))
        return poured - target

    f_lo, f_hi = f(lo), f(hi)
    if not (f_lo <= 0 <= f_hi):
        raise NumericalError(
            f"cannot bracket the demonstration for {v:g} l: peak tilts {lo:.3f} and {hi:.3f} rad pour "
            f"{evals[0][1] * 1000:.0f} and {evals[1][1] * 1000:.0f} ml; the target {target * 1000:.0f} ml "
            "must lie between them")
    side = 0
    while f_lo != 0 and f_hi != 0 and len(evals) < max_evals and min(abs(e[1] - target) for e in evals) > tol:
        x = hi - f_hi * (hi - lo) / (f_hi - f_lo)
        fx = f(x)
        if fx == 0:
            break
        if fx < 0:
            lo, f_lo = x, fx
            if side == -1:  # Illinois: the same end moved twice, halve the other's weight
                f_hi /= 2
            side = -1
        else:
            hi, f_hi = x, fx
            if side == 1:
                f_lo /= 2
            side = 1
    peak, poured = min(evals, key=lambda e: (abs(e[1] - target), e[0]))
    cal = Calibration(bottle_volume=v, target_volume=target, liquid_seed=seed, peak_tilt=peak,
                      poured_volume=poured, evaluations=tuple(evals))
    if path is not None:
        cal.save(path)
    return cal
