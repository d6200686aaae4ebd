"""The "learning gets faster as the database grows" reproduction part: its plan, floors, table and
figure (the runs themselves are the reproduction's job, minutes of pouring), and the pouring
task's sub-stepped rollout it uses.
"""

import pickle

import numpy as np

from dmprs.dmp import DMP
from dmprs.reproduce import growing as G
from dmprs.tasks.pouring import Pouring, tilt_profile


def sequence(gen, trials, first_errors, seed=0):
    runs = [{"volume": 0.3 + 0.05 * k, "n_demos": 2 + k, "converged": True, "trials_to_success": t,
             "n_trials": t, "first_error_ml": e, "first_success": abs(e) < 10, "stop_reason": ""}
            for k, (t, e) in enumerate(zip(trials, first_errors, strict=True))]
    return {"kind": "growing", "generalizer": gen, "order_seed": seed, "learner": "secant", "max_trials": 12,
            "options": {}, "runs": runs}


def test_plan_has_5_orders_of_12_volumes_per_generalizer_and_pickles():
    specs = G.plan_growing()
    assert {s.generalizer for s in specs} == {"linear", "lwr-gp"}
    assert all(len(s.volumes) >= 12 for s in specs) and len({s.order_seed for s in specs}) >= 5
    assert all(0.3 < v < 1.0 for v in G.VOLUMES)
    assert pickle.loads(pickle.dumps(specs)) == specs
    assert len(G.plan_growing(quick=True)) == 1


def test_floors_and_table():
    a = sequence("linear", [4, 3, 3, 2, 1, 2, 1, 1, 1, 1, 2, 1], [40, 30, 20, 12, 5, 11, 3, 2, 8, 1, 12, 4])
    fl = G.floors(a)
    assert fl["first_third"] == 3.0 and fl["last_third"] == 1.25
    assert fl["first_success_8plus"] == (5, 6)  # n_demos >= 8 from the 7th volume on
    rows = G.summarize_growing([a, sequence("linear", [5] * 12, [50] * 12, seed=1)])
    floors = [r for r in rows if r["n_demos"] == "floors"]
    assert len(floors) == 1 and floors[0]["runs"] == 2
    assert floors[0]["first_third_mean_trials"] == (3.0 + 5.0) / 2
    assert not floors[0]["floor_halving"] and floors[0]["first_success_8plus"] == "5/12"
    at2 = next(r for r in rows if r["n_demos"] == 2)
    assert at2["mean_trials"] == 4.5 and at2["mean_first_error_ml"] == 45.0
    assert "| linear | 2 | 2 | 4.50 | 45.0 | 0 % |" in G.markdown_growing(rows)


def test_a_volume_never_learned_counts_beyond_the_cap():
    a = sequence("linear", [None] + [1] * 11, [40] + [1] * 11)
    assert G.floors(a)["first_third"] == (13 + 3) / 4


def test_figure(tmp_path):
    path = G.figure_growing([sequence("linear", [3, 2, 1] * 4, [30, 10, 2] * 4),
                             sequence("lwr-gp", [4, 2, 2] * 4, [40, 12, 6] * 4)], tmp_path)
    assert path.is_file() and path.stat().st_size > 10_000


def test_pouring_substeps_integrate_finer_and_command_at_the_control_period():
    traj = tilt_profile(1.6)
    dmp = DMP.fit(traj.t, traj.y, n_basis=40, yd=traj.yd, ydd=traj.ydd)
    plain = Pouring(0.5).trajectory(dmp)
    assert plain == dmp.rollout(dt=0.005)  # the default is the plain rollout, bit for bit
    fine = Pouring(0.5, rollout_substeps=25).trajectory(dmp)
    ref = dmp.rollout(dt=0.005 / 25)
    np.testing.assert_allclose(fine.t, plain.t, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(fine.y, ref.y[::25])
    # Euler at 0.2 ms is ~25 x closer to the DMP's solution than at 5 ms: the refit of a stored
    # success drifts accordingly (docs/growing.md)
    def drift(tr, k):
        refit = DMP.fit(tr.t, tr.y, n_basis=40, yd=tr.yd, ydd=tr.ydd)
        return np.abs(Pouring(0.5, rollout_substeps=k).trajectory(refit).y - tr.y).max()
    assert drift(fine, 25) < 0.1 * drift(plain, 1)
