//! The forcing term of eq. 4, `f(x) = x sum_k w_k Psi_k(x) / sum_k Psi_k(x)`, evaluated one
//! phase at a time: the one evaluation of every rollout and stepper of the discrete DMPs (joint
//! and Cartesian), where it is most of the cost of a sample.
//!
//! It gives the bits of [`crate::basis::Basis::normalized_activations`] followed by the sum over
//! the active kernels in their order, computed faster: the kernel that brackets `x` is found by
//! walking from the last one (the phase only moves a little per sample) instead of a logarithm,
//! the logarithm's rule asked only where the phase lies within rounding of a centre; the ~10
//! exponentials are [`crate::exp::exp4`]'s, four at a time in AVX2 registers where the CPU has
//! them; and the weights are kept kernel-major and padded to whole vectors of coordinates, so
//! that the weighted sums run a vector of coordinates at a time (each coordinate still summed
//! over the kernels in their order).

use nalgebra::DMatrix;

use crate::basis::Basis;
#[cfg(target_arch = "x86_64")]
use crate::linalg::has_avx2_fma;

/// f64 lanes of an AVX2 vector.
const LANES: usize = 4;
/// A phase within this (relative) of a centre has its bracket from the logarithm's rule
/// ([`Basis::bracket`]): farther away the walk's bracket is the rule's whatever the rounding.
const NEAR_CENTRE: f64 = 1e-9;

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

/// How the weighted sums start: `-0.0` as `Iterator::sum` (the joint DMP's), or `0.0` (the
/// Cartesian DMP's accumulators). They differ only in the sign of a sum whose every term is a
/// negative zero.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum SumStart {
    NegativeZero,
    Zero,
}

#[derive(Debug, Clone)]
pub(crate) struct Forcing {
    basis: Basis,
    /// The centres and widths padded to whole vectors from any kernel.
    centers: Vec<f64>,
    widths: Vec<f64>,
    /// `weights[k * stride + d]`: kernel k's weight for coordinate d (0 for `d >= n`), the
    /// coordinates padded to whole `LANES`, so that they are summed in whole vectors.
    weights: Vec<f64>,
    stride: usize,
    start: f64,
    /// The kernel `k0` with `c_k0 >= x >= c_{k0+1}` at the last phase.
    hint: usize,
    /// The kernels' activations, with room for the active ones to be padded to whole `LANES`.
    psi: Vec<f64>,
}

impl Forcing {
    /// `weights` is `N x n` (column d = coordinate d), as a [`crate::Dmp`] holds them.
    pub fn new(basis: &Basis, weights: &DMatrix<f64>, start: SumStart) -> Self {
        let (nb, n) = weights.shape();
        let stride = padded(n);
        Self {
            basis: basis.clone(),
            centers: pad(basis.centers()),
            widths: pad(basis.widths()),
            weights: (0..nb)
                .flat_map(|k| (0..stride).map(move |d| (k, d)))
                .map(|(k, d)| if d < n { weights[(k, d)] } else { 0.0 })
                .collect(),
            stride,
            start: match start {
                SumStart::NegativeZero => -0.0,
                SumStart::Zero => 0.0,
            },
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
        let (lo, hi) = self.activations(x);
        self.weighted_sums(lo, hi, x, out);
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
        // SAFETY: this function's callers run where the CPU has AVX2 and FMA.
        unsafe { self.one_avx2(x, out) }
    }

    /// `f(x)` alone, in AVX2 registers: the exponentials four kernels at a time, the sums and
    /// the normalized activations taken from the registers (a value read back narrower than it
    /// was stored would wait for the store).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn one_avx2(&mut self, x: f64, out: &mut [f64]) {
        use std::arch::x86_64::*;
        let k0 = self.bracket(x);
        let (lo, hi, min_arg) = self.basis.active(x, k0);
        let (xv, min_v, neg_zero) = (
            _mm256_set1_pd(x),
            _mm256_set1_pd(min_arg),
            _mm256_set1_pd(-0.0),
        );
        let hi_v = _mm256_set1_epi64x(hi as i64);
        let mut sum = 0.0;
        let mut k = lo;
        while k < hi {
            let (c, w) = (&self.centers[k..k + LANES], &self.widths[k..k + LANES]);
            // SAFETY: `c` and `w` hold 4 f64s.
            let (c, w) = unsafe { (_mm256_loadu_pd(c.as_ptr()), _mm256_loadu_pd(w.as_ptr())) };
            let d = _mm256_sub_pd(xv, c);
            let e = _mm256_sub_pd(min_v, _mm256_mul_pd(_mm256_mul_pd(w, d), d));
            // Lanes past the active kernels take exp(0) (their exponents may be far out of the
            // exponential's fast range) and then -0.0, which adds nothing to the sum.
            let lanes = _mm256_set_epi64x(k as i64 + 3, k as i64 + 2, k as i64 + 1, k as i64);
            let active = _mm256_castsi256_pd(_mm256_cmpgt_epi64(hi_v, lanes));
            let p = _mm256_blendv_pd(neg_zero, crate::exp::exp4(_mm256_and_pd(e, active)), active);
            let (low, high) = (_mm256_castpd256_pd128(p), _mm256_extractf128_pd::<1>(p));
            sum += _mm_cvtsd_f64(low);
            sum += _mm_cvtsd_f64(_mm_unpackhi_pd(low, low));
            sum += _mm_cvtsd_f64(high);
            sum += _mm_cvtsd_f64(_mm_unpackhi_pd(high, high));
            let psi = &mut self.psi[k..k + LANES];
            // SAFETY: `psi` holds 4 f64s.
            unsafe { _mm256_storeu_pd(psi.as_mut_ptr(), p) };
            k += LANES;
        }
        let inv = _mm256_set1_pd(1.0 / sum);
        // Each coordinate summed over the kernels in their order, eight at a time (two
        // independent chains), the normalized activations broadcast from the registers.
        let stride = self.stride;
        assert!(hi * stride <= self.weights.len() && out.len() == stride);
        let weights = self.weights.as_ptr();
        let start = _mm256_set1_pd(self.start);
        let mut d = 0;
        while d < stride {
            let pair = d + 2 * LANES <= stride;
            let (mut acc0, mut acc1) = (start, start);
            let mut k = lo;
            while k < hi {
                // SAFETY: `psi` holds the chunk's 4 f64s (padded).
                let p = _mm256_mul_pd(
                    unsafe { _mm256_loadu_pd(self.psi[k..k + LANES].as_ptr()) },
                    inv,
                );
                let lanes = [
                    _mm256_permute4x64_pd::<0x00>(p),
                    _mm256_permute4x64_pd::<0x55>(p),
                    _mm256_permute4x64_pd::<0xaa>(p),
                    _mm256_permute4x64_pd::<0xff>(p),
                ];
                for (j, p) in lanes.into_iter().enumerate().take(hi - k) {
                    // SAFETY: kernel `k + j < hi` and `d + 8 <= stride` (or `d + 4`): within
                    // `weights` (asserted above).
                    let w = unsafe { weights.add((k + j) * stride + d) };
                    acc0 = _mm256_add_pd(acc0, _mm256_mul_pd(unsafe { _mm256_loadu_pd(w) }, p));
                    if pair {
                        let w1 = unsafe { _mm256_loadu_pd(w.add(LANES)) };
                        acc1 = _mm256_add_pd(acc1, _mm256_mul_pd(w1, p));
                    }
                }
                k += LANES;
            }
            // SAFETY: `d + 8 <= stride` (or `d + 4`), within `out`.
            unsafe {
                _mm256_storeu_pd(out.as_mut_ptr().add(d), _mm256_mul_pd(xv, acc0));
                if pair {
                    _mm256_storeu_pd(out.as_mut_ptr().add(d + LANES), _mm256_mul_pd(xv, acc1));
                }
            }
            d += if pair { 2 * LANES } else { LANES };
        }
    }

    /// The bracket of `x`: the walk from the last one, or the logarithm's rule near a centre.
    #[inline(always)]
    fn bracket(&mut self, x: f64) -> usize {
        let nb = self.basis.len();
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
        let near = |c: f64| (x - c).abs() <= NEAR_CENTRE * x;
        if near(c[k0]) || near(c[k0 + 1]) {
            return self.basis.bracket(x);
        }
        k0
    }

    /// The normalized activations of the active kernels `lo..hi` into `psi`, as
    /// [`Basis::normalized_activations`] computes them.
    #[inline(always)]
    fn activations(&mut self, x: f64) -> (usize, usize) {
        let k0 = self.bracket(x);
        let (lo, hi, min_arg) = self.basis.active(x, k0);
        let mut sum = 0.0;
        for k in lo..hi {
            let p = crate::exp::exp(min_arg - self.basis.arg(x, k));
            self.psi[k] = p;
            sum += p;
        }
        let inv = 1.0 / sum;
        for p in &mut self.psi[lo..hi] {
            *p *= inv;
        }
        (lo, hi)
    }

    /// `out[d] = x (start + sum_k w_kd psi_k)`, summed over the active kernels `lo..hi` in
    /// their order.
    #[inline(always)]
    fn weighted_sums(&self, lo: usize, hi: usize, x: f64, out: &mut [f64]) {
        // Four coordinates at a time.
        let blocks = self.stride / LANES;
        let weights = self.weights.as_chunks::<LANES>().0;
        for (block, out) in out.as_chunks_mut::<LANES>().0.iter_mut().enumerate() {
            let mut acc = [self.start; LANES];
            for (k, p) in (lo..hi).zip(&self.psi[lo..hi]) {
                let w = &weights[k * blocks + block];
                for l in 0..LANES {
                    acc[l] += w[l] * p;
                }
            }
            *out = acc.map(|a| x * a);
        }
    }

    /// Forgets the bracket (after a reset to phase 1 it is found from the first kernel).
    pub fn restart(&mut self) {
        self.hint = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Phases down a movement, a jump back up (a reset), down again at another rate, and every
    /// centre with its neighbours in the last place, where the bracket is decided by rounding.
    fn phases(basis: &Basis) -> Vec<f64> {
        let mut xs: Vec<f64> = (0..900).map(|i| (-(i as f64) / 150.0).exp()).collect();
        xs.extend((0..700).map(|i| (-(i as f64) / 77.0).exp()));
        for &c in basis.centers() {
            xs.extend([
                c.next_up(),
                c,
                c.next_down(),
                c * (1.0 - 2e-10),
                c * (1.0 + 2e-10),
            ]);
        }
        xs.extend([1e-30, 0.0]);
        xs
    }

    fn bits(v: &[f64]) -> Vec<u64> {
        v.iter().map(|p| p.to_bits()).collect()
    }

    /// The truth: the basis' normalized activations (the C library's exponentials), then the
    /// joint rollout's `x * sum_k w_kd psi_k` (`Iterator::sum`) or the Cartesian one's
    /// accumulators from 0.
    fn direct(basis: &Basis, w: &DMatrix<f64>, x: f64, start: SumStart) -> Vec<f64> {
        let mut psi = vec![0.0; basis.len()];
        let range = basis.normalized_activations(x, &mut psi);
        (0..w.ncols())
            .map(|d| {
                let terms = range.clone().map(|k| w[(k, d)] * psi[k]);
                match start {
                    SumStart::NegativeZero => x * terms.sum::<f64>(),
                    SumStart::Zero => x * terms.fold(0.0, |a, t| a + t),
                }
            })
            .collect()
    }

    #[test]
    fn gives_the_bits_of_the_basis_and_the_sum() {
        for (nb, n, alpha_x, wf) in [
            (2, 1, 2.0, 2.0),
            (25, 7, 2.0, 2.0),
            (50, 6, 2.0, 2.0),
            (50, 7, 3.0, 0.5),
            (120, 3, 2.0, 2.0),
            (30, 9, 1.0, 40.0),
        ] {
            let basis = Basis::new(nb, alpha_x, wf).unwrap();
            let w = DMatrix::from_fn(nb, n, |k, d| 100.0 * ((k * 5 + d) as f64 * 0.71).sin());
            for start in [SumStart::NegativeZero, SumStart::Zero] {
                let mut forcing = Forcing::new(&basis, &w, start);
                let mut out = vec![0.0; padded(n)];
                for x in phases(&basis) {
                    forcing.eval(x, &mut out);
                    let want = direct(&basis, &w, x, start);
                    assert_eq!(bits(&out[..n]), bits(&want), "nb={nb} n={n} x={x:e}");
                    assert!(out[n..].iter().all(|&f| f == 0.0), "padding is zero");
                }
            }
        }
    }

    #[test]
    fn the_sum_starts_as_asked() {
        // Every weight a negative zero: the only case where the two starts differ.
        let basis = Basis::new(10, 2.0, 2.0).unwrap();
        let w = DMatrix::from_element(10, 2, -0.0);
        for (start, negative) in [(SumStart::NegativeZero, true), (SumStart::Zero, false)] {
            let mut out = vec![1.0; padded(2)];
            Forcing::new(&basis, &w, start).eval(0.5, &mut out);
            assert!(
                out[..2]
                    .iter()
                    .all(|&f| f == 0.0 && f.is_sign_negative() == negative)
            );
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn the_vectors_give_the_scalar_bits() {
        if !has_avx2_fma() {
            return; // only the scalar code runs on this CPU
        }
        for (nb, n) in [(5, 1), (25, 3), (50, 4), (50, 7), (30, 9), (40, 12)] {
            let basis = Basis::new(nb, 2.0, 2.0).unwrap();
            let w = DMatrix::from_fn(nb, n, |k, d| 90.0 * ((k * 3 + d * 7) as f64 * 0.53).cos());
            let mut scalar = Forcing::new(&basis, &w, SumStart::NegativeZero);
            let mut vector = scalar.clone();
            let (mut a, mut b) = (vec![0.0; padded(n)], vec![f64::NAN; padded(n)]);
            for x in phases(&basis) {
                let (lo, hi) = scalar.activations(x);
                scalar.weighted_sums(lo, hi, x, &mut a);
                // SAFETY: the CPU supports the enabled features (checked above).
                unsafe { vector.eval_avx2(x, &mut b) };
                assert_eq!(bits(&a), bits(&b), "nb={nb} n={n} x={x:e}");
            }
        }
    }
}
