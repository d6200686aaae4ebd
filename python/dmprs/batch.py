"""Many DMPs rolled out in one call, on all cores with the GIL released."""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any, overload

from dmprs import _core
from dmprs._arrays import as_scalar, short
from dmprs.cartesian import CartesianDMP
from dmprs.dmp import DMP
from dmprs.errors import InvalidInputError
from dmprs.periodic import PeriodicCartesianDMP, PeriodicDMP
from dmprs.primitive import rollout_options
from dmprs.trajectory import CartesianTrajectory, Trajectory

__all__ = ["MAX_BATCH_BYTES", "rollout_batch"]

#: The most memory the trajectories of one batch may take in all. Each rollout is held to its
#: own bound (20 million values per array), but a batch keeps every trajectory at once: past
#: this, a mistaken batch would exhaust the machine's memory and the process be killed.
MAX_BATCH_BYTES = 4e9
#: float64 values per sample of a pose trajectory: t, position (3), quaternion (4) and the
#: linear and angular velocities and accelerations (3 each)
_POSE_VALUES = 20


@overload
def rollout_batch(
    dmps: Iterable[DMP | PeriodicDMP], dt: float = ..., duration: float | None = ..., *,
    until_rest: bool = ..., rest_tol: float = ..., phase: float = ...,
) -> list[Trajectory]: ...
@overload
def rollout_batch(
    dmps: Iterable[CartesianDMP | PeriodicCartesianDMP], dt: float = ..., duration: float | None = ..., *,
    until_rest: bool = ..., rest_tol: float = ..., phase: float = ...,
) -> list[CartesianTrajectory]: ...
@overload
def rollout_batch(
    dmps: Iterable[DMP | CartesianDMP | PeriodicDMP | PeriodicCartesianDMP], dt: float = ...,
    duration: float | None = ..., *,
    until_rest: bool = ..., rest_tol: float = ..., phase: float = ...,
) -> list[Trajectory | CartesianTrajectory]: ...
def rollout_batch(
    dmps: Iterable[DMP | CartesianDMP | PeriodicDMP | PeriodicCartesianDMP],
    dt: float = 0.001,
    duration: float | None = None,
    *,
    until_rest: bool = False,
    rest_tol: float = 1e-4,
    phase: float = 0.0,
) -> list[Trajectory] | list[CartesianTrajectory] | list[Trajectory | CartesianTrajectory]:
    """Rolls out many DMPs in one call, in parallel on all cores with the GIL released.

    The result equals ``[d.rollout(dt, duration, ...) for d in dmps]`` bit for bit. Each DMP
    keeps its own tau, so with ``duration=None`` the trajectories may differ in length.
    :class:`dmprs.CartesianDMP` s (which give :class:`dmprs.CartesianTrajectory` s) and the
    periodic :class:`dmprs.PeriodicDMP` s and :class:`dmprs.PeriodicCartesianDMP` s (started at
    ``phase``; a rhythm never comes to rest, so ``until_rest`` is refused with them) may be mixed in.
    A batch whose trajectories would take more than :data:`MAX_BATCH_BYTES` in all is refused
    before anything runs.
    """
    kinds = (DMP, CartesianDMP, PeriodicDMP, PeriodicCartesianDMP)
    names = "dmprs.DMP, dmprs.CartesianDMP, dmprs.PeriodicDMP or dmprs.PeriodicCartesianDMP"
    if isinstance(dmps, kinds) or not isinstance(dmps, Iterable):
        raise InvalidInputError(f"dmps must be an iterable of {names}; got {short(dmps)}")
    items = list(dmps)
    for i, d in enumerate(items):
        if not isinstance(d, kinds):
            raise InvalidInputError(f"dmps[{i}] is a {type(d).__name__}, not a {names}")
    opts = rollout_options(dt, duration, until_rest, rest_tol)
    phi0 = as_scalar(phase, "phase")
    joint = [(i, d) for i, d in enumerate(items) if isinstance(d, DMP)]
    pose = [(i, d) for i, d in enumerate(items) if isinstance(d, CartesianDMP)]
    rhythm = [(i, d) for i, d in enumerate(items) if isinstance(d, PeriodicDMP)]
    posed = [(i, d) for i, d in enumerate(items) if isinstance(d, PeriodicCartesianDMP)]
    if (rhythm or posed) and opts["until_rest"]:
        i = min(i for i, _ in [*rhythm, *posed])
        raise InvalidInputError(f"until_rest=True: dmps[{i}] is a {type(items[i]).__name__}, which never comes to rest")
    _check_memory(items, opts["dt"], opts["duration"])
    out: list[Any] = [None] * len(items)
    if joint:
        arrays = _core.rollout_batch([d._core for _, d in joint], **opts)
        for (i, _), a in zip(joint, arrays, strict=True):
            out[i] = Trajectory._trusted(*a)
    if pose:
        cartesian = _core.rollout_batch_cartesian([d._core for _, d in pose], **opts)
        for (i, _), c in zip(pose, cartesian, strict=True):
            out[i] = CartesianTrajectory._trusted(*c)
    if rhythm:
        periodic = _core.rollout_batch_periodic([d._core for _, d in rhythm], opts["dt"], opts["duration"], phi0)
        for (i, _), a in zip(rhythm, periodic, strict=True):
            out[i] = Trajectory._trusted(*a)
    if posed:
        poses = _core.rollout_batch_periodic_cartesian([d._core for _, d in posed], opts["dt"], opts["duration"],
                                                       phi0)
        for (i, _), c in zip(posed, poses, strict=True):
            out[i] = CartesianTrajectory._trusted(*c)
    return out


def _check_memory(items: list[Any], dt: float, duration: float | None) -> None:
    """Refuses a batch whose trajectories would take more than :data:`MAX_BATCH_BYTES` (their
    lengths as asked; a rollout ``until_rest`` may run longer, within its own bound).
    """
    total = 0.0
    for d in items:
        length = duration if duration is not None else (
            d.period if isinstance(d, (PeriodicDMP, PeriodicCartesianDMP)) else d.tau)
        per_sample = _POSE_VALUES if isinstance(d, (CartesianDMP, PeriodicCartesianDMP)) else 1 + 3 * d.n_dof
        total += 8.0 * per_sample * (length / dt + 1.0)
    if total > MAX_BATCH_BYTES:
        raise InvalidInputError(
            f"dmps: {len(items)} rollouts of dt = {dt:g} would take {total / 1e9:.3g} GB in all, beyond "
            f"{MAX_BATCH_BYTES / 1e9:g} GB: roll them out in smaller batches (or at a larger dt)")
