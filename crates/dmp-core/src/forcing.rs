//! The forcing term of eq. 4, `f(x) = x sum_k w_k Psi_k(x) / sum_k Psi_k(x)`, evaluated one
//! phase at a time for the steppers, where it is most of the cost of a control period.
//!
//! It computes what [`crate::basis::Basis::normalized_activations`] does (the same kernels,
//! relative to the most active one, those below `e^-37` of it left out) with two changes for
//! speed: the kernel that brackets `x` is found by walking from the last one (the phase only
//! moves a little per period) instead of a logarithm, and the ~10 exponentials are
//! [`crate::linalg::exp_in_place`]'s (within 2e-16 relative of libm's), computed four at a
//! time in AVX2 registers where the CPU has them, instead of ten libm calls. The weights are
//! kept kernel-major and padded to whole vectors of coordinates, and so is the output, so that
//! the weighted sums run a vector of coordinates at a time (each coordinate still summed over
//! the kernels in their order). A stepper therefore matches the rollout to rounding (about
//! 1e-15), not bit for bit.

use nalgebra::DMatrix;

use crate::basis::Basis;
use crate::linalg::exp_in_place;
#[cfg(target_arch = "x86_64")]
use crate::linalg::{exp4, has_avx2_fma};

/// Activations below `exp(-CUTOFF)` of the largest are zero, as in [`Basis`].
const CUTOFF: f64 = 37.0;
/// f64 lanes of an AVX2 vector.
const LANES: usize = 4;

/// The length of the arrays [`Forcing::eval`] writes `n` coordinates into: whole vectors, so
/// that they are stored and read back whole (a load that spans several stores, or a part of one,
/// waits for them to reach the cache).
pub(crate) const fn padded(n: usize) -> usize {
    n.next_multiple_of(LANES)
}

/// `v` and `LANES - 1` zeros.
fn pad(v: &[f64]) -> Vec<f64> {
    v.iter().copied().chain([0.0; LANES - 1]).collect()
}

/// `x / sum_k Psi_k` from the activations' four partial sums (eq. 4's normalization).
#[inline(always)]
fn scale(x: f64, sums: [f64; LANES]) -> f64 {
    x / ((sums[0] + sums[1]) + (sums[2] + sums[3]))
}

#[derive(Debug, Clone)]
pub(crate) struct Forcing {
    centers: Vec<f64>,
    widths: Vec<f64>,
    /// `weights[k * stride + d]`: kernel k's weight for coordinate d (0 for `d >= n`), the
    /// coordinates padded to whole `LANES`, so that they are summed in whole vectors.
    weights: Vec<f64>,
    stride: usize,
    /// The kernel `k0` with `c_k0 >= x >= c_{k0+1}` at the last phase.
    hint: usize,
    /// The kernels' activations, with room for the active ones to be padded to whole `LANES`.
    psi: Vec<f64>,
}

impl Forcing {
    /// `weights` is `N x n` (column d = coordinate d), as a [`crate::Dmp`] holds them.
    pub fn new(basis: &Basis, weights: &DMatrix<f64>) -> Self {
        let (nb, n) = weights.shape();
        let stride = padded(n);
        Self {
            // Padded (with kernels that are never active) to whole vectors from any kernel.
            centers: pad(basis.centers()),
            widths: pad(basis.widths()),
            weights: (0..nb)
                .flat_map(|k| (0..stride).map(move |d| (k, d)))
                .map(|(k, d)| if d < n { weights[(k, d)] } else { 0.0 })
                .collect(),
            stride,
            hint: 0,
            psi: vec![0.0; nb + LANES - 1],
        }
    }

    /// Writes `f(x)` into `out`: one value per coordinate, then zeros to [`padded`]`(n)`.
    #[inline(always)]
    pub fn eval(&mut self, x: f64, out: &mut [f64]) {
        #[cfg(target_arch = "x86_64")]
        if has_avx2_fma() {
            // SAFETY: the CPU supports the enabled features (checked just above).
            return unsafe { self.eval_avx2(x, out) };
        }
        assert_eq!(
            out.len(),
            self.stride,
            "the forcing term's output is padded"
        );
        let (lo, hi, min_arg) = self.active(x);
        let sums = self.activations(x, lo, hi, min_arg);
        self.weighted_sums(lo, hi, scale(x, sums), out);
    }

    /// [`Forcing::eval`] in AVX2 registers, for callers compiled for AVX2 (no run-time check).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    pub unsafe fn eval_avx2(&mut self, x: f64, out: &mut [f64]) {
        assert_eq!(
            out.len(),
            self.stride,
            "the forcing term's output is padded"
        );
        let (lo, hi, min_arg) = self.active(x);
        // SAFETY: this function's callers run where the CPU has AVX2 and FMA.
        unsafe {
            let sums = self.activations_avx2(x, lo, hi, min_arg);
            self.weighted_sums_avx2(lo, hi, scale(x, sums), out);
        }
    }

    /// `out[d] = scale sum_k w_kd psi_k`, summed over the active kernels `lo..hi` in their order.
    #[inline(always)]
    fn weighted_sums(&self, lo: usize, hi: usize, scale: f64, out: &mut [f64]) {
        // Four coordinates at a time.
        let blocks = self.stride / LANES;
        let weights = self.weights.as_chunks::<LANES>().0;
        for (block, out) in out.as_chunks_mut::<LANES>().0.iter_mut().enumerate() {
            let mut acc = [0.0; LANES];
            for (k, p) in (lo..hi).zip(&self.psi[lo..hi]) {
                let w = &weights[k * blocks + block];
                for l in 0..LANES {
                    acc[l] += w[l] * p;
                }
            }
            *out = acc.map(|a| a * scale);
        }
    }

    /// [`Forcing::weighted_sums`] in AVX2 registers, the same operations lane by lane, eight
    /// coordinates at a time where there are eight (two independent chains of additions).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn weighted_sums_avx2(&self, lo: usize, hi: usize, scale: f64, out: &mut [f64]) {
        use std::arch::x86_64::*;
        let stride = self.stride;
        assert!(hi <= self.psi.len() && hi * stride <= self.weights.len() && out.len() == stride);
        let (weights, psi, out) = (self.weights.as_ptr(), self.psi.as_ptr(), out.as_mut_ptr());
        let scale = _mm256_set1_pd(scale);
        let mut d = 0;
        // SAFETY (all pointers below): `k < hi` and `d + 8 <= stride` (or `d + 4`), asserted
        // above to be within `psi`, `weights` and `out`.
        while d + 2 * LANES <= stride {
            let (mut acc0, mut acc1) = (_mm256_setzero_pd(), _mm256_setzero_pd());
            for k in lo..hi {
                let p = _mm256_set1_pd(unsafe { *psi.add(k) });
                let w = unsafe { weights.add(k * stride + d) };
                let (w0, w1) = unsafe { (_mm256_loadu_pd(w), _mm256_loadu_pd(w.add(LANES))) };
                acc0 = _mm256_add_pd(acc0, _mm256_mul_pd(w0, p));
                acc1 = _mm256_add_pd(acc1, _mm256_mul_pd(w1, p));
            }
            unsafe {
                _mm256_storeu_pd(out.add(d), _mm256_mul_pd(acc0, scale));
                _mm256_storeu_pd(out.add(d + LANES), _mm256_mul_pd(acc1, scale));
            }
            d += 2 * LANES;
        }
        if d < stride {
            let mut acc = _mm256_setzero_pd();
            for k in lo..hi {
                let p = _mm256_set1_pd(unsafe { *psi.add(k) });
                let w = unsafe { _mm256_loadu_pd(weights.add(k * stride + d)) };
                acc = _mm256_add_pd(acc, _mm256_mul_pd(w, p));
            }
            unsafe { _mm256_storeu_pd(out.add(d), _mm256_mul_pd(acc, scale)) };
        }
    }

    /// `h_k (x - c_k)^2`, the exponent of kernel k.
    #[inline(always)]
    fn arg(&self, x: f64, k: usize) -> f64 {
        let d = x - self.centers[k];
        self.widths[k] * d * d
    }

    /// The active kernels `lo..hi` at phase `x` and the smallest exponent.
    #[inline(always)]
    fn active(&mut self, x: f64) -> (usize, usize, f64) {
        let nb = self.centers.len() - (LANES - 1);
        let c = &self.centers;
        // The centres decrease from c_0 = 1; clamp the bracket to the basis.
        let mut k0 = self.hint.min(nb - 2);
        while k0 > 0 && c[k0] < x {
            k0 -= 1;
        }
        while k0 + 2 < nb && c[k0 + 1] > x {
            k0 += 1;
        }
        self.hint = k0;
        let (a0, a1) = (self.arg(x, k0), self.arg(x, k0 + 1));
        let min_arg = a0.min(a1);
        let limit = min_arg + CUTOFF;
        // The exponents grow away from the bracket (geometric centres, widths scaled to the
        // spacing), so the active kernels are the ones reached before the first beyond `limit`.
        let mut lo = k0 + 1;
        while lo > 0 && self.arg(x, lo - 1) <= limit {
            lo -= 1;
        }
        let mut hi = k0 + 1;
        while hi < nb && (if hi == k0 + 1 { a1 } else { self.arg(x, hi) }) <= limit {
            hi += 1;
        }
        if lo == hi {
            return (k0, k0 + 1, min_arg);
        }
        (lo, hi, min_arg)
    }

    /// `psi[k] = exp(min_arg - h_k (x - c_k)^2)` for the active kernels, the rest of their
    /// last vector 0; returns the sums of every fourth one (one chain of ten dependent additions
    /// would take longer than the exponentials).
    #[inline(always)]
    fn activations(&mut self, x: f64, lo: usize, hi: usize, min_arg: f64) -> [f64; LANES] {
        let padded = lo + (hi - lo).next_multiple_of(LANES);
        for k in lo..padded {
            // Padded with exp(-inf) = 0, which changes no sum.
            self.psi[k] = if k < hi {
                min_arg - self.arg(x, k)
            } else {
                f64::NEG_INFINITY
            };
        }
        let psi = &mut self.psi[lo..padded];
        exp_in_place(psi);
        let mut sums = [0.0; LANES];
        for p in psi.as_chunks::<LANES>().0 {
            for l in 0..LANES {
                sums[l] += p[l];
            }
        }
        sums
    }

    /// [`Forcing::activations`] in AVX2 registers, the same operations lane by lane: the
    /// exponents are not stored and read back as vectors, which would wait for the stores.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn activations_avx2(
        &mut self,
        x: f64,
        lo: usize,
        hi: usize,
        min_arg: f64,
    ) -> [f64; LANES] {
        use std::arch::x86_64::*;
        let (xv, min_v, neg_inf) = (
            _mm256_set1_pd(x),
            _mm256_set1_pd(min_arg),
            _mm256_set1_pd(f64::NEG_INFINITY),
        );
        let hi_v = _mm256_set1_epi64x(hi as i64);
        let mut sums = _mm256_setzero_pd();
        for k in (lo..hi).step_by(LANES) {
            let (c, w) = (&self.centers[k..k + LANES], &self.widths[k..k + LANES]);
            // SAFETY: `c` and `w` hold 4 f64s each.
            let (c, w) = unsafe { (_mm256_loadu_pd(c.as_ptr()), _mm256_loadu_pd(w.as_ptr())) };
            let d = _mm256_sub_pd(xv, c);
            let e = _mm256_sub_pd(min_v, _mm256_mul_pd(_mm256_mul_pd(w, d), d));
            let lanes = _mm256_set_epi64x(k as i64 + 3, k as i64 + 2, k as i64 + 1, k as i64);
            let active = _mm256_castsi256_pd(_mm256_cmpgt_epi64(hi_v, lanes));
            let p = exp4(_mm256_blendv_pd(neg_inf, e, active));
            sums = _mm256_add_pd(sums, p);
            let psi = &mut self.psi[k..k + LANES];
            // SAFETY: `psi` holds 4 f64s.
            unsafe { _mm256_storeu_pd(psi.as_mut_ptr(), p) };
        }
        let mut out = [0.0; LANES];
        // SAFETY: `out` holds 4 f64s.
        unsafe { _mm256_storeu_pd(out.as_mut_ptr(), sums) };
        out
    }

    /// Forgets the bracket (after a reset to phase 1 it is found from the first kernel).
    pub fn restart(&mut self) {
        self.hint = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_vector_activations_give_the_scalar_ones_bits() {
        if !has_avx2_fma() {
            return; // only the scalar code runs on this CPU
        }
        for nb in [2, 5, 25, 50, 120] {
            let basis = Basis::new(nb, 2.0, 2.0).unwrap();
            let mut forcing = Forcing::new(&basis, &DMatrix::zeros(nb, 1));
            for i in 0..800 {
                let x = (-(i as f64) / 150.0).exp();
                let (lo, hi, min_arg) = forcing.active(x);
                let sums = forcing.activations(x, lo, hi, min_arg);
                let psi = forcing.psi[lo..hi].to_vec();
                forcing.psi.fill(f64::NAN);
                // SAFETY: the CPU supports the enabled features (checked above).
                let vector_sums = unsafe { forcing.activations_avx2(x, lo, hi, min_arg) };
                assert_eq!(
                    sums.map(f64::to_bits),
                    vector_sums.map(f64::to_bits),
                    "x={x}"
                );
                let bits = |v: &[f64]| v.iter().map(|p| p.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&psi), bits(&forcing.psi[lo..hi]), "nb={nb} x={x}");
            }
        }
    }

    #[test]
    fn the_vector_weighted_sums_give_the_scalar_ones_bits() {
        if !has_avx2_fma() {
            return; // only the scalar code runs on this CPU
        }
        let bits = |v: &[f64]| v.iter().map(|p| p.to_bits()).collect::<Vec<_>>();
        // One, two and three vectors of coordinates: pairs of vectors and a single one.
        for (nb, n) in [
            (5, 1),
            (25, 3),
            (50, 4),
            (50, 6),
            (50, 7),
            (30, 9),
            (40, 12),
        ] {
            let basis = Basis::new(nb, 2.0, 2.0).unwrap();
            let w = DMatrix::from_fn(nb, n, |k, d| 90.0 * ((k * 3 + d * 7) as f64 * 0.53).cos());
            let mut forcing = Forcing::new(&basis, &w);
            let (mut scalar, mut vector) = (vec![0.0; padded(n)], vec![f64::NAN; padded(n)]);
            for i in 0..700 {
                let x = (-(i as f64) / 120.0).exp();
                let (lo, hi, min_arg) = forcing.active(x);
                let scale = scale(x, forcing.activations(x, lo, hi, min_arg));
                forcing.weighted_sums(lo, hi, scale, &mut scalar);
                // SAFETY: the CPU supports the enabled features (checked above).
                unsafe { forcing.weighted_sums_avx2(lo, hi, scale, &mut vector) };
                assert_eq!(bits(&scalar), bits(&vector), "nb={nb} n={n} x={x}");
                assert!(scalar[n..].iter().all(|&f| f == 0.0), "padding is zero");
            }
        }
    }

    #[test]
    fn matches_the_basis_to_rounding_along_a_movement_and_back() {
        for (nb, n) in [(2, 1), (25, 7), (50, 6), (120, 3)] {
            let basis = Basis::new(nb, 2.0, 2.0).unwrap();
            let w = DMatrix::from_fn(nb, n, |k, d| 100.0 * ((k * 5 + d) as f64 * 0.71).sin());
            let mut forcing = Forcing::new(&basis, &w);
            let mut psi = vec![0.0; nb];
            let mut out = vec![0.0; padded(n)];
            // Down the phase, then a jump back up (a reset), then down again.
            let xs = (0..600)
                .map(|i| (-(i as f64) / 100.0).exp())
                .chain((0..600).map(|i| (-(i as f64) / 77.0).exp()));
            for x in xs {
                forcing.eval(x, &mut out);
                let range = basis.normalized_activations(x, &mut psi);
                for d in 0..n {
                    let want: f64 = x * range.clone().map(|k| w[(k, d)] * psi[k]).sum::<f64>();
                    assert!(
                        (out[d] - want).abs() <= 1e-13 * (1.0 + want.abs()),
                        "x={x} d={d}"
                    );
                }
            }
        }
    }
}
