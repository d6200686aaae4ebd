"""The paper's pouring (section 5.2) on the 7-DOF arm in MuJoCo (docs/arm.md): pour 0.2 l from a
bottle of unknown volume, learned in the query space from two demonstrations.

Two scripted "kinesthetic" demonstrations (:func:`dmprs.tasks.arm_pouring.pour_poses`: reach over
the glass, tilt about the mouth, hold, tilt back) are calibrated with the library's Illinois root
finder to pour 0.2 l from bottles of 0.3 l and 1.0 l, each encoded as a :class:`~dmprs.CartesianDMP`,
generalized linearly in the bottle volume (slerp for orientations), and the assumed volume is
learned by golden section (the paper's choice) or the root finder. Needs the ``robot`` extra.
"""

from __future__ import annotations

import functools
import os
import sys
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from dmprs._arrays import as_count, short
from dmprs.errors import DmprsError, InvalidInputError, NumericalError
from dmprs.experiments.base import SCALAR_LEARNERS, ExperimentSetup, LearnerSettings, build, ros2_domain
from dmprs.sim import arm_render, arm_scene
from dmprs.tasks.arm_pouring import (
    DEMO_VOLUMES,
    SUCCESS_TOLERANCE,
    TARGET_VOLUME,
    ArmPouring,
    ArmPouringAdapter,
    Calibration,
    calibrate_peak_tilt,
    pour_poses,
)
from dmprs.trajectory import CartesianTrajectory

#: rad: the calibration's bracket of peak tilts (1.4 rad pours nothing from 0.3 l, 2.7 rad
#: nearly everything from 1.0 l)
DEMO_BRACKET = (1.4, 2.7)
#: the DMPs' kernels (docs/method.md §9.3, as in 2-D)
N_BASIS = 40
#: the trial cap the reproduction learns the arm's pour with (each trial is seconds of granular flow)
MAX_TRIALS = 6
#: l: eq. 17's scale and the step scale of the policy gradient and Broyden, as in 2-D
SCALE = 0.05


@functools.lru_cache(maxsize=4)
def demonstrations(target_volume: float = TARGET_VOLUME, liquid_seed: int = 0, cache_dir: str | None = None,
                   ) -> tuple[tuple[NDArray[np.float64], CartesianTrajectory, Calibration], ...]:
    """The calibrated demonstrations: ((query, pose trajectory, calibration), ...) for the
    bottles of :data:`~dmprs.tasks.arm_pouring.DEMO_VOLUMES` (calibrations cached on disk in
    ``cache_dir`` or ``$DMPRS_CACHE_DIR`` when given).
    """
    return tuple(demonstration(volume, target_volume, liquid_seed, cache_dir) for volume in DEMO_VOLUMES)


def demonstration(bottle_volume: float, target_volume: float = TARGET_VOLUME, liquid_seed: int = 0,
                  cache_dir: str | None = None) -> tuple[NDArray[np.float64], CartesianTrajectory, Calibration]:
    """One calibrated demonstration of :func:`demonstrations`: (query, pose trajectory, calibration)."""
    cal = calibrate_peak_tilt(bottle_volume, target_volume, liquid_seed=liquid_seed, bracket=DEMO_BRACKET,
                              cache_dir=cache_dir)
    return np.array([cal.bottle_volume]), pour_poses(cal.peak_tilt), cal


def setup(bottle_volume: float = 0.5, target_volume: float = TARGET_VOLUME, tol: float = SUCCESS_TOLERANCE,
          liquid_seed: int = 0, demo_seed: int = 0, reseed_liquid: bool = False,
          cache_dir: str | os.PathLike[str] | None = None, robot: str = "sim", domain_id: int | None = None,
          ) -> ExperimentSetup:
    """Pour ``target_volume`` with the arm from a bottle holding ``bottle_volume`` l: the two
    calibrated pose demonstrations generalized linearly as :class:`~dmprs.CartesianDMP` s with
    N = 40 kernels (weights, tau and positions linear in the volume, the orientations by slerp),
    the desired query = the true volume; learners ``golden`` (default, paper mode, bracket
    [0.3, 1.0] l), ``root`` (Illinois) and the other scalar query learners. ``robot``: ``"sim"``
    (the scene in this process) or ``"ros2"`` (a ROS 2 robot on ``domain_id`` holding that bottle,
    e.g. ``dmprs robot serve arm-pouring --volume 0.5``, through
    :func:`dmprs.ros2.served.pouring_adapter`; needs the ``ros2`` extra); the demonstrations are
    calibrated in the scene either way.
    """
    task = ArmPouring(bottle_volume, target_volume=target_volume, tol=tol, liquid_seed=liquid_seed,
                      reseed_liquid=reseed_liquid)
    domain = ros2_domain(robot, domain_id)
    if domain is not None:
        if liquid_seed != 0 or reseed_liquid:
            raise InvalidInputError("the liquid is the robot's: give liquid_seed to `dmprs robot serve`")
        # the ros2 extra, imported only when asked for: the scene needs none of it
        from dmprs.ros2.served import pouring_adapter

        task.adapter = pouring_adapter(domain)
    seed = as_count(demo_seed, "demo_seed", 0)
    if cache_dir is not None and not isinstance(cache_dir, (str, os.PathLike)):
        raise InvalidInputError(f"cache_dir = {short(cache_dir)} must be a folder's path or None")
    cache = None if cache_dir is None else str(cache_dir)
    def demos() -> list[tuple[NDArray[np.float64], CartesianTrajectory]]:
        return [(q, tr) for q, tr, _ in demonstrations(task.target_volume, seed, cache)]

    settings = LearnerSettings(low=min(DEMO_VOLUMES), high=max(DEMO_VOLUMES), weight_scale=SCALE, task_scale=SCALE)
    return build(task, demos, bottle_volume, generalizer={"method": "linear", "n_basis": N_BASIS},
                 paper_learner="golden", learner_names=SCALAR_LEARNERS, settings=settings,
                 desired_name="bottle_volume")


def noise_floor(bottle_volume: float = 0.6, offsets: tuple[float, ...] = (-0.01, -0.005, 0.0, 0.005, 0.01),
                liquid_seeds: tuple[int, ...] = (0,)) -> list[dict[str, float]]:
    """Poured volume of the generalized movement at queries ``bottle_volume + offset`` (l), for
    each liquid seed: the granular outcome's response to a small change of the query, whose
    scatter about a straight line is the noise floor the success tolerance must exceed.
    """
    rows = []
    for seed in liquid_seeds:
        experiment = setup(bottle_volume, liquid_seed=seed, reseed_liquid=False)
        task = experiment.task
        with task.adapter as adapter:
            for off in offsets:
                q = experiment.desired_query + off
                adapter.reset(seed=seed)
                out = adapter.execute(task.trajectory(experiment.generalizer.predict(q)))
                if not out.ok:
                    raise NumericalError(
                        f"noise-floor trial at q = {q[0]:.4f} l was {out.status.value}: {out.message}")
                rows.append({"liquid_seed": seed, "query": float(q[0]),
                             "poured_volume": float(out.signals["poured_volume"])})
    return rows


def frame_strip(out: str | Path, bottle_volume: float = 0.6, learner_query: float | None = None) -> Path | None:
    """A frame strip ``out/arm_pouring_strip.png`` of the generalized pour for ``bottle_volume``
    (at the assumed volume ``learner_query``, default the true one) through MuJoCo's offscreen
    renderer; None, with a one-line note on stderr, where no OpenGL backend is available (set
    ``MUJOCO_GL=egl`` or ``osmesa``).
    """
    experiment = setup(bottle_volume)
    q = experiment.desired_query if learner_query is None else np.array([learner_query])
    task, scene = experiment.task, experiment.task.adapter
    assert isinstance(task, ArmPouring) and isinstance(scene, ArmPouringAdapter)
    joints, _, _, problems = scene.plan(task.trajectory(experiment.generalizer.predict(q)))
    if problems or joints is None or joints.yd is None:
        raise DmprsError(f"the pour to render was refused: {'; '.join(problems)}")
    liquid = arm_scene.settled_liquid(scene.n_particles, scene.liquid.liquid_seed)
    try:
        return arm_render.frame_strip(joints.t, joints.y, joints.yd, liquid,
                                      (0.0, 0.5, 1.4, 2.2, 2.8, 3.6, 4.6), Path(out) / "arm_pouring_strip.png")
    except DmprsError as exc:
        print(f"arm pouring: no frame strip ({exc})", file=sys.stderr)
        return None
