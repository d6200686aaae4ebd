//! The phase (canonical system, paper eq. 3) and the radial basis of the forcing term (eq. 4).
//!
//! Neither depends on the state y, so a rollout or fit computes them once per sample and shares
//! them across all degrees of freedom.

use crate::error::{Error, Result};

/// Relative activations below `exp(-ACTIVATION_CUTOFF)` (about 1e-16, the f64 rounding unit) are
/// treated as exactly zero: they cannot change the normalized sum (its largest term is 1) beyond
/// rounding, and skipping them saves all but about nine `exp` calls per phase value.
const ACTIVATION_CUTOFF: f64 = 37.0;

/// Gaussian kernels `Psi_k(x) = exp(-h_k (x - c_k)^2)` on the phase `x` (paper eq. 4), with the
/// centres and widths of the JSI lab code (docs/method.md §2.2):
/// `c_k = exp(-alpha_x (k-1)/(N-1))`, `h_k = width_factor / (c_{k+1} - c_k)^2`, `h_N = h_{N-1}`.
/// `width_factor = 2` is the lab code's value (`sigma_k = (c_{k+1}-c_k)/2`).
#[derive(Debug, Clone, PartialEq)]
pub struct Basis {
    centers: Vec<f64>,
    widths: Vec<f64>,
    /// `ln(c_k / c_{k+1}) = alpha_x / (N - 1)`.
    log_ratio: f64,
}

impl Basis {
    pub fn new(n_basis: usize, alpha_x: f64, width_factor: f64) -> Result<Self> {
        if n_basis < 2 {
            return Err(Error::InvalidParameter {
                name: "n_basis",
                value: n_basis.to_string(),
                requirement: "must be at least 2",
            });
        }
        crate::error::check_scalar("alpha_x", alpha_x, true)?;
        crate::error::check_scalar("width_factor", width_factor, true)?;
        let last = (n_basis - 1) as f64;
        let centers: Vec<f64> = (0..n_basis)
            .map(|k| (-alpha_x * k as f64 / last).exp())
            .collect();
        let mut widths: Vec<f64> = centers
            .windows(2)
            .map(|c| width_factor / ((c[1] - c[0]) * (c[1] - c[0])))
            .collect();
        widths.push(widths[n_basis - 2]);
        Ok(Self {
            centers,
            widths,
            log_ratio: alpha_x / last,
        })
    }

    pub fn len(&self) -> usize {
        self.centers.len()
    }

    pub fn is_empty(&self) -> bool {
        self.centers.is_empty()
    }

    pub fn centers(&self) -> &[f64] {
        &self.centers
    }

    pub fn widths(&self) -> &[f64] {
        &self.widths
    }

    /// Writes the normalized activations `Psi_k(x) / sum_i Psi_i(x)` into `out` and returns the
    /// index range `lo..hi` outside which they are zero (entries outside it are not written).
    ///
    /// The kernels are evaluated relative to the most active one: the ratio is unchanged, but it
    /// never underflows to 0/0, even far past tau where x -> 0 and every `Psi_k` is below
    /// `f64::MIN_POSITIVE` for large N. The exponentials are [`crate::exp::exp`]'s, the C
    /// library's bits; the rollouts' and steppers' forcing term gives these same bits.
    pub fn normalized_activations(&self, x: f64, out: &mut [f64]) -> std::ops::Range<usize> {
        debug_assert_eq!(out.len(), self.centers.len());
        let (lo, hi, min_arg) = self.active(x, self.bracket(x));
        let mut sum = 0.0;
        for (k, v) in (lo..hi).zip(&mut out[lo..hi]) {
            *v = crate::exp::exp(min_arg - self.arg(x, k));
            sum += *v;
        }
        let inv = 1.0 / sum;
        for v in &mut out[lo..hi] {
            *v *= inv;
        }
        lo..hi
    }

    /// The exponent `h_k (x - c_k)^2` of kernel k.
    #[inline(always)]
    pub(crate) fn arg(&self, x: f64, k: usize) -> f64 {
        let d = x - self.centers[k];
        self.widths[k] * d * d
    }

    /// The kernel `k0` with `c_k0 >= x >= c_{k0+1}`: `floor(ln(1/x) / ln(1/r))`, clamped to the
    /// basis (a phase within rounding of a centre may land on either side of it; every caller
    /// takes this rule's side, which fixes the most active kernel and so the bits).
    #[inline]
    pub(crate) fn bracket(&self, x: f64) -> usize {
        let steps = -(x.max(f64::MIN_POSITIVE)).ln() / self.log_ratio;
        if steps.is_finite() && steps > 0.0 {
            (steps as usize).min(self.centers.len() - 2)
        } else {
            0
        }
    }

    /// The active kernels `lo..hi` at phase `x`, whose bracket is `k0` ([`Basis::bracket`]),
    /// and the smallest exponent `min_arg`; the kernels below `exp(-ACTIVATION_CUTOFF)` of the
    /// most active are left out.
    ///
    /// Because the centres are geometric (`c_k = r^k`) and the widths scale with the spacing,
    /// `h_k (x - c_k)^2` grows monotonically away from the two centres that bracket `x`. So the
    /// most active kernel is one of those two, and the active set is found by walking outwards
    /// from them: about ten kernels are touched instead of all N.
    #[inline(always)]
    pub(crate) fn active(&self, x: f64, k0: usize) -> (usize, usize, f64) {
        let n = self.centers.len();
        let (a0, a1) = (self.arg(x, k0), self.arg(x, k0 + 1));
        let min_arg = a0.min(a1);
        let limit = min_arg + ACTIVATION_CUTOFF;
        let mut lo = k0 + 1;
        while lo > 0 && self.arg(x, lo - 1) <= limit {
            lo -= 1;
        }
        let mut hi = k0 + 1;
        while hi < n && (if hi == k0 + 1 { a1 } else { self.arg(x, hi) }) <= limit {
            hi += 1;
        }
        if lo == hi {
            // Only reachable if a rounding error made both bracketing kernels exceed the limit.
            return (k0, k0 + 1, min_arg);
        }
        (lo, hi, min_arg)
    }
}

/// The phase of eq. 3 solved in closed form, `x(t) = exp(-alpha_x t / tau)`, used for fitting.
pub fn phase(t: f64, tau: f64, alpha_x: f64) -> f64 {
    (-alpha_x * t / tau).exp()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centres_and_widths_follow_the_lab_code() {
        let b = Basis::new(5, 2.0, 2.0).unwrap();
        for (k, c) in b.centers().iter().enumerate() {
            assert!((c - (-2.0 * k as f64 / 4.0).exp()).abs() < 1e-15);
        }
        // sigma_k = (c_{k+1} - c_k)/2 and Psi = exp(-0.5 (x-c)^2 / sigma^2)
        let sigma = (b.centers()[1] - b.centers()[0]) / 2.0;
        assert!((b.widths()[0] - 0.5 / (sigma * sigma)).abs() < 1e-9 * b.widths()[0]);
        assert_eq!(b.widths()[4], b.widths()[3]);
    }

    #[test]
    fn normalized_activations_match_the_direct_formula() {
        let b = Basis::new(30, 2.0, 2.0).unwrap();
        let mut out = vec![0.0; 30];
        for &x in &[1.0, 0.9, 0.5, 0.2, 0.135, 0.3333] {
            let range = b.normalized_activations(x, &mut out);
            let psi: Vec<f64> = (0..30)
                .map(|k| (-b.widths()[k] * (x - b.centers()[k]).powi(2)).exp())
                .collect();
            let s: f64 = psi.iter().sum();
            for k in 0..30 {
                let got = if range.contains(&k) { out[k] } else { 0.0 };
                assert!((got - psi[k] / s).abs() < 1e-14, "x={x} k={k}");
            }
        }
    }

    #[test]
    fn the_walk_finds_every_significant_kernel() {
        for (n, alpha_x, wf) in [
            (2, 2.0, 2.0),
            (7, 1.0, 1.0),
            (50, 2.0, 2.0),
            (120, 4.0, 0.5),
        ] {
            let b = Basis::new(n, alpha_x, wf).unwrap();
            let mut out = vec![0.0; n];
            for i in 0..=400 {
                let x = (-(i as f64) / 100.0).exp(); // 1 down to e^-4, past the last centre
                let range = b.normalized_activations(x, &mut out);
                let args: Vec<f64> = (0..n)
                    .map(|k| b.widths()[k] * (x - b.centers()[k]).powi(2))
                    .collect();
                let min = args.iter().cloned().fold(f64::INFINITY, f64::min);
                let psi: Vec<f64> = args.iter().map(|a| (min - a).exp()).collect();
                let s: f64 = psi.iter().sum();
                for k in 0..n {
                    let got = if range.contains(&k) { out[k] } else { 0.0 };
                    assert!((got - psi[k] / s).abs() < 1e-15, "n={n} x={x} k={k}");
                }
            }
        }
    }

    #[test]
    fn activations_stay_finite_as_the_phase_vanishes() {
        let b = Basis::new(200, 2.0, 2.0).unwrap();
        let mut out = vec![0.0; 200];
        for &x in &[1e-3, 1e-30, 0.0] {
            let r = b.normalized_activations(x, &mut out);
            let s: f64 = out[r.clone()].iter().sum();
            assert!((s - 1.0).abs() < 1e-12);
            assert!(out[r].iter().all(|v| v.is_finite()));
        }
    }

    #[test]
    fn too_few_kernels_is_an_error() {
        assert!(matches!(
            Basis::new(1, 2.0, 2.0),
            Err(Error::InvalidParameter { .. })
        ));
    }
}
