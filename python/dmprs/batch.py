"""Many DMPs rolled out in one call, on all cores with the GIL released."""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any, overload

from dmprs import _core
from dmprs._arrays import short
from dmprs.cartesian import CartesianDMP
from dmprs.dmp import DMP
from dmprs.errors import InvalidInputError
from dmprs.primitive import rollout_options
from dmprs.trajectory import CartesianTrajectory, Trajectory

__all__ = ["rollout_batch"]


@overload
def rollout_batch(
    dmps: Iterable[DMP], dt: float = ..., duration: float | None = ..., *,
    until_rest: bool = ..., rest_tol: float = ...,
) -> list[Trajectory]: ...
@overload
def rollout_batch(
    dmps: Iterable[CartesianDMP], dt: float = ..., duration: float | None = ..., *,
    until_rest: bool = ..., rest_tol: float = ...,
) -> list[CartesianTrajectory]: ...
@overload
def rollout_batch(
    dmps: Iterable[DMP | CartesianDMP], dt: float = ..., duration: float | None = ..., *,
    until_rest: bool = ..., rest_tol: float = ...,
) -> list[Trajectory | CartesianTrajectory]: ...
def rollout_batch(
    dmps: Iterable[DMP | CartesianDMP],
    dt: float = 0.001,
    duration: float | None = None,
    *,
    until_rest: bool = False,
    rest_tol: float = 1e-4,
) -> list[Trajectory] | list[CartesianTrajectory] | list[Trajectory | CartesianTrajectory]:
    """Rolls out many DMPs in one call, in parallel on all cores with the GIL released.

    The result equals ``[d.rollout(dt, duration, ...) for d in dmps]`` bit for bit. Each DMP
    keeps its own tau, so with ``duration=None`` the trajectories may differ in length.
    :class:`dmprs.CartesianDMP` s (which give :class:`dmprs.CartesianTrajectory` s) may be mixed in.
    """
    if isinstance(dmps, DMP) or not isinstance(dmps, Iterable):
        raise InvalidInputError(f"dmps must be an iterable of dmprs.DMP or dmprs.CartesianDMP; got {short(dmps)}")
    items = list(dmps)
    for i, d in enumerate(items):
        if not isinstance(d, (DMP, CartesianDMP)):
            raise InvalidInputError(f"dmps[{i}] is a {type(d).__name__}, not a dmprs.DMP or dmprs.CartesianDMP")
    opts = rollout_options(dt, duration, until_rest, rest_tol)
    joint = [(i, d) for i, d in enumerate(items) if isinstance(d, DMP)]
    pose = [(i, d) for i, d in enumerate(items) if isinstance(d, CartesianDMP)]
    out: list[Any] = [None] * len(items)
    if joint:
        arrays = _core.rollout_batch([d._core for _, d in joint], **opts)
        for (i, _), a in zip(joint, arrays, strict=True):
            out[i] = Trajectory._trusted(*a)
    if pose:
        cartesian = _core.rollout_batch_cartesian([d._core for _, d in pose], **opts)
        for (i, _), c in zip(pose, cartesian, strict=True):
            out[i] = CartesianTrajectory._trusted(*c)
    return out
