"""What the steppers command a robot, whatever the options: copies that step as the original
(docs/method.md §2.5).
"""

from __future__ import annotations

import copy

import numpy as np
import pytest

import dmprs
from dmprs import _core
from tests.test_stepper import pose_reach, reach


def bits(arrays) -> list[bytes]:
    return [np.asarray(a).tobytes() for a in arrays]


# --- copies ------------------------------------------------------------------------------------


def _busy_joint():
    s = reach().stepper(0.001, velocity_max=2.0, acceleration_max=30.0)
    for k in range(150):
        s.step(s.output[0] - (0.01 if 50 <= k < 80 else 0.0))
    s.set_goal(reach().goal + 0.2)
    return s


def _busy_cartesian():
    s = pose_reach().stepper(0.001, obstacles=[[0.2, 0.05, 0.03, 0.02]], position_min=-1.0, position_max=1.0)
    for _ in range(150):
        s.step(s.output[0])
    return s


@pytest.mark.parametrize("make", [_busy_joint, _busy_cartesian])
@pytest.mark.parametrize("how", [copy.copy, copy.deepcopy])
def test_a_copy_is_an_independent_stepper_that_steps_as_the_original(make, how) -> None:
    original = make()
    twin = how(original)
    assert type(twin) is type(original)
    assert twin is not original and twin.output[0] is not original.output[0]
    assert bits(twin.output) == bits(original.output)
    assert (twin.steps, twin.phase, twin.tau) == (original.steps, original.phase, original.tau)
    # The copy moves on alone: the original is untouched by it ...
    reference = make()
    for _ in range(300):
        twin.step()
    assert bits(original.output) == bits(reference.output)
    # ... and from equal states the two step bit for bit alike.
    twin = how(original)
    for k in range(500):
        measured = original.output[0].copy()
        assert bits(original.step(measured)) == bits(twin.step(measured)), k


def test_the_core_classes_and_containers_copy_too() -> None:
    core = _core.Stepper.__new__(_core.Stepper, _busy_joint())
    assert type(core) is _core.Stepper
    assert bits(copy.deepcopy(core).step()) == bits(core.step())
    held = {"stepper": _busy_cartesian()}
    twin = copy.deepcopy(held)
    assert type(twin["stepper"]) is dmprs.stepper.CartesianStepper
    assert bits(twin["stepper"].step()) == bits(held["stepper"].step())
    with pytest.raises(dmprs.InvalidInputError):
        _core.Stepper.__new__(_core.Stepper, _busy_joint(), 0.001)
