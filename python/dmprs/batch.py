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

__all__ = ["rollout_batch"]


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
