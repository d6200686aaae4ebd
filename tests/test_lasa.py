"""Real human demonstrations: all 210 of the LASA handwriting data set, fitted and reproduced by
``DMP.fit``, and the closed-form response of the DMP to a change of goal or start.
"""

from __future__ import annotations

import numpy as np
import pytest

import dmprs
from dmprs.io.lasa import lasa_demos, lasa_shapes

N_BASIS = 50
#: reproduction RMS (Euclidean, mm) every demonstration stays within, and the median's bound;
#: the shapes span a few tens of mm (measured: max 1.42 mm, WShape #2, which starts at its peak
#: speed while a DMP starts at rest; median 0.024 mm)
MAX_RMS_MM, MEDIAN_RMS_MM = 2.0, 0.05


@pytest.fixture(scope="module")
def demos():
    return lasa_demos()


def reproduction_rms(dmp, traj) -> float:
    dt = float(np.median(np.diff(traj.t))) / 4
    out = dmp.rollout(dt=dt, duration=traj.duration)
    y = np.stack([np.interp(traj.t, out.t, out.y[:, k]) for k in range(traj.n_dof)], axis=1)
    return float(np.sqrt(np.mean(np.sum((y - traj.y) ** 2, axis=1))))


def test_the_data_set_is_all_there(demos):
    assert len(lasa_shapes()) == 30 and len(demos) == 210
    assert all(d.trajectory.n_samples == 1000 and d.trajectory.n_dof == 2 for d in demos)
    np.testing.assert_allclose([d.trajectory.y[-1] for d in demos], 0.0, atol=1e-9)  # all end at the origin


def test_every_demonstration_is_reproduced(demos):
    errors = np.array([reproduction_rms(dmprs.DMP.fit(d.trajectory.t, d.trajectory.y, N_BASIS), d.trajectory)
                       for d in demos])
    worst = demos[int(np.argmax(errors))]
    assert errors.max() < MAX_RMS_MM, f"{worst.shape} #{worst.index}: {errors.max():.3f} mm"
    assert np.median(errors) < MEDIAN_RMS_MM


def closed_form(t, tau, alpha_z):
    """With beta_z = alpha_z / 4 the DMP (eqs. 1-2) is a critically damped spring with
    omega = alpha_z / (2 tau), driven by a forcing term that does not depend on y, g or y0; so
    moving the goal by dg moves the path by dg (1 - (1 + w t) e^{-w t}) and moving the start by
    dy0 moves it by dy0 (1 + w t) e^{-w t}.
    """
    w = alpha_z / (2 * tau)
    decay = (1 + w * t) * np.exp(-w * t)
    return 1 - decay, decay


@pytest.mark.parametrize("shape_index", range(0, 30, 3))
def test_goal_and_start_changes_follow_the_closed_form(demos, shape_index):
    d = demos[7 * shape_index]
    dmp = dmprs.DMP.fit(d.trajectory.t, d.trajectory.y, N_BASIS)
    dt = dmp.tau / 20000
    base = dmp.rollout(dt=dt, duration=2 * dmp.tau)
    dg, dy0 = np.array([15.0, -10.0]), np.array([-8.0, 5.0])
    goal = dmp.with_goal(dmp.goal + dg).rollout(dt=dt, duration=2 * dmp.tau)
    start = dmp.with_start(dmp.start + dy0).rollout(dt=dt, duration=2 * dmp.tau)
    to_goal, from_start = closed_form(base.t, dmp.tau, dmp.alpha_z)
    # explicit Euler at tau / 20000: the discrete response is within 0.1 % of the closed form
    np.testing.assert_allclose(goal.y - base.y, np.outer(to_goal, dg), atol=1e-3 * np.abs(dg).max())
    np.testing.assert_allclose(start.y - base.y, np.outer(from_start, dy0), atol=1e-3 * np.abs(dy0).max())
    # it comes to rest at the new goal (within rest_tol = 0.01 mm)
    rest = dmp.with_goal(dmp.goal + dg).rollout(dt=1e-3, until_rest=True, rest_tol=0.01)
    np.testing.assert_allclose(rest.y[-1], dmp.goal + dg, atol=0.01)
    np.testing.assert_array_equal(start.y[0], dmp.start + dy0)
