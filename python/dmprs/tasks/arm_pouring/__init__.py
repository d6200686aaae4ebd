"""The paper's pouring (section 5) on a 7-DOF arm in MuJoCo: a KUKA LBR iiwa 14 (the LWR's
successor) holds a bottle of granular "liquid" and must pour **0.2 l** into a glass, whatever the
bottle holds (:mod:`dmprs.sim.arm_scene`, model in :mod:`dmprs.sim.arm_model`, docs/arm.md).

* :class:`ArmPouringAdapter` executes either a joint-space :class:`~dmprs.Trajectory` (7 DOFs,
  rad) or a :class:`~dmprs.CartesianTrajectory` of the bottle's mouth (such as a ``CartesianDMP``
  rollout), which it turns into joints by damped-least-squares differential IK (:mod:`dmprs.sim.arm_ik`). ``check`` does
  that IK pass dry and lists every reason to refuse: non-finite or non-unit poses, a start away
  from the home pose, unreachable poses, joint position and velocity limits, the arm or bottle
  touching the table or the glass; each names the time. A simulation that diverges becomes an
  ``error`` outcome.
* :class:`ArmPouring` scores it like the 2-D :class:`~dmprs.tasks.pouring.Pouring`: query = the
  (assumed) bottle volume in l, ``eps = V_poured - V*`` (``sign = -1``).
* :func:`pour_poses` is the scripted "kinesthetic" demonstrator: reach over the glass, tilt about
  the mouth, hold, tilt back, as a pose trajectory (:func:`pour_and_return_poses`: and back home,
  the phases overlapping); :func:`calibrate_peak_tilt` finds the peak
  tilt that pours a given volume with the library's Illinois root finder.
"""

from dmprs.tasks.arm_pouring.adapter import (
    CAPACITY,
    CONTROL_PERIOD,
    ArmPouringAdapter,
)
from dmprs.tasks.arm_pouring.calibration import Calibration, calibrate_peak_tilt, poured_volume
from dmprs.tasks.arm_pouring.demonstrator import (
    DEMO_TIMING,
    DEMO_VOLUMES,
    POUR_POSITION,
    demonstration_tangent,
    pour_and_return_cuts,
    pour_and_return_poses,
    pour_poses,
)
from dmprs.tasks.arm_pouring.poses import pose_to_tangent, tangent_to_pose
from dmprs.tasks.arm_pouring.task import SUCCESS_TOLERANCE, ArmPouring
from dmprs.tasks.liquid import PARTICLE_VOLUME, TARGET_VOLUME

__all__ = [
    "CAPACITY",
    "CONTROL_PERIOD",
    "DEMO_TIMING",
    "DEMO_VOLUMES",
    "PARTICLE_VOLUME",
    "POUR_POSITION",
    "SUCCESS_TOLERANCE",
    "TARGET_VOLUME",
    "ArmPouring",
    "ArmPouringAdapter",
    "Calibration",
    "calibrate_peak_tilt",
    "demonstration_tangent",
    "pose_to_tangent",
    "pour_and_return_cuts",
    "pour_and_return_poses",
    "pour_poses",
    "poured_volume",
    "tangent_to_pose",
]
