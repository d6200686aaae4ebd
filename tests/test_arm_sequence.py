"""The arm's reach, pour and return as one Cartesian sequence in the servo loop
(dmprs.experiments.arm_sequence), against its truths: the demonstration it is cut from (closed
form), the sequence's own rollout (the stepper in the loop commands it bit for bit), continuity at
the joins to the integrator's order (halving dt halves the jumps), a mouth that moves at every join
where the same movements with stops rest, and a pour within the task's tolerance.
"""

from __future__ import annotations

import copy

import numpy as np
import pytest

import dmprs
from dmprs.errors import InvalidInputError
from dmprs.experiments import arm_sequence as asq
from dmprs.experiments import online_arm as oa
from dmprs.portable import norms
from dmprs.profiles import min_jerk
from dmprs.reproduce import arm_sequence as part
from dmprs.sim import arm_model as am
from dmprs.sim.arm_ik import ArmKinematics
from dmprs.sim.arm_scene import HOME_POSE
from dmprs.tasks.arm_pouring import (
    DEMO_TIMING,
    POUR_POSITION,
    SUCCESS_TOLERANCE,
    TARGET_VOLUME,
    pour_and_return_cuts,
    pour_and_return_poses,
    pour_poses,
)

DT = 1e-3


@pytest.fixture(scope="module")
def runs() -> dict[str, asq.SequenceRun]:
    return {execution: asq.pour(execution) for execution in asq.EXECUTIONS}


def demo_speeds(overlap: float, t: float) -> tuple[float, float]:
    """The demonstration's mouth speed (m/s) and the bottle's turning rate (rad/s) at ``t``, in
    closed form: the min-jerk reach and tilt of pour_and_return_poses.
    """
    reach, up, hold, down = DEMO_TIMING
    tilt, leave = reach - overlap, reach - overlap + up + hold + down - overlap
    dist = float(np.linalg.norm(np.subtract(POUR_POSITION, HOME_POSE[:3])))
    speed = dist / reach * (min_jerk(t / reach)[1] - min_jerk((t - leave) / reach)[1])
    turn = oa.POUR_PEAK_TILT * (min_jerk((t - tilt) / up)[1] / up - min_jerk((t - tilt - up - hold) / down)[1] / down)
    return abs(float(speed)), abs(float(turn))


def test_the_demonstration_is_the_pour_then_its_reach_backwards_with_the_phases_overlapping() -> None:
    plain, base = pour_and_return_poses(2.0), pour_poses(2.0)
    assert np.array_equal(plain.pose[:base.n_samples], base.pose)  # without overlap: the pour, bit for bit
    np.testing.assert_allclose(plain.pose[-1], HOME_POSE, atol=1e-15)
    back = plain.pose[base.n_samples - 1:]  # then the reach backwards
    np.testing.assert_allclose(back[:, :3], base.pose[:len(back), :3][::-1], atol=1e-12)
    assert pour_and_return_cuts() == (0.5, 4.2)
    lap = pour_and_return_poses(2.0, 0.4)
    assert lap.t[-1] == pytest.approx(plain.t[-1] - 0.8)
    for cut in pour_and_return_cuts(0.4):
        speed, turn = demo_speeds(0.4, cut)
        assert speed > 0.5 and turn > 0.5  # mid-overlap: the mouth moves and the bottle turns
        k = round(cut / 0.002)
        assert norms((lap.pose[k + 1, :3] - lap.pose[k - 1, :3]) / 0.004) == pytest.approx(speed, rel=1e-4)
    for bad in (-0.1, 0.6, float("nan")):
        with pytest.raises(InvalidInputError, match="overlap"):
            pour_and_return_poses(2.0, bad)


def test_the_reach_and_the_pour_end_moving_and_the_return_at_rest() -> None:
    reach, pour, back = asq.pieces()
    assert [d.tau for d in (reach, pour, back)] == pytest.approx([0.3, 3.3, 0.3])
    for dmp, cut in zip((reach, pour), pour_and_return_cuts(asq.OVERLAP), strict=True):
        speed, turn = demo_speeds(asq.OVERLAP, cut)
        assert norms(dmp.final_velocity[:3]) == pytest.approx(speed, rel=1e-3)
        assert norms(dmp.final_velocity[3:]) == pytest.approx(turn, rel=1e-3)
    assert not back.final_velocity.any()
    assert not any(d.final_velocity.any() for d in asq.pieces(0.0))


def test_the_sequence_reproduces_the_demonstration() -> None:
    demo = pour_and_return_poses(oa.POUR_PEAK_TILT, asq.OVERLAP)
    tr = dmprs.Sequence(asq.pieces()).rollout(DT)
    k = np.arange(0, tr.n_samples, 2)  # the demonstration's 2 ms samples
    assert np.abs(tr.pose[k, :3] - demo.pose[: len(k), :3]).max() < 3e-3
    relative = dmprs.quaternion.product(tr.pose[k, 3:], dmprs.quaternion.conjugate(demo.pose[: len(k), 3:]))
    assert (2 * norms(dmprs.quaternion.log(relative))).max() < 0.02


def test_the_joins_are_continuous_to_the_integrators_order() -> None:
    seq = dmprs.Sequence(asq.pieces())
    jumps = []
    for dt in (DT, DT / 2):
        tr = seq.rollout(dt)
        v, a = np.hstack([tr.velocity, tr.angular_velocity]), np.hstack([tr.acceleration, tr.angular_acceleration])
        joins = [round(c / dt) for c in pour_and_return_cuts(asq.OVERLAP)]
        for j in joins:  # position and velocity go on by one Euler step
            np.testing.assert_allclose(tr.position[j], tr.position[j - 1] + tr.velocity[j - 1] * dt, atol=1e-15)
            np.testing.assert_allclose(v[j], v[j - 1] + a[j - 1] * dt, atol=1e-12)
        jumps.append(np.abs(a[joins] - a[[j - 1 for j in joins]]).max(axis=1))
    # the acceleration's jump across each join is the integrator's, first order: halving dt halves it
    np.testing.assert_allclose(jumps[0] / jumps[1], 2.0, rtol=0.15)


def test_the_servo_loop_commands_the_sequences_rollout(runs) -> None:
    run = runs["sequence"]
    tr = dmprs.Sequence(asq.pieces()).rollout(DT)
    n = tr.n_samples
    c = run.commands
    for name in ("pose", "velocity", "angular_velocity", "acceleration", "angular_acceleration"):
        assert np.array_equal(getattr(c, name)[:n], getattr(tr, name)), name
    assert run.joins.tolist() == [round(c / DT) for c in pour_and_return_cuts(asq.OVERLAP)]


def test_the_arm_does_not_stop_at_the_joins(runs) -> None:
    run, stops = runs["sequence"], runs["stops"]
    for j, cut in zip(run.joins, pour_and_return_cuts(asq.OVERLAP), strict=True):
        speed, turn = demo_speeds(asq.OVERLAP, cut)
        for v in (asq.twist(run.commands)[j], asq.twist(run.measured)[j]):  # commanded and measured, as demonstrated
            assert norms(v[:3]) == pytest.approx(speed, rel=0.1)
            assert norms(v[3:]) == pytest.approx(turn, rel=0.1)
    # the same movements with stops rest there: each starts from rest
    assert len(stops.joins) == 2
    assert (asq.twist(stops.commands)[stops.joins] == 0.0).all()
    # a join is no rougher than the rest of the movement, for the arm as for the command
    moving = np.flatnonzero((run.run.times > 0) & (run.run.times <= run.end_time))
    for v in (asq.twist(run.commands, 2), asq.twist(run.measured)):
        change = np.abs(np.diff(v, axis=0))  # change[k - 1]: into step k
        elsewhere = change[np.setdiff1d(moving, run.joins) - 1].max(axis=0)
        assert (change[run.joins - 1] <= elsewhere).all()


def test_the_sequence_ends_sooner_and_pours_within_the_tolerance(runs) -> None:
    run, stops = runs["sequence"], runs["stops"]
    # each movement runs its tau: the sequence is shorter by the two overlaps
    assert run.end_time == pytest.approx(sum(d.tau for d in asq.pieces()) - DT, abs=1e-9)
    assert stops.end_time - run.end_time == pytest.approx(2 * asq.OVERLAP, abs=1.5 * DT)
    assert abs(run.poured_volume - TARGET_VOLUME) < SUCCESS_TOLERANCE
    # the commanded mouth is still only while the bottle is held tilted, not at the joins
    assert run.still_time < DEMO_TIMING[2] + 0.1


def test_the_joint_commands_are_the_poses_through_the_ik(runs) -> None:
    run, kin = runs["sequence"].run, ArmKinematics()
    poses = runs["sequence"].commands.pose
    for k in range(0, len(poses), 97):
        np.testing.assert_allclose(kin.pose(run.command[k])[:3], poses[k, :3], atol=1e-5)
    # the joint velocity the servo is fed is the change of the joint command (central differences)
    q, qd = run.command, run.command_velocity
    central = (q[2:] - q[:-2]) / (2 * DT)
    assert np.abs(central - qd[1:-1]).max() < 0.01 * np.abs(qd).max()
    assert (np.abs(qd) < np.asarray(am.VELOCITY_LIMITS)).all()


def test_the_part_reports_the_truths_and_fails_a_sequence_that_stops(runs) -> None:
    from dmprs.reproduce.parts import BY_KIND, PARTS

    assert PARTS[-1] is part.PART and BY_KIND[part.KIND] is part.PART
    assert [(s.execution, s.liquid_seed) for s in part.plan_sequence(quick=True)] == [("sequence", 0), ("stops", 0)]
    results = [{**part.result_of(run, part.SequenceSpec(name)), "kind": part.KIND} for name, run in runs.items()]
    rows = part.summarize_sequence(results)
    assert [r["execution"] for r in rows] == ["sequence", "stops"] and rows[0]["met"] is True
    assert rows[0]["acceleration_change"][0] <= rows[0]["acceleration_change_inside"][0]
    md = part.markdown_sequence(rows)
    assert md.count("\n") == 4 and "| yes |" in md
    stopped = copy.deepcopy(results[0])
    for join in stopped["joins"]:
        join["commanded"] = join["measured"] = [0.0, 0.0]
    assert not part.held(stopped)
    rough = copy.deepcopy(results[0])
    rough["joins"][0]["velocity_step"] = 1e-3
    assert not part.held(rough)


def test_bad_input_is_refused_by_name() -> None:
    with pytest.raises(InvalidInputError, match="execution"):
        asq.pour("together")
    with pytest.raises(InvalidInputError, match="stages"):
        asq.IKStepper([], [], 2.0, ArmKinematics(), np.zeros(7))


def test_the_readmes_sequence_example_runs_and_does_what_it_says() -> None:
    from pathlib import Path

    readme = (Path(__file__).resolve().parents[1] / "README.md").read_text()
    block = readme.split("The arm reaches, pours and returns without stopping", 1)[1]
    block = block.split("```python\n", 1)[1].split("```", 1)[0]
    scope: dict = {}
    exec(block, scope)  # noqa: S102 - the README's own code
    run = scope["run"]
    assert [d.tau for d in (scope["reach"], scope["pour"], scope["back"])] == pytest.approx([0.3, 3.3, 0.3])
    assert (norms(scope["run"].commands.velocity[run.joins]) > 0.55).all()
    assert (norms(run.commands.angular_velocity[run.joins]) > 0.55).all()
    assert run.end_time == pytest.approx(3.9, abs=2e-3)
    assert abs(run.poured_volume - TARGET_VOLUME) < SUCCESS_TOLERANCE
