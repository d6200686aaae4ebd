//! Dense symmetric positive-definite kernels for the Gaussian process: in-place Cholesky,
//! triangular solves and the inverse from the factor. Matrices are square, column-major
//! `Vec<f64>`s with leading dimension `m`; only the lower triangle of a factor is used.
//!
//! Written out here (rather than using nalgebra's decomposition) so that every inner loop runs
//! over a contiguous column slice, which the compiler vectorizes, and so that the GP's
//! optimization loop reuses its buffers. All loops are sequential: results are bit-identical run
//! to run.

/// `sum_i a_i b_i` with eight independent partial sums. A plain `.sum()` of products is one
/// dependency chain the compiler may not reorder (floating-point addition is not associative), so
/// it runs at one add per FMA latency; eight chains vectorize. The order is fixed by the code, so
/// results are still bit-identical run to run.
#[inline]
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

/// Overwrites the lower triangle of `a` (`m x m`) with its Cholesky factor `L` (`A = L L^T`).
/// Returns false if `A` is not numerically positive definite. The strict upper triangle is left
/// untouched and never read.
pub fn cholesky_in_place(a: &mut [f64], m: usize) -> bool {
    debug_assert_eq!(a.len(), m * m);
    for j in 0..m {
        let (head, tail) = a.split_at_mut((j + 1) * m);
        let col_j = &mut head[j * m..];
        let d = col_j[j];
        if !d.is_finite() || d <= 0.0 {
            return false;
        }
        let d = d.sqrt();
        col_j[j] = d;
        let inv = 1.0 / d;
        for v in &mut col_j[j + 1..] {
            *v *= inv;
        }
        // Right-looking update of the trailing columns: A[k.., k] -= L[k, j] L[k.., j].
        let col_j = &head[j * m..];
        for k in j + 1..m {
            let lkj = col_j[k];
            if lkj == 0.0 {
                continue;
            }
            let col_k = &mut tail[(k - j - 1) * m..(k - j) * m];
            for (c, l) in col_k[k..].iter_mut().zip(&col_j[k..]) {
                *c -= lkj * l;
            }
        }
    }
    true
}

/// Solves `L x = b` in place (forward substitution, column-oriented).
pub fn solve_lower_in_place(l: &[f64], m: usize, b: &mut [f64]) {
    for k in 0..m {
        let col = &l[k * m..(k + 1) * m];
        let xk = b[k] / col[k];
        b[k] = xk;
        if xk != 0.0 {
            for (v, c) in b[k + 1..].iter_mut().zip(&col[k + 1..]) {
                *v -= xk * c;
            }
        }
    }
}

/// Solves `L^T x = b` in place (backward substitution; row i of `L^T` is column i of `L`).
pub fn solve_upper_t_in_place(l: &[f64], m: usize, b: &mut [f64]) {
    for i in (0..m).rev() {
        let col = &l[i * m..(i + 1) * m];
        let s = dot(&col[i + 1..], &b[i + 1..]);
        b[i] = (b[i] - s) / col[i];
    }
}

/// Writes `L^{-1}` (lower triangular, column-major) into `out`; entries above the diagonal are 0.
pub fn lower_inverse(l: &[f64], m: usize, out: &mut [f64]) {
    out.iter_mut().for_each(|v| *v = 0.0);
    for a in 0..m {
        let x = &mut out[a * m..(a + 1) * m];
        x[a] = 1.0;
        for k in a..m {
            let col = &l[k * m..(k + 1) * m];
            let xk = x[k] / col[k];
            x[k] = xk;
            if xk != 0.0 {
                for (v, c) in x[k + 1..].iter_mut().zip(&col[k + 1..]) {
                    *v -= xk * c;
                }
            }
        }
    }
}

/// `(A^{-1})_{ab}` for `a <= b` from `L^{-1}`: `A^{-1} = L^{-T} L^{-1}`, so the entry is the dot
/// product of columns a and b of `L^{-1}` over rows `b..m` (both vanish above their diagonal).
#[inline]
pub fn inverse_entry(linv: &[f64], m: usize, a: usize, b: usize) -> f64 {
    debug_assert!(a <= b);
    let ca = &linv[a * m + b..(a + 1) * m];
    let cb = &linv[b * m + b..(b + 1) * m];
    dot(ca, cb)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DMatrix;

    fn spd(m: usize) -> DMatrix<f64> {
        let b = DMatrix::from_fn(m, m, |i, j| ((i * 7 + j * 3) % 11) as f64 / 11.0 - 0.4);
        &b * b.transpose() + DMatrix::identity(m, m) * 0.5
    }

    #[test]
    fn factor_solve_and_inverse_match_nalgebra() {
        for m in [1, 2, 5, 17] {
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
            let mut linv = vec![0.0; m * m];
            lower_inverse(&l, m, &mut linv);
            let inv = a.clone().try_inverse().unwrap();
            for bcol in 0..m {
                for arow in 0..=bcol {
                    assert!((inverse_entry(&linv, m, arow, bcol) - inv[(arow, bcol)]).abs() < 1e-10);
                }
            }
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
