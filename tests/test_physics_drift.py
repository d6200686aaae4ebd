"""Drift of the arm's physics: one short pour against a stored reference.

The arm's reported numbers (the README's and docs/arm.md's tables) rest on MuJoCo and numpy at the
versions the ``robot`` extra pins. Granular flow is chaotic, so a float-level change anywhere (a new
MuJoCo, the model, the IK) changes which spheres reach the glass; this test makes such a change a
failing test that says what moved instead of silently different tables. What the CPU chooses (the
BLAS kernel, numpy's SIMD level) must change nothing (dmprs.portable;
tests/test_machine_independence.py), so the reference holds on every machine of the project's kind.

After a deliberate change, re-measure the reproduction, then rewrite the reference with
``python -m tests.test_physics_drift``.
"""

import json
import platform
import sys
from pathlib import Path

import mujoco
import numpy as np

from dmprs.tasks.arm_pouring import ArmPouringAdapter, pour_poses

REFERENCE = Path(__file__).parent / "data" / "arm_pour_reference.json"
#: the pour: 60 spheres of a 0.12 l bottle, tilted to 2.3 rad, held 0.3 s (a few seconds of CPU)
BOTTLE, PEAK_TILT, HOLD = 0.12, 2.3, 0.3
COUNTS = ("poured_particles", "remaining_particles", "spilled_particles")


def measure() -> dict:
    """The pour's particle counts, its poured-volume curve and the arm's final joint state."""
    with ArmPouringAdapter(BOTTLE, hold=HOLD) as adapter:
        adapter.reset(seed=0)
        out = adapter.execute(pour_poses(PEAK_TILT))
    assert out.ok, out.message
    return {"versions": {"mujoco": mujoco.__version__, "numpy": np.__version__, "machine": platform.machine()},
            "counts": {k: int(out.signals[k]) for k in COUNTS},
            "poured_curve_ml": [round(1000 * v) for v in out.signals["poured_volume_curve"]],
            "final_joints": out.executed.y[-1].tolist()}


def test_a_short_pour_matches_the_reference():
    ref = json.loads(REFERENCE.read_text())
    now = measure()
    versions = ", ".join(f"{k} {now['versions'][k]} (reference: {v})" for k, v in ref["versions"].items())
    why = (f"the arm's physics changed ({versions}): the arm's numbers in the README and docs/arm.md were "
           f"measured with the reference's versions; re-measure them (dmprs reproduce --update-docs) and "
           f"rewrite {REFERENCE.name} (python -m tests.test_physics_drift)")
    assert now["counts"] == ref["counts"], f"{why}; sphere counts {now['counts']} != {ref['counts']}"
    assert now["poured_curve_ml"] == ref["poured_curve_ml"], f"{why}; the poured volume over time differs"
    # the servo holds the last pose: a joint state off by more than rounding is a different motion
    np.testing.assert_allclose(now["final_joints"], ref["final_joints"], rtol=0, atol=1e-9, err_msg=why)


if __name__ == "__main__":
    REFERENCE.parent.mkdir(exist_ok=True)
    REFERENCE.write_text(json.dumps(measure(), indent=1) + "\n")
    print(f"wrote {REFERENCE}", file=sys.stderr)
