"""What a Gymnasium environment needs to know about a task: the generalizer of its demonstrations,
the range of queries, the contexts an episode can start in, and how to build the task for one.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dmprs.errors import InvalidInputError
from dmprs.experiments import arm_juggling, arm_pouring, arm_throwing, matchbox, pouring
from dmprs.generalize import Generalizer
from dmprs.tasks import arm_juggling as juggling_task
from dmprs.tasks import arm_throwing as throwing_task
from dmprs.tasks.arm_pouring import ArmPouring
from dmprs.tasks.base import Task
from dmprs.tasks.pouring import DEMO_VOLUMES, SUCCESS_TOLERANCE, TARGET_VOLUME, Pouring

__all__ = ["Scenario", "arm_pouring_scenario", "juggling_scenario", "matchbox_scenario", "pouring_scenario",
           "throwing_scenario"]


@dataclass
class Scenario:
    """A task family as a contextual problem: ``reset`` draws a context (what the observation
    shows), ``make_task(context)`` builds the task for it, ``desired_query(context)`` is the query
    it asks for, and queries range over ``[query_low, query_high]`` (the demonstrations' span, where
    the generalizer is valid). ``failure_reward`` is the reward of a trial without a measurement
    (rejected trajectory, simulation error): below that of any measured trial.
    """

    name: str
    generalizer: Generalizer
    query_low: NDArray[np.float64]
    query_high: NDArray[np.float64]
    context_low: NDArray[np.float64]
    context_high: NDArray[np.float64]
    context_names: tuple[str, ...]
    make_task: Callable[[NDArray[np.float64]], Task]
    desired_query: Callable[[NDArray[np.float64]], NDArray[np.float64]]
    failure_reward: float

    def sample_context(self, rng: np.random.Generator) -> NDArray[np.float64]:
        """A context drawn uniformly from its range with ``rng``."""
        return rng.uniform(self.context_low, self.context_high)


def matchbox_scenario(demos: str = "default", **config: float) -> Scenario:
    """Stand the matchbox upright (``dmprs.tasks.matchbox``): one context, the desired outcome
    angle pi/2; the query is the outcome angle the generalizer is asked for, between the
    demonstrations' labels. A measured trial scores ``-|eps|`` (rad) with eps = pi/2 - q_a, at
    most pi/2 in size, so a trial without a measurement scores -pi.
    """
    setup = matchbox.setup(demos, noise=None, **config)
    task = setup.task
    desired = np.array([math.pi / 2])
    return Scenario(
        name="matchbox", generalizer=setup.generalizer,
        query_low=np.array([setup.low]), query_high=np.array([setup.high]),
        context_low=desired, context_high=desired.copy(), context_names=("desired_outcome_angle",),
        make_task=lambda context: task, desired_query=lambda context: context.copy(),
        failure_reward=-math.pi,
    )


def pouring_scenario(volume_range: Sequence[float] = (0.3, 1.0), demo_volumes: Sequence[float] = DEMO_VOLUMES,
                     target_volume: float = TARGET_VOLUME, tol: float = SUCCESS_TOLERANCE, liquid_seed: int = 0,
                     cache_dir: str | None = None, **adapter_options: Any) -> Scenario:
    """Pour ``target_volume`` l from a bottle whose volume (the context) is drawn from
    ``volume_range`` at each reset (``dmprs.tasks.pouring``). The experiment's demonstrations
    (:func:`dmprs.experiments.pouring.setup`) pour the target from bottles of ``demo_volumes``
    with the liquid of ``liquid_seed``. The query is the assumed bottle volume, between the
    demonstrations' volumes; a measured trial scores ``-|V_poured - V*|`` (l), a trial without a
    measurement minus the largest volume.
    """
    lo, hi = (float(v) for v in volume_range)
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo <= hi):
        raise InvalidInputError(f"volume_range = {tuple(volume_range)!r} must be 0 < low <= high (l)")
    setup = pouring.setup((lo + hi) / 2, target_volume, tol, liquid_seed=liquid_seed, demo_seed=liquid_seed,
                          cache_dir=cache_dir, demo_volumes=tuple(demo_volumes))
    tasks: dict[float, Pouring] = {}

    def make_task(context: NDArray[np.float64]) -> Task:
        v = float(context[0])
        if v not in tasks:
            if len(tasks) >= 32:  # contexts are continuous: keep the cache small
                tasks.clear()
            tasks[v] = Pouring(v, target_volume=target_volume, tol=tol, liquid_seed=liquid_seed,
                               **adapter_options)
        return tasks[v]

    return Scenario(
        name="pouring", generalizer=setup.generalizer,
        query_low=np.array([min(demo_volumes)]), query_high=np.array([max(demo_volumes)]),
        context_low=np.array([lo]), context_high=np.array([hi]), context_names=("bottle_volume",),
        make_task=make_task, desired_query=lambda context: context.copy(),
        failure_reward=-max(hi, max(demo_volumes)),
    )


def throwing_scenario(generalizer: str = "linear", tol: float = throwing_task.SUCCESS_TOLERANCE) -> Scenario:
    """Throw the ball into a basket with the 7-DOF arm (``dmprs.tasks.arm_throwing``, needs the
    ``robot`` extra): the context is the basket's position (x, y in m), drawn at each reset from
    the box the demonstrations landed in; the query is the landing point the generalizer is asked
    for, within that box. A measured trial scores ``-|eps|`` (m), a trial without a landing minus
    the box's diagonal.
    """
    labels = np.array([label for label, _ in arm_throwing.demonstrations()])
    lo, hi = labels.min(axis=0), labels.max(axis=0)
    setup = arm_throwing.setup(tuple((lo + hi) / 2), generalizer, tol=tol)
    return Scenario(
        name="throwing", generalizer=setup.generalizer, query_low=lo, query_high=hi,
        context_low=lo.copy(), context_high=hi.copy(), context_names=("basket_x", "basket_y"),
        make_task=lambda context: setup.task, desired_query=lambda context: context.copy(),
        failure_reward=-float(np.linalg.norm(hi - lo)),
    )


def arm_pouring_scenario(volume_range: Sequence[float] = (0.4, 0.9), cache_dir: str | None = None) -> Scenario:
    """Pour 0.2 l with the 7-DOF arm (``dmprs.tasks.arm_pouring``, needs the ``robot`` extra)
    from a bottle whose volume (the context) is drawn from ``volume_range`` at each reset. The
    calibrated pose demonstrations of 0.3 and 1.0 l (cached on disk with ``cache_dir`` or
    ``DMPRS_CACHE_DIR``), generalized linearly as Cartesian DMPs; the query is the assumed bottle
    volume. A measured trial scores ``-|V_poured - V*|`` (l), a trial without a measurement -1.
    One step is a few seconds of MuJoCo.
    """
    lo, hi = (float(v) for v in volume_range)
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo <= hi):
        raise InvalidInputError(f"volume_range = {tuple(volume_range)!r} must be 0 < low <= high (l)")
    setup = arm_pouring.setup((lo + hi) / 2, cache_dir=cache_dir)
    tasks: dict[float, ArmPouring] = {}

    def make_task(context: NDArray[np.float64]) -> Task:
        v = float(context[0])
        if v not in tasks:
            if len(tasks) >= 8:  # each holds a settled liquid: keep the cache small
                tasks.clear()
            tasks[v] = ArmPouring(v)
        return tasks[v]

    return Scenario(
        name="arm-pouring", generalizer=setup.generalizer,
        query_low=np.array([setup.low]), query_high=np.array([setup.high]),
        context_low=np.array([lo]), context_high=np.array([hi]), context_names=("bottle_volume",),
        make_task=make_task, desired_query=lambda context: context.copy(), failure_reward=-1.0,
    )


def juggling_scenario(ball_seed: int = 0, tol: float = juggling_task.SUCCESS_TOLERANCE) -> Scenario:
    """Bounce the ball on the paddle to a desired apex with the 7-DOF arm
    (``dmprs.tasks.arm_juggling``, needs the ``robot`` extra): the context is the desired apex (m
    above the paddle at rest), drawn at each reset from between the demonstrations' apexes; the
    query is the apex the periodic generalizer is asked for, within that range. ``ball_seed``:
    the ball's drop and restitution in every episode. A measured trial scores ``-|eps|`` (m), a
    trial without a measurement (the ball stopped bouncing) minus the range's width.
    """
    apexes = np.array([float(label[0]) for label, _ in arm_juggling.demonstrations()])
    lo, hi = np.array([apexes.min()]), np.array([apexes.max()])
    setup = arm_juggling.setup(float((lo[0] + hi[0]) / 2), tol=tol, ball_seed=ball_seed)
    return Scenario(
        name="juggling", generalizer=setup.generalizer, query_low=lo, query_high=hi,
        context_low=lo.copy(), context_high=hi.copy(), context_names=("desired_apex",),
        make_task=lambda context: setup.task, desired_query=lambda context: context.copy(),
        failure_reward=-float(hi[0] - lo[0]),
    )
