"""Paddle juggling with the 7-DOF arm in MuJoCo, a periodic task learned in query space
(docs/juggling.md): three scripted rhythms labelled with the apex the ball reached, generalized
over the apex as periodic DMPs (``Generalizer(periodic=True)``, linear in the query), learned
with the one-dimensional query learners. Needs the ``robot`` extra.
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np
from numpy.typing import NDArray

from dmprs._arrays import as_count
from dmprs.errors import DmprsError
from dmprs.experiments.base import SCALAR_LEARNERS, ExperimentSetup, LearnerSettings, build
from dmprs.periodic import PeriodicDMP
from dmprs.tasks.arm_juggling import DEMO_PERIODS, SUCCESS_TOLERANCE, ArmJuggling, rhythm_period
from dmprs.trajectory import Trajectory

#: kernels of the demonstrations' periodic DMPs: 30 reproduce a rhythm's joints within 0.1 mrad
N_BASIS = 30
#: the learners' settings in m (the demos' apexes span about 0.2 m): eq. 17's scale, the
#: finite-difference probe, Broyden's trust radius and a step's scale
SETTINGS = LearnerSettings(weight_scale=0.05, task_scale=0.05, probe=0.02, trust_radius=0.1)
#: the seed the demonstrations are measured with (the scene's nominal ball and drop)
DEMO_SEED = 0


@functools.lru_cache(maxsize=2)
def demonstrations(n_basis: int = N_BASIS) -> tuple[tuple[NDArray[np.float64], Trajectory], ...]:
    """((apex, one period of the scripted joint rhythm), ...) for
    :data:`~dmprs.tasks.arm_juggling.DEMO_PERIODS`. The label is **measured**: the apex the ball
    reaches when the arm executes the demonstration's periodic DMP (``n_basis`` kernels, the DMP
    the generalizer returns at the demo's own query) with the drop of :data:`DEMO_SEED`. Raises if
    a demonstration does not keep the ball bouncing.
    """
    task = ArmJuggling(seed=DEMO_SEED)
    out = []
    with task.adapter as adapter:
        for period in DEMO_PERIODS:
            scripted = rhythm_period(period)
            dmp = PeriodicDMP.fit(scripted.t, scripted.y, period, n_basis, scripted.yd, scripted.ydd)
            adapter.reset(seed=0)
            outcome = adapter.execute(task.trajectory(dmp))
            if not outcome.ok:
                raise DmprsError(f"the demonstration rhythm of period {period} s failed: {outcome.message}")
            label = task.measure(outcome)
            label.setflags(write=False)
            out.append((label, scripted))
    return tuple(out)


def setup(desired: float = 0.25, tol: float = SUCCESS_TOLERANCE, ball_seed: int = 0, n_basis: int = N_BASIS,
          max_trials: int = 50) -> ExperimentSetup:
    """Bounce the ball to an apex of ``desired`` m above the paddle at rest (docs/juggling.md).

    Three scripted rhythms labelled with their measured apexes, generalized linearly in the apex
    as periodic DMPs of ``n_basis`` kernels (period, baseline, amplitude, start and weights);
    ``ball_seed``: how the ball is started and its restitution in the trials
    (:class:`~dmprs.sim.juggle_scene.Drop`); the demonstrations are measured with seed 0.
    ``tol``: success within this of the target (m). Learners: ``auto`` (the default: the root
    finder expanding its limits), ``root`` (the Illinois root finder between the demos'
    apexes), ``golden`` (golden section, the paper's pouring learner), ``broyden`` and the
    others of a one-dimensional query; limits: the demos' apexes.
    """
    settings = dataclasses.replace(SETTINGS, max_trials=as_count(max_trials, "max_trials", 1))
    task = ArmJuggling(tol, seed=as_count(ball_seed, "ball_seed", 0))
    made = build(task, lambda: demonstrations(n_basis), desired,
                 generalizer={"method": "linear", "periodic": True, "n_basis": n_basis},
                 paper_learner="root", learner_names=SCALAR_LEARNERS, settings=settings, desired_name="desired")
    apexes = made.database.queries[:, 0]
    made.settings = dataclasses.replace(made.settings, low=float(apexes.min()), high=float(apexes.max()))
    return made
