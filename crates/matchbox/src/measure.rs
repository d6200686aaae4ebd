//! From the box's tilt history to the paper's measures (eq. 18, docs/method.md §8.2-8.3).
//!
//! phi(t) is the rotation about the pivot axis from the initial pose, positive toward upright,
//! unwrapped and clipped to [0, pi] (fast strikes make the box somersault).

use std::f64::consts::{FRAC_PI_2, PI};

use super::config::MatchboxConfig;

/// How a flip ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Regime {
    /// Never reached upright (phi_max < pi/2).
    FlippedBack,
    /// Standing on its narrow face at the end.
    Upright,
    /// Passed upright and did not stay there.
    FlippedOver,
    /// Ended below the table top: knocked off the edge.
    OffTable,
}

impl Regime {
    pub fn as_str(self) -> &'static str {
        match self {
            Regime::FlippedBack => "flipped_back",
            Regime::Upright => "upright",
            Regime::FlippedOver => "flipped_over",
            Regime::OffTable => "off_table",
        }
    }
}

/// The measures of one episode.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Measures {
    pub phi_max: f64,
    /// First time phi >= pi/2, if ever.
    pub t0: Option<f64>,
    /// phi(t0 + Delta t), if t0 exists.
    pub phi_after: Option<f64>,
    /// The outcome in query units (docs/method.md §8.2): phi_max if flipped back, else phi(t0 + Dt).
    pub outcome_angle: f64,
    /// Eq. 18 as printed: outcome_angle - pi/2. Learners use the query convention
    /// eps = pi/2 - outcome_angle (its negative; docs/method.md §8.2).
    pub eps18: f64,
    pub regime: Regime,
}

/// Unwraps a sequence of raw angles in (-pi, pi] into a continuous one.
pub fn unwrap(raw: &[f64]) -> Vec<f64> {
    let mut out = Vec::with_capacity(raw.len());
    let mut offset = 0.0;
    let mut prev = match raw.first() {
        Some(&p) => p,
        None => return out,
    };
    for &a in raw {
        let d = a - prev;
        if d > PI {
            offset -= 2.0 * PI;
        } else if d < -PI {
            offset += 2.0 * PI;
        }
        out.push(a + offset);
        prev = a;
    }
    out
}

/// Linear interpolation of `y(t)` at `at` (clamped to the ends).
fn interp(t: &[f64], y: &[f64], at: f64) -> f64 {
    let j = t.partition_point(|&s| s <= at);
    if j == 0 {
        return y[0];
    }
    if j >= t.len() {
        return y[t.len() - 1];
    }
    let w = (at - t[j - 1]) / (t[j] - t[j - 1]);
    y[j - 1] + w * (y[j] - y[j - 1])
}

/// Measures of a clipped tilt history `phi` sampled at `t`. `off_table` says whether the box
/// ended below the table top.
pub fn measure(t: &[f64], phi: &[f64], off_table: bool, cfg: &MatchboxConfig) -> Measures {
    let phi_max = phi.iter().copied().fold(0.0, f64::max);
    let t0 = phi.iter().position(|&p| p >= FRAC_PI_2).map(|j| t[j]);
    let phi_after = t0.map(|t0| interp(t, phi, t0 + cfg.delta_t));
    let outcome_angle = phi_after.unwrap_or(phi_max);
    let end = t.last().copied().unwrap_or(0.0);
    let upright = t0.is_some()
        && t.iter()
            .zip(phi)
            .filter(|(s, _)| **s >= end - cfg.upright_hold)
            .all(|(_, p)| (p - FRAC_PI_2).abs() <= cfg.upright_tolerance);
    let regime = if off_table {
        Regime::OffTable
    } else if upright {
        Regime::Upright
    } else if t0.is_some() {
        Regime::FlippedOver
    } else {
        Regime::FlippedBack
    };
    Measures {
        phi_max,
        t0,
        phi_after,
        outcome_angle,
        eps18: outcome_angle - FRAC_PI_2,
        regime,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn series(f: impl Fn(f64) -> f64) -> (Vec<f64>, Vec<f64>) {
        let t: Vec<f64> = (0..=2000).map(|j| j as f64 * 1e-3).collect();
        let phi = t.iter().map(|&s| f(s)).collect();
        (t, phi)
    }

    #[test]
    fn unwrap_follows_somersaults() {
        let raw: Vec<f64> = (0..100)
            .map(|k| ((k as f64) * 0.3 + PI).rem_euclid(2.0 * PI) - PI)
            .collect();
        let u = unwrap(&raw);
        for k in 1..u.len() {
            assert!((u[k] - u[k - 1] - 0.3).abs() < 1e-12);
        }
    }

    #[test]
    fn flipped_back_uses_the_peak() {
        let cfg = MatchboxConfig::default();
        let (t, phi) = series(|s| 1.0 * (PI * s.min(1.0)).sin());
        let m = measure(&t, &phi, false, &cfg);
        assert_eq!(m.regime, Regime::FlippedBack);
        assert!((m.outcome_angle - 1.0).abs() < 1e-6 && m.t0.is_none());
        assert!((m.eps18 - (1.0 - FRAC_PI_2)).abs() < 1e-6);
    }

    #[test]
    fn upright_and_flipped_over_use_the_angle_delta_t_after_upright() {
        let cfg = MatchboxConfig::default();
        // Rises at 4 rad/s past upright, then settles at pi/2.
        let (t, phi) = series(|s| if s < 0.5 { 4.0 * s } else { FRAC_PI_2 });
        let m = measure(&t, &phi, false, &cfg);
        assert_eq!(m.regime, Regime::Upright);
        let t0 = m.t0.unwrap();
        assert!((t0 - 0.393).abs() < 1e-3);
        assert!(
            (m.outcome_angle - 4.0 * (t0 + 0.05)).abs() < 1e-3,
            "still rising 0.05 s after t0"
        );
        let (t, phi) = series(|s| (4.0 * s).min(PI));
        let m = measure(&t, &phi, false, &cfg);
        assert_eq!(m.regime, Regime::FlippedOver);
        assert!((m.outcome_angle - 4.0 * (m.t0.unwrap() + 0.05)).abs() < 1e-3);
        assert!(m.eps18 > 0.0);
        assert_eq!(measure(&t, &phi, true, &cfg).regime, Regime::OffTable);
    }
}
