"""Paddle juggling on the MuJoCo arm, a periodic task learned in query space: the paddle is where
its IK puts it, the ball flies ballistically between bounces and rebounds by the restitution law,
steady bouncing keeps the rhythm's period with the flight time of its apex, runs are
deterministic per seed and differ between seeds, bad queries and trajectories are refused with
reasons, and unseen apexes are learned within the floors, in fewer trials than Bayesian
optimization from the same first trial.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from dmprs import PeriodicDMP
from dmprs.adapters import Status
from dmprs.errors import InvalidInputError
from dmprs.experiments import arm_juggling
from dmprs.loop import learn
from dmprs.sim import juggle_scene as js
from dmprs.sim.paddle_ik import level_paddle_joints
from dmprs.tasks.arm_juggling import REACH, ArmJuggling, ArmJugglingAdapter, rhythm_period
from dmprs.trajectory import Trajectory

G = js.gravity()


def _rhythm(period: float, seed: int = 0) -> tuple[Trajectory, js.JuggleResult, js.Rhythm]:
    """A scripted rhythm's periodic DMP as the task runs it, simulated with ``seed``'s drop."""
    scripted = rhythm_period(period)
    dmp = PeriodicDMP.fit(scripted.t, scripted.y, period, 30, scripted.yd, scripted.ydd)
    traj = ArmJuggling(seed=seed).trajectory(dmp)
    z = js.paddle_heights(traj.y)
    rhythm = js.rhythm_of(traj.t, z)
    assert rhythm is not None
    drop = js.Drop.of_seed(seed)
    result = js.simulate_juggle(traj.t, traj.y, traj.yd, js.plan_release(traj.t, z, rhythm, drop), drop.damping_ratio)
    return traj, result, rhythm


@pytest.fixture(scope="module")
def steady() -> tuple[Trajectory, js.JuggleResult, js.Rhythm]:
    return _rhythm(0.45)


def test_the_paddle_is_level_where_the_closed_form_ik_puts_it() -> None:
    """MuJoCo's forward kinematics of the closed-form joints: the paddle's centre at the asked
    point, its normal (the tool body's z) straight up.
    """
    import mujoco

    m = js.model()
    d = mujoco.MjData(m)
    for x, z in [js.PADDLE_HOME, (0.7, 0.45), (0.85, 0.7)]:
        d.qpos[:7] = level_paddle_joints(x, z)
        mujoco.mj_kinematics(m, d)
        assert d.site_xpos[m.site("mouth").id] == pytest.approx([x, 0.0, z], abs=1e-12)
        assert d.xmat[m.body("bottle").id].reshape(3, 3)[:, 2] == pytest.approx([0, 0, 1], abs=1e-12)
    with pytest.raises(InvalidInputError, match="out of the arm's reach"):
        level_paddle_joints(2.0, 0.5)


def test_a_dropped_ball_rebounds_off_the_held_paddle_by_the_restitution_law() -> None:
    """Dropped from H onto the paddle held at home, the ball meets it at sqrt(2 g H) and leaves at
    e times that, e = exp(-pi zeta / sqrt(1 - zeta^2)) of the contact's damping ratio. Within 0.025: the law is a rigid surface's and a spring-damper's that may pull,
    while the servo's paddle gives a little under the impact and a contact only pushes (so the
    ball leaves before the damper would brake it).
    """
    home = np.array(js.home())
    t = np.linspace(0.0, 1.0, 501)
    q = np.tile(home, (len(t), 1))
    for zeta in (js.DAMPING_RATIO, 0.2):
        r = js.simulate_juggle(t, q, np.zeros_like(q), js.Release(0.0, 0.3), zeta)
        e = js.restitution(zeta)
        v_in = math.sqrt(2 * G * 0.3)
        assert r.takeoff_velocity[0] / v_in == pytest.approx(e, abs=0.025)
    assert js.restitution(js.DAMPING_RATIO) == pytest.approx(0.70, abs=0.005)


def test_the_ball_flies_ballistically_between_bounces(steady) -> None:
    """Each flight's apex is its takeoff height plus v^2 / 2 g (semi-implicit Euler at 0.25 ms
    overshoots by at most v dt / 2, 0.3 mm at these speeds).
    """
    _, r, _ = steady
    assert len(r.apex) >= 10
    closed = r.takeoff_height + r.takeoff_velocity**2 / (2 * G)
    assert np.abs(r.apex - closed).max() < 5e-4


def test_steady_bouncing_keeps_the_rhythm_with_the_flight_time_of_its_apex(steady) -> None:
    """Period-one bouncing: in the steady phase the ball takes off once per period of the commanded
    rhythm; each flight lasts the time to rise to its apex and fall back to where it lands,
    sqrt(2 (h - z_takeoff) / g) + sqrt(2 (h - z_landing) / g); and the period is the law's
    2 sqrt(2 h / g) for the rise h above the impact point, plus the 5 ms of contact.
    """
    _, r, rhythm = steady
    inside = (r.takeoff_time > r.release.time + 5 * rhythm.period) & (r.landing_time <= rhythm.end)
    flight = r.landing_time[inside] - r.takeoff_time[inside]
    up, down = r.apex[inside] - r.takeoff_height[inside], r.apex[inside] - r.landing_height[inside]
    assert inside.sum() >= 6
    assert np.diff(r.takeoff_time[inside]).mean() == pytest.approx(rhythm.period, rel=0.005)
    assert np.sqrt(2 * up / G) + np.sqrt(2 * down / G) == pytest.approx(flight, abs=1e-3)
    assert 2 * np.sqrt(2 * down.mean() / G) == pytest.approx(rhythm.period, rel=0.02)


def test_a_rhythm_starts_and_ends_at_rest_at_home(steady) -> None:
    traj, _, rhythm = steady
    home = np.array(js.home())
    assert traj.y[0] == pytest.approx(home, abs=1e-9) and traj.y[-1] == pytest.approx(home, abs=1e-4)
    assert np.abs(traj.yd[0]).max() < 1e-9 and np.abs(traj.yd[-1]).max() < 1e-3
    assert rhythm.period == pytest.approx(0.45, rel=1e-3)


def test_runs_are_deterministic_per_seed_and_seeds_differ() -> None:
    scripted = rhythm_period(0.4)
    dmp = PeriodicDMP.fit(scripted.t, scripted.y, 0.4, 30, scripted.yd, scripted.ydd)
    outcomes = []
    for seed in (3, 3, 4):
        task = ArmJuggling(seed=seed)
        with task.adapter as adapter:
            outcomes.append(adapter.execute(task.trajectory(dmp)))
    a, b, c = outcomes
    assert a.ok and a.signals == b.signals and np.array_equal(a.executed.y, b.executed.y)
    assert c.ok and c.signals["apex"] != a.signals["apex"]
    assert js.Drop.of_seed(3) != js.Drop.of_seed(4)


def test_a_trajectory_without_a_rhythm_is_aborted_with_the_reason() -> None:
    adapter = ArmJugglingAdapter()
    t = np.linspace(0.0, 1.0, 501)
    with adapter:
        o = adapter.execute(Trajectory(t, np.tile(np.array(js.home()), (len(t), 1))))
    assert o.status is Status.ABORTED and "rhythm" in o.message


@pytest.mark.parametrize("apex", [REACH[0] - 0.01, REACH[1] + 0.01, math.nan])
def test_an_apex_out_of_reach_is_refused_naming_the_range(apex: float) -> None:
    with pytest.raises(InvalidInputError, match="desired"):
        arm_juggling.setup(apex)
    if math.isfinite(apex):
        with pytest.raises(InvalidInputError, match=f"{REACH[0]:g} to {REACH[1]:g} m"):
            ArmJuggling().validate_query(apex)
    with pytest.raises(InvalidInputError, match="q0"):
        ArmJuggling().validate_query(apex, "q0")


def test_the_gymnasium_environment_steps_as_the_task_pipeline_by_hand() -> None:
    """``dmprs/ArmJuggling-v0``: the context is a desired apex between the demos', the action the
    query; a step scores -|eps| of the trial the task would run for that query.
    """
    import gymnasium as gym
    from gymnasium.utils.env_checker import check_env

    import dmprs.envs

    env = gym.make("dmprs/ArmJuggling-v0", ball_seed=2)
    with warnings.catch_warnings():  # the action is the query in m, not normalized: Gymnasium notes it
        warnings.filterwarnings("ignore", message=".*symmetric and normalized space")
        check_env(env.unwrapped, skip_render_check=True)
    scenario = env.unwrapped.scenario
    obs, _ = env.reset(seed=5)
    assert scenario.query_low[0] <= obs[0] <= scenario.query_high[0]
    _, reward, terminated, _, info = env.step(np.array([0.3]))
    task = ArmJuggling(seed=2)
    with task.adapter as adapter:
        outcome = adapter.execute(task.trajectory(scenario.generalizer.predict([0.3])))
    assert terminated and reward == -abs(float(task.error(obs, outcome)[0])) and info["apex"] == outcome.signals["apex"]
    assert "dmprs/ArmJuggling-v0" in dmprs.envs.ENV_IDS


def test_unseen_apexes_are_learned_within_the_floors_and_faster_than_bo() -> None:
    """Over 5 ball seeds at two apexes between the demos': the default learner succeeds (1 cm) in
    a median of at most 3 trials, every run within 8, the first (generalized) trial counted;
    Bayesian optimization from the same first trial (3 seeds, capped at 8) needs more.
    """
    demos = [float(label[0]) for label, _ in arm_juggling.demonstrations()]
    counts: dict[str, list[int]] = {"auto": [], "bo": []}
    for apex, seeds in ((0.22, ()), (0.3, (0, 1, 2))):
        assert min(demos) < apex < max(demos)
        for seed in range(5):
            setup = arm_juggling.setup(apex, ball_seed=seed)
            runs = [("auto", setup.make_learner("auto"))]
            runs += [("bo", setup.make_learner("bo", seed=seed))] if seed in seeds else []
            for name, made in runs:
                r = learn(setup.task, setup.generalizer, setup.desired_query, made, max_trials=8)
                counts[name].append(r.trials_to_success if r.converged else 9)
    assert np.median(counts["auto"]) <= 3 and max(counts["auto"]) <= 8
    assert np.median(counts["bo"]) > np.median(counts["auto"][5:])
