//! Tests of [`crate::sequence`]: the joins against the integrator's own relations and their
//! order in dt, the one-movement case against the DMP, the rollout against the stepper.

use nalgebra::{DMatrix, DVector};
use proptest::prelude::*;

use super::*;
use crate::chain::testing::{self, bits, halved};
use crate::dmp::DmpConfig;

/// A DMP with a shape of its own (`seed`) from `start` to `goal`, not at rest at tau.
fn shaped(seed: f64, start: &[f64], goal: &[f64], tau: f64) -> Dmp {
    let cfg = DmpConfig::default();
    let n = goal.len();
    let w = DMatrix::from_fn(cfg.n_basis, n, |k, d| {
        60.0 * libm::sin(0.7 * k as f64 + 1.3 * d as f64 + seed)
    });
    Dmp::new(
        cfg,
        w,
        DVector::from_column_slice(goal),
        DVector::from_column_slice(start),
        tau,
    )
    .unwrap()
}

/// Three movements of 3 DOFs, each starting at the goal of the one before.
fn three() -> Vec<Dmp> {
    vec![
        shaped(0.0, &[0.0, 0.5, -0.2], &[1.0, -0.3, 0.4], 0.6),
        shaped(1.1, &[1.0, -0.3, 0.4], &[0.2, 0.7, 1.0], 0.45),
        shaped(2.3, &[0.2, 0.7, 1.0], &[-0.5, 0.1, 0.3], 0.8),
    ]
}

fn open_loop(dt: f64) -> StepperOptions {
    StepperOptions {
        goal_filter: None,
        ..StepperOptions::new(dt)
    }
}

/// The samples at which a movement after the first begins, found by stepping.
fn joins(dmps: &[Dmp], dt: f64, samples: usize) -> Vec<usize> {
    testing::joins(SequenceStepper::new(dmps, &open_loop(dt)).unwrap(), samples)
}

/// The largest jump of `v` (time-major, `n` per sample) from sample `j - 1` to `j`.
fn jump(v: &[f64], n: usize, j: usize) -> f64 {
    (0..n)
        .map(|d| (v[j * n + d] - v[(j - 1) * n + d]).abs())
        .fold(0.0, f64::max)
}

#[test]
fn a_sequence_of_one_is_its_dmp() {
    let dmp = shaped(0.4, &[0.1, -0.2], &[0.9, 0.3], 0.7);
    for opts in [
        RolloutOptions::new(1e-3),
        RolloutOptions {
            until_rest: true,
            ..RolloutOptions::new(4e-3)
        },
    ] {
        let seq = rollout(std::slice::from_ref(&dmp), &opts).unwrap();
        let own = dmp.rollout(&opts).unwrap();
        assert_eq!(bits(&seq.t), bits(&own.t));
        for (a, b) in [(&seq.y, &own.y), (&seq.yd, &own.yd), (&seq.ydd, &own.ydd)] {
            assert_eq!(bits(a), bits(b));
        }
    }
    // The stepper, under phase stopping too.
    let opts = StepperOptions::new(1e-3);
    let mut seq = SequenceStepper::new(std::slice::from_ref(&dmp), &opts).unwrap();
    let mut own = Stepper::new(&dmp, &opts).unwrap();
    for k in 0..4000 {
        let lag = if (200..400).contains(&k) { 0.01 } else { 0.0 };
        let m: Vec<f64> = own.output().0.iter().map(|y| y - lag).collect();
        let a = seq.step(Some(&m)).unwrap();
        let a = (bits(a.0), bits(a.1), bits(a.2));
        let b = own.step(Some(&m)).unwrap();
        assert_eq!(a, (bits(b.0), bits(b.1), bits(b.2)), "step {k}");
        assert_eq!(seq.done(), own.done());
    }
    assert!(seq.done());
}

#[test]
fn the_rollout_is_the_stepper() {
    let dmps = three();
    let dt = 1e-3;
    let tr = rollout(&dmps, &RolloutOptions::new(dt)).unwrap();
    let mut s = SequenceStepper::new(&dmps, &open_loop(dt)).unwrap();
    for j in 0..tr.n_samples() {
        let (y, yd, ydd) = s.step(None).unwrap();
        let r = j * 3..(j + 1) * 3;
        assert_eq!(bits(y), bits(&tr.y[r.clone()]), "sample {j}");
        assert_eq!(bits(yd), bits(&tr.yd[r.clone()]), "sample {j}");
        assert_eq!(bits(ydd), bits(&tr.ydd[r]), "sample {j}");
    }
    // The movements follow one another at their taus: 600 + 450 samples, then the last's 801.
    assert_eq!(tr.n_samples(), 600 + 450 + 801);
    assert_eq!(joins(&dmps, dt, tr.n_samples()), vec![600, 1050]);
}

/// Position and velocity go on as the integrator's Euler step takes them; the acceleration's
/// jump is first order in dt (halves with dt), where an unaided start jumps by the difference
/// of the two movements' accelerations whatever dt.
#[test]
fn joins_are_continuous_to_the_integrators_order() {
    let dmps = three();
    let mut last = None;
    for dt in [2e-3, 1e-3, 5e-4] {
        let tr = rollout(&dmps, &RolloutOptions::new(dt)).unwrap();
        let n = 3;
        let at = joins(&dmps, dt, tr.n_samples());
        assert_eq!(at.len(), 2);
        let mut jumps = Vec::new();
        for &j in &at {
            for d in 0..n {
                let (p, c) = ((j - 1) * n + d, j * n + d);
                let y = tr.y[p] + tr.yd[p] * dt;
                let yd = tr.yd[p] + tr.ydd[p] * dt;
                assert!((tr.y[c] - y).abs() < 1e-12, "y at {j}: {} {y}", tr.y[c]);
                assert!(
                    (tr.yd[c] - yd).abs() < 1e-10,
                    "yd at {j}: {} {yd}",
                    tr.yd[c]
                );
            }
            jumps.push(jump(&tr.ydd, n, j));
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
    let s = SequenceStepper::new(&dmps, &open_loop(dt)).unwrap();
    let at = testing::unaided_jumps(s, tr.n_samples());
    assert_eq!(at.len(), 2);
    for (j, unaided) in at {
        // The join's term at its first sample is the jump it removes.
        let unaided = unaided.iter().fold(0.0, |m: f64, a| m.max(*a));
        let joined = jump(&tr.ydd, 3, j);
        assert!(unaided > 100.0 * joined, "{unaided} vs {joined} at {j}");
    }
}

/// Each movement started in motion ends where its DMP's own rollout from rest at the same
/// start ends: the start's transient and the join's term have faded by tau.
#[test]
fn each_movement_follows_its_own_shape() {
    let dmps = three();
    let dt = 1e-3;
    let tr = rollout(&dmps, &RolloutOptions::new(dt)).unwrap();
    let at = joins(&dmps, dt, tr.n_samples());
    let ends = [at[1] - 1, tr.n_samples() - 1];
    for (k, (&j0, &end)) in at.iter().zip(&ends).enumerate() {
        let dmp = &dmps[k + 1];
        let start = DVector::from_column_slice(&tr.y[j0 * 3..j0 * 3 + 3]);
        let own = dmp.with_start(start).unwrap();
        let own = own.rollout(&RolloutOptions::new(dt)).unwrap();
        let local = end - j0;
        for d in 0..3 {
            let e = (tr.y[end * 3 + d] - own.y[local * 3 + d]).abs();
            assert!(e < 1e-6, "movement {} DOF {d}: {e}", k + 1);
        }
    }
}

/// A held robot holds the movement that runs: the hand-over comes later, the joins stay
/// continuous, and the sequence still ends at the last goal.
#[test]
fn phase_stopping_delays_the_hand_over() {
    let dmps = three();
    let dt = 1e-3;
    let mut s = SequenceStepper::new(&dmps, &StepperOptions::new(dt)).unwrap();
    let mut held = None;
    let mut at = Vec::new();
    let mut prev: Option<Vec<f64>> = None;
    for j in 0..20_000 {
        let m = match (j, &held) {
            (300..700, Some(h)) => Some(h),
            (300..700, None) => {
                held = Some(s.output().0.to_vec());
                held.as_ref()
            }
            _ => None,
        };
        let before = s.active();
        let m = m.cloned();
        let (_, _, ydd) = s.step(m.as_deref()).unwrap();
        let ydd = ydd.to_vec();
        if s.active() != before {
            at.push(j);
            let p = prev.as_ref().unwrap();
            let jump = (0..3).map(|d| (ydd[d] - p[d]).abs()).fold(0.0, f64::max);
            assert!(jump < 1.0, "{jump} at {j}");
        }
        prev = Some(ydd);
        if s.done() {
            break;
        }
    }
    assert!(s.done());
    assert_eq!(at.len(), 2);
    assert!(at[0] > 700, "{at:?}");
    let goal = dmps[2].goal();
    for d in 0..3 {
        assert!((s.output().0[d] - goal[d]).abs() <= 1e-4);
    }
}

#[test]
fn until_rest_ends_at_the_last_goal() {
    let dmps = three();
    let opts = RolloutOptions {
        until_rest: true,
        ..RolloutOptions::new(1e-3)
    };
    let tr = rollout(&dmps, &opts).unwrap();
    assert!(tr.n_samples() > 1851);
    let last = tr.y.len() - 3;
    for d in 0..3 {
        assert!((tr.y[last + d] - dmps[2].goal()[d]).abs() <= 1e-4);
    }
    let with_duration = RolloutOptions {
        duration: Some(1.0),
        ..RolloutOptions::new(1e-3)
    };
    assert_eq!(rollout(&dmps, &with_duration).unwrap().n_samples(), 1001);
}

#[test]
fn bad_input_is_refused_by_name() {
    let dmps = three();
    let err = |r: Result<Trajectory>| r.unwrap_err().to_string();
    assert!(err(rollout(&[], &RolloutOptions::new(1e-3))).contains("dmps"));
    let mixed = [dmps[0].clone(), shaped(0.0, &[0.0], &[1.0], 0.5)];
    let e = err(rollout(&mixed, &RolloutOptions::new(1e-3)));
    assert!(e.contains("dmps[1]"), "{e}");
    assert!(err(rollout(&dmps, &RolloutOptions::new(f64::NAN))).contains("dt"));
    let limited = StepperOptions {
        velocity_max: Some(vec![1.0; 3]),
        ..StepperOptions::new(1e-3)
    };
    let e = SequenceStepper::new(&dmps, &limited)
        .unwrap_err()
        .to_string();
    assert!(e.contains("velocity_max"), "{e}");
    let moving = dmps[2]
        .with_final_velocity(DVector::from_element(3, 0.5))
        .unwrap();
    let ends_moving = [dmps[0].clone(), moving];
    let opts = RolloutOptions {
        until_rest: true,
        ..RolloutOptions::new(1e-3)
    };
    assert!(err(rollout(&ends_moving, &opts)).contains("until_rest"));
    let mut s = SequenceStepper::new(&dmps, &open_loop(1e-3)).unwrap();
    assert!(
        s.step(Some(&[0.0]))
            .unwrap_err()
            .to_string()
            .contains("measured")
    );
    assert_eq!(s.steps(), 0);
}

#[test]
fn a_final_velocity_hands_over_in_motion() {
    // A hit at 1.5 rad/s, then a movement that brings the arm to rest.
    let cfg = DmpConfig::default();
    let flat = |g: f64, y0: f64, tau: f64| {
        Dmp::new(
            cfg,
            DMatrix::zeros(cfg.n_basis, 1),
            DVector::from_element(1, g),
            DVector::from_element(1, y0),
            tau,
        )
        .unwrap()
    };
    let hit = flat(1.0, 0.0, 0.5)
        .with_final_velocity(DVector::from_element(1, 1.5))
        .unwrap();
    let dt = 1e-3;
    let tr = rollout(&[hit, flat(1.2, 1.0, 0.5)], &RolloutOptions::new(dt)).unwrap();
    let j = 500;
    assert!((tr.y[j] - 1.0).abs() < 2e-3, "{}", tr.y[j]);
    assert!((tr.yd[j] - 1.5).abs() < 1e-2, "{}", tr.yd[j]);
    assert!((tr.y[j] - tr.y[j - 1] - tr.yd[j - 1] * dt).abs() < 1e-12);
}

/// Random sequences: every join continues the integrator's Euler step in position and velocity,
/// and is no rougher in acceleration than the roughest sample inside a movement.
fn random_sequence() -> impl Strategy<Value = (Vec<Dmp>, f64)> {
    (1usize..4, 2usize..4, prop_oneof![Just(1e-3), Just(4e-3)]).prop_flat_map(|(n, m, dt)| {
        let movement = (
            proptest::collection::vec(-80.0f64..80.0, 10 * n),
            proptest::collection::vec(-2.0f64..2.0, n),
            0.2f64..1.5,
        );
        (proptest::collection::vec(movement, m), Just(dt)).prop_map(move |(ms, dt)| {
            let cfg = DmpConfig {
                n_basis: 10,
                ..DmpConfig::default()
            };
            let dmps = ms
                .into_iter()
                .map(|(w, g, tau)| {
                    let (w, g) = (DMatrix::from_vec(10, n, w), DVector::from_vec(g));
                    Dmp::new(cfg, w, g, DVector::zeros(n), tau).unwrap()
                })
                .collect();
            (dmps, dt)
        })
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]
    #[test]
    fn joins_continue_the_integrator((dmps, dt) in random_sequence()) {
        let n = dmps[0].n_dof();
        let tr = rollout(&dmps, &RolloutOptions::new(dt)).unwrap();
        let at = joins(&dmps, dt, tr.n_samples());
        prop_assert_eq!(at.len(), dmps.len() - 1);
        let inside = (1..tr.n_samples())
            .filter(|j| !at.contains(j))
            .map(|j| jump(&tr.ydd, n, j))
            .fold(0.0, f64::max);
        for &j in &at {
            for d in 0..n {
                let (p, c) = ((j - 1) * n + d, j * n + d);
                let scale = 1.0 + tr.y[p].abs() + tr.yd[p].abs() + tr.ydd[p].abs() * dt;
                prop_assert!((tr.y[c] - tr.y[p] - tr.yd[p] * dt).abs() < 1e-12 * scale);
                let yd = tr.yd[p] + tr.ydd[p] * dt;
                prop_assert!((tr.yd[c] - yd).abs() < 1e-11 * scale);
            }
            prop_assert!(jump(&tr.ydd, n, j) <= 1.01 * inside + 1e-9, "{} vs {}", jump(&tr.ydd, n, j), inside);
        }
    }
}
