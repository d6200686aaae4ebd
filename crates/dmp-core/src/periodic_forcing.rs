//! The periodic forcing term's shape, `sum_i psi_i(phi) w_i / sum_i psi_i(phi)` (eq. P4), evaluated
//! one phase at a time for the rollout and the stepper, where it is most of the cost of a step.
//!
//! It gives the bits of [`PeriodicBasis::normalized_activations`] followed by the sum over the
//! active kernels in their order, computed another way for speed. The walk there stops at
//! the first kernel below the cut-off on each side of the nearest centre; here a fixed window of
//! `2 half + 1` kernels about the nearest centre is evaluated whole, `half` chosen at construction
//! so that every kernel the walk can reach lies in it (with a margin of one unit of the exponent
//! for rounding), and the kernels below the cut-off get an activation of exactly zero. The centres'
//! cosines and sines and the weights are stored for the window's indices unwrapped (the circle
//! repeated past its end), so the window is one contiguous run with no index arithmetic. Every
//! operation is the walk's, in its order, and adding an exact zero changes no sum, so the loops
//! compile to vectors (AVX2 where the CPU has it) with the same bits on
//! every machine. A basis whose kernels are so wide that the window would cover the circle keeps
//! the walk.

use nalgebra::DMatrix;

#[cfg(target_arch = "x86_64")]
use crate::linalg::has_avx2_fma;
use crate::periodic::{ACTIVATION_CUTOFF, Activations, PeriodicBasis};

/// f64 lanes of an AVX2 vector: the window and the coordinates are padded to whole vectors.
const LANES: usize = 4;

#[derive(Debug, Clone, PartialEq)]
pub(crate) struct PeriodicForcing {
    basis: PeriodicBasis,
    /// `weights[j * stride + d]`: the weight of kernel `j mod N` (unwrapped index `j`) for
    /// coordinate `d`, 0 for `d >= n_dof`.
    weights: Vec<f64>,
    stride: usize,
    n_dof: usize,
    /// The window's half-width, or `None` when the walk is kept.
    half: Option<usize>,
    /// `cos c_{j mod N}` and `sin c_{j mod N}` at unwrapped index `j + N - half`, so that the
    /// window about centre `m` is `m..m + len`.
    cos_c: Vec<f64>,
    sin_c: Vec<f64>,
    /// The window's length rounded up to whole vectors.
    len: usize,
}

/// Scratch space for [`PeriodicForcing::eval`].
#[derive(Debug, Clone)]
pub(crate) struct ForcingScratch {
    psi: Vec<f64>,
    activations: Activations,
}

impl PeriodicForcing {
    /// The forcing term of `basis` with `weights`, `N x n_dof` (column d = coordinate d), as a
    /// [`crate::PeriodicDmp`] holds them.
    pub fn new(basis: PeriodicBasis, weights: &DMatrix<f64>) -> Self {
        let (n, n_dof) = weights.shape();
        let stride = n_dof.next_multiple_of(LANES);
        let half = window_half_width(&basis);
        let window = half.map_or(0, |h| 2 * h + 1);
        let len = window.next_multiple_of(LANES);
        // unwrapped index j holds kernel (j + N - half) mod N; the window about centre m (its
        // kernels m - half ..= m + half) is j = m..m + len
        let offset = n - half.unwrap_or(0);
        let kernel = |j: usize| (j + offset) % n;
        let rows = if half.is_some() { n + len } else { n };
        let weights = (0..rows)
            .flat_map(|j| (0..stride).map(move |d| (j, d)))
            .map(|(j, d)| {
                let k = if half.is_some() { kernel(j) } else { j };
                if d < n_dof { weights[(k, d)] } else { 0.0 }
            })
            .collect();
        let (cos_all, sin_all) = basis.trig();
        Self {
            cos_c: (0..n + len).map(|j| cos_all[kernel(j)]).collect(),
            sin_c: (0..n + len).map(|j| sin_all[kernel(j)]).collect(),
            basis,
            weights,
            stride,
            n_dof,
            half,
            len,
        }
    }

    pub fn basis(&self) -> &PeriodicBasis {
        &self.basis
    }

    pub fn scratch(&self) -> ForcingScratch {
        ForcingScratch {
            psi: vec![0.0; self.len],
            activations: Activations::with_capacity(self.basis.len()),
        }
    }

    /// The number of values [`PeriodicForcing::eval`] writes: the coordinates padded to whole
    /// vectors.
    pub fn stride(&self) -> usize {
        self.stride
    }

    /// Writes `sum_i psi_i(phi) w_i / sum_i psi_i(phi)` for every coordinate into `out[..n_dof]`
    /// (`out` is [`PeriodicForcing::stride`] long), `phi` in `[0, 2 pi)`.
    #[inline]
    pub fn eval(&self, phi: f64, scratch: &mut ForcingScratch, out: &mut [f64]) {
        assert_eq!(out.len(), self.stride, "the shape's output is padded");
        let Some(half) = self.half else {
            return self.walk(phi, &mut scratch.activations, out);
        };
        let (sin_phi, cos_phi) = libm::sincos(phi);
        let m = self.basis.nearest(phi);
        let top = self.basis.arg(m, cos_phi, sin_phi);
        let psi = &mut scratch.psi;
        #[cfg(target_arch = "x86_64")]
        if has_avx2_fma() {
            // SAFETY: the CPU supports the enabled features (checked just above).
            return unsafe { self.window_avx2(m, half, cos_phi, sin_phi, top, psi, out) };
        }
        self.window(m, half, cos_phi, sin_phi, top, psi, out);
    }

    /// [`PeriodicForcing::window`] in AVX2 registers: the activations four at a time, each
    /// operation the scalar one's (multiplies and adds, never fused), so the same bits.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    #[allow(clippy::too_many_arguments)]
    unsafe fn window_avx2(
        &self,
        m: usize,
        half: usize,
        cos_phi: f64,
        sin_phi: f64,
        top: f64,
        psi: &mut [f64],
        out: &mut [f64],
    ) {
        use std::arch::x86_64::*;
        let c = |v: f64| _mm256_set1_pd(v);
        let window = 2 * half + 1;
        let (cos_c, sin_c) = (&self.cos_c[m..m + self.len], &self.sin_c[m..m + self.len]);
        let (h, floor) = (c(self.basis.h()), c(top - ACTIVATION_CUTOFF));
        let (cos_v, sin_v, top_v, lowest) =
            (c(cos_phi), c(sin_phi), c(top), c(-ACTIVATION_CUTOFF - 1.0));
        let window_v = _mm256_set1_epi64x(window as i64);
        let mut j = 0;
        while j < self.len {
            // SAFETY: `j + 4 <= len`, the length of the window's slices and of `psi`.
            let (cj, sj) = unsafe {
                (
                    _mm256_loadu_pd(cos_c.as_ptr().add(j)),
                    _mm256_loadu_pd(sin_c.as_ptr().add(j)),
                )
            };
            let a = _mm256_mul_pd(
                h,
                _mm256_sub_pd(
                    _mm256_add_pd(_mm256_mul_pd(cos_v, cj), _mm256_mul_pd(sin_v, sj)),
                    c(1.0),
                ),
            );
            let e = self
                .basis
                .exp4(_mm256_max_pd(_mm256_sub_pd(a, top_v), lowest));
            let lanes = _mm256_set_epi64x(j as i64 + 3, j as i64 + 2, j as i64 + 1, j as i64);
            let keep = _mm256_and_pd(
                _mm256_cmp_pd::<_CMP_GT_OQ>(a, floor),
                _mm256_castsi256_pd(_mm256_cmpgt_epi64(window_v, lanes)),
            );
            // SAFETY: as above.
            unsafe { _mm256_storeu_pd(psi.as_mut_ptr().add(j), _mm256_and_pd(e, keep)) };
            j += LANES;
        }
        // SAFETY: this function runs where the CPU has AVX2 and FMA.
        unsafe { self.weigh_avx2(m, window, psi, out) };
    }

    /// [`PeriodicForcing::weigh`] in AVX2 registers, the same operations in the same order: the
    /// sum one chain over the kernels (the window's zeros after them add nothing to a positive
    /// sum), each coordinate's weighted sum one chain per lane.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn weigh_avx2(&self, m: usize, window: usize, psi: &mut [f64], out: &mut [f64]) {
        use std::arch::x86_64::*;
        let stride = self.stride;
        assert!(
            psi.len() == self.len
                && window <= self.len
                && (m + window) * stride <= self.weights.len()
                && out.len() == stride
        );
        let mut sum = 0.0;
        for chunk in psi.as_chunks::<LANES>().0 {
            for p in chunk {
                sum += p;
            }
        }
        let inv = _mm256_set1_pd(1.0 / sum);
        for chunk in psi.as_chunks_mut::<LANES>().0 {
            // SAFETY: `chunk` holds 4 f64s.
            unsafe {
                _mm256_storeu_pd(
                    chunk.as_mut_ptr(),
                    _mm256_mul_pd(_mm256_loadu_pd(chunk.as_ptr()), inv),
                )
            };
        }
        let rows = self.weights[m * stride..].as_ptr();
        let mut b = 0;
        while b < stride {
            let pair = b + 2 * LANES <= stride;
            let (mut acc0, mut acc1) = (_mm256_setzero_pd(), _mm256_setzero_pd());
            for (j, &p) in psi[..window].iter().enumerate() {
                let p = _mm256_set1_pd(p);
                // SAFETY: `j < window` and `b + 8 <= stride` (or `b + 4`): within the weights
                // (asserted above).
                let w = unsafe { rows.add(j * stride + b) };
                acc0 = _mm256_add_pd(acc0, _mm256_mul_pd(p, unsafe { _mm256_loadu_pd(w) }));
                if pair {
                    let w1 = unsafe { _mm256_loadu_pd(w.add(LANES)) };
                    acc1 = _mm256_add_pd(acc1, _mm256_mul_pd(p, w1));
                }
            }
            // SAFETY: `b + 8 <= stride` (or `b + 4`), within `out`.
            unsafe {
                _mm256_storeu_pd(out.as_mut_ptr().add(b), acc0);
                if pair {
                    _mm256_storeu_pd(out.as_mut_ptr().add(b + LANES), acc1);
                }
            }
            b += if pair { 2 * LANES } else { LANES };
        }
    }

    /// [`PeriodicForcing::eval`] over the window about centre `m`.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn window(
        &self,
        m: usize,
        half: usize,
        cos_phi: f64,
        sin_phi: f64,
        top: f64,
        psi: &mut [f64],
        out: &mut [f64],
    ) {
        let window = 2 * half + 1;
        let (cos_c, sin_c) = (&self.cos_c[m..m + self.len], &self.sin_c[m..m + self.len]);
        let h = self.basis.h();
        let floor = top - ACTIVATION_CUTOFF;
        for (j, ((p, c), s)) in psi.iter_mut().zip(cos_c).zip(sin_c).enumerate() {
            // the walk's exponent, then its test against the floor
            let a = h * (cos_phi * c + sin_phi * s - 1.0);
            let e = self.basis.exp((a - top).max(-ACTIVATION_CUTOFF - 1.0));
            *p = if a > floor && j < window { e } else { 0.0 };
        }
        self.weigh(m, window, psi, out);
    }

    /// The activations `psi` of the window about centre `m` normalized, and each coordinate's
    /// weighted sum over them into `out`.
    #[inline(always)]
    fn weigh(&self, m: usize, window: usize, psi: &mut [f64], out: &mut [f64]) {
        // summed in the walk's order (the zeros outside it change nothing; those past the window
        // are left out)
        let psi = &mut psi[..window];
        let sum = psi.iter().fold(0.0, |s, p| s + p);
        let inv_sum = 1.0 / sum;
        for p in psi.iter_mut() {
            *p *= inv_sum;
        }
        // each coordinate summed over the kernels in their order, in registers, two vectors of
        // four coordinates at a time so that their chains of additions overlap
        let blocks = self.stride / LANES;
        let rows = self.weights[m * self.stride..(m + window) * self.stride]
            .as_chunks::<LANES>()
            .0;
        let out = out.as_chunks_mut::<LANES>().0;
        let mut b = 0;
        while b < blocks {
            let pair = b + 1 < blocks;
            let (mut acc0, mut acc1) = ([0.0; LANES], [0.0; LANES]);
            for (j, p) in psi.iter().enumerate() {
                let w0 = &rows[j * blocks + b];
                for l in 0..LANES {
                    acc0[l] += p * w0[l];
                }
                if pair {
                    let w1 = &rows[j * blocks + b + 1];
                    for l in 0..LANES {
                        acc1[l] += p * w1[l];
                    }
                }
            }
            out[b] = acc0;
            if pair {
                out[b + 1] = acc1;
            }
            b += 2;
        }
    }

    /// The walk of [`PeriodicBasis::normalized_activations`] and its dot products, for a basis
    /// too wide for a window.
    fn walk(&self, phi: f64, act: &mut Activations, out: &mut [f64]) {
        let n = self.basis.len();
        self.basis.normalized_activations(phi, act);
        out.fill(0.0);
        let mut i = act.start;
        for &p in &act.values {
            // (kernel i's row is at unwrapped index i + half)
            let j = (i + self.half.unwrap_or(0)) % n;
            let row = &self.weights[j * self.stride..j * self.stride + self.n_dof];
            for (o, w) in out.iter_mut().zip(row) {
                *o += p * w;
            }
            i = if i + 1 == n { 0 } else { i + 1 };
        }
    }
}

/// The smallest `half` such that no kernel more than `half` centres from the one nearest the
/// phase is ever active, or `None` when the window would cover the circle.
///
/// The phase lies within half a spacing `s / 2` of its nearest centre, so kernel `j` centres away
/// is at least `(j - 1/2) s` from it, and its exponent is at most the nearest's minus
/// `h (cos(s / 2) - cos((j - 1/2) s))`; it is inactive once that exceeds the cut-off (by a margin
/// of one, far above the exponents' rounding).
fn window_half_width(basis: &PeriodicBasis) -> Option<usize> {
    use std::f64::consts::{PI, TAU};
    let n = basis.len();
    let s = TAU / n as f64;
    let drop = |j: usize| basis.h() * (libm::cos(s / 2.0) - libm::cos((j as f64 - 0.5) * s));
    let mut j = 1;
    while drop(j) <= ACTIVATION_CUTOFF + 1.0 {
        j += 1;
        if (j as f64 - 0.5) * s >= PI {
            return None;
        }
    }
    let half = j - 1;
    (2 * half < n).then_some(half)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn weights(n: usize, n_dof: usize) -> DMatrix<f64> {
        DMatrix::from_fn(n, n_dof, |k, d| {
            40.0 * ((k * 7 + d * 3) as f64 * 0.37).sin()
        })
    }

    #[test]
    fn the_window_gives_the_walks_bits() {
        for (n, width, n_dof) in [
            (50, 2.0, 7),
            (25, 2.0, 3),
            (7, 2.0, 1),
            (100, 5.0, 9),
            (12, 0.5, 4),
            (3, 2.0, 2),
            (40, 0.05, 2),
        ] {
            let basis = PeriodicBasis::new(n, width).unwrap();
            let w = weights(n, n_dof);
            let f = PeriodicForcing::new(basis.clone(), &w);
            let mut scratch = f.scratch();
            let mut out = vec![0.0; f.stride()];
            for j in 0..20_011 {
                let phi = (j as f64 * 0.000_314_159_7 * n as f64).rem_euclid(std::f64::consts::TAU);
                f.eval(phi, &mut scratch, &mut out);
                // the walk's activations summed kernel by kernel, as the integrator always did
                let mut want = vec![0.0; f.stride()];
                f.walk(phi, &mut scratch.activations, &mut want);
                for d in 0..n_dof {
                    assert_eq!(
                        out[d].to_bits(),
                        want[d].to_bits(),
                        "N = {n}, width {width}, phi = {phi}, d = {d}"
                    );
                }
            }
        }
    }

    #[test]
    fn narrow_kernels_take_a_window_and_wide_ones_the_walk() {
        let half = |n, width| window_half_width(&PeriodicBasis::new(n, width).unwrap());
        assert_eq!(half(50, 2.0), Some(4));
        assert_eq!(half(40, 0.05), None);
    }
}
