//! Numerical differentiation of sampled trajectories on a possibly non-uniform time grid.
//!
//! The scheme is `numpy.gradient(y, t, edge_order=2)`: second-order central differences for
//! non-uniform spacing inside, second-order one-sided differences at both ends. Accelerations are
//! the same operator applied to the velocities. It needs at least 3 samples.

use nalgebra::{DMatrix, DMatrixView};

/// Samples the scheme needs.
pub const MIN_SAMPLES: usize = 3;

/// d/dt of the columns of `y` (`D x T`, one column per sample). `t.len() == y.ncols() >= 3`, and
/// `t` strictly increasing (checked by the caller).
pub fn gradient(t: &[f64], y: &DMatrixView<'_, f64>) -> DMatrix<f64> {
    let n = t.len();
    debug_assert!(n >= MIN_SAMPLES && y.ncols() == n);
    let mut out = DMatrix::zeros(y.nrows(), n);
    for j in 0..n {
        // out[:, j] = a y[:, i] + b y[:, i+1] + c y[:, i+2]; written without temporaries, this
        // runs in the fit's hot path.
        let (i, [a, b, c]) = stencil(t, j);
        let (y0, y1, y2) = (y.column(i), y.column(i + 1), y.column(i + 2));
        for (d, o) in out.column_mut(j).iter_mut().enumerate() {
            *o = a * y0[d] + b * y1[d] + c * y2[d];
        }
    }
    out
}

/// The weights of the scheme at sample `j`: `dy/dt(t_j) = a y_i + b y_{i+1} + c y_{i+2}` with
/// `(i, [a, b, c])` returned; `a + b + c = 0`. Also used to differentiate quaternion samples in
/// the tangent space at sample `j` ([`crate::cartesian`]).
#[inline]
pub fn stencil(t: &[f64], j: usize) -> (usize, [f64; 3]) {
    let n = t.len();
    if j == 0 {
        // Start: one-sided, exact for quadratics.
        let (d1, d2) = (t[1] - t[0], t[2] - t[1]);
        (
            0,
            [
                -(2.0 * d1 + d2) / (d1 * (d1 + d2)),
                (d1 + d2) / (d1 * d2),
                -d1 / (d2 * (d1 + d2)),
            ],
        )
    } else if j == n - 1 {
        // End.
        let (d1, d2) = (t[n - 2] - t[n - 3], t[n - 1] - t[n - 2]);
        (
            n - 3,
            [
                d2 / (d1 * (d1 + d2)),
                -(d2 + d1) / (d1 * d2),
                (2.0 * d2 + d1) / (d2 * (d1 + d2)),
            ],
        )
    } else {
        // Interior: the three-point formula exact for quadratics.
        let hs = t[j] - t[j - 1];
        let hd = t[j + 1] - t[j];
        (
            j - 1,
            [
                -hd / (hs * (hs + hd)),
                (hd - hs) / (hs * hd),
                hs / (hd * (hs + hd)),
            ],
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// Second-order schemes differentiate quadratics exactly, on any grid.
        #[test]
        fn exact_for_quadratics(
            steps in proptest::collection::vec(0.01f64..1.0, 2..30),
            a in -5.0f64..5.0, b in -5.0f64..5.0, c in -5.0f64..5.0,
        ) {
            let mut t = vec![0.0];
            for s in &steps { t.push(t.last().unwrap() + s); }
            let y = DMatrix::from_iterator(1, t.len(), t.iter().map(|&x| a + b * x + c * x * x));
            let d = gradient(&t, &y.as_view());
            for (j, &x) in t.iter().enumerate() {
                let exact = b + 2.0 * c * x;
                prop_assert!((d[(0, j)] - exact).abs() < 1e-8 * (1.0 + exact.abs() + x * x));
            }
        }
    }
}
