"""Pouring (the paper's second experiment, section 5) in a 2-D particle simulation.

The robot tilts a bottle about its mouth and must pour **0.2 l** into a glass, whatever the
bottle holds. The query is the bottle's volume (l). Two scripted demonstrations pour 0.2 l from
bottles of 0.3 l and 1.0 l (docs/method.md §9.1); the learner then searches for the *assumed* volume
whose generalized movement pours 0.2 l from the real bottle.

* :class:`PouringAdapter` runs the pymunk scene of :mod:`dmprs.sim.pouring_scene` (:mod:`.adapter`) (one DOF: the
  tilt in rad, positive toward the glass, from and back to 0). Outcome signals are in SI: litres,
  seconds, radians.
* :class:`Pouring` scores it: ``measure`` = poured volume, ``target`` = 0.2 l for every query,
  ``sign = -1``, so ``eps = V_poured - V*`` (docs/method.md §5.3, §9.2): poured too much means eps > 0,
  so the assumed volume must increase, which tilts less. Success is ``|eps| < 0.010 l``.
* :func:`demonstration` is the scripted demonstrator: a minimum-jerk up (1 s), hold (1 s),
  down (1 s) tilt profile whose peak is found by a bracketed Illinois (regula falsi) search so it
  pours 0.2 l. Calibrations are computed, never shipped; they are cached per process and,
  with ``cache_dir`` (or the ``DMPRS_CACHE_DIR`` environment variable), on disk.

Seeds: the liquid (the disc radii, hence the settled packing) is drawn from ``liquid_seed``. By
default ``reset(seed)`` does **not** change it: the simulator is then deterministic and every
trial pours from the same liquid, as a real robot pours the same kind of liquid each time (the
paper's 10 ml tolerance assumes this, docs/method.md §9.2). With ``reseed_liquid=True``,
``reset(seed)`` draws a new liquid from ``seed``, which models trial-to-trial variation (the
same movement poured 212-226 ml from 0.5 l and 188-216 ml from 1.0 l over liquid seeds 0-3);
use a tolerance of 15-20 ml then.
"""

from dmprs.tasks.liquid import PARTICLE_VOLUME, TARGET_VOLUME
from dmprs.tasks.pouring.adapter import (
    CAPACITY,
    CONTROL_PERIOD,
    END_TOLERANCE,
    MAX_DURATION,
    MAX_TILT,
    MAX_TILT_ACCELERATION,
    MAX_TILT_RATE,
    MIN_TILT,
    SUCCESS_TOLERANCE,
    PouringAdapter,
    n_particles,
)
from dmprs.tasks.pouring.calibration import Calibration, calibrate_peak_tilt
from dmprs.tasks.pouring.demonstrator import DEMO_VOLUMES, demonstration, demonstration_dmp
from dmprs.tasks.pouring.profile import DEMO_TIMING, tilt_profile
from dmprs.tasks.pouring.task import Pouring

__all__ = [
    "CAPACITY",
    "CONTROL_PERIOD",
    "DEMO_TIMING",
    "DEMO_VOLUMES",
    "END_TOLERANCE",
    "MAX_DURATION",
    "MAX_TILT",
    "MAX_TILT_ACCELERATION",
    "MAX_TILT_RATE",
    "MIN_TILT",
    "PARTICLE_VOLUME",
    "SUCCESS_TOLERANCE",
    "TARGET_VOLUME",
    "Calibration",
    "Pouring",
    "PouringAdapter",
    "calibrate_peak_tilt",
    "demonstration",
    "demonstration_dmp",
    "n_particles",
    "tilt_profile",
]
