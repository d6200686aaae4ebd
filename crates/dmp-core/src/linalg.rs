//! Dense symmetric positive-definite kernels for the Gaussian process: in-place Cholesky,
//! triangular solves and the inverse from the factor. Matrices are square, column-major
//! `Vec<f64>`s with leading dimension `m`; only the lower triangle of a factor is used.
//!
//! Every kernel is written out here, sequential, with each sum in an order that the code fixes:
//! the results are bit-identical run to run and on every x86-64 machine with AVX2 and FMA,
//! whatever its vector width. A linear-algebra library's kernels are chosen by the CPU at run time
//! (AVX-512 where there is one, with other blockings and fused multiply-adds), which would make
//! the generalizers' outputs, and every learner that branches on them, differ between machines.

/// `sum_i a_i b_i` with eight independent partial sums. A plain `.sum()` of products is one
/// dependency chain the compiler may not reorder (floating-point addition is not associative), so
/// it runs at one add per FMA latency; eight chains vectorize. The order is fixed by the code, so
/// results are still bit-identical run to run.
#[inline(always)]
pub fn dot(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let mut acc = [0.0f64; 8];
    let (ca, cb) = (a.chunks_exact(8), b.chunks_exact(8));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for k in 0..8 {
            acc[k] += x[k] * y[k];
        }
    }
    let mut tail = 0.0;
    for (x, y) in ra.iter().zip(rb) {
        tail += x * y;
    }
    ((acc[0] + acc[4]) + (acc[1] + acc[5])) + ((acc[2] + acc[6]) + (acc[3] + acc[7])) + tail
}

/// The index and value of the largest of `v`, the first of equals so that ties break the same
/// way every time; NaNs are never chosen, and an empty `v` gives `(0, -inf)`.
pub(crate) fn argmax_first(v: &[f64]) -> (usize, f64) {
    v.iter()
        .enumerate()
        .fold((0, f64::NEG_INFINITY), |best, (i, &value)| {
            if value > best.1 { (i, value) } else { best }
        })
}

/// Whether this CPU runs the AVX2 + FMA code paths (std caches the answer after the first call).
#[inline]
pub fn has_avx2_fma() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// Runs `f`, compiled for AVX2 + FMA vectors where the CPU has them. The crate is built for the
/// x86-64 baseline (SSE2, 2 lanes) so that one wheel runs everywhere; the GP's O(m^2) loops (the
/// kernel matrix, the gradient sums, the predictions) run twice as wide inside this. `f` and the
/// `#[inline]` helpers it calls are inlined into the AVX2 copy. Rust never contracts `a * b + c`
/// into an FMA on its own, so both copies give the same bits; the choice depends only on the
/// machine, so results are reproducible on it.
#[inline(always)]
pub fn simd<R>(f: impl FnOnce() -> R) -> R {
    #[cfg(target_arch = "x86_64")]
    {
        #[target_feature(enable = "avx2,fma")]
        unsafe fn wide<R>(f: impl FnOnce() -> R) -> R {
            f()
        }
        if has_avx2_fma() {
            // SAFETY: the CPU supports the enabled features (checked just above).
            return unsafe { wide(f) };
        }
    }
    f()
}

/// `v_i <- exp(v_i)` for `v_i <= 709`, branch-free (the kernel matrix needs `m^2 / 2`
/// exponentials per likelihood evaluation, as many as the O(m^3) work at small m, a prediction
/// one per training point, and a stepper's forcing term about ten per control period).
/// Cody-Waite reduction `x = k ln 2 + r`, `|r| <= ln 2 / 2`, and the degree-12 Taylor polynomial
/// (truncation error below 2e-16 relative) in Estrin's form, whose dependency chain is 5
/// multiply-adds deep instead of Horner's 12, so that consecutive vectors overlap in the
/// pipeline; `2^k` from the exponent bits. Arguments below -708 give 0 (the true value is below
/// 1e-307); NaN stays NaN.
///
/// On x86-64 with AVX2 and FMA (checked at run time, so the same machine always takes the same
/// path) whole 4-lane vectors run with fused multiply-adds; a slice a multiple of 4 long has no
/// scalar tail. Inlined, so that a caller compiled for AVX2 inlines the vector code too.
#[inline(always)]
pub fn exp_in_place(v: &mut [f64]) {
    #[cfg(target_arch = "x86_64")]
    {
        if has_avx2_fma() {
            // SAFETY: the CPU supports the enabled features (checked just above).
            unsafe { exp_in_place_avx2(v) };
            return;
        }
    }
    for x in v {
        *x = exp_lane::<false>(*x);
    }
}

const LOG2E: f64 = std::f64::consts::LOG2_E;
/// ln 2 = LN2_HI + LN2_LO, LN2_HI with its low 21 bits zero (so k * LN2_HI is exact).
const LN2_HI: f64 = f64::from_bits(0x3fe6_2e42_fee0_0000);
const LN2_LO: f64 = f64::from_bits(0x3dea_39ef_3579_3c76);
/// 1.5 * 2^52: adding it rounds to an integer in the low bits.
const SHIFT: f64 = 6_755_399_441_055_744.0;
/// The range in which the reduction is computed; below it the result is 0.
const EXP_MIN: f64 = -708.0;
const EXP_MAX: f64 = 709.0;
/// 1/j! for j = 0..=12.
const F: [f64; 13] = [
    1.0,
    1.0,
    0.5,
    1.0 / 6.0,
    1.0 / 24.0,
    1.0 / 120.0,
    1.0 / 720.0,
    1.0 / 5_040.0,
    1.0 / 40_320.0,
    1.0 / 362_880.0,
    1.0 / 3_628_800.0,
    1.0 / 39_916_800.0,
    1.0 / 479_001_600.0,
];

/// One exponential of [`exp_in_place`], with fused multiply-adds (`FMA`, for a caller compiled
/// with them: a software fma would be very slow) or without.
#[inline(always)]
fn exp_lane<const FMA: bool>(x0: f64) -> f64 {
    let madd = |a: f64, b: f64, c: f64| if FMA { a.mul_add(b, c) } else { a * b + c };
    let xc = x0.clamp(EXP_MIN, EXP_MAX);
    let t = madd(xc, LOG2E, SHIFT);
    let k = t - SHIFT;
    let r = madd(-k, LN2_LO, madd(-k, LN2_HI, xc));
    // Estrin: pairs, then pairs of pairs with r^2, r^4, r^8.
    let (r2, r4) = (r * r, r * r * (r * r));
    let r8 = r4 * r4;
    let p01 = madd(F[1], r, F[0]);
    let p23 = madd(F[3], r, F[2]);
    let p45 = madd(F[5], r, F[4]);
    let p67 = madd(F[7], r, F[6]);
    let p89 = madd(F[9], r, F[8]);
    let p1011 = madd(F[11], r, F[10]);
    let p0_3 = madd(p23, r2, p01);
    let p4_7 = madd(p67, r2, p45);
    let p8_11 = madd(p1011, r2, p89);
    let p0_7 = madd(p4_7, r4, p0_3);
    let p8_12 = madd(F[12], r4, p8_11);
    let p = madd(p8_12, r8, p0_7);
    let scale = f64::from_bits(t.to_bits().wrapping_add(1023) << 52);
    // NaN needs no test of its own: it passes through the clamp and every step to `p`, and
    // fails `x0 < EXP_MIN`.
    if x0 < EXP_MIN { 0.0 } else { p * scale }
}

/// [`exp_in_place`] on a CPU with AVX2 and FMA: whole vectors by [`exp4`], the tail by
/// [`exp_lane`]; the same operations lane by lane, so the same bits.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
unsafe fn exp_in_place_avx2(v: &mut [f64]) {
    use std::arch::x86_64::{_mm256_loadu_pd, _mm256_storeu_pd};
    let (vectors, tail) = v.as_chunks_mut::<4>();
    for x in vectors {
        let p = x.as_mut_ptr();
        // SAFETY: `p` points to 4 f64s of this slice.
        unsafe { _mm256_storeu_pd(p, exp4(_mm256_loadu_pd(p))) };
    }
    for x in tail {
        *x = exp_lane::<true>(*x);
    }
}

/// [`exp_lane`]`::<true>` of four lanes, written out in intrinsics: the compiler's own
/// vectorization of the lane code vectorizes across several vectors at once and leaves a slice
/// of ten to its scalar remainder.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
pub(crate) fn exp4(x0: std::arch::x86_64::__m256d) -> std::arch::x86_64::__m256d {
    use std::arch::x86_64::*;
    let c = |v: f64| _mm256_set1_pd(v);
    let madd = |a, b, c| _mm256_fmadd_pd(a, b, c);
    // clamp: max(lo, x) and min(hi, x) return x when it is NaN, as `f64::clamp` does.
    let xc = _mm256_min_pd(c(EXP_MAX), _mm256_max_pd(c(EXP_MIN), x0));
    let t = madd(xc, c(LOG2E), c(SHIFT));
    let k = _mm256_sub_pd(t, c(SHIFT));
    let neg_k = _mm256_xor_pd(k, c(-0.0));
    let r = madd(neg_k, c(LN2_LO), madd(neg_k, c(LN2_HI), xc));
    let r2 = _mm256_mul_pd(r, r);
    let r4 = _mm256_mul_pd(r2, r2);
    let r8 = _mm256_mul_pd(r4, r4);
    let p01 = madd(c(F[1]), r, c(F[0]));
    let p23 = madd(c(F[3]), r, c(F[2]));
    let p45 = madd(c(F[5]), r, c(F[4]));
    let p67 = madd(c(F[7]), r, c(F[6]));
    let p89 = madd(c(F[9]), r, c(F[8]));
    let p1011 = madd(c(F[11]), r, c(F[10]));
    let p0_3 = madd(p23, r2, p01);
    let p4_7 = madd(p67, r2, p45);
    let p8_11 = madd(p1011, r2, p89);
    let p0_7 = madd(p4_7, r4, p0_3);
    let p8_12 = madd(c(F[12]), r4, p8_11);
    let p = madd(p8_12, r8, p0_7);
    let bits = _mm256_slli_epi64::<52>(_mm256_add_epi64(
        _mm256_castpd_si256(t),
        _mm256_set1_epi64x(1023),
    ));
    let e = _mm256_mul_pd(p, _mm256_castsi256_pd(bits));
    // 0 where x0 < EXP_MIN (false for NaN, which stays NaN).
    _mm256_andnot_pd(_mm256_cmp_pd::<_CMP_LT_OQ>(x0, c(EXP_MIN)), e)
}

/// Overwrites the lower triangle of `a` (`m x m`) with its Cholesky factor `L` (`A = L L^T`).
/// Returns false if `A` is not numerically positive definite (a pivot that is not > 0, NaN
/// included). The strict upper triangle is never read.
///
/// Left-looking, one column at a time: column `j` of `L` is column `j` of `A` less
/// `L[j, k] L[:, k]` for `k = 0, 1, ..., j - 1` in that order, then scaled by its pivot's root.
/// Every entry's sum runs in the same order whatever the vector width, so the factor has the same
/// bits on every x86-64 machine (a library kernel chosen by the CPU, AVX-512 or not, would not).
pub fn cholesky_in_place(a: &mut [f64], m: usize) -> bool {
    debug_assert_eq!(a.len(), m * m);
    simd(|| {
        for j in 0..m {
            let (done, rest) = a.split_at_mut(j * m);
            let col = &mut rest[j..m];
            let below = |k: usize| &done[k * m + j..(k + 1) * m];
            // The columns k with L[j, k] != 0, four at a time in one pass over `col` (each entry
            // still takes them in increasing k, so the bits are those of one column at a time).
            let mut ks = [0usize; 4];
            let mut n = 0;
            for k in 0..j {
                if done[k * m + j] != 0.0 {
                    ks[n] = k;
                    n += 1;
                    if n == 4 {
                        let c = ks.map(|k| (done[k * m + j], below(k)));
                        axpy4(col, &c);
                        n = 0;
                    }
                }
            }
            for &k in &ks[..n] {
                axpy1(col, done[k * m + j], below(k));
            }
            let pivot = col[0];
            if pivot.is_nan() || pivot <= 0.0 {
                return false;
            }
            let d = pivot.sqrt();
            col[0] = d;
            for v in &mut col[1..] {
                *v /= d;
            }
        }
        true
    })
}

/// Writes the lower triangle of `A^{-1} = L^{-T} L^{-1}` into `out` (`m x m`, column-major) from
/// the Cholesky factor `L` (lower triangle of `l`), as LAPACK's `potri` does: first `W = L^{-1}`
/// (lower triangular, column by column by forward substitution), then
/// `A^{-1}[i, j] = W[i.., i] . W[i.., j]` for `i >= j`, each a [`dot`] in a fixed order. The strict
/// upper triangle of `out` is unspecified.
pub fn spd_inverse_lower(l: &[f64], m: usize, out: &mut [f64]) {
    debug_assert!(l.len() == m * m && out.len() == m * m);
    let mut w = vec![0.0; m * m];
    simd(|| {
        for c in 0..m {
            let col = &mut w[c * m..(c + 1) * m];
            col[c] = 1.0;
            solve_lower_from(l, m, col, c);
        }
        for j in 0..m {
            for i in j..m {
                out[j * m + i] = dot(&w[i * m + i..(i + 1) * m], &w[j * m + i..(j + 1) * m]);
            }
        }
    });
}

/// Solves `L X = B` in place for the `k` columns of `b` (`m x k`, column-major), one column at a
/// time by [`solve_lower_in_place`].
pub fn solve_lower_many_in_place(l: &[f64], m: usize, b: &mut [f64], k: usize) {
    debug_assert!(l.len() == m * m && b.len() == m * k);
    simd(|| {
        for col in b.chunks_exact_mut(m.max(1)).take(k) {
            solve_lower_from(l, m, col, 0);
        }
    });
}

/// `v -= a c` entrywise.
#[inline(always)]
fn axpy1(v: &mut [f64], a: f64, c: &[f64]) {
    for (v, c) in v.iter_mut().zip(c) {
        *v -= a * c;
    }
}

/// `v -= a_0 c_0`, then `- a_1 c_1`, `- a_2 c_2`, `- a_3 c_3`, entry by entry in one pass: the
/// same operations in the same order as four [`axpy1`]s, reading and writing `v` once.
#[inline(always)]
fn axpy4(v: &mut [f64], c: &[(f64, &[f64]); 4]) {
    let n = v.len();
    let [(a0, c0), (a1, c1), (a2, c2), (a3, c3)] = c;
    let (c0, c1, c2, c3) = (&c0[..n], &c1[..n], &c2[..n], &c3[..n]);
    for i in 0..n {
        let mut x = v[i];
        x -= a0 * c0[i];
        x -= a1 * c1[i];
        x -= a2 * c2[i];
        x -= a3 * c3[i];
        v[i] = x;
    }
}

/// Forward substitution of `L x = b` for a `b` whose first `first` entries are zero (so are
/// those of `x`), column-oriented: each solved `x_k != 0` is taken out of the entries below it.
/// Four columns at a time, the entries below their diagonal block in one pass (in the same order
/// per entry as one column at a time, so the same bits).
#[inline(always)]
fn solve_lower_from(l: &[f64], m: usize, b: &mut [f64], first: usize) {
    let col = |k: usize| &l[k * m..(k + 1) * m];
    let mut k = first;
    while k + 4 <= m {
        // The diagonal block, one column at a time.
        for kk in k..k + 4 {
            let xk = b[kk] / col(kk)[kk];
            b[kk] = xk;
            if xk != 0.0 {
                axpy1(&mut b[kk + 1..k + 4], xk, &col(kk)[kk + 1..k + 4]);
            }
        }
        // Below it: the block's nonzero x's, in increasing k.
        let (mut c, mut n) = ([(0.0, &l[..0]); 4], 0);
        for (kk, &xk) in b.iter().enumerate().take(k + 4).skip(k) {
            if xk != 0.0 {
                c[n] = (xk, &col(kk)[k + 4..]);
                n += 1;
            }
        }
        let rest = &mut b[k + 4..];
        if n == 4 {
            axpy4(rest, &c);
        } else {
            for &(xk, ck) in &c[..n] {
                axpy1(rest, xk, ck);
            }
        }
        k += 4;
    }
    for k in k..m {
        let xk = b[k] / col(k)[k];
        b[k] = xk;
        if xk != 0.0 {
            axpy1(&mut b[k + 1..], xk, &col(k)[k + 1..]);
        }
    }
}

/// Solves `L x = b` in place (forward substitution, column-oriented).
pub fn solve_lower_in_place(l: &[f64], m: usize, b: &mut [f64]) {
    simd(|| solve_lower_from(l, m, b, 0))
}

/// Solves `L^T x = b` in place (backward substitution; row i of `L^T` is column i of `L`).
pub fn solve_upper_t_in_place(l: &[f64], m: usize, b: &mut [f64]) {
    simd(|| {
        for i in (0..m).rev() {
            let col = &l[i * m..(i + 1) * m];
            let s = dot(&col[i + 1..], &b[i + 1..]);
            b[i] = (b[i] - s) / col[i];
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DMatrix;

    #[test]
    fn argmax_first_takes_the_first_of_equals_and_never_a_nan() {
        assert_eq!(argmax_first(&[1.0, 3.0, 2.0, 3.0]), (1, 3.0));
        assert_eq!(argmax_first(&[f64::NAN, -1.0, f64::NAN, -0.5]), (3, -0.5));
        assert_eq!(
            argmax_first(&[f64::INFINITY, f64::INFINITY]),
            (0, f64::INFINITY)
        );
        assert_eq!(argmax_first(&[]), (0, f64::NEG_INFINITY));
    }

    fn spd(m: usize) -> DMatrix<f64> {
        let b = DMatrix::from_fn(m, m, |i, j| ((i * 7 + j * 3) % 11) as f64 / 11.0 - 0.4);
        &b * b.transpose() + DMatrix::identity(m, m) * 0.5
    }

    #[test]
    fn factor_solve_and_inverse_match_nalgebra() {
        for m in [1, 2, 5, 17, 70, 130] {
            let a = spd(m);
            let mut l = a.as_slice().to_vec();
            assert!(cholesky_in_place(&mut l, m));
            let expect = a.clone().cholesky().unwrap().l();
            for j in 0..m {
                for i in j..m {
                    assert!((l[j * m + i] - expect[(i, j)]).abs() < 1e-12);
                }
            }
            let b: Vec<f64> = (0..m).map(|i| (i as f64).sin()).collect();
            let mut x = b.clone();
            solve_lower_in_place(&l, m, &mut x);
            solve_upper_t_in_place(&l, m, &mut x);
            let ax = &a * nalgebra::DVector::from_column_slice(&x);
            for i in 0..m {
                assert!((ax[i] - b[i]).abs() < 1e-10);
            }
            let mut kinv = vec![0.0; m * m];
            spd_inverse_lower(&l, m, &mut kinv);
            let inv = a.clone().try_inverse().unwrap();
            for bcol in 0..m {
                for arow in bcol..m {
                    assert!((kinv[bcol * m + arow] - inv[(arow, bcol)]).abs() < 1e-10);
                }
            }
            // Many right-hand sides at once agree with one at a time.
            let k = 3;
            let mut many: Vec<f64> = (0..m * k).map(|i| (i as f64 * 0.37).cos()).collect();
            let mut single = many.clone();
            solve_lower_many_in_place(&l, m, &mut many, k);
            for c in 0..k {
                solve_lower_in_place(&l, m, &mut single[c * m..(c + 1) * m]);
            }
            for (u, v) in many.iter().zip(&single) {
                assert!((u - v).abs() < 1e-10);
            }
        }
    }

    #[test]
    fn exp_matches_std() {
        let mut xs: Vec<f64> = (0..20001).map(|i| -740.0 + i as f64 * 0.037).collect();
        xs.extend([
            0.0,
            -0.0,
            1e-300,
            -1e-17,
            0.5 * std::f64::consts::LN_2,
            -708.0,
            709.0,
            f64::NEG_INFINITY,
        ]);
        let mut ys = xs.clone();
        exp_in_place(&mut ys);
        for (&x, &y) in xs.iter().zip(&ys) {
            let e = x.exp();
            assert!(
                (y - e).abs() <= 4.0 * f64::EPSILON * e + 1e-307,
                "exp({x}) = {y} vs {e}"
            );
        }
        let mut nan = [f64::NAN];
        exp_in_place(&mut nan);
        assert!(nan[0].is_nan());
    }

    #[test]
    fn exp_vectors_and_lanes_give_the_same_bits() {
        // Every slice length from 0 to 13 (whole vectors and tails), over arguments that cover
        // the reduction's range, its edges, infinities and NaN.
        let xs: Vec<f64> = (0..4001)
            .map(|i| -745.0 + i as f64 * 0.3637)
            .chain([0.0, -0.0, 1e-300, -708.0, -708.0001, 709.0, 710.0, 1e308])
            .chain([f64::NEG_INFINITY, f64::INFINITY, f64::NAN, -f64::NAN])
            .collect();
        let fma = has_avx2_fma();
        for len in 0..=13 {
            for window in xs.chunks(len.max(1)).take(400) {
                let window = &window[..len.min(window.len())];
                let mut ys = window.to_vec();
                exp_in_place(&mut ys);
                for (&x, &y) in window.iter().zip(&ys) {
                    let lane = if fma {
                        exp_lane::<true>(x)
                    } else {
                        exp_lane::<false>(x)
                    };
                    assert_eq!(y.to_bits(), lane.to_bits(), "exp({x}), slice of {len}");
                }
            }
        }
    }

    #[test]
    fn the_simd_copy_gives_the_same_bits() {
        // Same sums in the same order, only wider vectors: `simd` must not change a result.
        let a: Vec<f64> = (0..1003).map(|i| (i as f64 * 0.37).sin() * 1e3).collect();
        let b: Vec<f64> = (0..1003).map(|i| (i as f64 * 0.11).cos() / 7.0).collect();
        assert_eq!(simd(|| dot(&a, &b)).to_bits(), dot(&a, &b).to_bits());
        let l: Vec<f64> = {
            let mut s = vec![0.0; 70 * 70];
            for j in 0..70 {
                for i in j..70 {
                    s[j * 70 + i] = if i == j {
                        2.0 + i as f64 * 0.01
                    } else {
                        b[i + j]
                    };
                }
            }
            s
        };
        let (mut x, mut y) = (a[..70].to_vec(), a[..70].to_vec());
        solve_lower_in_place(&l, 70, &mut x); // runs inside `simd`
        for k in 0..70 {
            // the same forward substitution, outside
            let col = &l[k * 70..(k + 1) * 70];
            let yk = y[k] / col[k];
            y[k] = yk;
            for (v, c) in y[k + 1..].iter_mut().zip(&col[k + 1..]) {
                *v -= yk * c;
            }
        }
        assert_eq!(x, y);
    }

    #[test]
    fn four_columns_at_a_time_give_the_bits_of_one_at_a_time() {
        // The reference: the plain left-looking factor and forward substitution, one column at a
        // time, skipping zero multipliers. Sizes around the blocking, with zeros in L (a
        // block-diagonal part) so that skipped columns fall inside and across blocks.
        fn reference_factor(a: &mut [f64], m: usize) {
            for j in 0..m {
                for k in 0..j {
                    let ljk = a[k * m + j];
                    if ljk != 0.0 {
                        for i in j..m {
                            a[j * m + i] -= ljk * a[k * m + i];
                        }
                    }
                }
                let d = a[j * m + j].sqrt();
                a[j * m + j] = d;
                for i in j + 1..m {
                    a[j * m + i] /= d;
                }
            }
        }
        fn reference_solve(l: &[f64], m: usize, b: &mut [f64]) {
            for k in 0..m {
                let xk = b[k] / l[k * m + k];
                b[k] = xk;
                if xk != 0.0 {
                    for i in k + 1..m {
                        b[i] -= xk * l[k * m + i];
                    }
                }
            }
        }
        for m in [1, 2, 3, 4, 5, 7, 8, 9, 13, 37, 64] {
            let mut a = spd(m).as_slice().to_vec();
            for j in 0..m {
                for i in 0..m {
                    if (i < m / 3) != (j < m / 3) {
                        a[j * m + i] = 0.0; // two diagonal blocks: zeros in the factor
                    }
                }
            }
            let mut fast = a.clone();
            assert!(cholesky_in_place(&mut fast, m));
            reference_factor(&mut a, m);
            for j in 0..m {
                for i in j..m {
                    assert_eq!(
                        fast[j * m + i].to_bits(),
                        a[j * m + i].to_bits(),
                        "L[{i}, {j}], m = {m}"
                    );
                }
            }
            let b: Vec<f64> = (0..m).map(|i| ((i * 7) % 5) as f64 - 2.0).collect();
            let (mut x, mut y) = (b.clone(), b.clone());
            solve_lower_in_place(&a, m, &mut x);
            reference_solve(&a, m, &mut y);
            assert_eq!(x, y, "m = {m}");
        }
    }

    #[test]
    fn an_indefinite_matrix_is_refused() {
        let mut a = vec![1.0, 2.0, 2.0, 1.0];
        assert!(!cholesky_in_place(&mut a, 2));
        let mut nan = vec![f64::NAN];
        assert!(!cholesky_in_place(&mut nan, 1));
    }
}
