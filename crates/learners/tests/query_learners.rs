//! Known answers for the query learners (issue 4, item 6): error learning, golden section, the
//! Illinois root finder and policy gradient.

mod common;

use common::{Noise, bisect, eps1, run};
use learners::{
    AskTell, ErrorLearning, ErrorLearningConfig, GoldenConfig, GoldenMode, GoldenSection,
    IllinoisRootFinder, Jacobian, LearnerError, PolicyGradient, PolicyGradientConfig,
    RootFinderConfig, Status,
};
use nalgebra::{DMatrix, dmatrix};

fn el(q0: &[f64], f: impl FnOnce(&mut ErrorLearningConfig)) -> ErrorLearning {
    let mut cfg = ErrorLearningConfig {
        tol: 1e-6,
        ..ErrorLearningConfig::default()
    };
    f(&mut cfg);
    ErrorLearning::new(q0, cfg).unwrap()
}

fn golden(q0: f64, lo: f64, hi: f64, mode: GoldenMode) -> GoldenSection {
    GoldenSection::new(
        q0,
        lo,
        hi,
        GoldenConfig {
            mode,
            tol: 1e-3,
            q_tol: Some(1e-4),
            max_trials: 60,
            max_expansions: 3,
            ..GoldenConfig::default()
        },
    )
    .unwrap()
}

fn finder(q0: f64, lo: f64, hi: f64) -> IllinoisRootFinder {
    IllinoisRootFinder::new(
        q0,
        lo,
        hi,
        RootFinderConfig {
            tol: 1e-3,
            q_tol: Some(1e-4),
            max_trials: 60,
            ..Default::default()
        },
    )
    .unwrap()
}

// ---- error learning -------------------------------------------------------------------------

#[test]
fn identity_gain_on_the_ideal_map_converges_in_one_trial() {
    let mut l = el(&[0.7, -0.2], |_| {});
    let n = run(&mut l, |q| vec![0.7 - q[0], -0.2 - q[1]]);
    assert_eq!(n, 1);
    assert!(l.converged());
    assert_eq!(l.best().unwrap().q, vec![0.7, -0.2]);
}

#[test]
fn identity_gain_removes_a_constant_bias_in_one_correction() {
    // q_a = q + c (slope 1): trial 1 measures eps = -c, trial 2 at q0 - c is exact.
    let c = [0.13, -0.4];
    let mut l = el(&[1.0, 2.0], |_| {});
    let n = run(&mut l, |q| vec![1.0 - (q[0] + c[0]), 2.0 - (q[1] + c[1])]);
    assert_eq!(n, 2);
    let q = &l.best().unwrap().q;
    assert!((q[0] - 0.87).abs() < 1e-12 && (q[1] - 2.4).abs() < 1e-12);
}

#[test]
fn matrix_gain_is_eq16_literally() {
    let k = dmatrix![0.5, 0.1; 0.0, 2.0];
    let mut l = el(&[0.0, 0.0], |c| c.gain = k.clone().into());
    let q = l.ask().unwrap();
    l.tell(&q, &[1.0, -1.0]).unwrap();
    let q1 = l.ask().unwrap();
    assert!((q1[0] - 0.4).abs() < 1e-15 && (q1[1] + 2.0).abs() < 1e-15);
}

#[test]
fn weighted_error_learning_is_eq17_with_a_task_scale() {
    let mut l = el(&[0.0], |c| {
        c.weighted = true;
        c.scale = 0.5;
    });
    let q = l.ask().unwrap();
    l.tell(&q, &[0.3]).unwrap();
    let expected = (-(0.3f64 / 0.5).powi(2)).exp() * 0.3;
    assert!((l.ask().unwrap()[0] - expected).abs() < 1e-15);
}

#[test]
fn identity_gain_cycles_at_slope_two_but_secant_and_finite_difference_converge() {
    // q_a = 2q: the gradient form with unit gain maps q to q0 - q (docs/method.md §5.2).
    let f = |q: &[f64]| vec![1.0 - 2.0 * q[0]];
    let mut fixed = el(&[1.0], |c| c.max_trials = 20);
    run(&mut fixed, f);
    assert_eq!(fixed.status(), Status::TrialCap);

    // Secant: trial 1 at q0, trial 2 with J = I, then J = 2 exactly -> the Newton step is exact.
    let mut secant = el(&[1.0], |c| c.jacobian = Jacobian::Secant);
    assert_eq!(run(&mut secant, f), 3);
    assert!((secant.best().unwrap().q[0] - 0.5).abs() < 1e-12);
    assert!((secant.jacobian()[(0, 0)] - 2.0).abs() < 1e-12);

    // Finite difference: q0, one probe, then the exact Newton step.
    let mut fd = el(&[1.0], |c| {
        c.jacobian = Jacobian::FiniteDifference { delta: 0.01 }
    });
    assert_eq!(run(&mut fd, f), 3);
    assert!((fd.jacobian()[(0, 0)] - 2.0).abs() < 1e-9);
}

#[test]
fn secant_safeguard_falls_back_to_identity_on_a_slope_outside_its_range() {
    // slope 20 is outside [0.1, 10]: J must be reset to I, not used.
    let mut l = el(&[0.0], |c| {
        c.jacobian = Jacobian::Secant;
        c.max_trials = 3;
    });
    run(&mut l, |q| vec![0.5 - 20.0 * q[0]]);
    assert_eq!(l.jacobian()[(0, 0)], 1.0);
}

#[test]
fn broyden_converges_on_a_coupled_linear_map() {
    let a = dmatrix![1.8, 0.3; -0.2, 0.7];
    let c = nalgebra::dvector![0.1, -0.05];
    let q0 = nalgebra::dvector![0.4, 0.9];
    let mut l = el(q0.as_slice(), |c| c.jacobian = Jacobian::Secant);
    let n = run(&mut l, |q| {
        let qa = &a * nalgebra::DVector::from_column_slice(q) + &c;
        (&q0 - qa).as_slice().to_vec()
    });
    assert!(l.converged(), "{:?}", l.status());
    assert!(n <= 12, "Broyden took {n} trials");
    let truth = a.clone().lu().solve(&(&q0 - &c)).unwrap();
    let q = &l.best().unwrap().q;
    assert!((q[0] - truth[0]).abs() < 1e-5 && (q[1] - truth[1]).abs() < 1e-5);
}

#[test]
fn wrong_sign_convention_runs_into_a_bound_and_says_so() {
    // eps with the wrong sign: q_a = q + 0.3 sin q, but eps = q_a - q0.
    let wrong = |q: &[f64]| vec![(q[0] + 0.3 * q[0].sin()) - 1.0];
    let mut l = el(&[1.2], |c| {
        c.low = Some(vec![0.0]);
        c.high = Some(vec![3.0]);
        c.max_trials = 100;
    });
    let n = run(&mut l, wrong);
    assert!(
        matches!(l.status(), Status::HitBound { high: true, value } if value == 3.0),
        "{:?}",
        l.status()
    );
    assert!(n < 15, "{n} trials");

    let mut free = el(&[1.2], |c| c.max_trials = 100);
    let n = run(&mut free, wrong);
    assert_eq!(free.status(), Status::Diverged);
    assert!(n < 15);

    let mut g = golden(1.2, 0.5, 2.0, GoldenMode::Robust);
    let n = run(&mut g, wrong);
    assert!(
        matches!(g.status(), Status::HitBound { high: true, .. }),
        "{:?}",
        g.status()
    );
    assert!(n < 40, "{n}");

    let mut r = finder(1.2, 0.5, 2.0);
    let n = run(&mut r, wrong);
    assert!(
        matches!(r.status(), Status::HitBound { high: true, value } if value == 2.0),
        "{:?}",
        r.status()
    );
    assert!(n < 40);

    let mut p = golden(1.2, 0.5, 2.0, GoldenMode::Paper);
    run(&mut p, wrong);
    assert!(
        matches!(p.status(), Status::HitBound { high: true, .. }),
        "{:?}",
        p.status()
    );
}

#[test]
fn a_bound_is_detected_along_the_step_not_along_eps() {
    // A negative gain walks away from the root at 0.6 although eps > 0: the step, not eps,
    // points past the lower limit.
    let mut l = el(&[0.5], |c| {
        c.gain = DMatrix::from_element(1, 1, -1.0).into();
        c.low = Some(vec![0.0]);
        c.high = Some(vec![1.0]);
        c.max_trials = 100;
    });
    let n = run(&mut l, eps1(0.5, |q| q - 0.1));
    assert!(
        matches!(l.status(), Status::HitBound { high: false, value } if value == 0.0),
        "{:?}",
        l.status()
    );
    assert!(n < 10, "{n}");
}

// ---- golden section -------------------------------------------------------------------------

fn sine_map(q: f64) -> f64 {
    q + 0.3 * q.sin()
}

#[test]
fn golden_section_finds_the_root_of_q_plus_0_3_sin_q() {
    let q0 = 1.0;
    let truth = bisect(|q| q0 - sine_map(q), 0.0, 2.0);
    for mode in [GoldenMode::Paper, GoldenMode::Robust] {
        let mut g = golden(q0, 0.3, 1.8, mode);
        run(&mut g, eps1(q0, sine_map));
        assert!(g.converged(), "{mode:?}: {:?}", g.status());
        let best = g.best().unwrap();
        // fix 2: the answer is the last executed query, and it meets |eps| < tol
        assert_eq!(best, g.history().last().unwrap());
        assert!(best.score < 1e-3);
        // slope of q_a >= 0.7, so |q - truth| <= |eps| / 0.7
        assert!((best.q[0] - truth).abs() < 1e-3 / 0.7);
    }
}

/// Golden section (robust) over [0, 1] from 0.5, tol 1e-3, with the given noise guard.
fn guarded_golden(noise: Option<f64>) -> GoldenSection {
    let cfg = GoldenConfig {
        mode: GoldenMode::Robust,
        tol: 1e-3,
        max_trials: 40,
        noise,
        ..GoldenConfig::default()
    };
    GoldenSection::new(0.5, 0.0, 1.0, cfg).unwrap()
}

/// Runs it on eps = 0.7 - q, the reading of the second trial (at q = 0.809, eps = -0.109) told
/// with the wrong sign; returns it and the trials it took.
fn golden_with_one_wrong_sign(noise: Option<f64>) -> (GoldenSection, usize) {
    let mut g = guarded_golden(noise);
    let mut k = 0;
    while g.status() == Status::Running {
        let q = g.ask().unwrap();
        let e = 0.7 - q[0];
        g.tell(&q, &[if k == 1 { -e } else { e }]).unwrap();
        k += 1;
    }
    (g, k)
}

#[test]
fn one_wrong_sign_puts_the_root_outside_the_bracket_for_good_without_the_noise_guard() {
    let (g, _) = golden_with_one_wrong_sign(None);
    assert!(!g.converged(), "{:?}", g.status());
    let (lo, hi) = g.bracket();
    // told eps > 0 at 0.809, the box raised q_l past the root
    assert!(lo > 0.7, "root 0.7 outside [{lo}, {hi}]");
}

#[test]
fn the_noise_guard_reopens_the_limit_a_wrong_sign_set_and_converges() {
    let (g, k) = golden_with_one_wrong_sign(Some(1e-4));
    assert!(g.converged(), "{:?} after {k} trials", g.status());
    assert!(g.reopened() >= 1);
    assert!((g.best().unwrap().q[0] - 0.7).abs() < 1e-3);
    // the guard costs trials, not the run: noise-free golden needs 12 here
    let mut clean = guarded_golden(Some(1e-4));
    let k_clean = run(&mut clean, |q| vec![0.7 - q[0]]);
    assert!(clean.converged() && clean.reopened() == 0);
    assert!(k <= k_clean + 8, "{k} trials against {k_clean}");
}

#[test]
fn the_noise_guard_repeats_a_doubtful_reading_and_takes_the_sign_of_the_mean() {
    let cfg = GoldenConfig {
        mode: GoldenMode::Robust,
        tol: 1e-3,
        noise: Some(0.01),
        max_repeats: 3,
        ..GoldenConfig::default()
    };
    let mut g = GoldenSection::new(0.5, 0.0, 1.0, cfg).unwrap();
    let q = g.ask().unwrap();
    g.tell(&q, &[-0.015]).unwrap(); // |eps| < 2 sigma: doubtful, asked again
    assert_eq!(g.ask().unwrap(), q);
    assert_eq!(g.bracket(), (0.0, 1.0));
    g.tell(&q, &[0.005]).unwrap(); // mean -0.005 < 2 sigma / sqrt 2: doubtful still
    assert_eq!(g.ask().unwrap(), q);
    g.tell(&q, &[0.031]).unwrap(); // third reading: the mean +0.007 decides, eps > 0 raises q_l
    assert_eq!(g.bracket(), (0.5, 1.0));
    assert!((g.ask().unwrap()[0] - (0.5 + 0.5 * 0.618)).abs() < 1e-12);
    // a clear reading moves the bracket at once
    let q = g.ask().unwrap();
    g.tell(&q, &[-0.05]).unwrap();
    assert_eq!(g.bracket(), (0.5, q[0]));
}

#[test]
fn the_noise_guard_refuses_a_bad_noise_or_repeat_count() {
    for (noise, repeats) in [
        (Some(-1.0), 3),
        (Some(f64::NAN), 3),
        (Some(0.0), 3),
        (Some(0.1), 0),
    ] {
        let cfg = GoldenConfig {
            noise,
            max_repeats: repeats,
            ..GoldenConfig::default()
        };
        assert!(
            GoldenSection::new(0.5, 0.0, 1.0, cfg).is_err(),
            "{noise:?} {repeats}"
        );
    }
}

#[test]
fn golden_section_terminates_on_abs_eps_not_signed_eps() {
    // The first eps is large and negative: the paper's literal "until eps < precision" would stop.
    let mut g = golden(1.0, 0.0, 1.0, GoldenMode::Paper);
    run(&mut g, eps1(0.5, |q| q));
    assert!(g.n_told() > 1);
    assert!(g.converged());
}

#[test]
fn golden_section_shrinks_its_bracket_by_0_382_or_0_618_per_trial() {
    let mut g = golden(0.9, 0.2, 1.7, GoldenMode::Paper);
    let mut f = eps1(0.9, sine_map);
    let mut prev: Option<f64> = None;
    while g.status() == Status::Running {
        let q = g.ask().unwrap();
        let e = f(&q);
        g.tell(&q, &e).unwrap();
        let (lo, hi) = g.bracket();
        let w = hi - lo;
        if let Some(p) = prev
            && g.status() == Status::Running
        {
            let r = w / p;
            assert!(
                (r - 0.618).abs() < 1e-9 || (r - 0.382).abs() < 1e-9,
                "ratio {r}"
            );
        }
        // the next point is at 0.618 or 0.382 of the new bracket
        if g.status() == Status::Running {
            let x = (g.ask().unwrap()[0] - lo) / w;
            assert!((x - 0.618).abs() < 1e-9 || (x - 0.382).abs() < 1e-9);
            // ask twice: same query
            assert_eq!(g.ask().unwrap()[0], lo + x * w);
        }
        prev = Some(w);
    }
}

#[test]
fn paper_mode_keeps_the_quirk_of_q0_outside_the_bracket_robust_mode_fixes_it() {
    // docs/method.md §6.2 #5: ql = 0.3, qh = 1.0, q0 = 1.2, eps > 0 -> next q = 1.076 (inverted bracket).
    let qa = |q: f64| q - 0.1; // root at 1.3
    let mut p = golden(1.2, 0.3, 1.0, GoldenMode::Paper);
    let q = p.ask().unwrap();
    p.tell(&q, &[1.2 - qa(q[0])]).unwrap();
    assert!((p.ask().unwrap()[0] - (1.2 + (1.0 - 1.2) * 0.618)).abs() < 1e-12);

    let mut r = golden(1.2, 0.3, 1.0, GoldenMode::Robust);
    run(&mut r, eps1(1.2, qa));
    assert!(r.converged(), "{:?}", r.status());
    assert!((r.best().unwrap().q[0] - 1.3).abs() < 1e-3);
}

#[test]
fn robust_mode_expands_to_a_root_outside_the_limits() {
    let mut r = golden(0.5, 0.3, 1.0, GoldenMode::Robust);
    run(&mut r, eps1(0.5, |q| q - 1.0)); // root at 1.5
    assert!(r.converged(), "{:?}", r.status());
    assert!((r.best().unwrap().q[0] - 1.5).abs() < 1e-3);
}

/// The matchbox-like map (paper Fig. 2c): the outcome jumps, with a narrow success window.
fn matchbox_like(q: f64) -> f64 {
    if q < 0.93 {
        q - 0.15
    } else if q <= 0.97 {
        1.0
    } else {
        q + 0.15
    }
}

#[test]
fn discontinuous_map_bracketing_learners_find_the_window_fixed_gain_cycles() {
    for mode in [GoldenMode::Paper, GoldenMode::Robust] {
        let mut g = golden(1.0, 0.5, 1.5, mode);
        run(&mut g, eps1(1.0, matchbox_like));
        assert!(g.converged(), "{mode:?}");
        assert!((0.93..=0.97).contains(&g.best().unwrap().q[0]));
    }
    let mut r = finder(1.0, 0.5, 1.5);
    run(&mut r, eps1(1.0, matchbox_like));
    assert!(r.converged());
    assert!((0.93..=0.97).contains(&r.best().unwrap().q[0]));

    let mut k = el(&[1.0], |c| {
        c.tol = 1e-3;
        c.max_trials = 30;
    });
    run(&mut k, eps1(1.0, matchbox_like));
    assert_eq!(
        k.status(),
        Status::TrialCap,
        "K = I oscillates across the jump"
    );
}

#[test]
fn a_jump_across_zero_without_a_window_is_bracketed_to_q_tol() {
    let jump = |q: f64| if q < 1.1 { q - 0.2 } else { q + 0.2 };
    let mut g = golden(1.0, 0.5, 1.5, GoldenMode::Robust);
    run(&mut g, eps1(1.0, jump));
    assert_eq!(g.status(), Status::Bracketed);
    let (lo, hi) = g.bracket();
    assert!(lo <= 1.1 && 1.1 <= hi && hi - lo < 1e-4);

    let mut r = finder(1.0, 0.5, 1.5);
    run(&mut r, eps1(1.0, jump));
    assert_eq!(r.status(), Status::Bracketed);
    let (lo, hi) = r.bracket();
    assert!(lo <= 1.1 && 1.1 <= hi && hi - lo < 1e-4);
}

#[test]
fn noisy_measurements_still_converge_near_the_root() {
    let q0 = 1.0;
    let truth = bisect(|q| q0 - sine_map(q), 0.0, 2.0);
    for seed in 0..10 {
        let sigma = 0.003;
        let mut noise = Noise::new(seed);
        let mut f = move |q: &[f64]| vec![q0 - sine_map(q[0]) + sigma * noise.gauss()];
        let mut g = GoldenSection::new(
            q0,
            0.3,
            1.8,
            GoldenConfig {
                mode: GoldenMode::Robust,
                tol: 0.01,
                q_tol: Some(1e-3),
                max_trials: 40,
                max_expansions: 3,
                ..GoldenConfig::default()
            },
        )
        .unwrap();
        run(&mut g, &mut f);
        // |eps_measured| < 0.01 and |noise| < 5 sigma -> |true eps| < 0.025 -> |q - truth| < 0.025/0.7
        assert!(
            matches!(g.status(), Status::Converged | Status::Bracketed),
            "{:?}",
            g.status()
        );
        assert!((g.best().unwrap().q[0] - truth).abs() < 0.04, "seed {seed}");
        let mut r = IllinoisRootFinder::new(
            q0,
            0.3,
            1.8,
            RootFinderConfig {
                tol: 0.01,
                q_tol: Some(1e-3),
                max_trials: 40,
                ..Default::default()
            },
        )
        .unwrap();
        run(&mut r, &mut f);
        assert!(matches!(r.status(), Status::Converged | Status::Bracketed));
        assert!((r.best().unwrap().q[0] - truth).abs() < 0.04, "seed {seed}");
        let mut k = el(&[q0], |c| {
            c.tol = 0.01;
            c.max_trials = 40;
        });
        run(&mut k, &mut f);
        assert!(k.converged());
        assert!((k.best().unwrap().q[0] - truth).abs() < 0.04, "seed {seed}");
    }
}

#[test]
fn root_finder_beats_golden_section_on_a_smooth_map() {
    let q0 = 1.0;
    let mut g = golden(q0, 0.3, 1.8, GoldenMode::Robust);
    let ng = run(&mut g, eps1(q0, sine_map));
    let mut r = finder(q0, 0.3, 1.8);
    let nr = run(&mut r, eps1(q0, sine_map));
    assert!(r.converged());
    assert!(nr < ng, "finder {nr} vs golden {ng}");
    assert!(nr <= 5, "{nr}");
}

// ---- policy gradient ------------------------------------------------------------------------

#[test]
fn policy_gradient_counts_every_perturbed_trial() {
    // q_a = q + c; J = (eps/s)^2 with s = 1; alpha0 = 1/2 makes the first update a Newton step.
    let c = 0.2;
    let mut pg = PolicyGradient::new(
        &[1.0],
        PolicyGradientConfig {
            alpha0: Some(0.5),
            decay: 0.602,
            delta: Some(0.05),
            scale: 1.0,
            evaluate_center: true,
            low: None,
            high: None,
            tol: 1e-9,
            max_trials: 50,
            pin_limit: 3,
        },
    )
    .unwrap();
    let n = run(&mut pg, eps1(1.0, |q| q + c));
    // centre q0, q0 + d, q0 - d, then the new centre q0 - c is exact: 1 + 2n + 1 trials.
    assert_eq!(n, 4);
    assert!(pg.converged());
    assert!((pg.best().unwrap().q[0] - 0.8).abs() < 1e-12);
}

#[test]
fn policy_gradient_converges_in_two_dimensions_with_decaying_steps() {
    let mut pg = PolicyGradient::new(
        &[0.0, 0.0],
        PolicyGradientConfig {
            alpha0: Some(0.3),
            decay: 0.602,
            delta: Some(0.01),
            scale: 1.0,
            evaluate_center: true,
            low: None,
            high: None,
            tol: 1e-3,
            max_trials: 400,
            pin_limit: 3,
        },
    )
    .unwrap();
    assert!((pg.alpha(3) - 0.3 / 4f64.powf(0.602)).abs() < 1e-15);
    run(&mut pg, |q| {
        vec![0.5 - (q[0] + 0.3 * q[0].sin()), -0.3 - 1.5 * q[1]]
    });
    assert!(pg.converged(), "{:?}", pg.status());
    // every update costs 1 + 2n = 5 trials, all of them counted
    assert!(pg.n_told() > 5);
    assert_eq!(pg.history().len(), pg.n_told());
}

// ---- bad input ------------------------------------------------------------------------------

#[test]
fn bad_input_is_a_clear_error() {
    let mut l = el(&[1.0], |_| {});
    assert_eq!(l.tell(&[1.0], &[0.1]), Err(LearnerError::NotAsked));
    let q = l.ask().unwrap();
    let e = l.tell(&q, &[f64::NAN]).unwrap_err();
    assert!(
        e.is_input_error() && e.to_string().contains("eps[0] is NaN"),
        "{e}"
    );
    let e = l.tell(&q, &[0.1, 0.2]).unwrap_err();
    assert!(
        e.is_input_error() && e.to_string().contains("eps has 2 entries, expected 1"),
        "{e}"
    );
    let e = l.tell(&[1.5], &[0.1]).unwrap_err();
    assert!(e.is_state_error(), "{e}");
    // nothing was recorded by the failed calls
    assert_eq!(l.n_told(), 0);
    l.tell(&q, &[0.0]).unwrap();
    let e = l.ask().unwrap_err();
    assert!(
        e.is_state_error() && e.to_string().contains("converged"),
        "{e}"
    );

    let cfg = GoldenConfig {
        mode: GoldenMode::Paper,
        tol: 1e-3,
        q_tol: Some(1e-4),
        max_trials: 10,
        max_expansions: 3,
        ..GoldenConfig::default()
    };
    let e = GoldenSection::new(0.5, 1.0, 1.0, cfg.clone()).unwrap_err();
    assert!(
        e.is_input_error() && e.to_string().contains("must be < high"),
        "{e}"
    );
    let e = IllinoisRootFinder::new(
        0.5,
        2.0,
        1.0,
        RootFinderConfig {
            tol: 1e-3,
            q_tol: Some(1e-4),
            max_trials: 10,
            ..Default::default()
        },
    )
    .unwrap_err();
    assert!(e.is_input_error());
    let e = ErrorLearning::new(
        &[0.5],
        ErrorLearningConfig {
            low: Some(vec![1.0]),
            high: Some(vec![0.0]),
            ..ErrorLearningConfig {
                tol: 1e-3,
                max_trials: 10,
                ..ErrorLearningConfig::default()
            }
        },
    )
    .unwrap_err();
    assert!(
        e.is_input_error() && e.to_string().contains("must be < high"),
        "{e}"
    );
    let e = ErrorLearning::new(
        &[0.5],
        ErrorLearningConfig {
            gain: DMatrix::identity(2, 2).into(),
            ..ErrorLearningConfig {
                tol: 1e-3,
                max_trials: 10,
                ..ErrorLearningConfig::default()
            }
        },
    )
    .unwrap_err();
    assert!(
        e.to_string()
            .contains("gain has shape (2, 2), expected shape (1, 1)"),
        "{e}"
    );
    let e = ErrorLearning::new(
        &[0.5],
        ErrorLearningConfig {
            jacobian: Jacobian::Fixed(DMatrix::zeros(1, 1).into()),
            ..ErrorLearningConfig {
                tol: 1e-3,
                max_trials: 10,
                ..ErrorLearningConfig::default()
            }
        },
    )
    .unwrap_err();
    assert!(e.to_string().contains("invertible"), "{e}");
}

// ---- never a non-finite query (issue 13 item 6) ---------------------------------------------

#[test]
fn a_step_that_overflows_stops_the_learner_as_diverged() {
    // K = 1e308: the eq. 16 step 1e308 * 10 overflows.
    let cfg = ErrorLearningConfig {
        gain: 1e308.into(),
        ..ErrorLearningConfig::default()
    };
    let mut l = ErrorLearning::new(&[1.0], cfg).unwrap();
    let q = l.ask().unwrap();
    l.tell(&q, &[10.0]).unwrap();
    assert_eq!(l.status(), Status::Diverged);
    assert!(l.ask().unwrap_err().is_state_error());

    // delta = 1e300: the cost (eps/s)^2 of the perturbed trials overflows, the gradient is NaN.
    let cfg = PolicyGradientConfig {
        delta: Some(1e300),
        ..PolicyGradientConfig::default()
    };
    let mut pg = PolicyGradient::new(&[0.0], cfg).unwrap();
    run(&mut pg, eps1(0.5, |q| q));
    assert_eq!(pg.status(), Status::Diverged);
    assert!(pg.history().iter().all(|t| t.q[0].is_finite()));
}

#[test]
fn a_bracket_whose_width_overflows_is_refused_for_what_it_is() {
    for e in [
        GoldenSection::new(0.5, -1e308, 1e308, GoldenConfig::default()).unwrap_err(),
        IllinoisRootFinder::new(0.5, -1e308, 1e308, RootFinderConfig::default()).unwrap_err(),
    ] {
        assert!(
            e.is_input_error() && e.to_string().contains("width overflows"),
            "{e}"
        );
        assert!(!e.to_string().contains("q_tol"), "{e}");
    }
}

#[test]
fn the_default_q_tol_is_a_fraction_of_the_bracket() {
    // Robust golden section stops as Bracketed once [q_l, q_h] < 1e-4 (high - low) = 2e-4 when
    // eps jumps across zero at 1 without ever being small.
    let cfg = GoldenConfig {
        mode: GoldenMode::Robust,
        ..GoldenConfig::default()
    };
    let mut g = GoldenSection::new(0.5, 0.0, 2.0, cfg).unwrap();
    run(&mut g, |q| vec![if q[0] < 1.0 { 1.0 } else { -1.0 }]);
    assert_eq!(g.status(), Status::Bracketed);
    let (lo, hi) = g.bracket();
    assert!(hi - lo < 2e-4 && hi - lo > 2e-4 * 0.618 * 0.5, "{lo} {hi}");
}
