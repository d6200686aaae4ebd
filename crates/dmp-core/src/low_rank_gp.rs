//! The posterior mean of a GP with given hyperparameters, conditioned on every training point
//! through a low-rank factor of its kernel matrix: the subset of regressors on points chosen by
//! a pivoted Cholesky factorization, computed stably through a QR factorization (Foster et al.
//! 2009, "Stable and efficient Gaussian process calculations", JMLR 10; docs/method.md §3.2).
//!
//! With `K_f ~ L L^T`, `L` (`M x r`) the first `r` columns of the Cholesky factor of `K_f` with
//! diagonal pivoting, the GP is the Bayesian linear regression on the `r` features
//! `phi(q) = L_pp^{-1} k(pivots, q)` (`L_pp`: the pivots' rows of `L`, lower triangular):
//!
//! ```text
//! mean(q) = mu + phi(q)^T w,   w = argmin |L w - (y - mu)|^2 + noise_var |w|^2
//!         = mu + k(pivots, q)^T L_pp^{-T} w
//! ```
//!
//! a kernel sum over the `r` pivots, like the exact GP's over every point. Each pivot is the
//! point whose prior variance the chosen ones explain least; the factorization stops once no
//! point's unexplained variance exceeds [`TOLERANCE`] `x noise_var`, so what the factor leaves
//! out of the kernel matrix is a small part of the noise the GP already assumes at every point.
//! Where the length scales are long against the points' spread (smooth outputs), `r` stays far
//! below `M`: the cost is `M r^2` to condition and `r` per prediction.

use nalgebra::{DMatrix, DVector};

use crate::error::{Error, Result, fmt_g};
use crate::gp::{
    Hyperparameters, half_sq_distances, kernel_sum, query_ranges, scale_dimension_major,
};
use crate::linalg::{argmax_first, exp_in_place, simd, solve_upper_t_in_place};

/// The factorization stops once every point's unexplained prior variance is at most this
/// fraction of the noise variance.
pub const TOLERANCE: f64 = 1e-3;

/// How the refusals name the method, with the argument that chose it.
pub(crate) const SPARSE_GPS: &str = "sparse GPs (gp_sparse=True)";

/// A GP's posterior mean over a pivoted low-rank factor of its kernel matrix.
#[derive(Debug, Clone)]
pub(crate) struct LowRankGp {
    mean: f64,
    length_scales: Vec<f64>,
    /// The pivots divided by the length scales, dimension-major (`xd[d * r + j]`).
    xd: Vec<f64>,
    /// `signal_var L_pp^{-T} w`, so that the mean is `mean + sum_j exp(..) weights_j`.
    weights: Vec<f64>,
}

impl LowRankGp {
    /// Conditions a GP with hyperparameters `hyper` on outputs `y` at the points `x` (`n x M`),
    /// with a constant prior mean equal to the mean of `y` (as [`crate::gp::GaussianProcess`]).
    /// Fails if the factor would need more than `max_rank` pivots.
    pub(crate) fn condition(
        x: &DMatrix<f64>,
        y: &[f64],
        hyper: &Hyperparameters,
        max_rank: usize,
    ) -> Result<Self> {
        let (n, m) = x.shape();
        let l_s = &hyper.length_scales;
        let mut xd = vec![0.0; n * m];
        scale_dimension_major(x.as_slice(), n, l_s, &mut xd);
        let Some((l, pivots)) = pivoted_cholesky(&xd, m, hyper, max_rank) else {
            let relative: Vec<String> = l_s
                .iter()
                .zip(query_ranges(&x.as_view()))
                .map(|(l, range)| fmt_g(l / range))
                .collect();
            return Err(Error::Unsuited {
                method: SPARSE_GPS,
                detail: format!(
                    "more than {max_rank} demos are needed to represent this output to within \
                     {TOLERANCE} x its noise variance (its length scales are [{}] x the queries' \
                     ranges: short against the demos' spread); use local GPs (gp_neighbours) \
                     instead",
                    relative.join(", ")
                ),
            });
        };
        let r = pivots.len();
        let mean = y.iter().sum::<f64>() / m as f64;
        let w = regularized_least_squares(&l, m, r, y, mean, hyper.noise_var)?;
        // v = L_pp^{-T} w; L_pp (column-major, r x r) is lower triangular by construction.
        let mut lpp = vec![0.0; r * r];
        for c in 0..r {
            for (a, &p) in pivots.iter().enumerate().skip(c) {
                lpp[c * r + a] = l[c * m + p];
            }
        }
        let mut v = w;
        solve_upper_t_in_place(&lpp, r, &mut v);
        let weights: Vec<f64> = v.iter().map(|v| v * hyper.signal_var).collect();
        if let Some(bad) = weights.iter().find(|v| !v.is_finite()) {
            return Err(Error::Numerical {
                context: "sparse Gaussian process",
                detail: format!("a weight is {bad}"),
            });
        }
        let mut pxd = vec![0.0; n * r];
        for d in 0..n {
            for (j, &p) in pivots.iter().enumerate() {
                pxd[d * r + j] = xd[d * m + p];
            }
        }
        Ok(Self {
            mean,
            length_scales: l_s.clone(),
            xd: pxd,
            weights,
        })
    }

    /// How many points the factor kept.
    #[cfg(test)]
    pub(crate) fn rank(&self) -> usize {
        self.weights.len()
    }

    /// The posterior mean at `q` (`n` values; the caller checks the length).
    pub(crate) fn mean_at(&self, q: &[f64]) -> f64 {
        self.mean + kernel_sum(&self.xd, &self.length_scales, q, &self.weights)
    }
}

/// The first columns of the Cholesky factor of `K_f` with diagonal pivoting (column-major,
/// `m` rows each) and the pivots, in order, over the `m` points `xd` (dimension-major, scaled);
/// `None` if more than `max_rank` pivots are needed.
fn pivoted_cholesky(
    xd: &[f64],
    m: usize,
    hyper: &Hyperparameters,
    max_rank: usize,
) -> Option<(Vec<f64>, Vec<usize>)> {
    let sv = hyper.signal_var;
    let stop = TOLERANCE * hyper.noise_var;
    // The prior variance each point's chosen pivots leave unexplained.
    let mut left = vec![sv; m];
    let mut l: Vec<f64> = Vec::new();
    let mut pivots: Vec<usize> = Vec::new();
    let mut col = vec![0.0; m];
    simd(|| {
        loop {
            let (i, worst) = argmax_first(&left);
            if worst <= stop || pivots.len() == m {
                return Some(());
            }
            if pivots.len() == max_rank {
                return None;
            }
            half_sq_distances(xd, m, 0, |d| xd[d * m + i], &mut col);
            exp_in_place(&mut col);
            col.iter_mut().for_each(|v| *v *= sv);
            for c in l.chunks_exact(m) {
                let lic = c[i];
                col.iter_mut().zip(c).for_each(|(v, c)| *v -= lic * c);
            }
            let inv = 1.0 / worst.sqrt();
            col.iter_mut().for_each(|v| *v *= inv);
            // The chosen pivots' rows are exact zeros, so that L_pp is triangular.
            for &p in &pivots {
                col[p] = 0.0;
            }
            left.iter_mut()
                .zip(&col)
                .for_each(|(d, c)| *d = (*d - c * c).max(0.0));
            left[i] = 0.0;
            pivots.push(i);
            l.extend_from_slice(&col);
        }
    })?;
    Some((l, pivots))
}

/// `argmin |L w - (y - mean)|^2 + noise_var |w|^2` for `L` (`m x r`, column-major), by a QR
/// factorization of `[L; sqrt(noise_var) I]`: the normal equations would square the condition
/// number, about `M signal_var / noise_var`.
fn regularized_least_squares(
    l: &[f64],
    m: usize,
    r: usize,
    y: &[f64],
    mean: f64,
    noise_var: f64,
) -> Result<Vec<f64>> {
    let s = noise_var.sqrt();
    let a = DMatrix::from_fn(m + r, r, |i, j| {
        if i < m {
            l[j * m + i]
        } else if i - m == j {
            s
        } else {
            0.0
        }
    });
    let mut b = DVector::from_fn(m + r, |i, _| if i < m { y[i] - mean } else { 0.0 });
    let qr = a.qr();
    qr.q_tr_mul(&mut b);
    let top = b.rows(0, r).into_owned();
    qr.r()
        .solve_upper_triangular(&top)
        .map(|w| w.iter().copied().collect())
        .ok_or_else(|| Error::Numerical {
            context: "sparse Gaussian process",
            detail: "its least-squares system is singular".into(),
        })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gp::{GaussianProcess, GpOptions};

    /// `m` points in the unit square (a Halton-like lattice) and a smooth output over them.
    fn data(m: usize) -> (DMatrix<f64>, Vec<f64>) {
        let x = DMatrix::from_fn(2, m, |d, j| {
            let k = (j + 1) as f64;
            if d == 0 {
                (k * 0.618_033_988_749_895).fract()
            } else {
                (k * 0.754_877_666_246_693).fract()
            }
        });
        let y = (0..m)
            .map(|j| 1.5 + 0.5 * x[(0, j)] + 0.2 * (3.0 * x[(1, j)]).sin())
            .collect();
        (x, y)
    }

    fn exact(x: &DMatrix<f64>, y: &[f64], h: &Hyperparameters) -> GaussianProcess {
        let fixed = GpOptions {
            optimize: false,
            ..GpOptions::default()
        };
        GaussianProcess::fit(&x.as_view(), y, Some(h.clone()), &fixed).unwrap()
    }

    fn probes() -> Vec<[f64; 2]> {
        (0..50)
            .map(|k| [0.05 + 0.018 * k as f64, 0.95 - 0.017 * k as f64])
            .collect()
    }

    #[test]
    fn smooth_outputs_need_few_pivots_and_give_the_exact_mean() {
        let (x, y) = data(300);
        let h = Hyperparameters {
            length_scales: vec![50.0, 1.5],
            signal_var: 0.05,
            noise_var: 1e-8 * 0.05,
        };
        let (lr, gp) = (
            LowRankGp::condition(&x, &y, &h, 1000).unwrap(),
            exact(&x, &y, &h),
        );
        assert!(lr.rank() < 60, "rank {}", lr.rank());
        let range = 0.7;
        for q in probes() {
            let (got, want) = (lr.mean_at(&q), gp.predict_mean_at(&q));
            assert!((got - want).abs() < 1e-6 * range, "{q:?}: {got} vs {want}");
        }
    }

    #[test]
    fn a_factor_of_every_point_is_the_exact_gp() {
        // Short length scales: no point explains another, so every point becomes a pivot.
        let (x, y) = data(30);
        let h = Hyperparameters {
            length_scales: vec![0.02, 0.02],
            signal_var: 1.0,
            noise_var: 1e-6,
        };
        let (lr, gp) = (
            LowRankGp::condition(&x, &y, &h, 1000).unwrap(),
            exact(&x, &y, &h),
        );
        assert_eq!(lr.rank(), 30);
        for q in probes()
            .into_iter()
            .chain((0..30).map(|j| [x[(0, j)], x[(1, j)]]))
        {
            assert!(
                (lr.mean_at(&q) - gp.predict_mean_at(&q)).abs() < 1e-9,
                "{q:?}"
            );
        }
    }

    #[test]
    fn too_many_pivots_are_refused_with_the_reason() {
        let (x, y) = data(100);
        let h = Hyperparameters {
            length_scales: vec![0.01, 0.01],
            signal_var: 1.0,
            noise_var: 1e-6,
        };
        let err = LowRankGp::condition(&x, &y, &h, 40).unwrap_err();
        assert!(matches!(err, Error::Unsuited { .. }) && err.is_input_error());
        let err = err.to_string();
        // The length scales relative to the queries' ranges.
        let ranges = query_ranges(&x.as_view());
        let relative = format!("[{}, {}]", fmt_g(0.01 / ranges[0]), fmt_g(0.01 / ranges[1]));
        assert!(
            err.contains("more than 40 demos")
                && err.contains(&relative)
                && err.contains("gp_neighbours"),
            "{err}"
        );
    }
}
