"""The throwing experiment: five scripted demonstration throws labelled with where they landed,
generalized over the 2-D query (x, y) with ``"linear"`` (piecewise linear on the Delaunay
triangulation of the five landing points) or ``"lwr-gp"``, learned with the n-D query learners.

The coordinator registers :func:`arm_throwing_setup` as ``SETUPS["arm-throwing"]`` (it is not
imported by :mod:`dmprs.experiments`: this module imports it: dependencies point one way).
Requires the ``robot`` extra (MuJoCo).
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dmprs._arrays import as_count, short
from dmprs.errors import InvalidInputError
from dmprs.experiments import ExperimentSetup
from dmprs.tasks.noise import Noise
from dmprs.trajectory import Trajectory

#: kernels of the demonstrations' DMPs: 30 reproduce a throw's joints within 3 mrad (the landing
#: within ~1 cm of the scripted throw's)
N_BASIS = 30
#: the generalizers by name, with their options: "lwr-gp-affine" is lwr-gp with an affine trend,
#: which extrapolates beyond the demos (plain lwr-gp cannot: docs/throwing.md)
GENERALIZERS: dict[str, dict[str, Any]] = {
    "linear": {"method": "linear"},
    "lwr-gp": {"method": "lwr-gp"},
    "lwr-gp-affine": {"method": "lwr-gp", "trend": "affine"},
}
#: m: eq. 17's scale for the "weighted" learner (the demos' landings span ~0.5 m)
WEIGHT_SCALE = 0.3
#: m: the "finite-difference" learner's probe step, and the CMA-ES step size
PROBE = 0.05
CMA_SIGMA = 0.1


@functools.lru_cache(maxsize=2)
def demonstrations(n_basis: int = N_BASIS) -> tuple[tuple[NDArray[np.float64], Trajectory], ...]:
    """((landing point, scripted joint trajectory), ...) for :data:`DEMOS`. The label is
    **measured**: where the ball lands when the arm executes the demonstration's DMP (``n_basis``
    kernels, the DMP every generalizer returns at the demo's own query), noise off. Raises if a
    demonstration does not land."""
    from dmprs.dmp import DMP
    from dmprs.errors import DmprsError
    from dmprs.tasks.arm_throwing.demonstrator import DEMOS, throw_trajectory
    from dmprs.tasks.arm_throwing.task import ArmThrowing

    task = ArmThrowing()
    out = []
    with task.adapter as adapter:
        for strength, yaw in DEMOS:
            scripted = throw_trajectory(strength, yaw)
            dmp = DMP.fit(scripted.t, scripted.y, n_basis, scripted.yd, scripted.ydd)
            adapter.reset(seed=0)
            outcome = adapter.execute(task.trajectory(dmp))
            if not outcome.ok:
                raise DmprsError(f"the demonstration throw (strength {strength}, yaw {yaw} rad) failed: "
                                 f"{outcome.message}")
            label = task.measure(outcome)
            label.setflags(write=False)
            out.append((label, scripted))
    return tuple(out)


def throwing_learners(max_trials: int = 50) -> dict[str, Callable[..., Any]]:
    """The n-D query learners by name (eq. 16 with J = I, Broyden, finite differences, eq. 17's
    weighting) and CMA-ES, each starting at the desired landing point."""
    from dmprs import learners as L

    def cma(q0: NDArray[np.float64], **kw: Any) -> Any:
        from dmprs.cmaes import CMAES

        kw.setdefault("max_trials", max_trials)
        return CMAES(q0, kw.pop("sigma0", CMA_SIGMA), first_x0=True, **kw)

    return {
        "secant": lambda q0, **kw: L.ErrorLearning(q0, jacobian="secant", max_trials=max_trials, **kw),
        "error": lambda q0, **kw: L.ErrorLearning(q0, max_trials=max_trials, **kw),
        "finite-difference": lambda q0, **kw: L.ErrorLearning(
            q0, jacobian="finite-difference", delta=kw.pop("delta", PROBE), max_trials=max_trials, **kw),
        # docs/method.md §5.4: J from probes, refined by Broyden, steps in a trust region
        "broyden": lambda q0, **kw: L.ErrorLearning(
            q0, jacobian="finite-difference", delta=kw.pop("delta", PROBE), broyden=True,
            trust_radius=kw.pop("trust_radius", 0.5), max_trials=max_trials, **kw),
        "weighted": lambda q0, **kw: L.ErrorLearning(
            q0, jacobian="secant", weighted=True, scale=kw.pop("scale", WEIGHT_SCALE), max_trials=max_trials, **kw),
        "cma": cma,
    }


def arm_throwing_setup(target: ArrayLike = (1.0, 0.0), generalizer: str = "linear", tol: float | None = None,
                       noise: Noise | None = None, n_basis: int = N_BASIS, max_trials: int = 50) -> ExperimentSetup:
    """Throw the ball into a basket at ``target`` = (x, y) m on the floor (docs/throwing.md).

    Five scripted throws (:data:`~dmprs.tasks.arm_throwing.DEMOS`) labelled with their measured
    landing points; ``generalizer``: ``"linear"`` (piecewise linear on their Delaunay
    triangulation, affine extrapolation from the nearest triangle outside it), ``"lwr-gp"`` or
    ``"lwr-gp-affine"`` (with an affine trend, which extrapolates);
    DMPs of ``n_basis`` kernels. Learners: ``secant`` (default: error learning with Broyden's
    update of the Jacobian), ``error`` (eq. 16, K = J = I), ``finite-difference``, ``weighted``
    (eq. 17), ``cma``. ``tol``: the basket's radius (m, default 5 cm). ``noise``: a
    :class:`dmprs.tasks.noise.Noise` (execution in rad, measurement in m) for the trials; the
    demonstrations are measured without it.
    """
    from dmprs.database import Database
    from dmprs.generalize import Generalizer
    from dmprs.tasks.arm_throwing.task import TOLERANCE, ArmThrowing

    if not isinstance(generalizer, str) or generalizer not in GENERALIZERS:
        raise InvalidInputError(f"generalizer = {short(generalizer)} is invalid: use one of {tuple(GENERALIZERS)}")
    n_basis = as_count(n_basis, "n_basis", 2)
    max_trials = as_count(max_trials, "max_trials", 1)
    task = ArmThrowing(TOLERANCE if tol is None else tol, noise=noise)
    desired = task.validate_query(target, "target")  # before the demonstrations: a refusal is quick
    db = Database(query_names=task.query_names, query_units=task.query_units)
    for label, trajectory in demonstrations(n_basis):
        db.add(label, trajectory)
    gen = Generalizer(db, n_basis=n_basis, **GENERALIZERS[generalizer])
    return ExperimentSetup(task=task, database=db, generalizer=gen,
                           desired_query=desired, default_learner="secant",
                           learners=throwing_learners(max_trials))
