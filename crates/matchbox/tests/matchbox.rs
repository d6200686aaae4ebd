//! The matchbox simulation has the paper's structure, is deterministic and rejects bad input.

use matchbox::{
    FingerPath, MatchboxConfig, Measures, Regime, min_jerk_strike, simulate, simulate_batch,
};

fn strike(duration: f64) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let cfg = MatchboxConfig::default();
    let (from, to) = cfg.default_strike();
    min_jerk_strike(from, to, duration, 1e-3)
}

/// The measures of one default scripted strike of `duration` seconds.
fn measures(duration: f64) -> Measures {
    let (t, x, z) = strike(duration);
    let path = FingerPath {
        t: &t,
        x: &x,
        z: &z,
    };
    simulate(&path, &MatchboxConfig::default())
        .unwrap()
        .measures
}

/// Sweeping the strike speed goes flipped back, then upright, then flipped over (paper §5), with
/// an upright window of at least +-6 % of strike speed (docs/method.md §8.3).
#[test]
fn faster_strikes_go_back_then_upright_then_over() {
    let durations: Vec<f64> = (0..=40).map(|k| 0.14 - 0.002 * k as f64).collect(); // slow -> fast
    let cfg = MatchboxConfig::default();
    let strikes: Vec<_> = durations.iter().map(|&d| strike(d)).collect();
    let paths: Vec<FingerPath> = strikes
        .iter()
        .map(|(t, x, z)| FingerPath { t, x, z })
        .collect();
    let regimes: Vec<Regime> = simulate_batch(&paths, &cfg)
        .into_iter()
        .map(|e| e.unwrap().measures.regime)
        .collect();
    let first_up = regimes
        .iter()
        .position(|r| *r == Regime::Upright)
        .expect("an upright window");
    let last_up = regimes.iter().rposition(|r| *r == Regime::Upright).unwrap();
    assert!(
        regimes[..first_up]
            .iter()
            .all(|r| *r == Regime::FlippedBack),
        "{regimes:?}"
    );
    assert!(
        regimes[last_up + 1..]
            .iter()
            .all(|r| *r == Regime::FlippedOver),
        "{regimes:?}"
    );
    let upright = regimes[first_up..=last_up]
        .iter()
        .filter(|r| **r == Regime::Upright)
        .count();
    assert!(
        upright as f64 >= 0.8 * (last_up - first_up + 1) as f64,
        "{regimes:?}"
    );
    // Speed is proportional to 1 / duration.
    let (slow, fast) = (durations[first_up], durations[last_up]);
    let half_width = (slow - fast) / (slow + fast);
    assert!(
        half_width >= 0.06,
        "upright window {fast}..{slow} s is only +-{:.1} %",
        100.0 * half_width
    );
}

#[test]
fn flip_back_errors_are_bounded_by_the_tipping_angle() {
    // phi_max cannot exceed the tipping angle pi/2 - atan(16/36) = 66 deg without going on to
    // upright or over (docs/method.md §8.3): flip-back errors jump across zero (paper Fig. 2c).
    let tipping = std::f64::consts::FRAC_PI_2 - (16.0f64 / 36.0).atan();
    for d in [0.16, 0.14, 0.12] {
        let m = measures(d);
        assert_eq!(m.regime, Regime::FlippedBack);
        assert!(
            m.phi_max > 0.1 && m.phi_max < tipping + 0.02,
            "{}",
            m.phi_max.to_degrees()
        );
        assert_eq!(m.outcome_angle, m.phi_max);
    }
}

#[test]
fn episodes_are_bit_identical_and_batch_equals_serial() {
    let (t, x, z) = strike(0.1);
    let path = FingerPath {
        t: &t,
        x: &x,
        z: &z,
    };
    let cfg = MatchboxConfig::default();
    let a = simulate(&path, &cfg).unwrap();
    let b = simulate(&path, &cfg).unwrap();
    assert_eq!(a, b);
    let batch = simulate_batch(&[path, path, path], &cfg);
    for e in batch {
        assert_eq!(e.unwrap(), a);
    }
    assert_eq!(a.t.len(), a.phi.len());
    assert!((a.t[a.t.len() - 1] - (0.1 + cfg.settle_time)).abs() < 1e-9);
}

#[test]
fn bad_trajectories_are_errors_with_a_reason() {
    let cfg = MatchboxConfig::default();
    let (t, x, mut z) = strike(0.1);
    let check = |t: &[f64], x: &[f64], z: &[f64]| FingerPath { t, x, z }.problems(&cfg).join("; ");
    z[10] = f64::NAN;
    assert!(check(&t, &x, &z).contains("z[10] is NaN"));
    let (t, x, z) = strike(0.1);
    assert!(check(&t[..1], &x[..1], &z[..1]).contains("at least 2"));
    assert!(check(&t, &x[..5], &z).contains("samples"));
    let mut bad_t = t.clone();
    bad_t[3] = bad_t[2];
    assert!(check(&bad_t, &x, &z).contains("strictly increasing"));
    let through: Vec<f64> = x.iter().map(|v| v - 0.02).collect(); // fingertip under the table
    assert!(check(&t, &through, &z).contains("passes through the table"));
    let high: Vec<f64> = z.iter().map(|v| v + 0.2).collect();
    assert!(check(&t, &x, &high).contains("leaves the workspace"));
    assert!(
        simulate(
            &FingerPath {
                t: &t,
                x: &through,
                z: &z
            },
            &cfg
        )
        .is_err()
    );
    let long: Vec<f64> = t.iter().map(|v| v * 1e6).collect();
    assert!(check(&long, &x, &z).contains("exceeds the 60 s"));
    let bad_cfg = MatchboxConfig {
        overhang: 0.03,
        ..cfg
    };
    assert!(
        simulate(
            &FingerPath {
                t: &t,
                x: &x,
                z: &z
            },
            &bad_cfg
        )
        .is_err()
    );
    assert_eq!(measures(0.1).regime, measures(0.1).regime);
}
