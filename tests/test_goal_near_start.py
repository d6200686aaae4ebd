"""A goal at or near the start: the DMP's forcing term carries no (g - y0) factor (docs/method.md
§2.7), so moving the goal adds the spring's step response to the demonstrated shape, whatever
the goal's distance from the start: nothing mirrors, nothing explodes, a goal equal to the start
keeps the demonstration's shape.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import dmprs

DT = 0.001


def demo(end: float) -> tuple[np.ndarray, np.ndarray]:
    """A one-second reach from 0 to ``end`` with a bump on the way."""
    t = np.arange(0.0, 1.0 + DT / 2, DT)
    s = t / t[-1]
    return t, end * (10 * s**3 - 15 * s**4 + 6 * s**5) + 0.3 * np.sin(np.pi * s) ** 2


def step_response(dmp: dmprs.DMP, shift: float, n: int, dt: float = DT) -> np.ndarray:
    """What moving the goal by ``shift`` adds to the rollout: the explicit-Euler recursion of the
    spring alone (eqs. 1-2 without f), iterated here independently of the core.
    """
    alpha, beta, h = dmp.alpha_z, dmp.beta_z, dt / dmp.tau
    dy, dz, out = 0.0, 0.0, np.empty(n)
    for k in range(n):
        out[k] = dy
        dy, dz = dy + h * dz, dz + h * alpha * (beta * (shift - dy) - dz)
    return out


@pytest.mark.parametrize("end", [1.0, 1e-3, 0.0])
@pytest.mark.parametrize("goal", [0.0, 1e-6, -0.5])
def test_a_goal_at_or_near_the_start_adds_the_springs_step_response_to_the_shape(end: float, goal: float) -> None:
    # demos ending far from, near and at their start; goals at, next to and behind the start:
    # the rollout is the demonstration's plus the spring's response to the goal's shift, so the
    # demonstrated bump is kept, neither mirrored nor scaled by (g - y0) / (g_demo - y0_demo)
    t, y = demo(end)
    dmp = dmprs.DMP.fit(t, y, 30)
    base = dmp.rollout(DT, duration=2.0).y[:, 0]
    moved = dmp.with_goal([goal]).rollout(DT, duration=2.0).y[:, 0]
    assert np.isfinite(moved).all()
    shift = goal - float(dmp.goal[0])
    np.testing.assert_allclose(moved - base, step_response(dmp, shift, len(base)), rtol=0, atol=1e-12)
    # a goal equal to the start still moves: the demonstrated bump, about 0.3 high
    if goal == 0.0:
        assert np.ptp(moved) > 0.25


def test_the_step_response_converges_to_the_critically_damped_closed_form() -> None:
    # y(t) = shift (1 - (1 + a) e^-a), a = alpha_z t / (2 tau): explicit Euler's error halves
    # with dt
    t, y = demo(1.0)
    dmp = dmprs.DMP.fit(t, y, 30)
    errors = []
    for dt in (2e-3, 1e-3, 5e-4):
        tt = np.arange(round(1.0 / dt) + 1) * dt
        a = dmp.alpha_z * tt / (2 * dmp.tau)
        closed = -(1 - (1 + a) * np.exp(-a))
        errors.append(np.abs(step_response(dmp, -1.0, len(tt), dt) - closed).max())
    assert errors[0] / errors[1] == pytest.approx(2.0, rel=0.1)
    assert errors[1] / errors[2] == pytest.approx(2.0, rel=0.1)


def test_the_readmes_goal_near_start_example_runs_and_does_what_it_says() -> None:
    readme = (Path(__file__).resolve().parents[1] / "README.md").read_text()
    block = readme.split("A goal at or near the start never", 1)[1].split("```python\n", 1)[1].split("```", 1)[0]
    scope: dict = {"np": np, "dmprs": dmprs}
    exec(block, scope)  # noqa: S102 - the README's own code
    tr = scope["tr"]
    assert np.isfinite(tr.y).all()
    assert tr.y[:, 0].max() == pytest.approx(0.3, abs=0.01) and abs(tr.y[-1, 0]) < 0.01
