//! # matchbox
//!
//! The matchbox flip-up of the paper's first experiment (Fig. 3), simulated with Rapier 3-D.
//!
//! A kinematic fingertip follows a DMP's trajectory up under the overhanging edge of a matchbox
//! lying on a table; the box tips about its bottom edge and flips back, stands upright on its
//! 53 x 16 mm face, or flips over, depending on the strike speed. The measures are those of the
//! paper's eq. 18 with the sign resolved as in docs/method.md §8.2. It knows no DMPs and no learners:
//! a fingertip path in, the box's measures out.

mod config;
mod measure;
mod sim;

pub use config::{Error, FLOOR_Z, MatchboxConfig, Result, TABLE_THICKNESS};
pub use measure::{Measures, Regime, measure, unwrap};
pub use sim::{Episode, FingerPath, MAX_SIMULATED_TIME, simulate};

use rayon::prelude::*;

/// Simulates many strikes in parallel; the same as calling [`simulate`] on each, bit for bit.
pub fn simulate_batch(paths: &[FingerPath<'_>], cfg: &MatchboxConfig) -> Vec<Result<Episode>> {
    paths.par_iter().map(|p| simulate(p, cfg)).collect()
}

/// A minimum-jerk fingertip strike between two points over `duration` seconds, sampled every
/// `dt` seconds: the scripted demonstrator's movement.
pub fn min_jerk_strike(
    from: [f64; 2],
    to: [f64; 2],
    duration: f64,
    dt: f64,
) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let n = (duration / dt).round().max(2.0) as usize;
    let mut t = Vec::with_capacity(n + 1);
    let (mut x, mut z) = (Vec::with_capacity(n + 1), Vec::with_capacity(n + 1));
    for j in 0..=n {
        let s = j as f64 / n as f64;
        let m = 10.0 * s.powi(3) - 15.0 * s.powi(4) + 6.0 * s.powi(5);
        t.push(s * duration);
        x.push(from[0] + m * (to[0] - from[0]));
        z.push(from[1] + m * (to[1] - from[1]));
    }
    (t, x, z)
}
