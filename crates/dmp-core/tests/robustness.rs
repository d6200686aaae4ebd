//! Whatever valid-looking input the fit and the integrator get, they return a finite result or a
//! clear error: never a panic, never NaN or inf (the reliability issue). Against independent
//! truth where there is one: the closed-form spring for stiff settings the sub-steps rescue.

use dmp_core::dmp::MAX_FIT_ALPHA_X;
use dmp_core::euler::stable_step;
use dmp_core::{Demonstration, Dmp, DmpConfig, Error, RolloutOptions};
use nalgebra::{DMatrix, DVector};
use proptest::prelude::*;

fn demo_data(n: usize, span: f64, freq: f64, amp: f64) -> (Vec<f64>, DMatrix<f64>) {
    let t: Vec<f64> = (0..n).map(|j| span * j as f64 / (n - 1) as f64).collect();
    let y = DMatrix::from_iterator(1, n, t.iter().map(|&s| amp * (freq * s / span).sin()));
    (t, y)
}

fn fit(t: &[f64], y: &DMatrix<f64>, config: DmpConfig) -> dmp_core::Result<Dmp> {
    let demo = Demonstration {
        t,
        y: y.as_view(),
        yd: None,
        ydd: None,
    };
    Dmp::fit(&demo, config)
}

#[test]
fn a_large_alpha_x_fits_up_to_the_design_matrix_floor_and_is_refused_beyond() {
    // Below ln 1e8 the late rows keep some entries above the cut-off: finite weights. Beyond it
    // (the alpha_x = 22.6 reproduced a 0.5 movement as 1587) the fit is refused.
    let (t, y) = demo_data(50, 1.0, 1.0, 1.0);
    for alpha_x in [17.0, 18.42] {
        let config = DmpConfig {
            alpha_x,
            ..DmpConfig::default()
        };
        let dmp = fit(&t, &y, config).unwrap();
        assert!(
            dmp.weights().iter().all(|w| w.is_finite()),
            "alpha_x = {alpha_x}"
        );
    }
    assert!((MAX_FIT_ALPHA_X - 1e8f64.ln()).abs() < 1e-12);
    for alpha_x in [18.43, 20.0, 22.6, 45.0] {
        let config = DmpConfig {
            alpha_x,
            ..DmpConfig::default()
        };
        let err = fit(&t, &y, config).unwrap_err();
        let msg = err.to_string();
        assert!(
            matches!(
                err,
                Error::InvalidParameter {
                    name: "alpha_x",
                    ..
                }
            ) && msg.contains("18.42"),
            "{msg}"
        );
    }
}

#[test]
fn a_rollout_beyond_its_work_bound_is_refused_at_once() {
    // alpha_z = 1e4 at tau = 0.01: a thousand sub-steps per 1 ms sample; 100 s of it would take a
    // minute. Refused before any step, naming the bound.
    let (t, y) = demo_data(11, 0.01, 50.0, 1.0);
    let config = DmpConfig {
        alpha_z: 1e4,
        beta_z: 2.5e3,
        ..DmpConfig::default()
    };
    let dmp = fit(&t, &y, config).unwrap();
    let opts = RolloutOptions {
        duration: Some(100.0),
        ..RolloutOptions::new(1e-3)
    };
    let msg = dmp.rollout(&opts).unwrap_err().to_string();
    assert!(
        msg.contains("state updates") && msg.contains("5e7"),
        "{msg}"
    );
    let opts = RolloutOptions {
        duration: Some(1.0),
        ..RolloutOptions::new(1e-3)
    };
    assert!(dmp.rollout(&opts).is_ok());
}

#[test]
fn a_rollout_too_stiff_for_its_step_is_sub_stepped_to_the_closed_form() {
    // tau = 0.01 with dt = 1e-3: dt / tau = 0.1 is beyond Euler's limit 2 / 24 for alpha_z = 48.
    let (y0, g, tau) = (0.0, 1.0, 0.01);
    let cfg = DmpConfig::default();
    let dmp = Dmp::new(
        cfg,
        DMatrix::zeros(cfg.n_basis, 1),
        DVector::from_element(1, g),
        DVector::from_element(1, y0),
        tau,
    )
    .unwrap();
    let opts = RolloutOptions {
        duration: Some(5.0 * tau),
        ..RolloutOptions::new(1e-3)
    };
    let tr = dmp.rollout(&opts).unwrap();
    let omega = 24.0 / tau;
    // First-order Euler at h |lambda| = 0.48 per sub-step: within 0.1 of a unit step at every
    // sample (without sub-steps it oscillates with growing amplitude, to -16 at t = tau).
    for (j, &t) in tr.t.iter().enumerate() {
        let exact = g + (y0 - g) * (1.0 + omega * t) * (-omega * t).exp();
        assert!(
            (tr.y[j] - exact).abs() < 0.1,
            "t = {t}: {} vs {exact}",
            tr.y[j]
        );
    }
    assert!((tr.y.last().unwrap() - g).abs() < 1e-3);
}

#[test]
fn a_step_beyond_a_thousand_sub_steps_is_refused_naming_dt_and_tau() {
    let cfg = DmpConfig {
        alpha_z: 1e9,
        beta_z: 2.5e8,
        ..DmpConfig::default()
    };
    let dmp = Dmp::new(
        cfg,
        DMatrix::zeros(cfg.n_basis, 1),
        DVector::from_element(1, 1.0),
        DVector::from_element(1, 0.0),
        1.0,
    )
    .unwrap();
    let err = dmp.rollout(&RolloutOptions::new(1e-3)).unwrap_err();
    let msg = err.to_string();
    assert!(matches!(err, Error::Numerical { .. }), "{msg}");
    assert!(
        msg.contains("dt = 0.001") && msg.contains("tau = 1") && msg.contains("alpha_z = 1e9"),
        "{msg}"
    );
}

#[test]
fn the_stability_limit_is_euler_s_on_the_spring_eigenvalues() {
    // Critically damped: a double eigenvalue -alpha_z / 2, Euler stable below h = 4 / alpha_z.
    assert!((stable_step(48.0, 12.0, 2.0) - 0.25 * 4.0 / 48.0).abs() < 1e-15);
    // Underdamped: |lambda|^2 = alpha_z beta_z, Re = -alpha_z / 2, so h < 1 / beta_z.
    assert!((stable_step(10.0, 100.0, 2.0) - 0.25 / 100.0).abs() < 1e-15);
    // A fast phase: h < 1 / alpha_x keeps x positive.
    assert!((stable_step(1.0, 0.25, 50.0) - 0.25 / 50.0).abs() < 1e-15);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(100))]

    /// The fit of any finite demonstration on an increasing grid, with any valid constants, is
    /// finite weights or an error, never a panic.
    #[test]
    fn the_fit_is_finite_or_an_error(
        n in 3usize..120, span in 1e-4f64..1e3, freq in 0.1f64..200.0, amp in -1e6f64..1e6,
        n_basis in 2usize..300, alpha_x in 0.05f64..800.0, alpha_z in 0.1f64..1e5,
        width_factor in 0.01f64..50.0,
    ) {
        let (t, y) = demo_data(n, span, freq, amp);
        let config = DmpConfig { n_basis, alpha_z, beta_z: alpha_z / 4.0, alpha_x, width_factor };
        if let Ok(dmp) = fit(&t, &y, config) {
            prop_assert!(dmp.weights().iter().all(|w| w.is_finite()));
        }
    }

    /// Any valid DMP rolled out at any step: every returned value finite, or a numerical error;
    /// and at a step within the stability limit the rollout settles towards the goal.
    #[test]
    fn the_integrator_is_finite_or_an_error(
        span in 1e-3f64..10.0, freq in 0.1f64..60.0, alpha_z in 0.5f64..1e6,
        alpha_x in 0.1f64..100.0, dt in 1e-4f64..0.5, tau in 1e-3f64..2.0,
        goal in prop_oneof![-1e3f64..1e3, Just(1e300), Just(-1e308)],
    ) {
        let (t, y) = demo_data(40, span, freq, 1.0);
        let config = DmpConfig { alpha_z, beta_z: alpha_z / 4.0, alpha_x, ..DmpConfig::default() };
        // Fitted with a fittable phase, then given this one (a fit refuses alpha_x > ln 1e8).
        let fitted = fit(&t, &y, DmpConfig { alpha_x: alpha_x.min(MAX_FIT_ALPHA_X), ..config }).unwrap();
        let dmp = Dmp::new(config, fitted.weights().clone(), DVector::from_element(1, goal),
                           fitted.y0().clone(), tau).unwrap();
        match dmp.rollout(&RolloutOptions { duration: Some(10.0 * tau), ..RolloutOptions::new(dt) }) {
            Ok(tr) => {
                prop_assert!(tr.y.iter().chain(&tr.yd).chain(&tr.ydd).all(|v| v.is_finite()));
                let last = *tr.y.last().unwrap();
                // 10 tau: the phase is below exp(-alpha_x 10) and the spring has settled.
                if alpha_x >= 1.0 && alpha_z >= 8.0 {
                    let max_w = dmp.weights().amax();
                    let tol = 1e-2 * (1.0 + goal.abs() + max_w / (alpha_z * alpha_z / 4.0));
                    prop_assert!((last - goal).abs() <= tol, "{last} vs {goal}");
                }
            }
            Err(e) => prop_assert!(matches!(e, Error::Numerical { .. } | Error::InvalidParameter { .. }), "{e}"),
        }
    }
}
