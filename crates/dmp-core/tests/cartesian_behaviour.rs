//! The Cartesian DMP against independent truths: the discrete DMP of the angle of a fixed-axis
//! rotation, unit norm, convergence to the goal, equivariance under a constant rotation, and
//! invariance under the sign of the samples.

use dmp_core::quaternion::{self, Quaternion};
use dmp_core::{
    CartesianDemonstration, CartesianDmp, CartesianTrajectory, Demonstration, Dmp, DmpConfig,
    RolloutOptions,
};
use nalgebra::{DMatrix, Rotation3, UnitQuaternion, Vector3};
use proptest::prelude::*;

const N: usize = 400;

fn config(n_basis: usize) -> DmpConfig {
    DmpConfig {
        n_basis,
        ..DmpConfig::default()
    }
}

fn times(tau: f64) -> Vec<f64> {
    (0..N).map(|j| tau * j as f64 / (N - 1) as f64).collect()
}

/// Minimum jerk from 0 to 1 with a wobble that vanishes at both ends.
fn profile(s: f64, wobble: f64) -> f64 {
    10.0 * s.powi(3) - 15.0 * s.powi(4)
        + 6.0 * s.powi(5)
        + wobble * (std::f64::consts::PI * s).sin().powi(2) * (3.0 * s).sin()
}

fn axis_angle(axis: &Vector3<f64>, angle: f64) -> Quaternion {
    let a = axis.normalize() * (angle / 2.0).sin();
    [(angle / 2.0).cos(), a.x, a.y, a.z]
}

fn to_nalgebra(q: &[f64]) -> UnitQuaternion<f64> {
    UnitQuaternion::new_unchecked(nalgebra::Quaternion::new(q[0], q[1], q[2], q[3]))
}

/// A `7 x N` pose demo: position along a curve, orientation turning about a moving axis.
fn general_demo(tau: f64) -> (Vec<f64>, DMatrix<f64>) {
    let t = times(tau);
    let pose = DMatrix::from_fn(7, N, |r, j| {
        let s = j as f64 / (N - 1) as f64;
        let a = profile(s, 0.3);
        let axis = Vector3::new(1.0, 0.5 * s, 2.0 - s);
        let q = axis_angle(&axis, 0.2 + 1.7 * a);
        match r {
            0 => 0.3 + 0.4 * a,
            1 => -0.2 * a + 0.05 * (2.0 * s).sin(),
            2 => 0.5 - 0.1 * a,
            c => q[c - 3],
        }
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

/// The rotation angle between two orientations (of either sign), in [0, pi].
fn angle_to(goal: &Quaternion, q: &[f64]) -> f64 {
    let d = quaternion::product(goal, &quaternion::conjugate(&[q[0], q[1], q[2], q[3]]));
    let e = quaternion::log(&quaternion::same_hemisphere(&d, &quaternion::IDENTITY));
    2.0 * (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt()
}

fn last_quaternion(tr: &CartesianTrajectory) -> &[f64] {
    &tr.quaternion[tr.quaternion.len() - 4..]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    /// A rotation about one fixed axis by theta(t) is the discrete DMP of theta(t) with the same
    /// constants: the orientation weights are the axis times theta's weights, and the rollout's
    /// angle, angular velocity and acceleration are the discrete rollout's, to 1e-10.
    #[test]
    fn a_fixed_axis_rotation_is_the_discrete_dmp_of_its_angle(
        axis in prop::array::uniform3(-1.0f64..1.0),
        theta0 in -1.0f64..1.0, amplitude in -2.2f64..2.2, wobble in -0.5f64..0.5,
        tau in 0.5f64..3.0,
    ) {
        let axis = Vector3::from(axis);
        prop_assume!(axis.norm() > 0.1);
        let n = axis.normalize();
        let t = times(tau);
        let theta: Vec<f64> = (0..N)
            .map(|j| theta0 + amplitude * profile(j as f64 / (N - 1) as f64, wobble))
            .collect();
        let pose = DMatrix::from_fn(7, N, |r, j| {
            if r < 3 { 0.1 * r as f64 } else { axis_angle(&axis, theta[j])[r - 3] }
        });
        let cart = CartesianDmp::fit(&demo(&t, &pose), config(30)).unwrap();
        let y = DMatrix::from_row_slice(1, N, &theta);
        let scalar = Dmp::fit(
            &Demonstration { t: &t, y: y.as_view(), yd: None, ydd: None },
            config(30),
        ).unwrap();
        let scale = scalar.weights().amax().max(1.0);
        for k in 0..30 {
            for d in 0..3 {
                let want = n[d] * scalar.weights()[(k, 0)];
                prop_assert!((cart.weights()[(k, 3 + d)] - want).abs() <= 1e-10 * scale);
            }
        }
        let opts = RolloutOptions { duration: Some(1.5 * tau), ..RolloutOptions::new(0.002) };
        let (rc, rs) = (cart.rollout(&opts).unwrap(), scalar.rollout(&opts).unwrap());
        prop_assert_eq!(rc.n_samples(), rs.n_samples());
        let q0 = to_nalgebra(&cart.start_quaternion());
        for j in 0..rs.n_samples() {
            // The angle turned from the start, about the axis.
            let q = to_nalgebra(&rc.quaternion[4 * j..4 * j + 4]);
            let turned = (q * q0.inverse()).scaled_axis().dot(&n);
            prop_assert!((theta0 + turned - rs.y[j]).abs() <= 1e-10, "j={}", j);
            for d in 0..3 {
                prop_assert!((rc.angular_velocity[3 * j + d] - n[d] * rs.yd[j]).abs() <= 1e-10 * scale);
                prop_assert!((rc.angular_acceleration[3 * j + d] - n[d] * rs.ydd[j]).abs() <= 1e-10 * scale * 50.0);
            }
        }
    }

    /// Any Cartesian DMP, however wild its weights: every rollout quaternion is unit to 1e-12,
    /// and at rest the orientation is at the goal to 1e-6 rad (and the position at its goal).
    #[test]
    fn rollouts_stay_unit_and_come_to_rest_at_the_goal(
        w in prop::collection::vec(-300.0f64..300.0, 6 * 12),
        goal in prop::array::uniform4(-1.0f64..1.0), start in prop::array::uniform4(-1.0f64..1.0),
        tau in 0.2f64..2.0, dt in 0.0005f64..0.01,
    ) {
        let (gn, sn) = (quaternion::norm(&goal), quaternion::norm(&start));
        prop_assume!(gn > 0.1 && sn > 0.1);
        let g = goal.map(|c| c / gn);
        let s = start.map(|c| c / sn);
        let weights = DMatrix::from_column_slice(12, 6, &w);
        let dmp = CartesianDmp::new(
            config(12), weights,
            &[0.5, -0.2, 0.1, g[0], g[1], g[2], g[3]],
            &[0.0, 0.0, 0.0, s[0], s[1], s[2], s[3]],
            tau,
        ).unwrap();
        let opts = RolloutOptions { until_rest: true, rest_tol: 1e-8, ..RolloutOptions::new(dt) };
        let tr = dmp.rollout(&opts).unwrap();
        for q in tr.quaternion.chunks_exact(4) {
            let q = [q[0], q[1], q[2], q[3]];
            prop_assert!((quaternion::norm(&q) - 1.0).abs() <= 1e-12);
        }
        prop_assert!(angle_to(&dmp.goal_quaternion(), last_quaternion(&tr)) <= 1e-6);
        let p = &tr.position[tr.position.len() - 3..];
        prop_assert!((p[0] - 0.5).abs() <= 1e-6 && (p[1] + 0.2).abs() <= 1e-6 && (p[2] - 0.1).abs() <= 1e-6);
    }

    /// With a new goal pose (of either sign) the movement ends there.
    #[test]
    fn with_a_new_goal_the_movement_ends_there(
        axis in prop::array::uniform3(-1.0f64..1.0), angle in -3.0f64..3.0, flip in any::<bool>(),
        position in prop::array::uniform3(-1.0f64..1.0),
    ) {
        let axis = Vector3::from(axis);
        prop_assume!(axis.norm() > 0.1);
        let (t, pose) = general_demo(1.0);
        let dmp = CartesianDmp::fit(&demo(&t, &pose), config(25)).unwrap();
        let q = axis_angle(&axis, angle).map(|c| if flip { -c } else { c });
        let new = dmp.with_goal(&[position[0], position[1], position[2], q[0], q[1], q[2], q[3]]).unwrap();
        let opts = RolloutOptions { until_rest: true, rest_tol: 1e-8, ..RolloutOptions::new(0.001) };
        let tr = new.rollout(&opts).unwrap();
        prop_assert!(angle_to(&q, last_quaternion(&tr)) <= 1e-6);
        let end = &tr.position[tr.position.len() - 3..];
        for (got, want) in end.iter().zip(position) {
            prop_assert!((got - want).abs() <= 1e-6);
        }
    }
}

/// Fitting the demo rotated by a constant R (positions and orientations) gives the rollout
/// rotated by R.
#[test]
fn a_rotated_demo_gives_the_rotated_rollout() {
    let (t, pose) = general_demo(1.3);
    let rot = Rotation3::from_scaled_axis(Vector3::new(0.4, -1.1, 0.7));
    let r = UnitQuaternion::from_rotation_matrix(&rot);
    let mut rotated = pose.clone();
    for j in 0..N {
        let p = rot * Vector3::new(pose[(0, j)], pose[(1, j)], pose[(2, j)]);
        let q = r * to_nalgebra(pose.column(j).rows(3, 4).as_slice());
        let qc = q.quaternion().coords; // (x, y, z, w)
        for (row, v) in [p.x, p.y, p.z, qc[3], qc[0], qc[1], qc[2]]
            .into_iter()
            .enumerate()
        {
            rotated[(row, j)] = v;
        }
    }
    let opts = RolloutOptions {
        duration: Some(2.0),
        ..RolloutOptions::new(0.001)
    };
    let a = CartesianDmp::fit(&demo(&t, &pose), config(30))
        .unwrap()
        .rollout(&opts)
        .unwrap();
    let b = CartesianDmp::fit(&demo(&t, &rotated), config(30))
        .unwrap()
        .rollout(&opts)
        .unwrap();
    for j in 0..a.n_samples() {
        let pa = rot * Vector3::from_column_slice(&a.position[3 * j..3 * j + 3]);
        let pb = Vector3::from_column_slice(&b.position[3 * j..3 * j + 3]);
        assert!((pa - pb).amax() < 1e-9, "position at j={j}");
        let qa = r * to_nalgebra(&a.quaternion[4 * j..4 * j + 4]);
        let qb = to_nalgebra(&b.quaternion[4 * j..4 * j + 4]);
        assert!(
            qa.angle_to(&qb) < 1e-9,
            "orientation at j={j}: {}",
            qa.angle_to(&qb)
        );
        let wa = rot * Vector3::from_column_slice(&a.angular_velocity[3 * j..3 * j + 3]);
        let wb = Vector3::from_column_slice(&b.angular_velocity[3 * j..3 * j + 3]);
        assert!((wa - wb).amax() < 1e-8, "angular velocity at j={j}");
    }
}

/// Samples alternating between q and -q (the same rotations) fit exactly as the continuous demo.
#[test]
fn alternating_signs_fit_as_if_continuous() {
    let (t, pose) = general_demo(1.0);
    let mut flipped = pose.clone();
    for j in (1..N).step_by(2) {
        for r in 3..7 {
            flipped[(r, j)] = -pose[(r, j)];
        }
    }
    let a = CartesianDmp::fit(&demo(&t, &pose), config(25)).unwrap();
    let b = CartesianDmp::fit(&demo(&t, &flipped), config(25)).unwrap();
    assert_eq!(a, b);
}

/// The fitted DMP reproduces its demonstration (a sanity bound, not a truth: the fit is least
/// squares on 25 kernels).
#[test]
fn the_fit_reproduces_the_demo() {
    let (t, pose) = general_demo(1.0);
    let dmp = CartesianDmp::fit(&demo(&t, &pose), config(40)).unwrap();
    let opts = RolloutOptions::new((t[1] - t[0]) / 4.0);
    let tr = dmp.rollout(&opts).unwrap();
    let mut worst: f64 = 0.0;
    for j in 0..N {
        let k = 4 * j;
        worst = worst.max(angle_to(
            &[pose[(3, j)], pose[(4, j)], pose[(5, j)], pose[(6, j)]],
            &tr.quaternion[4 * k..4 * k + 4],
        ));
    }
    assert!(worst < 2e-3, "worst orientation error {worst} rad");
}

#[test]
fn bad_quaternions_are_refused_naming_the_sample() {
    let (t, mut pose) = general_demo(1.0);
    pose[(3, 17)] *= 1.01;
    let err = CartesianDmp::fit(&demo(&t, &pose), config(10)).unwrap_err();
    assert!(err.to_string().contains("pose[17]"), "{err}");
    let ok = CartesianDmp::fit(
        &CartesianDemonstration {
            normalize: true,
            ..demo(&t, &pose)
        },
        config(10),
    );
    assert!(ok.is_ok());
    for r in 3..7 {
        pose[(r, 5)] = 0.0;
    }
    let err = CartesianDmp::fit(
        &CartesianDemonstration {
            normalize: true,
            ..demo(&t, &pose)
        },
        config(10),
    )
    .unwrap_err();
    assert!(
        err.to_string().contains("pose[5]") && err.to_string().contains("zero"),
        "{err}"
    );
}
