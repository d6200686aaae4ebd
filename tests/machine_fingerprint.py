"""The bits of what feeds the chaotic simulators and the learners' branches, hashed: a short pour
on the arm, a 2-D pour, the GP and triangulated generalizers. Run as
``python -m tests.machine_fingerprint``; prints one ``name sha256`` line per part.
``tests/test_machine_independence.py`` runs it under every BLAS kernel and numpy dispatch level
this machine can execute and asks for identical lines.
"""

import hashlib
import json

import numpy as np

import dmprs
from dmprs.tasks.arm_pouring import ArmPouringAdapter, pour_poses
from dmprs.tasks.pouring import PouringAdapter
from dmprs.tasks.pouring.profile import tilt_profile
from tests.test_generalize import database


def _digest(*arrays: object) -> str:
    h = hashlib.sha256()
    for a in arrays:
        h.update(np.ascontiguousarray(np.asarray(a, dtype=np.float64)).tobytes())
    return h.hexdigest()[:16]


def arm_pour() -> str:
    with ArmPouringAdapter(0.12, hold=0.3) as adapter:
        adapter.reset(seed=0)
        out = adapter.execute(pour_poses(2.3))
    return _digest(out.executed.y, out.signals["poured_volume_curve"], out.signals["poured_particles"])


def pour_2d() -> str:
    with PouringAdapter(0.5, liquid_seed=0) as adapter:
        adapter.reset(seed=0)
        out = adapter.execute(tilt_profile(1.6))
    return _digest(out.executed.y, out.signals["poured_volume"])


def generalizers() -> str:
    rng = np.random.default_rng(3)
    q2 = rng.uniform(0.0, 1.0, (12, 2))
    gp = dmprs.Generalizer(database([[q] for q in np.linspace(0, 1, 7)]), "lwr-gp", n_basis=10)
    tri = dmprs.Generalizer(database(list(q2)), "linear", n_basis=10)
    return _digest(gp.parameters([0.37]), gp.parameters([1.3]), tri.parameters([0.41, 0.52]),
                   tri.parameters([1.2, -0.3]))


PARTS = {"arm_pour": arm_pour, "pour_2d": pour_2d, "generalizers": generalizers}

if __name__ == "__main__":
    print(json.dumps({name: part() for name, part in PARTS.items()}))
