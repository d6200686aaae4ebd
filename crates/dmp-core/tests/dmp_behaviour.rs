//! Behaviour of the DMP against independent truth: the closed-form critically damped spring,
//! symmetries of eqs. 1-3, and reproduction of smooth demonstrations.

use dmp_core::{Demonstration, Dmp, DmpConfig, Error, RolloutOptions, rollout_batch};
use nalgebra::{DMatrix, DVector};
use proptest::prelude::*;

fn zero_weight_dmp(y0: f64, g: f64, tau: f64) -> Dmp {
    let cfg = DmpConfig::default();
    Dmp::new(
        cfg,
        DMatrix::zeros(cfg.n_basis, 1),
        DVector::from_element(1, g),
        DVector::from_element(1, y0),
        tau,
    )
    .unwrap()
}

/// With w = 0, eqs. 1-2 are tau^2 ydd + alpha_z tau yd + alpha_z beta_z (y - g) = 0, critically
/// damped for beta_z = alpha_z/4 with omega = alpha_z / (2 tau), starting at rest:
/// y(t) = g + (y0 - g)(1 + omega t) exp(-omega t).
fn spring(y0: f64, g: f64, tau: f64, t: f64) -> f64 {
    let omega = 48.0 / (2.0 * tau);
    g + (y0 - g) * (1.0 + omega * t) * (-omega * t).exp()
}

fn max_spring_error(dt: f64) -> f64 {
    let (y0, g, tau) = (0.3, 1.7, 0.8);
    let tr = zero_weight_dmp(y0, g, tau)
        .rollout(&RolloutOptions::new(dt))
        .unwrap();
    tr.t.iter()
        .zip(&tr.y)
        .map(|(&t, &y)| (y - spring(y0, g, tau, t)).abs())
        .fold(0.0, f64::max)
}

#[test]
fn zero_weights_follow_the_closed_form_spring_and_error_shrinks_with_dt() {
    let coarse = max_spring_error(1e-3);
    let fine = max_spring_error(1e-4);
    assert!(coarse < 0.02 * 1.4, "dt=1e-3 error {coarse}");
    assert!(fine < 0.003 * 1.4, "dt=1e-4 error {fine}");
    // Explicit Euler is first order: ten times smaller steps, about ten times smaller error.
    let ratio = coarse / fine;
    assert!((7.0..13.0).contains(&ratio), "error ratio {ratio}");
}

/// A smooth 3-DOF demonstration that starts and ends at rest (minimum jerk plus a bump).
fn demo(n: usize, duration: f64) -> (Vec<f64>, DMatrix<f64>) {
    let t: Vec<f64> = (0..n)
        .map(|j| duration * j as f64 / (n - 1) as f64)
        .collect();
    let mut y = DMatrix::zeros(3, n);
    for (j, &tj) in t.iter().enumerate() {
        let s = tj / duration;
        let mj = 10.0 * s.powi(3) - 15.0 * s.powi(4) + 6.0 * s.powi(5);
        y[(0, j)] = mj;
        y[(1, j)] = 0.5 - 2.0 * mj;
        y[(2, j)] = 0.3 * (std::f64::consts::PI * s).sin().powi(2);
    }
    (t, y)
}

fn fit(t: &[f64], y: &DMatrix<f64>, n_basis: usize) -> Dmp {
    let demo = Demonstration {
        t,
        y: y.as_view(),
        yd: None,
        ydd: None,
    };
    Dmp::fit(
        &demo,
        DmpConfig {
            n_basis,
            ..DmpConfig::default()
        },
    )
    .unwrap()
}

#[test]
fn fit_then_rollout_reproduces_a_smooth_demo_within_one_percent() {
    let (t, y) = demo(1001, 1.0);
    let dmp = fit(&t, &y, 25);
    let tr = dmp.rollout(&RolloutOptions::new(1e-3)).unwrap();
    assert_eq!(tr.n_samples(), 1001);
    for d in 0..3 {
        let row = y.row(d);
        let range = row.max() - row.min();
        let err = (0..1001)
            .map(|j| (tr.y[j * 3 + d] - y[(d, j)]).abs())
            .fold(0.0, f64::max);
        assert!(err < 0.01 * range, "dof {d}: error {err} of range {range}");
    }
}

#[test]
fn derivatives_given_or_computed_give_nearly_the_same_fit() {
    let (t, y) = demo(2001, 2.0);
    let (mut yd, mut ydd) = (DMatrix::zeros(3, 2001), DMatrix::zeros(3, 2001));
    // Exact derivatives of the min-jerk DOF (s = t/2).
    for (j, &tj) in t.iter().enumerate() {
        let s = tj / 2.0;
        let v = (30.0 * s * s - 60.0 * s.powi(3) + 30.0 * s.powi(4)) / 2.0;
        let a = (60.0 * s - 180.0 * s * s + 120.0 * s.powi(3)) / 4.0;
        for (d, k) in [(0, 1.0), (1, -2.0)] {
            yd[(d, j)] = k * v;
            ydd[(d, j)] = k * a;
        }
        let w = std::f64::consts::PI / 2.0;
        yd[(2, j)] = 0.3 * w * (2.0 * w * tj).sin();
        ydd[(2, j)] = 0.3 * 2.0 * w * w * (2.0 * w * tj).cos();
    }
    let exact = Dmp::fit(
        &Demonstration {
            t: &t,
            y: y.as_view(),
            yd: Some(yd.as_view()),
            ydd: Some(ydd.as_view()),
        },
        DmpConfig::default(),
    )
    .unwrap();
    let numeric = fit(&t, &y, 25);
    let scale = exact.weights().amax();
    assert!((exact.weights() - numeric.weights()).amax() < 1e-3 * scale);
}

#[test]
fn non_uniform_sample_times_fit_as_well_as_uniform_ones() {
    let n = 800;
    let t: Vec<f64> = (0..n)
        .map(|j| {
            let s = j as f64 / (n - 1) as f64;
            s - 0.1 * (2.0 * std::f64::consts::PI * s).sin() / (2.0 * std::f64::consts::PI)
        })
        .collect();
    let y = DMatrix::from_iterator(
        1,
        n,
        t.iter()
            .map(|&s| 10.0 * s.powi(3) - 15.0 * s.powi(4) + 6.0 * s.powi(5)),
    );
    let dmp = fit(&t, &y, 25);
    let tr = dmp.rollout(&RolloutOptions::new(1e-3)).unwrap();
    for (j, &tj) in tr.t.iter().enumerate() {
        let s: f64 = tj;
        let truth = 10.0 * s.powi(3) - 15.0 * s.powi(4) + 6.0 * s.powi(5);
        assert!((tr.y[j] - truth).abs() < 0.01, "t={tj}");
    }
}

#[test]
fn converges_to_a_new_goal() {
    let (t, y) = demo(501, 1.0);
    let dmp = fit(&t, &y, 25)
        .with_goal(DVector::from_vec(vec![2.0, -1.0, 0.7]))
        .unwrap();
    let opts = RolloutOptions {
        until_rest: true,
        rest_tol: 1e-6,
        ..RolloutOptions::new(1e-3)
    };
    let tr = dmp.rollout(&opts).unwrap();
    let last = &tr.y[tr.y.len() - 3..];
    for (got, want) in last.iter().zip([2.0, -1.0, 0.7]) {
        assert!((got - want).abs() <= 1e-6);
    }
    assert!(tr.t.last().unwrap() > &1.0, "ran past tau to reach rest");
}

#[test]
fn rollout_is_bit_identical_across_runs_and_in_batch() {
    let (t, y) = demo(301, 0.5);
    let dmp = fit(&t, &y, 30);
    let opts = RolloutOptions::new(1e-3);
    let a = dmp.rollout(&opts).unwrap();
    let b = fit(&t, &y, 30).rollout(&opts).unwrap();
    assert_eq!(a, b);
    let many: Vec<Dmp> = (0..64)
        .map(|k| dmp.with_tau(0.2 + 0.01 * k as f64).unwrap())
        .collect();
    let batch = rollout_batch(&many, &opts).unwrap();
    for (d, tr) in many.iter().zip(&batch) {
        assert_eq!(&d.rollout(&opts).unwrap(), tr);
    }
}

#[test]
fn bad_input_is_an_error_not_a_panic() {
    let (t, y) = demo(50, 1.0);
    let bad_t = {
        let mut t2 = t.clone();
        t2[10] = t2[9];
        t2
    };
    let d = |t: &[f64], y: &DMatrix<f64>| {
        Dmp::fit(
            &Demonstration {
                t,
                y: y.as_view(),
                yd: None,
                ydd: None,
            },
            DmpConfig::default(),
        )
    };
    assert!(matches!(
        d(&bad_t, &y),
        Err(Error::NotIncreasing { index: 10, .. })
    ));
    let mut nan_y = y.clone();
    nan_y[(1, 7)] = f64::NAN;
    let err = d(&t, &nan_y).unwrap_err();
    assert_eq!(err.to_string(), "y[7, 1] is NaN: all values must be finite");
    assert!(matches!(
        d(&t[..2], &y.columns(0, 2).into_owned()),
        Err(Error::TooFewSamples { .. })
    ));
    assert!(matches!(d(&t[..20], &y), Err(Error::Shape { .. })));
    let dmp = d(&t, &y).unwrap();
    for dt in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        assert!(dmp.rollout(&RolloutOptions::new(dt)).is_err());
    }
    let huge = RolloutOptions {
        duration: Some(1e9),
        ..RolloutOptions::new(1e-3)
    };
    assert!(matches!(
        dmp.rollout(&huge),
        Err(Error::InvalidParameter { name: "dt", .. })
    ));
    assert!(dmp.with_tau(0.0).is_err());
    assert!(dmp.with_goal(DVector::from_vec(vec![1.0])).is_err());
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(32))]

    /// Eqs. 1-2 depend on y only through g - y: shifting start and goal by c shifts the rollout.
    #[test]
    fn shifting_start_and_goal_shifts_the_rollout(c in -10.0f64..10.0, tau in 0.2f64..3.0) {
        let (t, y) = demo(201, 1.0);
        let dmp = fit(&t, &y, 20).with_tau(tau).unwrap();
        let shifted = dmp
            .with_goal(dmp.goal().add_scalar(c)).unwrap()
            .with_start(dmp.y0().add_scalar(c)).unwrap();
        let opts = RolloutOptions::new(2e-3);
        let (a, b) = (dmp.rollout(&opts).unwrap(), shifted.rollout(&opts).unwrap());
        for (ya, yb) in a.y.iter().zip(&b.y) {
            prop_assert!((yb - ya - c).abs() < 1e-9 * (1.0 + c.abs()));
        }
        prop_assert_eq!(a.yd.len(), b.yd.len());
    }

    /// Scaling tau by k with dt scaled by k visits the same positions at k times the time.
    #[test]
    fn scaling_tau_stretches_time_only(k in 0.25f64..4.0) {
        let (t, y) = demo(201, 1.0);
        let dmp = fit(&t, &y, 20);
        let a = dmp.rollout(&RolloutOptions::new(1e-3)).unwrap();
        let b = dmp.with_tau(k).unwrap().rollout(&RolloutOptions::new(1e-3 * k)).unwrap();
        prop_assert_eq!(a.n_samples(), b.n_samples());
        for j in 0..a.n_samples() {
            prop_assert!((b.t[j] - k * a.t[j]).abs() < 1e-9 * k);
            for d in 0..3 {
                let i = j * 3 + d;
                prop_assert!((a.y[i] - b.y[i]).abs() < 1e-9);
                prop_assert!((a.yd[i] - k * b.yd[i]).abs() < 1e-7);
            }
        }
    }

    /// Any finite weights give a finite rollout that starts at y0.
    #[test]
    fn rollouts_of_random_dmps_are_finite(
        w in proptest::collection::vec(-500.0f64..500.0, 10),
        g in -5.0f64..5.0, y0 in -5.0f64..5.0, tau in 0.05f64..5.0,
    ) {
        let cfg = DmpConfig { n_basis: 10, ..DmpConfig::default() };
        let dmp = Dmp::new(cfg, DMatrix::from_vec(10, 1, w), DVector::from_element(1, g), DVector::from_element(1, y0), tau).unwrap();
        let tr = dmp.rollout(&RolloutOptions::new(1e-3)).unwrap();
        prop_assert_eq!(tr.y[0], y0);
        prop_assert!(tr.y.iter().chain(&tr.yd).chain(&tr.ydd).all(|v| v.is_finite()));
    }
}
