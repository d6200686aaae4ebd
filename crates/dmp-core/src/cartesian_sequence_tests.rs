//! Tests of [`crate::cartesian_sequence`]: the joins against the integrator's own relations and
//! their order in dt, the one-movement case against the DMP, the rollout against the stepper,
//! and a rotation about one axis against the joint sequence on the angle.

use nalgebra::{DMatrix, DVector};

use super::*;
use crate::chain::testing::{self, bits, halved};
use crate::dmp::{Dmp, DmpConfig};
use crate::quaternion::{self, Quaternion};

/// A unit quaternion of `angle` (rad) about the unit `axis`.
fn about(axis: [f64; 3], angle: f64) -> Quaternion {
    quaternion::exp(&axis.map(|c| 0.5 * angle * c))
}

fn pose(p: [f64; 3], q: Quaternion) -> [f64; POSE_WIDTH] {
    [p[0], p[1], p[2], q[0], q[1], q[2], q[3]]
}

/// Weights with a shape of their own (`seed`), zero on the orientation rows not in `rows`.
fn weights(seed: f64, rows: &[usize]) -> DMatrix<f64> {
    let cfg = DmpConfig::default();
    DMatrix::from_fn(cfg.n_basis, 6, |k, d| {
        let on = d < 3 || rows.contains(&d);
        if on {
            40.0 * libm::sin(0.7 * k as f64 + 1.3 * d as f64 + seed)
        } else {
            0.0
        }
    })
}

fn shaped(seed: f64, start: [f64; 7], goal: [f64; 7], tau: f64) -> CartesianDmp {
    CartesianDmp::new(
        DmpConfig::default(),
        weights(seed, &[3, 4, 5]),
        &goal,
        &start,
        tau,
    )
    .unwrap()
}

/// Three movements, each starting at the goal pose of the one before (reach, pour, return).
fn three() -> Vec<CartesianDmp> {
    let a = pose([0.0, 0.5, -0.2], about([0.0, 0.0, 1.0], 0.2));
    let b = pose([0.6, -0.3, 0.4], about([0.6, 0.0, 0.8], 1.1));
    let c = pose([0.2, 0.4, 0.6], about([0.0, 1.0, 0.0], -0.9));
    let d = pose([-0.3, 0.1, 0.3], about([0.0, 0.0, 1.0], 0.4));
    vec![
        shaped(0.0, a, b, 0.6),
        shaped(1.1, b, c, 0.45),
        shaped(2.3, c, d, 0.8),
    ]
}

fn open_loop(dt: f64) -> CartesianStepperOptions {
    CartesianStepperOptions {
        base: StepperOptions {
            goal_filter: None,
            ..StepperOptions::new(dt)
        },
        ..CartesianStepperOptions::new(dt)
    }
}

fn same_bits(a: &CartesianTrajectory, b: &CartesianTrajectory) {
    assert_eq!(bits(&a.t), bits(&b.t));
    assert_eq!(bits(&a.position), bits(&b.position));
    assert_eq!(bits(&a.quaternion), bits(&b.quaternion));
    assert_eq!(bits(&a.velocity), bits(&b.velocity));
    assert_eq!(bits(&a.acceleration), bits(&b.acceleration));
    assert_eq!(bits(&a.angular_velocity), bits(&b.angular_velocity));
    assert_eq!(bits(&a.angular_acceleration), bits(&b.angular_acceleration));
}

/// The samples at which a movement after the first begins, found by stepping.
fn joins(dmps: &[CartesianDmp], dt: f64, samples: usize) -> Vec<usize> {
    testing::joins(
        CartesianSequenceStepper::new(dmps, &open_loop(dt)).unwrap(),
        samples,
    )
}

/// The largest jump of `v` (time-major, 3 per sample) from sample `j - 1` to `j`.
fn jump(v: &[f64], j: usize) -> f64 {
    (0..3)
        .map(|d| (v[j * 3 + d] - v[(j - 1) * 3 + d]).abs())
        .fold(0.0, f64::max)
}

fn quat(tr: &CartesianTrajectory, j: usize) -> Quaternion {
    [0, 1, 2, 3].map(|c| tr.quaternion[4 * j + c])
}

/// The angle (rad) between two orientations (from the rotation vector, exact near 0 where
/// `acos` of the dot product is not).
fn angle(a: &Quaternion, b: &Quaternion) -> f64 {
    let d = quaternion::same_hemisphere(
        &quaternion::product(a, &quaternion::conjugate(b)),
        &quaternion::IDENTITY,
    );
    let r = quaternion::log(&d);
    2.0 * (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt()
}

#[test]
fn a_sequence_of_one_is_its_dmp() {
    let dmp = three().remove(1);
    for opts in [
        RolloutOptions::new(1e-3),
        RolloutOptions {
            until_rest: true,
            ..RolloutOptions::new(4e-3)
        },
    ] {
        let seq = rollout(std::slice::from_ref(&dmp), &opts).unwrap();
        same_bits(&seq, &dmp.rollout(&opts).unwrap());
    }
}

#[test]
fn the_rollout_is_the_stepper_and_deterministic() {
    let dmps = three();
    let dt = 1e-3;
    let tr = rollout(&dmps, &RolloutOptions::new(dt)).unwrap();
    same_bits(&tr, &rollout(&dmps, &RolloutOptions::new(dt)).unwrap());
    let mut s = CartesianSequenceStepper::new(&dmps, &open_loop(dt)).unwrap();
    for round in 0..2 {
        for j in 0..tr.n_samples() {
            let (p, v, a) = s.step(None).unwrap();
            assert_eq!(bits(&p[..3]), bits(&tr.position[3 * j..3 * j + 3]), "{j}");
            assert_eq!(bits(&p[3..]), bits(&tr.quaternion[4 * j..4 * j + 4]), "{j}");
            assert_eq!(bits(&v[..3]), bits(&tr.velocity[3 * j..3 * j + 3]), "{j}");
            assert_eq!(bits(&v[3..]), bits(&tr.angular_velocity[3 * j..3 * j + 3]));
            assert_eq!(bits(&a[..3]), bits(&tr.acceleration[3 * j..3 * j + 3]));
            assert_eq!(
                bits(&a[3..]),
                bits(&tr.angular_acceleration[3 * j..3 * j + 3])
            );
        }
        assert_eq!(s.active(), 2, "round {round}");
        s.reset(None).unwrap();
    }
    assert_eq!(tr.n_samples(), 600 + 450 + 801);
    assert_eq!(joins(&dmps, dt, tr.n_samples()), vec![600, 1050]);
}

/// Position, orientation and both velocities go on as the integrator's step takes them; both
/// accelerations' jumps are first order in dt (halve with dt), where an unaided start jumps by
/// the difference of the two movements' accelerations whatever dt.
#[test]
fn joins_are_continuous_to_the_integrators_order() {
    let dmps = three();
    let mut last: Option<Vec<f64>> = None;
    for dt in [2e-3, 1e-3, 5e-4] {
        let tr = rollout(&dmps, &RolloutOptions::new(dt)).unwrap();
        let at = joins(&dmps, dt, tr.n_samples());
        assert_eq!(at.len(), 2);
        let mut jumps = Vec::new();
        for &j in &at {
            let p = j - 1;
            for d in 0..3 {
                let (a, b) = (3 * p + d, 3 * j + d);
                let y = tr.position[a] + tr.velocity[a] * dt;
                let v = tr.velocity[a] + tr.acceleration[a] * dt;
                let w = tr.angular_velocity[a] + tr.angular_acceleration[a] * dt;
                assert!((tr.position[b] - y).abs() < 1e-12, "p at {j}");
                assert!((tr.velocity[b] - v).abs() < 1e-10, "v at {j}");
                assert!((tr.angular_velocity[b] - w).abs() < 1e-10, "omega at {j}");
            }
            let omega = [0, 1, 2].map(|d| tr.angular_velocity[3 * p + d]);
            let q = quaternion::product(
                &quaternion::exp(&omega.map(|c| 0.5 * dt * c)),
                &quat(&tr, p),
            );
            assert!(angle(&q, &quat(&tr, j)) < 1e-12, "q at {j}");
            // The commanded quaternion keeps its sign across the join.
            assert!(quaternion::dot(&quat(&tr, p), &quat(&tr, j)) > 0.0);
            jumps.push(jump(&tr.acceleration, j));
            jumps.push(jump(&tr.angular_acceleration, j));
        }
        if let Some(before) = last.replace(jumps.clone()) {
            halved(&before, &jumps, dt);
        }
    }
}

#[test]
fn an_unaided_start_would_jump() {
    let dmps = three();
    let dt = 1e-3;
    let tr = rollout(&dmps, &RolloutOptions::new(dt)).unwrap();
    let s = CartesianSequenceStepper::new(&dmps, &open_loop(dt)).unwrap();
    let at = testing::unaided_jumps(s, tr.n_samples());
    assert_eq!(at.len(), 2);
    for (j, unaided) in at {
        let (linear, angular) = unaided.split_at(3);
        let largest = |v: &[f64]| v.iter().fold(0.0, |m: f64, a| m.max(*a));
        assert!(
            largest(linear) > 100.0 * jump(&tr.acceleration, j),
            "at {j}"
        );
        assert!(
            largest(angular) > 100.0 * jump(&tr.angular_acceleration, j),
            "at {j}"
        );
    }
}

/// Each movement started in motion ends where its DMP's own rollout from rest at the same
/// start ends, and the last one comes to rest at its goal pose; every quaternion is unit.
#[test]
fn each_movement_reaches_its_own_end() {
    let dmps = three();
    let dt = 1e-3;
    let opts = RolloutOptions {
        until_rest: true,
        ..RolloutOptions::new(dt)
    };
    let tr = rollout(&dmps, &opts).unwrap();
    let at = joins(&dmps, dt, 600 + 450 + 801);
    let ends = [at[1] - 1, 600 + 450 + 800];
    for (k, (&j0, &end)) in at.iter().zip(&ends).enumerate() {
        let start = pose([0, 1, 2].map(|d| tr.position[3 * j0 + d]), quat(&tr, j0));
        let own = dmps[k + 1].with_start(&start).unwrap();
        let own = own.rollout(&RolloutOptions::new(dt)).unwrap();
        let local = end - j0;
        for d in 0..3 {
            let e = (tr.position[3 * end + d] - own.position[3 * local + d]).abs();
            assert!(e < 1e-6, "movement {} position {d}: {e}", k + 1);
        }
        let e = angle(&quat(&tr, end), &quat(&own, local));
        assert!(e < 1e-6, "movement {} orientation: {e}", k + 1);
    }
    let last = tr.n_samples() - 1;
    let goal = dmps[2].goal();
    for (p, g) in tr.position[3 * last..].iter().zip(&goal) {
        assert!((p - g).abs() <= 1e-4);
    }
    let g = [goal[3], goal[4], goal[5], goal[6]];
    assert!(angle(&quat(&tr, last), &g) <= 1e-4);
    for j in 0..tr.n_samples() {
        assert!((quaternion::norm(&quat(&tr, j)) - 1.0).abs() < 1e-12, "{j}");
    }
}

/// A rotation about one fixed axis is a joint DMP on the angle: the Cartesian sequence's
/// angle is the joint sequence's (an independent implementation of the join).
#[test]
fn a_rotation_about_one_axis_is_the_joint_sequence_on_the_angle() {
    let z = [0.0, 0.0, 1.0];
    let poses = [
        ([0.0, 0.5, -0.2], 0.3),
        ([0.6, -0.3, 0.4], 1.2),
        ([0.2, 0.4, 0.6], -0.5),
        ([-0.3, 0.1, 0.3], 0.1),
    ];
    let taus = [0.6, 0.45, 0.8];
    let mut cart = Vec::new();
    let mut joint = Vec::new();
    for k in 0..3 {
        let w = weights(0.9 * k as f64, &[5]);
        let (s, g) = (poses[k], poses[k + 1]);
        let start = pose(s.0, about(z, s.1));
        let goal = pose(g.0, about(z, g.1));
        cart.push(
            CartesianDmp::new(DmpConfig::default(), w.clone(), &goal, &start, taus[k]).unwrap(),
        );
        let cols = w.select_columns(&[0, 1, 2, 5]);
        let y0 = DVector::from_vec(vec![s.0[0], s.0[1], s.0[2], s.1]);
        let yg = DVector::from_vec(vec![g.0[0], g.0[1], g.0[2], g.1]);
        joint.push(Dmp::new(DmpConfig::default(), cols, yg, y0, taus[k]).unwrap());
    }
    let opts = RolloutOptions::new(1e-3);
    let c = rollout(&cart, &opts).unwrap();
    let j = crate::sequence::rollout(&joint, &opts).unwrap();
    assert_eq!(c.n_samples(), j.n_samples());
    for i in 0..c.n_samples() {
        let q = quat(&c, i);
        assert!(q[1].abs() < 1e-15 && q[2].abs() < 1e-15);
        let theta = 2.0 * q[3].atan2(q[0]);
        let tol = 1e-9;
        assert!((theta - j.y[4 * i + 3]).abs() < tol, "angle at {i}");
        assert!(
            (c.angular_velocity[3 * i + 2] - j.yd[4 * i + 3]).abs() < 1e-7,
            "omega at {i}"
        );
        let e = (c.angular_acceleration[3 * i + 2] - j.ydd[4 * i + 3]).abs();
        assert!(
            e < 1e-5 * j.ydd[4 * i + 3].abs().max(1.0),
            "omegadot at {i}: {e}"
        );
        for d in 0..3 {
            assert!((c.position[3 * i + d] - j.y[4 * i + d]).abs() < 1e-12);
        }
    }
}

#[test]
fn bad_input_is_refused_by_name() {
    let name = |e: Error| match e {
        Error::InvalidParameter { name, .. } | Error::Shape { name, .. } => name,
        Error::NonFinite { name, .. } | Error::Quaternion { name, .. } => name,
        e => panic!("{e:?}"),
    };
    let dt = 1e-3;
    let e = rollout(&[], &RolloutOptions::new(dt)).unwrap_err();
    assert_eq!(name(e), "dmps");
    let e = CartesianSequenceStepper::new(&[], &open_loop(dt)).unwrap_err();
    assert_eq!(name(e), "dmps");
    let mut limited = open_loop(dt);
    limited.base.velocity_max = Some(vec![1.0; 6]);
    let e = CartesianSequenceStepper::new(&three(), &limited).unwrap_err();
    assert_eq!(name(e), "velocity_max/acceleration_max");
    // A refused step changes nothing, at a join too.
    let mut s = CartesianSequenceStepper::new(&three(), &open_loop(dt)).unwrap();
    for _ in 0..600 {
        s.step(None).unwrap();
    }
    let before = s.clone();
    let e = s.step(Some(&[0.0; 7])).unwrap_err();
    assert_eq!(name(e), "measured");
    let e = s.step_coupled(None, Some(&[0.0; 5])).unwrap_err();
    assert_eq!(name(e), "coupling");
    assert_eq!(s.active(), before.active());
    assert_eq!(s.steps(), before.steps());
}

/// A movement whose DMP holds its quaternions with the other sign turns the same way and
/// commands the same quaternions: the hand-over keeps the sign the sequence runs with.
#[test]
fn the_quaternions_sign_does_not_matter() {
    let dmps = three();
    let flip = |p: [f64; 7]| [p[0], p[1], p[2], -p[3], -p[4], -p[5], -p[6]];
    let mut flipped = dmps.clone();
    let d = &dmps[1];
    flipped[1] = CartesianDmp::new(
        *d.config(),
        d.weights().clone(),
        &flip(d.goal()),
        &flip(d.start()),
        d.tau(),
    )
    .unwrap();
    let opts = RolloutOptions::new(1e-3);
    same_bits(
        &rollout(&dmps, &opts).unwrap(),
        &rollout(&flipped, &opts).unwrap(),
    );
}
