//! The Cartesian DMP with a final linear and angular velocity (docs/cartesian.md, "A final
//! velocity") against independent truths: the 1-D final-velocity DMP of the angle of a fixed-axis
//! rotation, the spring alone on its moving goals, a closed-form demonstration ending in motion
//! (first order in dt), and zero being today's Cartesian DMP bit for bit.

use dmp_core::quaternion::{self, Quaternion};
use dmp_core::{
    CartesianDemonstration, CartesianDmp, CartesianStepper, CartesianStepperOptions,
    CartesianTrajectory, Dmp, DmpConfig, FinalVelocity, RolloutOptions,
};
use nalgebra::{DMatrix, DVector, Vector3};

const LINEAR: [f64; 3] = [0.4, -0.3, 0.25];
const ANGULAR: [f64; 3] = [0.6, -0.2, 0.5];

fn config(n_basis: usize) -> DmpConfig {
    DmpConfig {
        n_basis,
        ..DmpConfig::default()
    }
}

fn axis_angle(axis: &Vector3<f64>, angle: f64) -> Quaternion {
    let a = axis.normalize() * (angle / 2.0).sin();
    [(angle / 2.0).cos(), a.x, a.y, a.z]
}

/// `[x, y, z, qw, qx, qy, qz]`.
fn pose(p: [f64; 3], q: Quaternion) -> [f64; 7] {
    [p[0], p[1], p[2], q[0], q[1], q[2], q[3]]
}

/// A DMP with a shape of its own and a final velocity.
fn shaped() -> CartesianDmp {
    let cfg = config(25);
    let w = DMatrix::from_fn(cfg.n_basis, 6, |k, d| {
        30.0 * libm::sin(0.7 * k as f64 + 1.1 * d as f64)
    });
    let goal = pose(
        [0.5, -0.2, 0.3],
        axis_angle(&Vector3::new(1.0, 2.0, -0.5), 1.1),
    );
    let start = pose(
        [0.0, 0.1, 0.0],
        axis_angle(&Vector3::new(-0.3, 1.0, 0.2), 0.4),
    );
    CartesianDmp::new(cfg, w, &goal, &start, 0.9).unwrap()
}

/// The rotation vector from `q` to `goal`, `2 log(goal * conj(q))`.
fn rotation_to(goal: &Quaternion, q: &[f64]) -> [f64; 3] {
    let d = quaternion::product(goal, &quaternion::conjugate(&[q[0], q[1], q[2], q[3]]));
    quaternion::log(&quaternion::same_hemisphere(&d, &quaternion::IDENTITY)).map(|c| 2.0 * c)
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|c| c * c).sum::<f64>().sqrt()
}

/// The last sample's distance from the goal pose and from the final velocity: position (m),
/// linear velocity, orientation (rad), angular velocity.
fn final_errors(dmp: &CartesianDmp, tr: &CartesianTrajectory) -> [f64; 4] {
    let twist = dmp.final_velocity().unwrap();
    let j = tr.n_samples() - 1;
    let goal = dmp.goal();
    let diff = |a: &[f64], b: &[f64]| norm(&[a[0] - b[0], a[1] - b[1], a[2] - b[2]]);
    [
        diff(&tr.position[3 * j..3 * j + 3], &goal[..3]),
        diff(&tr.velocity[3 * j..3 * j + 3], &twist[..3]),
        norm(&rotation_to(
            &dmp.goal_quaternion(),
            &tr.quaternion[4 * j..4 * j + 4],
        )),
        diff(&tr.angular_velocity[3 * j..3 * j + 3], &twist[3..]),
    ]
}

#[test]
fn a_zero_final_velocity_is_todays_cartesian_dmp() {
    let dmp = shaped();
    let same = dmp.with_final_velocity([0.0; 3], [0.0; 3]).unwrap();
    assert_eq!(same, dmp);
    assert!(same.final_velocity().is_none());
    let opts = RolloutOptions::new(1e-3);
    assert_eq!(same.rollout(&opts).unwrap(), dmp.rollout(&opts).unwrap());
    let (t, p) = ending_in_motion(0.0, [0.0; 3], [0.0; 3]);
    let fitted = CartesianDmp::fit(&demo(&t, &p), config(30)).unwrap();
    let zero = FinalVelocity::Given(DVector::zeros(6));
    let with_zero = CartesianDmp::fit_with_final_velocity(&demo(&t, &p), config(30), zero).unwrap();
    assert_eq!(with_zero, fitted);
    assert!(with_zero.final_velocity().is_none());
}

/// Without a forcing term both springs track their moving goals: Euler tracks them with their
/// velocities fed forward exactly, and what is left at tau is the transient from rest, `(1 + a)
/// e^-a` of the initial offset with `a = alpha_z / 2` (about `a` times more in velocity). So the
/// request is met to 1e-8 (1e-7 in velocity) at any dt.
#[test]
fn the_springs_alone_meet_the_request() {
    let dmp = CartesianDmp::new(
        config(25),
        DMatrix::zeros(25, 6),
        &shaped().goal(),
        &shaped().start(),
        0.9,
    )
    .unwrap()
    .with_final_velocity(LINEAR, ANGULAR)
    .unwrap();
    for dt in [1e-3, 4e-3, 0.01] {
        let e = final_errors(&dmp, &dmp.rollout(&RolloutOptions::new(dt)).unwrap());
        println!("{e:?} at {dt}");
        assert!(e[0] < 1e-8 && e[2] < 1e-8, "{e:?} at {dt}");
        assert!(e[1] < 1e-7 && e[3] < 1e-7, "{e:?} at {dt}");
    }
}

/// A rotation about one fixed axis `n` with final angular velocity `omega n` is the 1-D
/// final-velocity DMP of its angle, step for step; the position is the 3-D one.
#[test]
fn a_fixed_axis_rotation_is_the_joint_final_velocity_dmp_of_its_angle() {
    let cfg = config(25);
    let n = Vector3::new(0.3, -1.0, 0.6).normalize();
    let w_theta = DVector::from_fn(cfg.n_basis, |k, _| 50.0 * libm::sin(0.9 * k as f64));
    let (theta0, theta_g, omega, tau) = (0.3, 1.4, -0.7, 1.1);
    let mut w = DMatrix::from_fn(cfg.n_basis, 6, |k, d| {
        20.0 * libm::cos(0.5 * k as f64 + d as f64)
    });
    for d in 0..3 {
        w.column_mut(3 + d).copy_from(&(&w_theta * n[d]));
    }
    let cart = CartesianDmp::new(
        cfg,
        w.clone(),
        &pose([0.2, 0.0, -0.1], axis_angle(&n, theta_g)),
        &pose([0.0, 0.3, 0.1], axis_angle(&n, theta0)),
        tau,
    )
    .unwrap()
    .with_final_velocity(LINEAR, [omega * n.x, omega * n.y, omega * n.z])
    .unwrap();
    let angle = Dmp::new(
        cfg,
        DMatrix::from_column_slice(cfg.n_basis, 1, w_theta.as_slice()),
        DVector::from_element(1, theta_g),
        DVector::from_element(1, theta0),
        tau,
    )
    .unwrap()
    .with_final_velocity(DVector::from_element(1, omega))
    .unwrap();
    let position = Dmp::new(
        cfg,
        w.columns(0, 3).into_owned(),
        DVector::from_column_slice(&[0.2, 0.0, -0.1]),
        DVector::from_column_slice(&[0.0, 0.3, 0.1]),
        tau,
    )
    .unwrap()
    .with_final_velocity(DVector::from_column_slice(&LINEAR))
    .unwrap();
    let opts = RolloutOptions {
        duration: Some(1.3 * tau),
        ..RolloutOptions::new(2e-3)
    };
    let (rc, ra, rp) = (
        cart.rollout(&opts).unwrap(),
        angle.rollout(&opts).unwrap(),
        position.rollout(&opts).unwrap(),
    );
    assert_eq!(rc.n_samples(), ra.n_samples());
    let start = axis_angle(&n, theta0);
    for j in 0..ra.n_samples() {
        let turned = Vector3::from(rotation_to(
            &rc.quaternion[4 * j..4 * j + 4].try_into().unwrap(),
            &start,
        ));
        assert!(
            (theta0 + turned.dot(&n) - ra.y[j]).abs() < 1e-10,
            "angle at {j}"
        );
        assert!(
            (turned - n * turned.dot(&n)).norm() < 1e-10,
            "off the axis at {j}"
        );
        for d in 0..3 {
            assert!((rc.angular_velocity[3 * j + d] - n[d] * ra.yd[j]).abs() < 1e-9);
            assert!((rc.position[3 * j + d] - rp.y[3 * j + d]).abs() < 1e-12);
            assert!((rc.velocity[3 * j + d] - rp.yd[3 * j + d]).abs() < 1e-12);
        }
    }
}

/// A closed-form demonstration of duration `big_t` that starts at rest and ends at `(g, v)` in
/// position and `(h(1), omega)` in orientation: position min-jerk plus `v T (s^5 - s^4)`;
/// orientation `exp(k(s) T/2 omega) * h(s)` with `k = s^5 - s^4` (`k(1) = 0`, `k'(1) = 1`,
/// `k'(0) = 0`) and `h` a turn about a slowly moving axis that is at rest at both ends, so the
/// angular velocity is `k'(s) omega + R(k) omega_h`: 0 at the start, `omega` at the end.
fn ending_in_motion(big_t: f64, v: [f64; 3], omega: [f64; 3]) -> (Vec<f64>, DMatrix<f64>) {
    let big_t = if big_t == 0.0 { 1.2 } else { big_t };
    let n = 1201;
    let t: Vec<f64> = (0..n).map(|j| big_t * j as f64 / (n - 1) as f64).collect();
    let pose = DMatrix::from_fn(7, n, |r, j| {
        let s = t[j] / big_t;
        let (s3, s4, s5) = (s * s * s, s * s * s * s, s * s * s * s * s);
        let min_jerk = 10.0 * s3 - 15.0 * s4 + 6.0 * s5;
        let k = s5 - s4;
        if r < 3 {
            let goal = [0.5, -0.2, 0.3][r];
            return goal * min_jerk + v[r] * big_t * k;
        }
        let u = (1.0 - s) * (1.0 - s);
        let h = axis_angle(&Vector3::new(1.0, 0.5 * u, 1.0 + u), 1.2 * min_jerk);
        let turn = quaternion::exp(&omega.map(|c| c * k * big_t / 2.0));
        quaternion::product(&turn, &h)[r - 3]
    });
    (t, pose)
}

fn demo<'a>(t: &'a [f64], pose: &'a DMatrix<f64>) -> CartesianDemonstration<'a> {
    CartesianDemonstration {
        t,
        pose: pose.as_view(),
        velocity: None,
        acceleration: None,
        angular_velocity: None,
        angular_acceleration: None,
        normalize: false,
    }
}

/// The fitted DMP ends at the requested pose and velocities to the integrator's first order:
/// halving dt halves every final error. Its rollout reproduces the demonstration, and "from the
/// demo" reads the demonstration's last velocities.
#[test]
fn a_demonstration_ending_in_motion_is_reproduced_to_first_order() {
    let (t, p) = ending_in_motion(1.2, LINEAR, ANGULAR);
    let twist = DVector::from_iterator(6, LINEAR.into_iter().chain(ANGULAR));
    let dmp = CartesianDmp::fit_with_final_velocity(
        &demo(&t, &p),
        config(40),
        FinalVelocity::Given(twist),
    )
    .unwrap();
    let from_demo =
        CartesianDmp::fit_with_final_velocity(&demo(&t, &p), config(40), FinalVelocity::FromDemo)
            .unwrap();
    let read = from_demo.final_velocity().unwrap();
    for d in 0..3 {
        assert!((read[d] - LINEAR[d]).abs() < 1e-4, "{read:?}");
        assert!((read[3 + d] - ANGULAR[d]).abs() < 1e-4, "{read:?}");
    }
    let errors: Vec<[f64; 4]> = [2e-3, 1e-3, 5e-4]
        .iter()
        .map(|&dt| final_errors(&dmp, &dmp.rollout(&RolloutOptions::new(dt)).unwrap()))
        .collect();
    println!("final errors at 2, 1, 0.5 ms: {errors:?}");
    for (coarse, fine) in errors.iter().zip(&errors[1..]) {
        for c in 0..4 {
            let ratio = coarse[c] / fine[c];
            assert!((1.6..2.4).contains(&ratio), "{errors:?}");
        }
    }
    assert!(errors[1][0] < 1e-3 && errors[1][2] < 1e-3, "{errors:?}");
    assert!(errors[1][1] < 2e-2 && errors[1][3] < 2e-2, "{errors:?}");
    // The whole movement, at the demonstration's own step.
    let tr = dmp.rollout(&RolloutOptions::new(1e-3)).unwrap();
    assert_eq!(tr.n_samples(), t.len());
    for j in 0..t.len() {
        let q: Quaternion = [p[(3, j)], p[(4, j)], p[(5, j)], p[(6, j)]];
        assert!(
            norm(&rotation_to(&q, &tr.quaternion[4 * j..4 * j + 4])) < 1e-2,
            "at {j}"
        );
        for d in 0..3 {
            assert!((tr.position[3 * j + d] - p[(d, j)]).abs() < 1e-2, "at {j}");
        }
    }
}

#[test]
fn quaternions_stay_unit_and_rollouts_are_deterministic() {
    let dmp = shaped()
        .with_final_velocity(LINEAR, [2.0, -1.5, 3.0])
        .unwrap();
    let opts = RolloutOptions {
        duration: Some(2.0 * dmp.tau()),
        ..RolloutOptions::new(1e-3)
    };
    let tr = dmp.rollout(&opts).unwrap();
    for q in tr.quaternion.chunks(4) {
        assert!((norm(q) - 1.0).abs() < 1e-12);
    }
    assert_eq!(tr, dmp.rollout(&opts).unwrap());
}

#[test]
fn the_derived_movements_keep_the_final_velocity() {
    let dmp = shaped().with_final_velocity(LINEAR, ANGULAR).unwrap();
    let twist = dmp.final_velocity().unwrap();
    let goal = pose(
        [1.0, 0.0, 0.0],
        axis_angle(&Vector3::new(0.0, 0.0, 1.0), 0.5),
    );
    assert_eq!(dmp.with_goal(&goal).unwrap().final_velocity(), Some(twist));
    assert_eq!(dmp.with_start(&goal).unwrap().final_velocity(), Some(twist));
    let slower = dmp
        .with_tau(2.0 * dmp.tau())
        .unwrap()
        .final_velocity()
        .unwrap();
    for d in 0..6 {
        assert!((slower[d] - twist[d] * dmp.tau() / (2.0 * dmp.tau())).abs() < 1e-15);
    }
}

#[test]
fn bad_input_is_refused_by_name() {
    let dmp = shaped().with_final_velocity(LINEAR, ANGULAR).unwrap();
    let opts = RolloutOptions {
        until_rest: true,
        ..RolloutOptions::new(1e-3)
    };
    let err = dmp.rollout(&opts).unwrap_err().to_string();
    assert!(err.contains("until_rest"), "{err}");
    let err = shaped()
        .with_final_velocity([0.0, f64::NAN, 0.0], [0.0; 3])
        .unwrap_err()
        .to_string();
    assert!(err.contains("final_velocity"), "{err}");
    let (t, p) = ending_in_motion(1.2, LINEAR, ANGULAR);
    for bad in [DVector::zeros(5), DVector::from_element(6, f64::INFINITY)] {
        let err = CartesianDmp::fit_with_final_velocity(
            &demo(&t, &p),
            config(30),
            FinalVelocity::Given(bad),
        )
        .unwrap_err()
        .to_string();
        assert!(err.contains("final_velocity"), "{err}");
    }
}

fn max_abs_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).fold(0.0, |m, (a, b)| m.max((a - b).abs()))
}

/// Open loop the stepper is the rollout to rounding, past tau too (its moving goals from the
/// phase at the clock's sub-step: `k` sub-steps of `dt` are the rollout at `dt / k`), and it is
/// never done.
#[test]
fn the_stepper_is_the_rollout() {
    let dmp = shaped().with_final_velocity(LINEAR, ANGULAR).unwrap();
    for k in [1, 2] {
        let dt = 2e-3;
        let tr = dmp
            .rollout(&RolloutOptions {
                duration: Some(1.5 * dmp.tau()),
                ..RolloutOptions::new(dt / k as f64)
            })
            .unwrap();
        let mut opts = CartesianStepperOptions::new(dt);
        opts.base.substeps = Some(k);
        let mut s = CartesianStepper::new(&dmp, &opts).unwrap();
        for j in 0..(tr.n_samples() - 1) / k + 1 {
            let (pose, v, _) = s.step(None).unwrap();
            let r = j * k;
            let worst = [
                max_abs_diff(&pose[..3], &tr.position[3 * r..3 * r + 3]),
                max_abs_diff(&pose[3..], &tr.quaternion[4 * r..4 * r + 4]),
                max_abs_diff(&v[..3], &tr.velocity[3 * r..3 * r + 3]),
                max_abs_diff(&v[3..], &tr.angular_velocity[3 * r..3 * r + 3]),
            ];
            assert!(
                worst.iter().all(|&e| e < 1e-11),
                "{worst:?} at {j}, k = {k}"
            );
            assert!(!s.done());
        }
    }
}

/// Phase stopping holds the moving goals with the rest of the movement: a stepper held at its
/// start for a while still meets the goal pose and the final velocity once released, at the
/// phase of tau.
#[test]
fn a_held_stepper_meets_the_request_once_released() {
    let dmp = CartesianDmp::new(
        config(25),
        DMatrix::zeros(25, 6),
        &shaped().goal(),
        &shaped().start(),
        0.9,
    )
    .unwrap()
    .with_final_velocity(LINEAR, ANGULAR)
    .unwrap();
    let dt = 1e-3;
    let mut s = CartesianStepper::new(&dmp, &CartesianStepperOptions::new(dt)).unwrap();
    let start = dmp.start();
    let mut held = start;
    held[0] += 0.5; // far from the command: the phase all but stops
    for _ in 0..300 {
        s.step(Some(&held)).unwrap();
    }
    assert!(s.phase() > 0.95, "held at {}", s.phase());
    let tau_phase = (-dmp.config().alpha_x).exp();
    let mut last = None;
    for _ in 0..20_000 {
        let (pose, v) = s.step(None).map(|(p, v, _)| (*p, *v)).unwrap();
        if s.phase() <= tau_phase * (1.0 + 1e-9) {
            last = Some((pose, v));
            break;
        }
    }
    let (pose, v) = last.expect("the phase reaches tau");
    let twist = dmp.final_velocity().unwrap();
    let goal = dmp.goal();
    assert!(max_abs_diff(&pose[..3], &goal[..3]) < 1e-3, "{pose:?}");
    assert!(
        norm(&rotation_to(&dmp.goal_quaternion(), &pose[3..])) < 1e-3,
        "{pose:?}"
    );
    assert!(max_abs_diff(&v[..], &twist[..]) < 1e-2, "{v:?}");
}
