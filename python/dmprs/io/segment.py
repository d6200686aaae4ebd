"""Cutting recordings into demonstrations and putting them on a uniform clock.

A recording keeps the times it was recorded at (absolute, in s: header stamps of a bag,
timestamps of a dataset). :func:`resample` interpolates it onto a uniform grid;
:func:`split_at_rest` finds the movements in one long recording separated by pauses;
:func:`cut` takes given time ranges.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from dmprs._arrays import as_float_array, as_scalar
from dmprs.errors import InvalidInputError
from dmprs.trajectory import Trajectory

__all__ = ["MAX_RESAMPLED_VALUES", "MIN_SAMPLES", "cut", "motion_ranges", "resample", "split_at_rest"]

#: A demonstration needs at least this many samples: DMP.fit differentiates the positions twice
#: by finite differences (crates/dmp-core/src/finite_difference.rs, MIN_SAMPLES).
MIN_SAMPLES = 3
#: Resampling may produce at most this many values (samples x degrees of freedom, 400 MB of
#: float64): the grid's size is checked before it is allocated.
MAX_RESAMPLED_VALUES = 50_000_000


def uniform_count(duration: float, rate: float, n_dof: int) -> int:
    """The number of samples of a uniform grid of ``rate`` Hz over ``duration`` s (from the first
    sample, up to the last grid point at or before the end), refused before anything is allocated
    if it would exceed MAX_RESAMPLED_VALUES or fall short of MIN_SAMPLES.
    """
    hz = as_scalar(rate, "rate", positive=True)
    with np.errstate(over="ignore"):
        steps = np.float64(duration) / (1.0 / hz)
    if not np.isfinite(steps) or (steps + 1) * n_dof > MAX_RESAMPLED_VALUES:
        raise InvalidInputError(
            f"resampling {duration:.6g} s at {hz:g} Hz gives {steps + 1:.4g} samples x {n_dof} DOF, more than "
            f"the {MAX_RESAMPLED_VALUES:.0e} values allowed (lower the rate)")
    n = int(np.floor(steps + 1e-9)) + 1
    if n < MIN_SAMPLES:
        raise InvalidInputError(
            f"resampling {duration:.4g} s at {hz:g} Hz leaves {n} samples; a demonstration needs at least "
            f"{MIN_SAMPLES} (raise the rate)")
    return n


def resample(trajectory: Trajectory, rate: float, *, start_at_zero: bool = True) -> Trajectory:
    """Linear interpolation of positions (and velocities, if known) onto a uniform grid of
    ``rate`` Hz from the first sample; times start at 0 unless ``start_at_zero=False``. The last
    sample is the last grid point at or before the recording's end.
    """
    n = uniform_count(trajectory.duration, rate, trajectory.n_dof)
    t = trajectory.t
    t_new = t[0] + np.arange(n) * (1.0 / float(rate))

    def interp(y: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.stack([np.interp(t_new, t, y[:, d]) for d in range(y.shape[1])], axis=1)

    yd = None if trajectory.yd is None else interp(trajectory.yd)
    return Trajectory(t_new - t[0] if start_at_zero else t_new, interp(trajectory.y), yd)


def from_zero(trajectory: Trajectory) -> Trajectory:
    """The same samples with times counted from the first one."""
    return Trajectory(trajectory.t - trajectory.t[0], trajectory.y, trajectory.yd, trajectory.ydd)


def cut(trajectory: Trajectory, ranges: Sequence[tuple[float, float]]) -> list[Trajectory]:
    """The parts of ``trajectory`` with ``start <= t <= stop`` for each ``(start, stop)``, in the
    recording's own times (absolute), each with times from 0.
    """
    out = []
    for k, rng in enumerate(ranges):
        start, stop = (as_scalar(v, f"ranges[{k}]") for v in rng)
        keep = (trajectory.t >= start) & (trajectory.t <= stop)
        if keep.sum() < MIN_SAMPLES:
            raise InvalidInputError(
                f"ranges[{k}] = ({start:g}, {stop:g}) s holds {int(keep.sum())} samples of a recording "
                f"from {trajectory.t[0]:g} to {trajectory.t[-1]:g} s; a demonstration needs at least {MIN_SAMPLES}")
        out.append(from_zero(Trajectory(trajectory.t[keep], trajectory.y[keep],
                                        None if trajectory.yd is None else trajectory.yd[keep])))
    return out


def motion_ranges(t: NDArray[np.float64], y: NDArray[np.float64], *, speed_tol: float,
                  min_rest: float = 0.2, min_duration: float = 0.3) -> list[tuple[float, float]]:
    """Time ranges of the movements in a recording: where the speed ``|dy/dt|`` (Euclidean over
    the columns of ``y``) exceeds ``speed_tol``, with pauses shorter than ``min_rest`` s bridged
    and movements shorter than ``min_duration`` s dropped. Each range is widened by one sample on
    either side, so it starts and ends at rest.
    """
    tt = as_float_array(t, "t", 1)
    yy = as_float_array(y, "y", (1, 2))
    yy = yy.reshape(-1, 1) if yy.ndim == 1 else yy
    tol = as_scalar(speed_tol, "speed_tol", positive=True)
    rest = as_scalar(min_rest, "min_rest")
    shortest = as_scalar(min_duration, "min_duration")
    if len(tt) < 3:
        return []
    speed = np.linalg.norm(np.gradient(yy, tt, axis=0), axis=1)
    return moving_ranges(tt, speed > tol, rest, shortest)


def moving_ranges(tt: NDArray[np.float64], is_moving: NDArray[np.bool_], rest: float,
                  shortest: float) -> list[tuple[float, float]]:
    """The ranges of :func:`motion_ranges` from a per-sample moving flag."""
    moving = np.concatenate([[False], is_moving, [False]])
    edges = np.flatnonzero(np.diff(moving.astype(np.int8)))
    runs = [(int(a), int(b) - 1) for a, b in zip(edges[::2], edges[1::2], strict=True)]  # inclusive indices
    merged: list[tuple[int, int]] = []
    for a, b in runs:
        if merged and tt[a] - tt[merged[-1][1]] < rest:
            merged[-1] = (merged[-1][0], b)
        else:
            merged.append((a, b))
    out = []
    for a, b in merged:
        a, b = max(a - 1, 0), min(b + 1, len(tt) - 1)
        if tt[b] - tt[a] >= shortest:
            out.append((float(tt[a]), float(tt[b])))
    return out


def split_at_rest(trajectory: Trajectory, *, speed_tol: float, min_rest: float = 0.2,
                  min_duration: float = 0.3) -> list[Trajectory]:
    """The movements of one long recording, cut where it rests (see :func:`motion_ranges`),
    each with times from 0. ``speed_tol`` is in the units of y per second (joint speeds: rad/s).
    """
    ranges = motion_ranges(trajectory.t, trajectory.y, speed_tol=speed_tol, min_rest=min_rest,
                           min_duration=min_duration)
    if not ranges:
        raise InvalidInputError(
            f"no movement faster than speed_tol = {speed_tol:g} per s for at least {min_duration:g} s "
            f"in a recording of {trajectory.duration:.4g} s")
    return cut(trajectory, ranges)
