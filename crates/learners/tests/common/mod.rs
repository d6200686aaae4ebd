//! Helpers shared by the learner tests: run a learner against a synthetic map until it stops.

#![allow(dead_code)]

use learners::{AskTell, Status};

/// Runs `learner` with `feedback(q)` until it stops; returns the number of trials.
pub fn run<L: AskTell>(learner: &mut L, mut feedback: impl FnMut(&[f64]) -> Vec<f64>) -> usize {
    let mut guard = 0;
    while learner.status() == Status::Running {
        let q = learner.ask().unwrap();
        let f = feedback(&q);
        learner.tell(&q, &f).unwrap();
        guard += 1;
        assert!(guard < 100_000, "learner did not stop");
    }
    learner.n_told()
}

/// eps = q0 - q_a(q) for a scalar map q_a.
pub fn eps1(q0: f64, qa: impl Fn(f64) -> f64) -> impl FnMut(&[f64]) -> Vec<f64> {
    move |q: &[f64]| vec![q0 - qa(q[0])]
}

/// The root of a decreasing scalar function on [lo, hi] by plain bisection (independent of the
/// learners under test).
pub fn bisect(f: impl Fn(f64) -> f64, mut lo: f64, mut hi: f64) -> f64 {
    assert!(f(lo) > 0.0 && f(hi) < 0.0);
    for _ in 0..200 {
        let m = 0.5 * (lo + hi);
        if f(m) > 0.0 { lo = m } else { hi = m }
    }
    0.5 * (lo + hi)
}

/// A tiny deterministic Gaussian noise source (Box-Muller on a 64-bit LCG), so that the test
/// of noisy measurements does not depend on the RNG the learners use.
pub struct Noise(u64);
impl Noise {
    pub fn new(seed: u64) -> Self {
        Self(
            seed.wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407),
        )
    }
    fn uniform(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((self.0 >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }
    pub fn gauss(&mut self) -> f64 {
        let (u, v) = (self.uniform(), self.uniform());
        (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
    }
}
