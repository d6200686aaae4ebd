//! The forcing term of eq. 4, `f(x) = x sum_k w_k Psi_k(x) / sum_k Psi_k(x)`, evaluated one
//! phase at a time for the steppers, where it is most of the cost of a control period.
//!
//! It computes what [`crate::basis::Basis::normalized_activations`] does (the same kernels,
//! relative to the most active one, those below `e^-37` of it left out) with two changes for
//! speed: the kernel that brackets `x` is found by walking from the last one (the phase only
//! moves a little per period) instead of a logarithm, and the ~10 exponentials are the
//! vectorized [`crate::linalg::exp_in_place`] (within 2e-16 relative of libm's) instead of ten
//! libm calls. The weights are kept kernel-major, so one pass over the active kernels updates
//! every coordinate. A stepper therefore matches the rollout to rounding (about 1e-15), not bit
//! for bit.

use nalgebra::DMatrix;

use crate::basis::Basis;
use crate::linalg::{exp_in_place_generic, has_avx2_fma};

/// Activations below `exp(-CUTOFF)` of the largest are zero, as in [`Basis`].
const CUTOFF: f64 = 37.0;
/// f64 lanes of an AVX2 vector.
const LANES: usize = 4;

#[derive(Debug, Clone)]
pub(crate) struct Forcing {
    centers: Vec<f64>,
    widths: Vec<f64>,
    /// `weights[k * stride + d]`: kernel k's weight for coordinate d (0 for `d >= n`), the
    /// coordinates padded to whole `LANES`, so that they are summed in whole vectors.
    weights: Vec<f64>,
    stride: usize,
    n: usize,
    /// The kernel `k0` with `c_k0 >= x >= c_{k0+1}` at the last phase.
    hint: usize,
    /// The kernels' activations, with room for the active ones to be padded to whole `LANES`.
    psi: Vec<f64>,
}

impl Forcing {
    /// `weights` is `N x n` (column d = coordinate d), as a [`crate::Dmp`] holds them.
    pub fn new(basis: &Basis, weights: &DMatrix<f64>) -> Self {
        let (nb, n) = weights.shape();
        let stride = n.next_multiple_of(LANES);
        Self {
            centers: basis.centers().to_vec(),
            widths: basis.widths().to_vec(),
            weights: (0..nb)
                .flat_map(|k| (0..stride).map(move |d| (k, d)))
                .map(|(k, d)| if d < n { weights[(k, d)] } else { 0.0 })
                .collect(),
            stride,
            n,
            hint: 0,
            psi: vec![0.0; nb + LANES - 1],
        }
    }

    /// Writes `f(x)` into `out` (one value per coordinate).
    #[inline(always)]
    pub fn eval(&mut self, x: f64, out: &mut [f64]) {
        let nb = self.centers.len();
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
        let arg = |k: usize| {
            let d = x - c[k];
            self.widths[k] * d * d
        };
        let (a0, a1) = (arg(k0), arg(k0 + 1));
        let min_arg = a0.min(a1);
        let limit = min_arg + CUTOFF;
        // The arguments grow away from the bracket (geometric centres, widths scaled to the
        // spacing), so the active kernels are the ones reached before the first beyond `limit`.
        let mut lo = k0 + 1;
        while lo > 0 {
            let a = arg(lo - 1);
            if a > limit {
                break;
            }
            self.psi[lo - 1] = min_arg - a;
            lo -= 1;
        }
        let mut hi = k0 + 1;
        while hi < nb {
            let a = if hi == k0 + 1 { a1 } else { arg(hi) };
            if a > limit {
                break;
            }
            self.psi[hi] = min_arg - a;
            hi += 1;
        }
        if lo == hi {
            self.psi[k0] = min_arg - a0;
            lo = k0;
            hi = k0 + 1;
        }
        // Padded with exp(-inf) = 0 to whole vectors, which change no sum.
        let padded = lo + (hi - lo).next_multiple_of(LANES);
        self.psi[hi..padded].fill(f64::NEG_INFINITY);
        let psi = &mut self.psi[lo..padded];
        // `exp_in_place`'s choice, inlined: the steppers' AVX2 copies inline this with FMA.
        if has_avx2_fma() {
            exp_in_place_generic::<true>(psi);
        } else {
            exp_in_place_generic::<false>(psi);
        }
        // Four partial sums: one chain of ten dependent additions would take longer than the
        // exponentials.
        let mut sums = [0.0; LANES];
        for p in psi.as_chunks::<LANES>().0 {
            for l in 0..LANES {
                sums[l] += p[l];
            }
        }
        let scale = x / ((sums[0] + sums[1]) + (sums[2] + sums[3]));
        // Four coordinates at a time, each summed over the active kernels in their order.
        let blocks = self.stride / LANES;
        let weights = self.weights.as_chunks::<LANES>().0;
        for (block, out) in out[..self.n].chunks_mut(LANES).enumerate() {
            let mut acc = [0.0; LANES];
            for (k, p) in (lo..hi).zip(psi.iter()) {
                let w = &weights[k * blocks + block];
                for l in 0..LANES {
                    acc[l] += w[l] * p;
                }
            }
            for (o, a) in out.iter_mut().zip(acc) {
                *o = a * scale;
            }
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

    #[test]
    fn matches_the_basis_to_rounding_along_a_movement_and_back() {
        for (nb, n) in [(2, 1), (25, 7), (50, 6), (120, 3)] {
            let basis = Basis::new(nb, 2.0, 2.0).unwrap();
            let w = DMatrix::from_fn(nb, n, |k, d| 100.0 * ((k * 5 + d) as f64 * 0.71).sin());
            let mut forcing = Forcing::new(&basis, &w);
            let mut psi = vec![0.0; nb];
            let mut out = vec![0.0; n];
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
