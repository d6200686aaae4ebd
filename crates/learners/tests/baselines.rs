//! PoWER and PI² in weight space: they reduce a quadratic cost, are deterministic for a seed,
//! and PI² with a terminal-only cost and no projection is PI^BB.

mod common;

use learners::{AskTell, Pi2, Pi2Config, Power, PowerConfig, Status};

fn target(dim: usize) -> Vec<f64> {
    (0..dim).map(|i| (i as f64 * 0.7).sin()).collect()
}

fn sq_dist(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum()
}

fn power(seed: u64, dim: usize) -> Power {
    Power::new(
        &vec![0.0; dim],
        &[0.3],
        PowerConfig {
            n_best: 10,
            adapt_variance: false,
            variance_window: 100,
            target_return: None,
            max_trials: 400,
            seed,
        },
    )
    .unwrap()
}

#[test]
fn power_reduces_a_quadratic_cost() {
    let dim = 6;
    let t = target(dim);
    let mut p = power(1, dim);
    let start = sq_dist(&[0.0; 6], &t);
    common::run(&mut p, |th| vec![(-sq_dist(th, &t)).exp()]);
    assert_eq!(p.status(), Status::TrialCap);
    let end = sq_dist(p.mean(), &t);
    assert!(end < 0.1 * start, "{start} -> {end}");
}

#[test]
fn power_adaptive_variance_stays_within_its_clip() {
    let dim = 3;
    let t = target(dim);
    let mut p = Power::new(
        &[0.0; 3],
        &[0.3, 0.2, 0.1],
        PowerConfig {
            n_best: 10,
            adapt_variance: true,
            variance_window: 100,
            target_return: Some(0.999),
            max_trials: 600,
            seed: 5,
        },
    )
    .unwrap();
    common::run(&mut p, |th| vec![(-sq_dist(th, &t)).exp()]);
    for (v, s) in p.variance().iter().zip([0.3f64, 0.2, 0.1]) {
        assert!(*v >= 0.1 * s * s - 1e-15 && *v <= 10.0 * s * s + 1e-15);
    }
    assert!(p.converged(), "{:?}", p.status());
    assert!(p.best().unwrap().feedback[0] >= 0.999);
}

#[test]
fn power_is_deterministic_for_a_seed() {
    let t = target(4);
    let go = |seed| {
        let mut p = power(seed, 4);
        common::run(&mut p, |th| vec![(-sq_dist(th, &t)).exp()]);
        p.history().to_vec()
    };
    assert_eq!(go(7), go(7));
    assert_ne!(go(7), go(8));
}

#[test]
fn power_rejects_a_non_positive_return() {
    let mut p = power(0, 2);
    let th = p.ask().unwrap();
    let e = p.tell(&th, &[0.0]).unwrap_err();
    assert!(
        e.is_input_error() && e.to_string().contains("must be > 0"),
        "{e}"
    );
}

fn pi2_cfg(seed: u64, projection: bool) -> Pi2Config {
    Pi2Config {
        n_rollouts: 10,
        n_reuse: 5,
        h: 10.0,
        n_updates: 20,
        n_dof: 2,
        n_steps: 50,
        alpha_x: 2.0,
        width_factor: 2.0,
        projection,
        cost_tol: None,
        max_trials: 250,
        seed,
    }
}

#[test]
fn pi2_with_a_terminal_cost_and_no_projection_is_pi_bb() {
    let dim = 2 * 8;
    let t = target(dim);
    let mut l = Pi2::new(&vec![0.1; dim], &[0.2], pi2_cfg(3, false)).unwrap();
    let cost = |th: &[f64]| vec![sq_dist(th, &t)];
    // Run two updates (the second reuses 5 rollouts), checking each against PI^BB computed here.
    let mut batch: Vec<(Vec<f64>, f64)> = Vec::new();
    for update in 0..2 {
        let theta = l.ask().unwrap(); // the noiseless evaluation rollout
        assert_eq!(theta, l.theta());
        l.tell(&theta, &cost(&theta)).unwrap();
        let new = if update == 0 { 10 } else { 5 };
        for _ in 0..new {
            let th = l.ask().unwrap();
            let c = cost(&th)[0];
            l.tell(&th, &[c]).unwrap();
            batch.push((th, c));
        }
        // PI^BB (Stulp & Sigaud 2012): theta += sum_k P_k (theta_k - theta)
        let (lo, hi) = batch
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), (_, c)| {
                (l.min(*c), h.max(*c))
            });
        let p: Vec<f64> = batch
            .iter()
            .map(|(_, c)| (-10.0 * (c - lo) / (hi - lo)).exp())
            .collect();
        let sum: f64 = p.iter().sum();
        let expected: Vec<f64> = (0..dim)
            .map(|j| {
                theta[j]
                    + batch
                        .iter()
                        .zip(&p)
                        .map(|((th, _), pk)| pk / sum * (th[j] - theta[j]))
                        .sum::<f64>()
            })
            .collect();
        for (a, b) in l.theta().iter().zip(&expected) {
            assert!((a - b).abs() < 1e-12, "update {update}: {a} vs {b}");
        }
        // the 5 cheapest rollouts are reused
        batch.sort_by(|a, b| a.1.total_cmp(&b.1));
        batch.truncate(5);
    }
}

#[test]
fn pi2_with_projection_blends_neighbouring_weights_and_still_learns() {
    // With the projection the update is not PI^BB (M_i is not the identity) ...
    let dim = 2 * 8;
    let t = target(dim);
    let mut a = Pi2::new(&vec![0.0; dim], &[0.2], pi2_cfg(4, true)).unwrap();
    let mut b = Pi2::new(&vec![0.0; dim], &[0.2], pi2_cfg(4, false)).unwrap();
    for _ in 0..11 {
        let (qa, qb) = (a.ask().unwrap(), b.ask().unwrap());
        assert_eq!(qa, qb); // same seed, same noise before the first update
        a.tell(&qa, &[sq_dist(&qa, &t)]).unwrap();
        b.tell(&qb, &[sq_dist(&qb, &t)]).unwrap();
    }
    let diff = sq_dist(a.theta(), b.theta());
    assert!(diff > 1e-6, "projection made no difference");
    // ... but it reduces the cost, with terminal and with per-step costs.
    let start = sq_dist(&vec![0.0; dim], &t);
    common::run(&mut a, |th| vec![sq_dist(th, &t)]);
    assert!(
        sq_dist(a.theta(), &t) < 0.3 * start,
        "{} -> {}",
        start,
        sq_dist(a.theta(), &t)
    );
    let mut c = Pi2::new(&vec![0.0; dim], &[0.2], pi2_cfg(4, true)).unwrap();
    common::run(&mut c, |th| vec![sq_dist(th, &t) / 50.0; 50]);
    assert!(sq_dist(c.theta(), &t) < 0.3 * start);
}

#[test]
fn pi2_reduces_a_quadratic_cost_and_converges_on_an_evaluation_rollout() {
    let dim = 2 * 8;
    let t = target(dim);
    let mut cfg = pi2_cfg(11, false);
    cfg.cost_tol = Some(0.05);
    cfg.max_trials = 1000;
    let mut l = Pi2::new(&vec![0.0; dim], &[0.2], cfg).unwrap();
    let n = common::run(&mut l, |th| vec![sq_dist(th, &t)]);
    assert!(l.converged(), "{:?} after {n}", l.status());
    // evaluation rollouts are the 1st, 12th, 18th, ... (1 + 10, then 1 + 5 per update)
    assert!(
        n == 1 || (n - 12) % 6 == 0,
        "converged on trial {n}, not an evaluation rollout"
    );
    assert!(sq_dist(l.theta(), &t) <= 0.05);
}

#[test]
fn pi2_is_deterministic_for_a_seed_and_checks_its_cost_shape() {
    let dim = 2 * 8;
    let t = target(dim);
    let go = |seed| {
        let mut l = Pi2::new(&vec![0.0; dim], &[0.2], pi2_cfg(seed, true)).unwrap();
        common::run(&mut l, |th| vec![sq_dist(th, &t)]);
        l.theta().to_vec()
    };
    assert_eq!(go(1), go(1));
    assert_ne!(go(1), go(2));
    let mut l = Pi2::new(&vec![0.0; dim], &[0.2], pi2_cfg(1, true)).unwrap();
    let th = l.ask().unwrap();
    let e = l.tell(&th, &[1.0, 2.0]).unwrap_err();
    assert!(
        e.to_string()
            .contains("costs has 2 entries, expected 1 or 50 entries"),
        "{e}"
    );
    let e = Pi2::new(&[0.0; 15], &[0.2], pi2_cfg(1, true)).unwrap_err();
    assert!(e.is_input_error(), "{e}");
}

#[test]
fn power_never_asks_a_non_finite_query() {
    // sigma = 1e200: the variance sigma^2 overflows; refused up front.
    let e = Power::new(&[0.0; 3], &[1e200], PowerConfig::default()).unwrap_err();
    assert!(
        e.is_input_error() && e.to_string().contains("overflows"),
        "{e}"
    );
}

#[test]
fn power_is_invariant_to_the_scale_of_finite_returns_up_to_f64_max() {
    // The update is a ratio of return-weighted sums: returns scaled by 2^1000 (exactly, about
    // 1e301) give the same means bit for bit, and a return of 1e308 no longer overflows them.
    let returns = [1.5, 3.0, 0.5, 2.0, 1.25, 4.0];
    let run = |scale: f64| {
        let mut p = Power::new(&[0.0; 3], &[0.3], PowerConfig::default()).unwrap();
        for r in returns {
            let th = p.ask().unwrap();
            p.tell(&th, &[r * scale]).unwrap();
        }
        (p.mean().to_vec(), p.variance().to_vec(), p.status())
    };
    let (plain, scaled) = (run(1.0), run(2f64.powi(1000)));
    assert_eq!(plain, scaled);
    assert!(plain.0.iter().all(|m| m.is_finite()));
    let mut p = Power::new(&[0.0; 3], &[0.3], PowerConfig::default()).unwrap();
    for r in [1e308, f64::MAX, 1e-300] {
        let th = p.ask().unwrap();
        p.tell(&th, &[r]).unwrap();
        assert!(p.mean().iter().chain(p.variance()).all(|v| v.is_finite()));
        assert_ne!(p.status(), Status::Diverged);
    }
}

#[test]
fn pi2_refuses_sizes_no_rollout_has_and_says_why() {
    for n_steps in [1usize << 40, 1_000_000_000] {
        let cfg = Pi2Config {
            n_steps,
            ..Pi2Config::default()
        };
        let e = Pi2::new(&[0.0; 5], &[0.1], cfg).unwrap_err();
        assert!(
            e.is_input_error() && e.to_string().contains("n_steps x n_basis"),
            "{e}"
        );
    }
    let cfg = Pi2Config {
        n_steps: 100_000,
        ..Pi2Config::default()
    };
    assert!(Pi2::new(&[0.0; 5], &[0.1], cfg).is_ok());
}
