"""The arm-pouring adapter and task: tracking, conservation, determinism, a short pour, and every
kind of bad trajectory refused with a clear message. Small bottles (5-60 spheres) keep the module
to seconds; the settled liquids are cached per process by the code under test.
"""

import math

import numpy as np
import pytest

from dmprs.adapters import Status, check_adapter, load_adapter
from dmprs.sim import arm_model as am
from dmprs.sim import arm_scene
from dmprs.tasks.arm_pouring import ArmPouring, ArmPouringAdapter, pour_poses
from dmprs.trajectory import CartesianTrajectory, Trajectory

SMALL = 0.01  # l: 5 spheres, for tests about the arm alone


def min_jerk(s):
    s = np.clip(s, 0, 1)
    return 10 * s**3 - 15 * s**4 + 6 * s**5


#: directions of a move of every joint that keeps the bottle above the table (A2 leans back)
UP = np.array([1, -1, 1, 1, 1, 1, 1])


def joint_move(amplitude, duration=1.0, dt=0.002, joints=range(7)):
    """From home to home + amplitude on ``joints`` (in the directions UP) and back, min-jerk,
    with exact velocities.
    """
    home = arm_scene.home_configuration()
    t = np.arange(0, 2 * duration + dt / 2, dt)
    s = min_jerk(t / duration) - min_jerk((t - duration) / duration)
    sd = np.gradient(s, t)
    delta = np.zeros(7)
    delta[list(joints)] = amplitude * UP[list(joints)]
    return Trajectory(t, home + s[:, None] * delta, sd[:, None] * delta)


def execute(adapter, trajectory):
    with adapter:
        adapter.reset(seed=0)
        return adapter.execute(trajectory)


def test_the_arm_tracks_a_joint_trajectory():
    # Every joint moves 0.2 rad out and back in 2 s (up to 0.37 rad/s): the PD with gravity
    # compensation tracks it within 5 mrad on every joint at every 1 ms step.
    out = execute(ArmPouringAdapter(SMALL), joint_move(0.2))
    assert out.ok, out.message
    assert out.signals["tracking_error"] < 5e-3
    np.testing.assert_allclose(out.executed.y, joint_move(0.2).y, atol=5e-3)
    assert out.signals["ik_position_error"] == 0.0


def test_a_short_pour_conserves_the_liquid():
    adapter = ArmPouringAdapter(0.12, hold=0.3)  # 60 spheres
    out = execute(adapter, pour_poses(2.3))
    assert out.ok, out.message
    s = out.signals
    assert s["particles"] == 60
    assert s["poured_particles"] + s["remaining_particles"] + s["spilled_particles"] == 60
    assert s["poured_particles"] > 0  # a 2.3 rad tilt pours
    assert s["poured_volume"] == pytest.approx(s["poured_particles"] * 0.002)
    assert s["max_tilt"] == pytest.approx(2.3, abs=0.01)
    assert s["ik_position_error"] < 1e-3
    curve = s["poured_volume_curve"]
    assert curve[0] == 0 and curve[-1] == pytest.approx(s["poured_volume"])
    assert len(curve) == len(s["poured_volume_time"])


def test_nothing_leaves_a_bottle_that_stays_upright():
    out = execute(ArmPouringAdapter(0.06), joint_move(0.1))
    assert out.ok, out.message
    assert out.signals["remaining_particles"] == 30
    assert out.signals["poured_particles"] == out.signals["spilled_particles"] == 0


def test_same_trial_twice_is_bit_identical():
    adapter = ArmPouringAdapter(0.06, hold=0.2)
    trajectory = pour_poses(2.2)
    a, b = execute(adapter, trajectory), execute(adapter, trajectory)
    assert a.ok and b.ok
    assert np.array_equal(a.executed.y, b.executed.y)
    for k in a.signals:
        assert np.array_equal(np.asarray(a.signals[k]), np.asarray(b.signals[k])), k


def test_conformance():
    passed = check_adapter(ArmPouringAdapter(SMALL), joint_move(0.05, duration=0.3))
    assert "execute returns the declared signals" in passed


def test_registered_by_name():
    assert isinstance(load_adapter("arm-pouring", bottle_volume=SMALL), ArmPouringAdapter)


# --- bad trajectories: one test per case -----------------------------------------------------

def rejected(trajectory, volume=SMALL):
    out = execute(ArmPouringAdapter(volume), trajectory)
    assert out.status is Status.REJECTED
    return out.message


def test_rejects_nan_in_a_joint_trajectory():
    good = joint_move(0.1)
    y = good.y.copy()
    y[100, 3] = np.nan
    msg = rejected(Trajectory._trusted(good.t.copy(), y, None, None))
    assert "y[100, 3] (a4) is not finite" in msg


def test_rejects_nan_in_a_pose_trajectory():
    good = pour_poses(2.0)
    pose = good.pose.copy()
    pose[50, 4] = np.nan
    assert "quaternion[50, 1] is not finite" in rejected(CartesianTrajectory.unchecked(good.t, pose))


def test_rejects_a_joint_beyond_its_position_limit():
    msg = rejected(joint_move(2.0, joints=[2]))  # A3 from 0 to 115 deg and back: fine
    assert "position" not in msg
    msg = rejected(joint_move(3.1, joints=[2]))  # A3 to 178 deg: beyond 170 deg
    assert "position of a3" in msg and "above the maximum 2.96706" in msg and "at t =" in msg


def test_rejects_a_joint_beyond_its_velocity_limit():
    msg = rejected(joint_move(0.8, duration=0.3, joints=[3]))  # A4 at 5 rad/s, limit 75 deg/s
    assert "velocity of a4" in msg and "above the maximum 1.309" in msg


def test_rejects_a_trajectory_through_the_table():
    # A2 forward by 0.6 rad swings the wrist and the bottle down into the table
    msg = rejected(joint_move(-0.6, duration=1.5, joints=[1]))
    assert "collide" in msg and "table" in msg and "at t =" in msg


def test_rejects_a_pose_trajectory_into_the_glass():
    # the mouth lowered 25 cm over the glass: the bottle goes into the glass's rim
    poses = pour_poses(0.0).pose.copy()
    t = pour_poses(0.0).t
    poses[:, 2] -= 0.25 * min_jerk(t / t[-1])
    msg = rejected(CartesianTrajectory.from_pose(t, poses))
    assert "collide" in msg and "glass" in msg


def test_rejects_an_unreachable_pose():
    t = np.linspace(0, 2, 1001)
    base = pour_poses(0.0, timing=(1.0, 0.4, 0.2, 0.4))
    poses = base.pose.copy()
    poses[:, 0] += 0.9 * min_jerk(t / 2.0)  # 0.9 m farther out: 1.65 m from the base
    msg = rejected(CartesianTrajectory.from_pose(t, poses))
    assert "unreachable" in msg and "at t =" in msg


def test_rejects_a_non_unit_quaternion():
    base = pour_poses(1.0)
    poses = base.pose.copy()
    poses[10:, 3:] *= 1.01
    assert "norm 1.01" in rejected(CartesianTrajectory.unchecked(base.t, poses))


def test_rejects_a_start_away_from_home():
    base = pour_poses(1.0)
    poses = base.pose.copy()
    poses[:, 1] += 0.05
    assert "starts 50 mm" in rejected(CartesianTrajectory.from_pose(base.t, poses))
    assert "starts at" in rejected(Trajectory(base.t[:100], np.zeros((100, 7))))


def test_rejects_the_wrong_kind_of_object():
    assert "expected a dmprs.Trajectory (7 joints) or a dmprs.CartesianTrajectory" in rejected("not a trajectory")
    assert "7 DOFs" not in rejected(Trajectory(np.linspace(0, 1, 10), np.zeros((10, 3))))


def test_a_diverging_simulation_is_an_error_outcome(monkeypatch, tmp_path):
    monkeypatch.chdir(tmp_path)  # MuJoCo writes its warnings to ./MUJOCO_LOG.TXT
    adapter = ArmPouringAdapter(SMALL)
    liquid = arm_scene.settled_liquid(adapter.n_particles, 0)
    # a sphere shot at 1e30 m/s: finite, but the next steps are not
    qvel = liquid.qvel.copy()
    qvel[8] = 1e30
    exploded = arm_scene.SettledLiquid(liquid.n, liquid.seed, liquid.model, liquid.qpos, qvel, liquid.solver)
    monkeypatch.setattr(arm_scene, "settle_liquid", lambda *a, **k: exploded)
    out = execute(adapter, joint_move(0.05, duration=0.3))
    assert out.status is Status.ERROR and "diverged" in out.message


# --- the task ---------------------------------------------------------------------------------

def test_task_scores_like_the_2d_pouring():
    task = ArmPouring(0.06, target_volume=0.02, tol=0.01)
    out = execute(task.adapter, joint_move(0.05, duration=0.3))
    assert task.error([0.5], out)[0] == pytest.approx(0.0 - 0.02)  # nothing poured: eps < 0
    assert not task.success([0.5], out)
    with pytest.raises(ValueError, match="must be > 0"):
        task.validate_query([-0.1])
    with pytest.raises(ValueError, match="capacity"):
        ArmPouring(1.5)


def test_pour_geometry_constants_are_consistent():
    # the upright bottle passes over the glass's rim
    assert am.GLASS_HEIGHT + 2 * am.WALL < arm_scene.HOME_POSE[2] - am.BOTTLE_LENGTH - 2 * am.WALL
    assert math.isclose(am.PARTICLE_RADIUS ** 3 * 4 / 3 * math.pi, 2e-6)


def test_calibration_finds_the_peak_and_is_cached_on_disk(tmp_path, monkeypatch):
    from dmprs.tasks.arm_pouring import calibration as arm_pouring

    args = {"target_volume": 0.02, "bracket": (1.9, 2.6), "max_evaluations": 3, "cache_dir": tmp_path}
    cal = arm_pouring.calibrate_peak_tilt(0.06, **args)
    assert len(cal.evaluations) <= 3
    assert cal.poured_volume == min((p for _, p in cal.evaluations), key=lambda p: abs(p - 0.02))
    assert len(list(tmp_path.glob("arm-pouring-demo-*.json"))) == 1
    arm_pouring._calibrate.cache_clear()

    def no_pours(*args, **kwargs):
        raise AssertionError("the cached calibration was recomputed")

    monkeypatch.setattr(arm_pouring, "poured_volume", no_pours)
    assert arm_pouring.calibrate_peak_tilt(0.06, **args) == cal


def test_timeout_interrupts_the_settling_of_the_liquid_and_the_hold():
    import time

    polls = []
    assert arm_scene.settle_liquid(50, 4243, should_stop=lambda: polls.append(1) or len(polls) > 3) is None
    assert len(polls) == 4  # asked every 10 steps, stopped at once, and nothing cached:
    assert arm_scene.settle_liquid(50, 4243, should_stop=lambda: False) is not None

    adapter = ArmPouringAdapter(0.1, liquid_seed=4242)  # a liquid no other test settles
    move = joint_move(0.02, duration=0.15)
    with adapter:
        adapter.reset(seed=0)
        start = time.perf_counter()
        out = adapter.execute(move, timeout_s=0.1)  # the 0.4 s settle alone is ~0.5 s of MuJoCo
        assert out.status is Status.TIMEOUT and time.perf_counter() - start < 0.3
        slow = ArmPouringAdapter(0.1, liquid_seed=4242, hold=5.0)  # then 5 s of holding still
        with slow:
            slow.reset(seed=0)
            start = time.perf_counter()
            out = slow.execute(move, timeout_s=0.1)
            assert out.status is Status.TIMEOUT and time.perf_counter() - start < 0.3


@pytest.mark.parametrize(("options", "why"), [
    ({"hold": "x"}, "hold must be a real number"), ({"hold": -1}, "hold = -1 s must be between 0 and 10"),
    ({"hold": float("nan")}, "hold is nan"), ({"liquid_seed": "0"}, "liquid_seed = '0'"),
    ({"reseed_liquid": "no"}, "reseed_liquid must be True or False"), ({"bottle_volume": "big"}, "bottle_volume"),
])
def test_adapter_options_are_checked_at_the_boundary(options, why):
    with pytest.raises(ValueError, match=why) as info:
        ArmPouringAdapter(**options)
    assert type(info.value).__name__ == "InvalidInputError"


def test_the_task_refuses_a_bottle_it_cannot_simulate():
    with pytest.raises(ValueError, match="at most the simulated bottle's capacity of 1 l"):
        ArmPouring(0.5).validate_query([1.5])
    with pytest.raises(ValueError, match="tol must be a real number"):
        ArmPouring(0.5, tol="x")
