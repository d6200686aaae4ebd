//! Property tests: the Illinois root finder never needs more trials than golden section's worst
//! case, and golden section shrinks its bracket by 0.382 or 0.618 per trial, on random monotone
//! maps (smooth, steep/flat, with jumps across zero).

mod common;

use learners::{
    AskTell, GoldenConfig, GoldenMode, GoldenSection, IllinoisRootFinder, RootFinderConfig, Status,
};
use proptest::prelude::*;

/// A decreasing eps(q) with root r: linear + cubic + an optional jump across zero at r.
fn make_eps(r: f64, s1: f64, s3: f64, jump: f64) -> impl Fn(f64) -> f64 + Copy {
    move |q: f64| {
        let d = q - r;
        -(s1 * d
            + s3 * d * d * d
            + if d > 0.0 {
                jump
            } else if d < 0.0 {
                -jump
            } else {
                0.0
            })
    }
}

/// Golden section's worst case from the same first trial: the bracket after trial m is at most
/// W1 * 0.618^(m-1); the first m where that is below q_tol.
fn golden_worst_case(q0: f64, lo: f64, hi: f64, eps_q0: f64, q_tol: f64) -> usize {
    let w1 = if eps_q0 > 0.0 { hi - q0 } else { q0 - lo };
    let mut m = 1;
    let mut w = w1;
    while w >= q_tol {
        w *= 0.618;
        m += 1;
    }
    m
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]

    #[test]
    fn root_finder_never_needs_more_trials_than_golden_sections_worst_case(
        lo in -2.0..0.0f64, width in 0.5..4.0f64, r_frac in 0.01..0.99f64, q0_frac in 0.0..1.0f64,
        s1 in 0.05..5.0f64, s3 in 0.0..5.0f64, jump in prop_oneof![Just(0.0), 0.001..0.5f64],
        tol in prop_oneof![Just(1e-12), 1e-4..1e-2f64], q_tol in 1e-6..1e-2f64,
    ) {
        let hi = lo + width;
        let (r, q0) = (lo + r_frac * width, lo + q0_frac * width);
        let eps = make_eps(r, s1, s3, jump);
        let cfg = RootFinderConfig { tol, q_tol: Some(q_tol), max_trials: 1000, ..Default::default() };
        let mut f = IllinoisRootFinder::new(q0, lo, hi, cfg).unwrap();
        let n = common::run(&mut f, |q| vec![eps(q[0])]);
        let bound = golden_worst_case(q0, lo, hi, eps(q0), q_tol);
        prop_assert!(n <= bound, "finder {} > golden worst case {}", n, bound);
        prop_assert!(matches!(f.status(), Status::Converged | Status::Bracketed), "{:?}", f.status());
        let (a, b) = f.bracket();
        if f.status() == Status::Bracketed {
            prop_assert!(a <= r && r <= b);
        }
        // Golden section (robust, no expansion needed) from the same start also stops within the bound.
        let gcfg = GoldenConfig { mode: GoldenMode::Robust, tol, q_tol: Some(q_tol), max_trials: 1000, max_expansions: 0, ..GoldenConfig::default() };
        let mut g = GoldenSection::new(q0, lo, hi, gcfg).unwrap();
        let ng = common::run(&mut g, |q| vec![eps(q[0])]);
        prop_assert!(ng <= bound, "golden {} > its own worst case {}", ng, bound);
    }

    #[test]
    fn root_finder_with_expansions_finds_a_root_outside_its_limits(
        lo in -2.0..0.0f64, width in 0.5..4.0f64, beyond in 0.01..1.5f64, above in any::<bool>(),
        q0_frac in 0.0..1.0f64, s1 in 0.05..5.0f64, s3 in 0.0..5.0f64,
    ) {
        let hi = lo + width;
        // a root up to 1.5 widths past one limit: within reach of 4 expansions (1.618 + 2.618 + ...)
        let r = if above { hi + beyond * width } else { lo - beyond * width };
        let q0 = lo + q0_frac * width;
        let eps = make_eps(r, s1, s3, 0.0);
        let fixed = RootFinderConfig { tol: 1e-6, q_tol: Some(1e-9), max_trials: 1000, ..Default::default() };
        let mut f = IllinoisRootFinder::new(q0, lo, hi, fixed.clone()).unwrap();
        common::run(&mut f, |q| vec![eps(q[0])]);
        prop_assert!(matches!(f.status(), Status::HitBound { .. }), "without expansions: {:?}", f.status());
        let cfg = RootFinderConfig { max_expansions: 4, ..fixed };
        let mut f = IllinoisRootFinder::new(q0, lo, hi, cfg).unwrap();
        common::run(&mut f, |q| vec![eps(q[0])]);
        prop_assert!(matches!(f.status(), Status::Converged | Status::Bracketed), "{:?}", f.status());
        let (a, b) = f.bracket();
        prop_assert!(a <= r && r <= b, "root {} outside the final bracket [{}, {}]", r, a, b);
        let (el, eh) = f.expansions();
        prop_assert!(el + eh >= 1 && el.max(eh) <= 4);
    }

    #[test]
    fn golden_section_brackets_shrink_by_the_golden_factors(
        r in 0.1..0.9f64, q0 in 0.0..1.0f64, s1 in 0.05..5.0f64, s3 in 0.0..5.0f64,
    ) {
        let eps = make_eps(r, s1, s3, 0.0);
        let cfg = GoldenConfig { mode: GoldenMode::Paper, tol: 1e-6, q_tol: Some(1e-9), max_trials: 40, max_expansions: 0, ..GoldenConfig::default() };
        let mut g = GoldenSection::new(q0, 0.0, 1.0, cfg).unwrap();
        let mut prev = None;
        while g.status() == Status::Running {
            let q = g.ask().unwrap();
            g.tell(&q, &[eps(q[0])]).unwrap();
            let (a, b) = g.bracket();
            prop_assert!(a <= r && r <= b, "root {} left the bracket [{}, {}]", r, a, b);
            if let Some(p) = prev && g.status() == Status::Running {
                let ratio: f64 = (b - a) / p;
                prop_assert!((ratio - 0.618).abs() < 1e-9 || (ratio - 0.382).abs() < 1e-9, "ratio {}", ratio);
            }
            prev = Some(b - a);
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn one_wrong_sign_does_not_corrupt_golden_sections_bracket_with_the_noise_guard(
        r in 0.1..0.9f64, q0 in 0.05..0.95f64, s1 in 0.2..5.0f64, s3 in 0.0..5.0f64,
        flip in 0usize..6, robust in any::<bool>(),
    ) {
        // eps exact except the reading of trial `flip`, whose sign is wrong (at full size, so
        // guard 1 does not see it unless it is small): guard 2 must re-open the wrong limit.
        let eps = make_eps(r, s1, s3, 0.0);
        let cfg = GoldenConfig {
            mode: if robust { GoldenMode::Robust } else { GoldenMode::Paper },
            tol: 1e-4, q_tol: Some(1e-9), max_trials: 80, max_expansions: 0,
            noise: Some(1e-6), ..GoldenConfig::default()
        };
        let mut g = GoldenSection::new(q0, 0.0, 1.0, cfg).unwrap();
        let mut k = 0;
        while g.status() == Status::Running {
            let q = g.ask().unwrap();
            let e = eps(q[0]);
            g.tell(&q, &[if k == flip { -e } else { e }]).unwrap();
            k += 1;
        }
        prop_assert_eq!(g.status(), Status::Converged, "after {} trials, bracket {:?}", k, g.bracket());
        prop_assert!((g.best().unwrap().q[0] - r).abs() < 1e-4 / s1);
    }
}
