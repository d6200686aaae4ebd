"""Throwing into a basket with the 7-DOF arm in MuJoCo, a 2-D query (docs/throwing.md): five
scripted demonstration throws labelled with where they landed, generalized over the landing point
(x, y) with ``"linear"`` (piecewise linear on the Delaunay triangulation of the five landing
points), ``"lwr-gp"`` or ``"lwr-gp-affine"``, learned with the n-D query learners. With
``release=True`` the final-velocity throw: each demonstration up to its release, a DMP with a
final velocity generalized with the rest, and a braking movement after it
(:mod:`dmprs.tasks.arm_throwing.release`). Needs the ``robot`` extra.
"""

from __future__ import annotations

import dataclasses
import functools
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dmprs._arrays import as_count, short
from dmprs.dmp import DMP
from dmprs.errors import DmprsError, InvalidInputError
from dmprs.experiments.base import ExperimentSetup, LearnerSettings, build, ros2_domain
from dmprs.tasks.arm_throwing import DEMOS, SUCCESS_TOLERANCE, ArmThrowing, throw_trajectory
from dmprs.tasks.arm_throwing.release import split
from dmprs.tasks.noise import Noise
from dmprs.trajectory import Trajectory

#: kernels of the demonstrations' DMPs: 30 reproduce a throw's joints within 3 mrad (the landing
#: within about a centimetre of the scripted throw's)
N_BASIS = 30
#: the generalizers by name, with their options: "lwr-gp-affine" is lwr-gp with an affine trend,
#: which extrapolates beyond the demos (plain lwr-gp cannot: docs/throwing.md)
GENERALIZERS: dict[str, dict[str, Any]] = {
    "linear": {"method": "linear"},
    "lwr-gp": {"method": "lwr-gp"},
    "lwr-gp-affine": {"method": "lwr-gp", "trend": "affine"},
}
LEARNER_NAMES = ("auto", "secant", "error", "finite-difference", "broyden", "weighted", "cma", "bo", "bo-default")
#: the learners' settings in m: eq. 17's scale (the demos' landings span about half a metre), the
#: finite-difference probe, Broyden's trust radius and CMA-ES's first step
SETTINGS = LearnerSettings(weight_scale=0.3, probe=0.05, trust_radius=0.5, weighted_jacobian="secant",
                           cma_sigma=0.1)


@functools.lru_cache(maxsize=4)
def demonstrations(n_basis: int = N_BASIS, release: bool = False) -> tuple[tuple[NDArray[np.float64], Trajectory], ...]:
    """((landing point, scripted joint trajectory), ...) for :data:`~dmprs.tasks.arm_throwing.DEMOS`.
    The label is **measured**: where the ball lands when the arm executes the demonstration's DMP
    (``n_basis`` kernels, the DMP every generalizer returns at the demo's own query), noise off.
    With ``release=True`` the trajectory is the scripted throw up to its release
    (:func:`~dmprs.tasks.arm_throwing.release.split`) and its DMP has the release velocity as its
    final velocity; the arm executes it with its braking (:meth:`ArmThrowing.trajectory`).
    Raises if a demonstration does not land.
    """
    if not isinstance(release, bool):
        raise InvalidInputError(f"release = {short(release)} is invalid: use True or False")
    task = ArmThrowing()
    out = []
    with task.adapter as adapter:
        for strength, yaw in DEMOS:
            scripted = throw_trajectory(strength, yaw)
            if release:
                scripted = split(scripted)[0]
            dmp = DMP.fit(scripted.t, scripted.y, n_basis, scripted.yd, scripted.ydd,
                          final_velocity="demo" if release else None)
            adapter.reset(seed=0)
            outcome = adapter.execute(task.trajectory(dmp))
            if not outcome.ok:
                raise DmprsError(f"the demonstration throw (strength {strength}, yaw {yaw} rad) failed: "
                                 f"{outcome.message}")
            label = task.measure(outcome)
            label.setflags(write=False)
            out.append((label, scripted))
    return tuple(out)


def setup(target: ArrayLike = (1.0, 0.0), generalizer: str = "linear", tol: float = SUCCESS_TOLERANCE,
          noise: Noise | None = None, n_basis: int = N_BASIS, max_trials: int = 50, robot: str = "sim",
          domain_id: int | None = None, release: bool = False) -> ExperimentSetup:
    """Throw the ball into a basket at ``target`` = (x, y) m on the floor (docs/throwing.md).

    Five scripted throws labelled with their measured landing points; ``generalizer``:
    ``"linear"`` (piecewise linear on their Delaunay triangulation, affine extrapolation from the
    nearest triangle outside it), ``"lwr-gp"`` or ``"lwr-gp-affine"`` (with an affine trend,
    which extrapolates); DMPs of ``n_basis`` kernels. Learners: ``auto`` (the default: the secant below), ``secant`` (the paper-style choice: error
    learning with Broyden's update of the Jacobian), ``error`` (eq. 16, K = J = I),
    ``finite-difference``, ``broyden``, ``weighted`` (eq. 17), ``cma``. ``tol``: the basket's
    radius (m). ``noise``: a :class:`dmprs.tasks.noise.Noise` (execution in rad, measurement in
    m) for the trials; the demonstrations are measured without it. ``robot``: ``"sim"`` (the
    scene in this process) or ``"ros2"`` (a ROS 2 robot on ``domain_id``, e.g. ``dmprs robot
    serve arm-throwing``, through :func:`dmprs.ros2.served.throwing_adapter`; needs the ``ros2``
    extra); the demonstrations are measured in the scene either way. ``release``: the
    final-velocity throw (docs/throwing.md): the demonstrations up to their release, generalized
    with their release velocities (``Generalizer(..., final_velocity=True)``), each generalized
    DMP executed with its braking movement.
    """
    if not isinstance(generalizer, str) or generalizer not in GENERALIZERS:
        raise InvalidInputError(f"generalizer = {short(generalizer)} is invalid: use one of {tuple(GENERALIZERS)}")
    if not isinstance(release, bool):
        raise InvalidInputError(f"release = {short(release)} is invalid: use True or False")
    n_basis = as_count(n_basis, "n_basis", 2)
    settings = dataclasses.replace(SETTINGS, max_trials=as_count(max_trials, "max_trials", 1))
    task = ArmThrowing(tol, noise=noise)
    domain = ros2_domain(robot, domain_id)
    if domain is not None:
        if noise is not None:
            raise InvalidInputError("noise is the simulated robot's: a ROS 2 robot has its own")
        # the ros2 extra, imported only when asked for: the scene needs none of it
        from dmprs.ros2.served import throwing_adapter

        task.adapter = throwing_adapter(domain)
    options = {"n_basis": n_basis, **GENERALIZERS[generalizer], **({"final_velocity": True} if release else {})}
    return build(task, lambda: demonstrations(n_basis, release), target, generalizer=options,
                 paper_learner="secant", learner_names=LEARNER_NAMES, settings=settings, desired_name="target")
