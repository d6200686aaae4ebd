//! The steppers against independent truth: the offline rollout (sample for sample), the rollout
//! at a finer step (sub-steps), a held robot, goal jumps with and without the filter, velocity
//! and acceleration limits against the unconstrained path, position limits and a sphere on the
//! path.

use dmp_core::coupling::SphereObstacle;
use dmp_core::quaternion::{self, Quaternion};
use dmp_core::{
    CartesianDmp, CartesianStepper, CartesianStepperOptions, Dmp, DmpConfig, RolloutOptions,
    Stepper, StepperOptions,
};
use nalgebra::{DMatrix, DVector};
use proptest::prelude::*;

fn config(n_basis: usize) -> DmpConfig {
    DmpConfig {
        n_basis,
        ..DmpConfig::default()
    }
}

fn joint_dmp(weights: &[f64], n_basis: usize, goal: &[f64], start: &[f64], tau: f64) -> Dmp {
    let n_dof = goal.len();
    Dmp::new(
        config(n_basis),
        DMatrix::from_column_slice(n_basis, n_dof, &weights[..n_basis * n_dof]),
        DVector::from_column_slice(goal),
        DVector::from_column_slice(start),
        tau,
    )
    .unwrap()
}

fn unit(q: [f64; 4]) -> Quaternion {
    let n = quaternion::norm(&q);
    q.map(|c| c / n)
}

fn cartesian_dmp(
    weights: &[f64],
    n_basis: usize,
    goal: [f64; 7],
    start: [f64; 7],
    tau: f64,
) -> CartesianDmp {
    let w = DMatrix::from_column_slice(n_basis, 6, &weights[..n_basis * 6]);
    CartesianDmp::new(config(n_basis), w, &goal, &start, tau).unwrap()
}

fn pose(p: [f64; 3], q: [f64; 4]) -> [f64; 7] {
    let q = unit(q);
    [p[0], p[1], p[2], q[0], q[1], q[2], q[3]]
}

/// Open loop: `steps + 1` samples of a joint stepper, flattened like a rollout.
fn run_joint(s: &mut Stepper, samples: usize) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let (mut y, mut yd, mut ydd) = (vec![], vec![], vec![]);
    for _ in 0..samples {
        let (a, b, c) = s.step(None).unwrap();
        y.extend_from_slice(a);
        yd.extend_from_slice(b);
        ydd.extend_from_slice(c);
    }
    (y, yd, ydd)
}

fn bits(v: &[f64]) -> Vec<u64> {
    v.iter().map(|v| v.to_bits()).collect()
}

fn max_abs_diff(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(32))]

    /// Without coupling the k-th step is the rollout's sample k, bit for bit,
    /// at steps within the stability limit and at coarse ones that the rollout sub-steps.
    #[test]
    fn a_joint_stepper_reproduces_the_rollout(
        weights in prop::collection::vec(-300.0f64..300.0, 4 * 30),
        n_basis in 2usize..30,
        n_dof in 1usize..5,
        goal in prop::collection::vec(-2.0f64..2.0, 4),
        start in prop::collection::vec(-2.0f64..2.0, 4),
        tau in 0.05f64..2.0,
        dt in prop::sample::select(vec![1e-3, 2e-3, 5e-3, 1e-2]),
    ) {
        let dmp = joint_dmp(&weights, n_basis, &goal[..n_dof], &start[..n_dof], tau);
        let tr = dmp.rollout(&RolloutOptions::new(dt)).unwrap();
        let mut s = Stepper::new(&dmp, &StepperOptions::new(dt)).unwrap();
        let (y, yd, ydd) = run_joint(&mut s, tr.n_samples());
        prop_assert_eq!(bits(&y), bits(&tr.y));
        prop_assert_eq!(bits(&yd), bits(&tr.yd));
        prop_assert_eq!(bits(&ydd), bits(&tr.ydd));
        prop_assert!((s.phase() - (-2.0f64 * tr.t[tr.n_samples() - 1] / tau).exp()).abs() < 0.01);
    }

    /// Explicit sub-steps: each period is `k` steps of the rollout at `dt / k`.
    #[test]
    fn sub_steps_are_the_rollout_at_a_finer_step(
        weights in prop::collection::vec(-300.0f64..300.0, 2 * 20),
        goal in prop::collection::vec(-2.0f64..2.0, 2),
        tau in 0.3f64..2.0,
        k in 2usize..6,
    ) {
        let dt = 4e-3;
        let dmp = joint_dmp(&weights, 20, &goal, &[0.1, -0.4], tau);
        let fine = dmp.rollout(&RolloutOptions::new(dt / k as f64)).unwrap();
        let opts = StepperOptions { substeps: Some(k), ..StepperOptions::new(dt) };
        let mut s = Stepper::new(&dmp, &opts).unwrap();
        prop_assert_eq!(s.substeps(), k);
        let samples = (fine.n_samples() - 1) / k + 1;
        let (y, yd, ydd) = run_joint(&mut s, samples);
        for j in 0..samples {
            let r = j * k * 2;
            prop_assert!(max_abs_diff(&y[2 * j..2 * j + 2], &fine.y[r..r + 2]) <= 1e-12);
            prop_assert!(max_abs_diff(&yd[2 * j..2 * j + 2], &fine.yd[r..r + 2]) <= 1e-12);
            prop_assert!(max_abs_diff(&ydd[2 * j..2 * j + 2], &fine.ydd[r..r + 2]) <= 1e-9);
        }
    }

    /// The Cartesian stepper reproduces the Cartesian rollout, sample for sample, and with
    /// sub-steps the rollout at `dt / k`.
    #[test]
    fn a_cartesian_stepper_reproduces_the_rollout(
        weights in prop::collection::vec(-300.0f64..300.0, 6 * 25),
        n_basis in 2usize..25,
        p in prop::array::uniform3(-1.0f64..1.0),
        gq in prop::array::uniform4(-1.0f64..1.0),
        sq in prop::array::uniform4(-1.0f64..1.0),
        tau in 0.3f64..2.0,
        k in 1usize..4,
    ) {
        prop_assume!(quaternion::norm(&gq) > 0.1 && quaternion::norm(&sq) > 0.1);
        let dmp = cartesian_dmp(&weights, n_basis, pose(p, gq), pose([0.1, 0.2, 0.3], sq), tau);
        let dt = 2e-3;
        let fine = dmp.rollout(&RolloutOptions::new(dt / k as f64)).unwrap();
        let mut opts = CartesianStepperOptions::new(dt);
        opts.base.substeps = Some(k);
        let mut s = CartesianStepper::new(&dmp, &opts).unwrap();
        for j in 0..(fine.n_samples() - 1) / k + 1 {
            let (pose, v, a) = s.step(None).unwrap();
            let r = j * k;
            prop_assert!(max_abs_diff(&pose[..3], &fine.position[3 * r..3 * r + 3]) <= 1e-12);
            prop_assert!(max_abs_diff(&pose[3..], &fine.quaternion[4 * r..4 * r + 4]) <= 1e-12);
            prop_assert!(max_abs_diff(&v[..3], &fine.velocity[3 * r..3 * r + 3]) <= 1e-12);
            prop_assert!(max_abs_diff(&v[3..], &fine.angular_velocity[3 * r..3 * r + 3]) <= 1e-12);
            let acc = fine.acceleration[3 * r..3 * r + 3].iter().chain(&fine.angular_acceleration[3 * r..3 * r + 3]);
            let scale = 1.0 + acc.clone().fold(0.0f64, |m, v| m.max(v.abs()));
            let want: Vec<f64> = acc.copied().collect();
            prop_assert!(max_abs_diff(a, &want) <= 1e-12 * scale);
        }
    }
}

/// Within the stability limit the stepper is the rollout bit for bit (the rollout is the stepper
/// run open loop), joint and Cartesian, and the goal filter does nothing, bit for bit, until a
/// goal changes.
#[test]
fn steps_are_the_rollout_and_an_idle_goal_filter_is_inert() {
    let w: Vec<f64> = (0..3 * 25)
        .map(|i| 40.0 * ((i as f64) * 0.37).sin())
        .collect();
    let dmp = joint_dmp(&w, 25, &[0.4, -1.0, 2.0], &[0.0, 0.5, 1.0], 0.8);
    let tr = dmp.rollout(&RolloutOptions::new(1e-3)).unwrap();
    let mut s = Stepper::new(&dmp, &StepperOptions::new(1e-3)).unwrap();
    let (y, yd, ydd) = run_joint(&mut s, tr.n_samples());
    assert_eq!(
        (bits(&y), bits(&yd), bits(&ydd)),
        (bits(&tr.y), bits(&tr.yd), bits(&tr.ydd))
    );
    let unfiltered = StepperOptions {
        goal_filter: None,
        ..StepperOptions::new(1e-3)
    };
    let mut plain = Stepper::new(&dmp, &unfiltered).unwrap();
    assert_eq!(run_joint(&mut plain, tr.n_samples()), (y, yd, ydd));
    let c = cartesian_dmp(
        &w.repeat(2),
        25,
        pose([0.3, 0.1, 0.0], [0.9, 0.1, 0.3, 0.2]),
        pose([0.0; 3], [1.0, 0.0, 0.0, 0.0]),
        0.8,
    );
    let tr = c.rollout(&RolloutOptions::new(1e-3)).unwrap();
    let mut s = CartesianStepper::new(&c, &CartesianStepperOptions::new(1e-3)).unwrap();
    for j in 0..tr.n_samples() {
        let (pose, v, a) = s.step(None).unwrap();
        let want_v = [
            &tr.velocity[3 * j..3 * j + 3],
            &tr.angular_velocity[3 * j..3 * j + 3],
        ];
        let want_a = [
            &tr.acceleration[3 * j..3 * j + 3],
            &tr.angular_acceleration[3 * j..3 * j + 3],
        ];
        assert_eq!(
            bits(&pose[..3]),
            bits(&tr.position[3 * j..3 * j + 3]),
            "{j}"
        );
        assert_eq!(
            bits(&pose[3..]),
            bits(&tr.quaternion[4 * j..4 * j + 4]),
            "{j}"
        );
        assert_eq!(bits(v), bits(&want_v.concat()), "{j}");
        assert_eq!(bits(a), bits(&want_a.concat()), "{j}");
    }
}

/// The common period (no limits, sub-steps or moving goal) runs in one pass over the
/// coordinates, with or without a coupling term; it must give the bits of the staged period,
/// which position limits that are never approached select, open loop and phase-stopped, across
/// an unfiltered goal jump, with a coupling term that varies and then one that holds the
/// movement off its goal (blocked), and the rest at the end.
#[test]
fn the_one_pass_period_gives_the_staged_periods_bits() {
    let w: Vec<f64> = (0..7 * 30)
        .map(|i| 60.0 * ((i as f64) * 0.53).sin())
        .collect();
    let start = [0.0, 0.5, 1.0, -0.3, 0.2, 0.0, 2.0];
    let dmp = joint_dmp(&w, 30, &[0.4, -1.0, 2.0, 0.1, 0.9, 0.0, 1.5], &start, 0.8);
    let moving = dmp
        .with_final_velocity(nalgebra::DVector::from_vec(vec![
            0.5, 0.0, -1.0, 0.2, 0.0, 0.3, 1.0,
        ]))
        .unwrap();
    for dmp in [dmp, moving] {
        for coupled in [false, true] {
            one_pass_is_staged(&dmp, coupled);
        }
    }
}

fn one_pass_is_staged(dmp: &Dmp, coupled: bool) {
    let base = StepperOptions {
        goal_filter: None,
        ..StepperOptions::new(2e-3)
    };
    let far = StepperOptions {
        position_min: Some(vec![-1e9; 7]),
        position_max: Some(vec![1e9; 7]),
        ..base.clone()
    };
    let mut one_pass = Stepper::new(dmp, &base).unwrap();
    let mut staged = Stepper::new(dmp, &far).unwrap();
    let mut blocked = 0;
    for k in 0..3000 {
        if k == 300 {
            for s in [&mut one_pass, &mut staged] {
                s.set_goal(&[1.0, 0.0, 1.0, 0.5, 0.5, 0.5, 0.0]).unwrap();
            }
        }
        // A robot that lags behind the command for a while: phase stopping.
        let lag = if (500..700).contains(&k) { 0.02 } else { 0.0 };
        let measured: Vec<f64> = one_pass.output().0.iter().map(|y| y - lag).collect();
        let m = (k % 2 == 0).then_some(measured.as_slice());
        // a push that varies, then a constant one the spring balances 0.1 off the goal
        let push: Vec<f64> = (0..7)
            .map(|d| match k {
                ..1500 => 30.0 * (0.01 * k as f64 + d as f64).sin(),
                _ => 48.0 * 12.0 * 0.1,
            })
            .collect();
        let c = coupled.then_some(push.as_slice());
        let a = one_pass.step_coupled(m, c).unwrap();
        let a = (a.0.to_vec(), a.1.to_vec(), a.2.to_vec());
        let b = staged.step_coupled(m, c).unwrap();
        assert_eq!(a, (b.0.to_vec(), b.1.to_vec(), b.2.to_vec()), "step {k}");
        assert_eq!(one_pass.phase().to_bits(), staged.phase().to_bits());
        assert_eq!(one_pass.tau().to_bits(), staged.tau().to_bits());
        assert_eq!(one_pass.done(), staged.done(), "step {k}");
        assert_eq!(one_pass.blocked(), staged.blocked(), "step {k}");
        blocked += usize::from(one_pass.blocked());
    }
    // held off its goal by the push the movement is blocked, never done; without it, it rests
    // (a movement with a final velocity moves on and is never either)
    let plain = dmp.final_velocity().is_none();
    assert_eq!(one_pass.done(), plain && !coupled);
    assert_eq!(blocked > 0, plain && coupled, "{blocked} blocked steps");
}

/// A 1-DOF reach from 0 to 1 in 1 s with a bump (weights from a fit).
fn reach(n_dof: usize) -> Dmp {
    let t: Vec<f64> = (0..500).map(|j| j as f64 / 499.0).collect();
    let y = DMatrix::from_fn(n_dof, 500, |d, j| {
        let s = t[j];
        let mj = 10.0 * s.powi(3) - 15.0 * s.powi(4) + 6.0 * s.powi(5);
        (1.0 + 0.5 * d as f64) * mj + 0.3 * (std::f64::consts::PI * s).sin().powi(2)
    });
    let demo = dmp_core::Demonstration {
        t: &t,
        y: y.as_view(),
        yd: None,
        ydd: None,
    };
    Dmp::fit(&demo, config(30)).unwrap()
}

/// A robot held still for 0.5 s mid-movement: the phase stops, the command waits near the held
/// position, and after the release the command goes on without a jump to the goal.
#[test]
fn a_held_robot_stops_the_phase_and_resumes_smoothly() {
    let dmp = reach(1);
    let dt = 1e-3;
    let mut s = Stepper::new(&dmp, &StepperOptions::new(dt)).unwrap();
    // The robot: a critically damped tracker of the command (bandwidth 40 rad/s), held from
    // t = 0.3 s to 0.8 s.
    let (mut q, mut qd) = (dmp.y0()[0], 0.0);
    let (wn, hold) = (40.0, (300, 800));
    let (mut phase_at_hold, mut phase_at_release, mut max_gap, mut max_acc_after) =
        (0.0, 0.0, 0.0f64, 0.0f64);
    let mut prev_yd = 0.0;
    let mut max_dyd_after = 0.0f64;
    for k in 0..6000 {
        let (y, yd, ydd) = {
            let (y, yd, ydd) = s.step(Some(&[q])).unwrap();
            (y[0], yd[0], ydd[0])
        };
        if k == hold.0 {
            phase_at_hold = s.phase();
        }
        if (hold.0..hold.1).contains(&k) {
            max_gap = max_gap.max((y - q).abs());
        }
        if k == hold.1 {
            phase_at_release = s.phase();
        }
        if k > hold.1 {
            max_acc_after = max_acc_after.max(ydd.abs());
            max_dyd_after = max_dyd_after.max((yd - prev_yd).abs() / dt);
        }
        prev_yd = yd;
        if (hold.0..hold.1).contains(&k) {
            qd = 0.0;
        } else {
            let qdd = wn * wn * (y - q) + 2.0 * wn * (yd - qd) + ydd;
            qd += qdd * dt;
            q += qd * dt;
        }
        if s.done() {
            break;
        }
    }
    let nominal = dmp.rollout(&RolloutOptions::new(dt)).unwrap();
    let nominal_acc = nominal.ydd.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    println!(
        "hold: phase {phase_at_hold:.4} -> {phase_at_release:.4}, command within {max_gap:.4} of the held robot, \
         |ydd| after release <= {max_acc_after:.2}, |d yd / dt| <= {max_dyd_after:.2} (nominal max |ydd| {nominal_acc:.2}), steps {}",
        s.steps()
    );
    // Unheld, the phase would fall by 1 - e^-1 = 63 % in 0.5 s.
    assert!((phase_at_hold - phase_at_release) / phase_at_hold < 0.1);
    assert!(max_gap < 0.1, "{max_gap}");
    // No jump: the command's velocity changes by a bounded acceleration per period.
    assert!(
        max_acc_after < 10.0 * nominal_acc,
        "{max_acc_after} vs {nominal_acc}"
    );
    assert!(max_dyd_after < 10.0 * nominal_acc);
    assert!(s.done(), "did not reach the goal");
    assert!((s.output().0[0] - dmp.goal()[0]).abs() <= 1e-4);
}

/// A goal jump mid-movement: with the filter the commanded acceleration stays a fraction of the
/// unfiltered jump's, and both reach the new goal.
#[test]
fn the_goal_filter_bounds_the_acceleration_of_a_goal_jump() {
    let dmp = reach(2);
    let dt = 1e-3;
    let run = |filter: Option<f64>| {
        let opts = StepperOptions {
            goal_filter: filter,
            ..StepperOptions::new(dt)
        };
        let mut s = Stepper::new(&dmp, &opts).unwrap();
        let mut peak = 0.0f64;
        for k in 0..20000 {
            if k == 400 {
                s.set_goal(&[0.4, 2.5]).unwrap();
            }
            let (_, _, ydd) = s.step(None).unwrap();
            if k >= 400 {
                peak = peak.max(ydd.iter().fold(0.0f64, |m, v| m.max(v.abs())));
            }
            if s.done() {
                return (peak, s.output().0.to_vec(), k);
            }
        }
        panic!("not at rest at the new goal");
    };
    let (jump, y_jump, _) = run(None);
    let (filtered, y_filtered, k) = run(Some(24.0));
    println!(
        "goal jump: peak |ydd| {jump:.1} unfiltered, {filtered:.1} filtered; at rest after {k} steps"
    );
    assert!(filtered < 0.5 * jump, "{filtered} vs {jump}");
    for (y, g) in y_jump.iter().chain(&y_filtered).zip([0.4, 2.5, 0.4, 2.5]) {
        assert!((y - g).abs() <= 1e-4);
    }
}

/// The path of a stepper, resampled at the phases of a reference rollout: the largest distance
/// between them, per DOF, along the reference's phases (both phases decrease monotonically).
fn path_deviation(phases: &[f64], ys: &[f64], ref_x: &[f64], ref_y: &[f64], n: usize) -> f64 {
    let mut worst = 0.0f64;
    let mut j = 0;
    for (i, &x) in ref_x.iter().enumerate() {
        while j + 1 < phases.len() && phases[j + 1] > x {
            j += 1;
        }
        if j + 1 >= phases.len() || phases[j] < x {
            continue;
        }
        let s = (phases[j] - x) / (phases[j] - phases[j + 1]);
        for d in 0..n {
            let y = ys[j * n + d] + s * (ys[(j + 1) * n + d] - ys[j * n + d]);
            worst = worst.max((y - ref_y[i * n + d]).abs());
        }
    }
    worst
}

/// Velocity limits 50 % below the movement's peak: met at every step, the movement takes
/// longer, and it follows the unconstrained path.
#[test]
fn velocity_and_acceleration_limits_slow_the_clock_not_the_path() {
    let dmp = reach(2);
    let dt = 1e-3;
    let free = dmp
        .rollout(&RolloutOptions {
            until_rest: true,
            ..RolloutOptions::new(dt)
        })
        .unwrap();
    let n = 2;
    let peak = |v: &[f64], d: usize| {
        v.iter()
            .skip(d)
            .step_by(n)
            .fold(0.0f64, |m, v| m.max(v.abs()))
    };
    let v_max = [peak(&free.yd, 0) / 1.5, peak(&free.yd, 1) / 1.5];
    let a_max = [peak(&free.ydd, 0) / 1.5, peak(&free.ydd, 1) / 1.5];
    let phases_free: Vec<f64> = free
        .t
        .iter()
        .map(|t| (-2.0 * t / dmp.tau()).exp())
        .collect();
    for accel in [false, true] {
        let opts = StepperOptions {
            velocity_max: Some(v_max.to_vec()),
            acceleration_max: accel.then(|| a_max.to_vec()),
            ..StepperOptions::new(dt)
        };
        let mut s = Stepper::new(&dmp, &opts).unwrap();
        let (mut phases, mut ys) = (vec![], vec![]);
        let (mut v_excess, mut a_excess) = (0.0f64, 0.0f64);
        while !s.done() {
            let (y, yd, ydd) = s.step(None).unwrap();
            for d in 0..n {
                v_excess = v_excess.max(yd[d].abs() / v_max[d] - 1.0);
                a_excess = a_excess.max(ydd[d].abs() / a_max[d] - 1.0);
            }
            ys.extend_from_slice(y);
            phases.push(s.phase());
            assert!(s.steps() < 100_000);
        }
        let deviation = path_deviation(&phases, &ys, &phases_free, &free.y, n);
        println!(
            "limits (acceleration {accel}): {} steps against {} free; max |yd|/limit - 1 = {v_excess:.2e}, \
             max |ydd|/limit - 1 = {a_excess:.2e}, path deviation {deviation:.2e}",
            s.steps(),
            free.n_samples()
        );
        assert!(v_excess <= 1e-12, "velocity exceeded by {v_excess}");
        if accel {
            assert!(a_excess <= 1e-9, "acceleration exceeded by {a_excess}");
        }
        assert!(s.steps() as usize > free.n_samples() + 100);
        assert!(deviation < 2e-3, "path deviation {deviation}");
    }
}

/// A path that overshoots its upper position limit stays inside it with the repulsion, and a goal
/// beyond the limit is approached from inside.
#[test]
fn position_limits_keep_the_command_inside() {
    let dmp = reach(1);
    let free = dmp.rollout(&RolloutOptions::new(1e-3)).unwrap();
    let top = free.y.iter().fold(f64::MIN, |m, &v| m.max(v));
    let limit = dmp.goal()[0] + 0.5 * (top - dmp.goal()[0]);
    assert!(top > limit);
    for goal in [dmp.goal()[0], limit + 0.5] {
        let opts = StepperOptions {
            position_min: Some(vec![-1.0]),
            position_max: Some(vec![limit]),
            limit_margin: Some(vec![0.02]),
            ..StepperOptions::new(1e-3)
        };
        let mut s = Stepper::new(&dmp, &opts).unwrap();
        s.set_goal(&[goal]).unwrap();
        let mut highest = f64::MIN;
        for _ in 0..5000 {
            let (y, _, _) = s.step(None).unwrap();
            highest = highest.max(y[0]);
        }
        println!(
            "position limit {limit:.4} (free path peaks at {top:.4}), goal {goal:.3}: highest command {highest:.4}"
        );
        assert!(highest < limit, "{highest} >= {limit}");
        if goal < limit - 0.02 {
            assert!((s.output().0[0] - goal).abs() < 1e-4);
        }
    }
}

/// A sphere centred on the unperturbed path of a Cartesian reach: the command keeps a positive
/// clearance and still reaches the goal.
#[test]
fn a_sphere_on_the_path_is_avoided_and_the_goal_reached() {
    let t: Vec<f64> = (0..500).map(|j| j as f64 / 499.0).collect();
    let pose_demo = DMatrix::from_fn(7, 500, |r, j| {
        let s = t[j];
        let a = 10.0 * s.powi(3) - 15.0 * s.powi(4) + 6.0 * s.powi(5);
        let q = unit([1.0, 0.0, 0.0, 0.4 * a]);
        match r {
            0 => 0.4 * a,
            1 => 0.1 * (std::f64::consts::PI * a).sin(),
            2 => 0.05 * a,
            c => q[c - 3],
        }
    });
    let demo = dmp_core::CartesianDemonstration {
        t: &t,
        pose: pose_demo.as_view(),
        velocity: None,
        acceleration: None,
        angular_velocity: None,
        angular_acceleration: None,
        normalize: false,
    };
    let dmp = CartesianDmp::fit(&demo, config(30)).unwrap();
    let free = dmp.rollout(&RolloutOptions::new(1e-3)).unwrap();
    let mid = free.n_samples() / 3;
    let center = [0, 1, 2].map(|d| free.position[3 * mid + d]);
    for radius in [0.0, 0.03, 0.05] {
        let mut opts = CartesianStepperOptions::new(1e-3);
        opts.obstacles = vec![SphereObstacle { center, radius }];
        let mut s = CartesianStepper::new(&dmp, &opts).unwrap();
        let mut clearance = f64::MAX;
        while !s.done() {
            let (pose, _, _) = s.step(None).unwrap();
            clearance = clearance.min(opts.obstacles[0].clearance(&[pose[0], pose[1], pose[2]]));
            assert!(s.steps() < 20_000, "not at rest");
        }
        println!(
            "sphere of radius {radius} on the path: minimum clearance {clearance:.4} m, at rest after {} steps",
            s.steps()
        );
        assert!(clearance > 0.0);
        let goal = dmp.goal();
        assert!((0..3).all(|d| (s.output().0[d] - goal[d]).abs() <= 1e-4));
    }
}
