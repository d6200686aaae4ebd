//! Gaussian process regression (Rasmussen & Williams 2006, ch. 2 and 5; docs/method.md §3.2): the
//! squared-exponential ARD covariance plus noise,
//!
//! ```text
//! k(q, q') = signal_var * exp(-1/2 sum_d (q_d - q'_d)^2 / l_d^2) + noise_var * [q == q']
//! ```
//!
//! with a constant prior mean equal to the mean of the training outputs (docs/method.md §3.2: with a
//! zero mean, extrapolated goals and durations would collapse towards 0). Prediction is the
//! posterior mean (R&W eq. 2.25) and the standard deviation of the latent function (eq. 2.26,
//! without the noise term). Hyperparameters are fitted by ML-II: maximizing the log marginal
//! likelihood (eq. 2.30) with its analytic gradient (eq. 5.9), in log space, with box bounds and
//! deterministic restarts from Halton points.

use std::sync::atomic::{AtomicBool, Ordering};

use nalgebra::DMatrixView;
use rayon::prelude::*;

use crate::error::{Error, Result, check_scalar, fmt_g};
use crate::linalg::{
    cholesky_in_place, dot, exp_in_place, simd, solve_lower_in_place, solve_lower_many_in_place,
    solve_upper_t_in_place, spd_inverse_lower,
};
use crate::optimize::{MinimizeOptions, Objective, halton, minimize_box};

const LOG_2PI: f64 = 1.837_877_066_409_345_3;

/// Training points per block of a one-point prediction (a stack buffer of correlations).
const MEAN_BLOCK: usize = 64;

/// The covariance hyperparameters, in the units of the data.
#[derive(Debug, Clone, PartialEq)]
pub struct Hyperparameters {
    /// One length scale per input dimension (ARD).
    pub length_scales: Vec<f64>,
    pub signal_var: f64,
    pub noise_var: f64,
}

impl Hyperparameters {
    /// `[ln l_1 .. ln l_n, ln signal_var, ln noise_var]`, the space the optimizer works in.
    pub fn to_log(&self) -> Vec<f64> {
        let mut v: Vec<f64> = self.length_scales.iter().map(|l| l.ln()).collect();
        v.push(self.signal_var.ln());
        v.push(self.noise_var.ln());
        v
    }

    pub fn from_log(theta: &[f64]) -> Self {
        let n = theta.len() - 2;
        Self {
            length_scales: theta[..n].iter().map(|t| t.exp()).collect(),
            signal_var: theta[n].exp(),
            noise_var: theta[n + 1].exp(),
        }
    }

    fn validate(&self, n_dim: usize) -> Result<()> {
        if self.length_scales.len() != n_dim {
            return Err(Error::Shape {
                name: "length_scale",
                expected: format!("({n_dim},), one per input dimension"),
                got: format!("({},)", self.length_scales.len()),
            });
        }
        for &l in &self.length_scales {
            check_scalar("length_scale", l, true)?;
        }
        check_scalar("signal_var", self.signal_var, true)?;
        check_scalar("noise_var", self.noise_var, true)?;
        Ok(())
    }
}

/// Box bounds `(low, high)` on each hyperparameter; `low == high` holds it fixed.
#[derive(Debug, Clone, PartialEq)]
pub struct HyperBounds {
    pub length_scales: Vec<(f64, f64)>,
    pub signal_var: (f64, f64),
    pub noise_var: (f64, f64),
}

impl HyperBounds {
    fn log_box(&self) -> (Vec<f64>, Vec<f64>) {
        let all: Vec<(f64, f64)> = self
            .length_scales
            .iter()
            .copied()
            .chain([self.signal_var, self.noise_var])
            .collect();
        (
            all.iter().map(|b| b.0.ln()).collect(),
            all.iter().map(|b| b.1.ln()).collect(),
        )
    }

    fn validate(&self, n_dim: usize) -> Result<()> {
        if self.length_scales.len() != n_dim {
            return Err(Error::Shape {
                name: "length_scale_bounds",
                expected: format!("({n_dim}, 2), one pair per input dimension"),
                got: format!("({}, 2)", self.length_scales.len()),
            });
        }
        let named = self
            .length_scales
            .iter()
            .map(|b| ("length_scale_bounds", *b))
            .chain([
                ("signal_var_bounds", self.signal_var),
                ("noise_var_bounds", self.noise_var),
            ]);
        for (name, (lo, hi)) in named {
            check_scalar(name, lo, true)?;
            check_scalar(name, hi, true)?;
            if lo > hi {
                return Err(Error::InvalidParameter {
                    name,
                    value: format!("({lo}, {hi})"),
                    requirement: "low must not exceed high",
                });
            }
        }
        Ok(())
    }

    /// Widens each bound to contain `h` (so that a user's explicit start is never clipped).
    fn containing(mut self, h: &Hyperparameters) -> Self {
        let widen = |b: &mut (f64, f64), v: f64| {
            b.0 = b.0.min(v);
            b.1 = b.1.max(v);
        };
        for (b, &l) in self.length_scales.iter_mut().zip(&h.length_scales) {
            widen(b, l);
        }
        widen(&mut self.signal_var, h.signal_var);
        widen(&mut self.noise_var, h.noise_var);
        self
    }
}

/// How to fit.
#[derive(Debug, Clone, PartialEq)]
pub struct GpOptions {
    /// Maximize the log marginal likelihood (ML-II); otherwise use the initial hyperparameters.
    pub optimize: bool,
    /// Extra starts after the initial hyperparameters, at Halton points of the log box.
    pub n_restarts: usize,
    /// `None`: the data-relative defaults of [`default_bounds`], widened to contain the start.
    pub bounds: Option<HyperBounds>,
    pub minimize: MinimizeOptions,
}

/// The most restarts and optimizer iterations a fit may ask for: far beyond any benefit (the
/// defaults are 4 and 200), and small enough that a fit cannot run for minutes by mistake.
pub const MAX_RESTARTS: usize = 1000;
pub const MAX_ITER: usize = 100_000;

impl GpOptions {
    pub fn validate(&self) -> Result<()> {
        if self.n_restarts > MAX_RESTARTS {
            return Err(Error::InvalidParameter {
                name: "n_restarts",
                value: self.n_restarts.to_string(),
                requirement: "must be at most 1000 (each restart is a full optimization)",
            });
        }
        if self.minimize.max_iter == 0 || self.minimize.max_iter > MAX_ITER {
            return Err(Error::InvalidParameter {
                name: "max_iter",
                value: self.minimize.max_iter.to_string(),
                requirement: "must be between 1 and 100000",
            });
        }
        Ok(())
    }
}

impl Default for GpOptions {
    fn default() -> Self {
        Self {
            optimize: true,
            n_restarts: 4,
            bounds: None,
            minimize: MinimizeOptions::default(),
        }
    }
}

/// Training inputs stored sample-major (`x[j * n_dim + d]`), as a C-ordered `(m, n)` array.
fn check_data(x: &DMatrixView<'_, f64>, y: &[f64]) -> Result<()> {
    let (n_dim, m) = x.shape();
    if n_dim == 0 {
        return Err(Error::Shape {
            name: "X",
            expected: "(m, n) with n >= 1".into(),
            got: format!("({m}, 0)"),
        });
    }
    if m == 0 {
        return Err(Error::TooFewSamples {
            name: "X",
            got: 0,
            needed: 1,
            why: "a GP needs training data",
        });
    }
    if y.len() != m {
        return Err(Error::Shape {
            name: "y",
            expected: format!("({m},), one value per row of X"),
            got: format!("({},)", y.len()),
        });
    }
    crate::error::check_finite_matrix("X", x)?;
    if let Some((j, &v)) = y.iter().enumerate().find(|(_, v)| !v.is_finite()) {
        return Err(Error::NonFinite {
            name: "y",
            location: format!("[{j}]"),
            value: v,
        });
    }
    // The data-relative defaults are multiples of these: an overflow would surface later as a
    // complaint about a hyperparameter the caller never passed.
    let (ranges, var) = data_scales(x, y);
    if let Some(d) = ranges.iter().position(|r| !r.is_finite()) {
        return Err(Error::InvalidParameter {
            name: "X",
            value: format!("column {d} spanning {}", fmt_g(ranges[d])),
            requirement: "its range overflows f64; rescale the inputs",
        });
    }
    if !var.is_finite() {
        let max = y.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        return Err(Error::InvalidParameter {
            name: "y",
            value: format!("values up to {}", fmt_g(max)),
            requirement: "their variance overflows f64; rescale the outputs",
        });
    }
    Ok(())
}

/// The range of each input dimension (row) of `x`, 1 where it is 0.
pub(crate) fn query_ranges(x: &DMatrixView<'_, f64>) -> Vec<f64> {
    x.row_iter()
        .map(|r| {
            let span = r.max() - r.min();
            if span > 0.0 { span } else { 1.0 }
        })
        .collect()
}

/// The scales of the data that data-relative hyperparameters and bounds are multiples of: the
/// range of each input dimension and the variance of the outputs (each 1 where it is 0).
pub(crate) fn data_scales(x: &DMatrixView<'_, f64>, y: &[f64]) -> (Vec<f64>, f64) {
    let ranges = query_ranges(x);
    let m = y.len() as f64;
    let mean = y.iter().sum::<f64>() / m;
    let var = y.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / m;
    (ranges, if var > 0.0 { var } else { 1.0 })
}

/// A data-based start for ML-II: each length scale the range of its input, the signal variance
/// the variance of the outputs, the noise variance 1 % of it (1 where a range or variance is 0).
pub fn default_hyperparameters(x: &DMatrixView<'_, f64>, y: &[f64]) -> Result<Hyperparameters> {
    check_data(x, y)?;
    let (ranges, var) = data_scales(x, y);
    Ok(Hyperparameters {
        length_scales: ranges,
        signal_var: var,
        noise_var: 1e-2 * var,
    })
}

/// Data-relative bounds: `l_d` in `[1e-3, 1e3] x range_d`, `signal_var` in `[1e-4, 1e4] x var(y)`,
/// `noise_var` in `[1e-10, 10] x var(y)`.
pub fn default_bounds(x: &DMatrixView<'_, f64>, y: &[f64]) -> Result<HyperBounds> {
    check_data(x, y)?;
    let (ranges, var) = data_scales(x, y);
    Ok(HyperBounds {
        length_scales: ranges.iter().map(|r| (1e-3 * r, 1e3 * r)).collect(),
        signal_var: (1e-4 * var, 1e4 * var),
        noise_var: (1e-10 * var, 10.0 * var),
    })
}

/// The start of a fit: given values where the caller has them, [`default_hyperparameters`] for
/// the rest.
pub fn resolve_hyperparameters(
    x: &DMatrixView<'_, f64>,
    y: &[f64],
    length_scales: Option<Vec<f64>>,
    signal_var: Option<f64>,
    noise_var: Option<f64>,
) -> Result<Hyperparameters> {
    let d = default_hyperparameters(x, y)?;
    let h = Hyperparameters {
        length_scales: length_scales.unwrap_or(d.length_scales),
        signal_var: signal_var.unwrap_or(d.signal_var),
        noise_var: noise_var.unwrap_or(d.noise_var),
    };
    h.validate(x.nrows())?;
    Ok(h)
}

/// Bounds for a fit: given ones where the caller has them, else [`default_bounds`] widened to
/// contain the start.
pub fn resolve_bounds(
    x: &DMatrixView<'_, f64>,
    y: &[f64],
    start: &Hyperparameters,
    length_scales: Option<Vec<(f64, f64)>>,
    signal_var: Option<(f64, f64)>,
    noise_var: Option<(f64, f64)>,
) -> Result<HyperBounds> {
    let d = default_bounds(x, y)?.containing(start);
    let b = HyperBounds {
        length_scales: length_scales.unwrap_or(d.length_scales),
        signal_var: signal_var.unwrap_or(d.signal_var),
        noise_var: noise_var.unwrap_or(d.noise_var),
    };
    b.validate(x.nrows())?;
    Ok(b)
}

/// Scratch buffers of one likelihood evaluation, reused across the optimizer's calls.
///
/// Only lower triangles (column-major) are formed, and the inner loops run down contiguous
/// columns with the inputs stored dimension-major, so that they vectorize: at n = 100-200 the
/// kernel and the gradient sums otherwise cost as much as the O(n^3) factorization.
struct Workspace {
    m: usize,
    n_dim: usize,
    /// Inputs divided by the length scales, dimension-major (`xd[d * m + j]`).
    xd: Vec<f64>,
    /// Lower triangle of `K_f` (signal part only), column-major.
    kf: Vec<f64>,
    /// Cholesky factor of `K_f + noise I`.
    l: Vec<f64>,
    /// Lower triangle of `K^{-1}` (gradient only).
    kinv: Vec<f64>,
    alpha: Vec<f64>,
    /// One column of scratch.
    col: Vec<f64>,
}

impl Workspace {
    fn new(m: usize, n_dim: usize) -> Self {
        Self {
            m,
            n_dim,
            xd: vec![0.0; m * n_dim],
            kf: vec![0.0; m * m],
            l: vec![0.0; m * m],
            kinv: Vec::new(),
            alpha: vec![0.0; m],
            col: vec![0.0; m],
        }
    }

    /// Builds `K`, factors it and solves for `alpha = K^{-1} r`. Returns the log marginal
    /// likelihood (R&W eq. 2.30), or `None` if `K` is not numerically positive definite.
    fn factor(&mut self, x: &[f64], r: &[f64], h: &Hyperparameters) -> Option<f64> {
        let (m, n) = (self.m, self.n_dim);
        scale_dimension_major(x, n, &h.length_scales, &mut self.xd);
        let (xd, kf) = (&self.xd, &mut self.kf);
        simd(|| {
            for b in 0..m {
                // Column b below the diagonal: squared scaled distances, then the kernel.
                let col = &mut kf[b * m..(b + 1) * m];
                col[b] = h.signal_var;
                let below = &mut col[b + 1..];
                half_sq_distances(xd, m, b + 1, |d| xd[d * m + b], below);
                exp_in_place(below);
                below.iter_mut().for_each(|v| *v *= h.signal_var);
            }
        });
        self.l.copy_from_slice(&self.kf);
        for i in 0..m {
            self.l[i * m + i] += h.noise_var;
        }
        if !cholesky_in_place(&mut self.l, m) {
            return None;
        }
        self.alpha.copy_from_slice(r);
        solve_lower_in_place(&self.l, m, &mut self.alpha);
        let fit = dot(&self.alpha, &self.alpha);
        solve_upper_t_in_place(&self.l, m, &mut self.alpha);
        let log_det: f64 = (0..m).map(|i| self.l[i * m + i].ln()).sum();
        let lml = -0.5 * fit - log_det - 0.5 * m as f64 * LOG_2PI;
        lml.is_finite().then_some(lml)
    }

    /// The gradient of the log marginal likelihood with respect to the log hyperparameters
    /// (R&W eq. 5.9): `1/2 tr((alpha alpha^T - K^{-1}) dK/dtheta_j)`, with
    /// `dK/d ln l_d = K_f (x_d - x'_d)^2 / l_d^2`, `dK/d ln signal_var = K_f`,
    /// `dK/d ln noise_var = noise_var I`. Call after a successful [`Self::factor`].
    fn gradient(&mut self, h: &Hyperparameters) -> Vec<f64> {
        let (m, n) = (self.m, self.n_dim);
        if self.kinv.len() != m * m {
            self.kinv = vec![0.0; m * m];
        }
        spd_inverse_lower(&self.l, m, &mut self.kinv);
        let mut g_len = vec![0.0; n];
        let (mut g_sig, mut g_noise) = (0.0, 0.0);
        let (kinv, alpha, kf, xd, col) =
            (&self.kinv, &self.alpha, &self.kf, &self.xd, &mut self.col);
        simd(|| {
            for b in 0..m {
                let kinv_b = &kinv[b * m..(b + 1) * m];
                // Diagonal: K_f = signal_var, no length-scale term.
                let w = alpha[b] * alpha[b] - kinv_b[b];
                g_sig += w * h.signal_var;
                g_noise += w * h.noise_var;
                // Pairs (a, b), a > b, each counted twice: t_a = 2 (alpha_a alpha_b - K^{-1}_ab) K_f,ab.
                let t = &mut col[b + 1..];
                let (ab, kf_b) = (alpha[b], &kf[b * m + b + 1..(b + 1) * m]);
                for (((v, &ki), &al), &k) in t
                    .iter_mut()
                    .zip(&kinv_b[b + 1..])
                    .zip(&alpha[b + 1..])
                    .zip(kf_b)
                {
                    *v = 2.0 * (al * ab - ki) * k;
                }
                g_sig += sum(t);
                for (d, g) in g_len.iter_mut().enumerate() {
                    let xd = &xd[d * m..(d + 1) * m];
                    *g += weighted_sq_diff(t, &xd[b + 1..], xd[b]);
                }
            }
        });
        let mut g: Vec<f64> = g_len.into_iter().map(|v| 0.5 * v).collect();
        g.push(0.5 * g_sig);
        g.push(0.5 * g_noise);
        g
    }
}

/// `xd[d * m + j] = x[j * n + d] / l_d`: sample-major inputs to dimension-major scaled ones, so
/// that the distance loops run along contiguous memory.
pub(crate) fn scale_dimension_major(x: &[f64], n: usize, length_scales: &[f64], xd: &mut [f64]) {
    let m = x.len() / n;
    for (d, l) in length_scales.iter().enumerate() {
        let inv = 1.0 / l;
        for (j, v) in xd[d * m..(d + 1) * m].iter_mut().enumerate() {
            *v = x[j * n + d] * inv;
        }
    }
}

/// `out_i = -1/2 sum_d (xd_d[from + i] - q_d)^2`: the exponents of the squared-exponential
/// kernel between training points `from..from + out.len()` (dimension-major, `m` per dimension)
/// and the scaled point `q` (`q(d)` is its coordinate `d`). One fused pass for the usual 1-3
/// input dimensions, one pass per dimension otherwise; the same sums in the same order either way.
#[inline(always)]
pub(crate) fn half_sq_distances(
    xd: &[f64],
    m: usize,
    from: usize,
    q: impl Fn(usize) -> f64,
    out: &mut [f64],
) {
    match xd.len() / m {
        1 => half_sq_distances_fused::<1>(xd, m, from, q, out),
        2 => half_sq_distances_fused::<2>(xd, m, from, q, out),
        3 => half_sq_distances_fused::<3>(xd, m, from, q, out),
        n => {
            out.iter_mut().for_each(|v| *v = 0.0);
            for d in 0..n {
                let c = q(d);
                for (s, v) in out.iter_mut().zip(&xd[d * m + from..(d + 1) * m]) {
                    *s += (v - c) * (v - c);
                }
            }
            out.iter_mut().for_each(|v| *v *= -0.5);
        }
    }
}

#[inline(always)]
fn half_sq_distances_fused<const D: usize>(
    xd: &[f64],
    m: usize,
    from: usize,
    q: impl Fn(usize) -> f64,
    out: &mut [f64],
) {
    let len = out.len();
    let c: [f64; D] = std::array::from_fn(&q);
    let cols: [&[f64]; D] = std::array::from_fn(|d| &xd[d * m + from..d * m + from + len]);
    for (i, o) in out.iter_mut().enumerate() {
        let mut s = 0.0;
        for d in 0..D {
            let t = cols[d][i] - c[d];
            s += t * t;
        }
        *o = s * -0.5;
    }
}

/// `sum_i exp(-1/2 |(q - x_i) / l|^2) weights_i` over the points `xd` (dimension-major, divided by
/// the length scales `l`, one weight each), block by block through a stack buffer so that the
/// exponentials run as vectors with no heap allocation: a GP's posterior mean at one point.
pub(crate) fn kernel_sum(xd: &[f64], l: &[f64], q: &[f64], weights: &[f64]) -> f64 {
    let m = weights.len();
    simd(|| {
        let mut buf = [0.0f64; MEAN_BLOCK];
        let mut s = 0.0;
        for from in (0..m).step_by(MEAN_BLOCK) {
            let k = &mut buf[..MEAN_BLOCK.min(m - from)];
            half_sq_distances(xd, m, from, |d| q[d] / l[d], k);
            exp_in_place(k);
            s += dot(k, &weights[from..]);
        }
        s
    })
}

/// `sum_i v_i` with four independent partial sums (vectorizes; fixed order, deterministic).
#[inline(always)]
fn sum(v: &[f64]) -> f64 {
    let mut acc = [0.0f64; 4];
    let chunks = v.chunks_exact(4);
    let tail: f64 = chunks.remainder().iter().sum();
    for c in chunks {
        for k in 0..4 {
            acc[k] += c[k];
        }
    }
    (acc[0] + acc[2]) + (acc[1] + acc[3]) + tail
}

/// `sum_i t_i (x_i - c)^2` with four independent partial sums.
#[inline(always)]
fn weighted_sq_diff(t: &[f64], x: &[f64], c: f64) -> f64 {
    let mut acc = [0.0f64; 4];
    let (ct, cx) = (t.chunks_exact(4), x.chunks_exact(4));
    let tail: f64 = ct
        .remainder()
        .iter()
        .zip(cx.remainder())
        .map(|(w, v)| w * (v - c) * (v - c))
        .sum();
    for (w, v) in ct.zip(cx) {
        for k in 0..4 {
            acc[k] += w[k] * (v[k] - c) * (v[k] - c);
        }
    }
    (acc[0] + acc[2]) + (acc[1] + acc[3]) + tail
}

/// The log marginal likelihood of centred outputs `r` at log hyperparameters `theta`, and its
/// gradient. `x` is sample-major `(m, n_dim)`. `None` if the kernel matrix is not positive definite.
pub fn log_marginal_likelihood(
    x: &[f64],
    n_dim: usize,
    r: &[f64],
    theta: &[f64],
) -> Option<(f64, Vec<f64>)> {
    let mut ws = Workspace::new(r.len(), n_dim);
    let h = Hyperparameters::from_log(theta);
    let lml = ws.factor(x, r, &h)?;
    Some((lml, ws.gradient(&h)))
}

/// The log marginal likelihood alone (no gradient), for profiling and line searches.
pub fn log_marginal_likelihood_value(
    x: &[f64],
    n_dim: usize,
    r: &[f64],
    theta: &[f64],
) -> Option<f64> {
    let mut ws = Workspace::new(r.len(), n_dim);
    ws.factor(x, r, &Hyperparameters::from_log(theta))
}

/// A fitted Gaussian process.
#[derive(Debug, Clone)]
pub struct GaussianProcess {
    n_dim: usize,
    m: usize,
    /// Raw training inputs (sample-major) and centred outputs, for [`Self::log_marginal_likelihood_at`].
    x: Vec<f64>,
    r: Vec<f64>,
    /// Training inputs divided by the length scales, dimension-major (`xd[d * m + i]`).
    xd: Vec<f64>,
    y_mean: f64,
    hyper: Hyperparameters,
    /// Cholesky factor of `K_f + noise_var I`, column-major lower.
    l: Vec<f64>,
    /// `signal_var * K^{-1} (y - mean)`, so that the mean is `mean + sum_i exp(..) alpha_i`.
    alpha_scaled: Vec<f64>,
    lml: f64,
}

impl GaussianProcess {
    /// Fits to inputs `x` (`n_dim x m`: column j is sample j, i.e. a C-ordered `(m, n)` array) and
    /// outputs `y` (`m`). `initial = None` starts from [`default_hyperparameters`].
    pub fn fit(
        x: &DMatrixView<'_, f64>,
        y: &[f64],
        initial: Option<Hyperparameters>,
        options: &GpOptions,
    ) -> Result<Self> {
        Self::fit_cancellable(x, y, initial, options, &AtomicBool::new(false))
    }

    /// [`Self::fit`] that gives up with [`Error::Cancelled`] once `cancel` is set: it is polled
    /// before every restart of the optimization, so a caller on another thread (the Python
    /// bindings, on Ctrl-C) can stop a long fit.
    pub fn fit_cancellable(
        x: &DMatrixView<'_, f64>,
        y: &[f64],
        initial: Option<Hyperparameters>,
        options: &GpOptions,
        cancel: &AtomicBool,
    ) -> Result<Self> {
        options.validate()?;
        check_data(x, y)?;
        let (n_dim, m) = x.shape();
        let initial = match initial {
            Some(h) => {
                h.validate(n_dim)?;
                h
            }
            None => default_hyperparameters(x, y)?,
        };
        let xv: Vec<f64> = x.iter().copied().collect(); // column-major n x m = sample-major
        let y_mean = y.iter().sum::<f64>() / m as f64;
        let r: Vec<f64> = y.iter().map(|v| v - y_mean).collect();
        let hyper = if options.optimize {
            let bounds = match &options.bounds {
                Some(b) => {
                    b.validate(n_dim)?;
                    b.clone()
                }
                None => default_bounds(x, y)?.containing(&initial),
            };
            let (ranges, var) = data_scales(x, y);
            let plausible = HyperBounds {
                length_scales: ranges.iter().map(|r| (0.1 * r, 10.0 * r)).collect(),
                signal_var: (0.1 * var, 100.0 * var),
                noise_var: (1e-6 * var, var),
            };
            optimize_hyperparameters(
                &xv, n_dim, &r, &initial, &bounds, &plausible, options, cancel,
            )?
        } else {
            initial
        };
        let mut ws = Workspace::new(m, n_dim);
        let lml = ws.factor(&xv, &r, &hyper).ok_or_else(|| Error::Numerical {
            context: "Gaussian process fit",
            detail: format!(
                "the kernel matrix is not positive definite with noise_var = {:e} (duplicate inputs need noise_var > 0)",
                hyper.noise_var
            ),
        })?;
        let alpha_scaled = ws.alpha.iter().map(|a| a * hyper.signal_var).collect();
        let mut xd = vec![0.0; m * n_dim];
        scale_dimension_major(&xv, n_dim, &hyper.length_scales, &mut xd);
        Ok(Self {
            n_dim,
            m,
            x: xv,
            r,
            xd,
            y_mean,
            hyper,
            l: ws.l,
            alpha_scaled,
            lml,
        })
    }

    pub fn hyperparameters(&self) -> &Hyperparameters {
        &self.hyper
    }
    pub fn log_marginal_likelihood(&self) -> f64 {
        self.lml
    }
    /// The log marginal likelihood of the training data and its gradient at other log
    /// hyperparameters `theta = [ln l_1 .. ln l_n, ln signal_var, ln noise_var]`.
    pub fn log_marginal_likelihood_at(&self, theta: &[f64]) -> Result<(f64, Vec<f64>)> {
        if theta.len() != self.n_dim + 2 {
            return Err(Error::Shape {
                name: "theta",
                expected: format!(
                    "({},): n length scales, signal_var, noise_var (logs)",
                    self.n_dim + 2
                ),
                got: format!("({},)", theta.len()),
            });
        }
        if let Some((i, &v)) = theta.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(Error::NonFinite {
                name: "theta",
                location: format!("[{i}]"),
                value: v,
            });
        }
        log_marginal_likelihood(&self.x, self.n_dim, &self.r, theta).ok_or_else(|| {
            Error::Numerical {
                context: "log marginal likelihood",
                detail: "the kernel matrix is not positive definite at these hyperparameters"
                    .into(),
            }
        })
    }

    pub fn prior_mean(&self) -> f64 {
        self.y_mean
    }
    pub fn n_dim(&self) -> usize {
        self.n_dim
    }
    pub fn n_train(&self) -> usize {
        self.m
    }

    /// `exp(-1/2 |(q - x_i) / l|^2)` for every training point, into `out` (`m` values). Call
    /// inside [`simd`].
    #[inline(always)]
    fn correlations(&self, q: &[f64], out: &mut [f64]) {
        let l = &self.hyper.length_scales;
        half_sq_distances(&self.xd, self.m, 0, |d| q[d] / l[d], out);
        exp_in_place(out);
    }

    /// Posterior mean at one point `q` (`n_dim` values; the caller checks the length). No heap
    /// allocation: this is the generalizer's hot path. The training points go through a stack
    /// buffer in blocks, so that the exponentials run as vectors.
    pub fn predict_mean_at(&self, q: &[f64]) -> f64 {
        debug_assert_eq!(q.len(), self.n_dim);
        self.y_mean + kernel_sum(&self.xd, &self.hyper.length_scales, q, &self.alpha_scaled)
    }

    /// `y_mean + k . alpha` summed block by block as in [`Self::predict_mean_at`], so that both
    /// give the same bits.
    #[inline(always)]
    fn mean_from_correlations(&self, k: &[f64]) -> f64 {
        let s = k
            .chunks(MEAN_BLOCK)
            .zip(self.alpha_scaled.chunks(MEAN_BLOCK))
            .fold(0.0, |s, (k, a)| s + dot(k, a));
        self.y_mean + s
    }

    /// Posterior mean and, if asked, standard deviation of the latent function at the columns of
    /// `xq` (`n_dim x p`).
    pub fn predict(
        &self,
        xq: &DMatrixView<'_, f64>,
        with_std: bool,
    ) -> Result<(Vec<f64>, Option<Vec<f64>>)> {
        if xq.nrows() != self.n_dim {
            return Err(Error::Shape {
                name: "X",
                expected: format!(
                    "(p, {}), as many columns as the training inputs",
                    self.n_dim
                ),
                got: format!("({}, {})", xq.ncols(), xq.nrows()),
            });
        }
        crate::error::check_finite_matrix("X", xq)?;
        let (m, p) = (self.m, xq.ncols());
        let mut q = vec![0.0; self.n_dim];
        let point = |j: usize, q: &mut [f64]| {
            q.iter_mut()
                .zip(xq.column(j).iter())
                .for_each(|(a, b)| *a = *b);
        };
        if !with_std {
            // One column of correlations, reused: faster than a block-wise `predict_mean_at` per
            // point (fewer, longer exp loops) and than a fresh m x p buffer (page faults).
            let mut k = vec![0.0; m];
            let mean = simd(|| {
                (0..p)
                    .map(|j| {
                        point(j, &mut q);
                        self.correlations(&q, &mut k);
                        self.mean_from_correlations(&k)
                    })
                    .collect()
            });
            return Ok((mean, None));
        }
        // The correlations of all test points, one column each: they are also the right-hand
        // sides of one blocked triangular solve (TRSM) for the std.
        let mut kq = vec![0.0; m * p];
        let mut mean = Vec::with_capacity(p);
        simd(|| {
            for (j, k) in kq.chunks_exact_mut(m).enumerate() {
                point(j, &mut q);
                self.correlations(&q, k);
                mean.push(self.mean_from_correlations(k));
            }
        });
        // var = k** - k*^T K^{-1} k* = signal_var - |L^{-1} k*|^2 with k* = signal_var c
        // (R&W eq. 2.26, solved with the factor).
        let sv = self.hyper.signal_var;
        kq.iter_mut().for_each(|v| *v *= sv);
        solve_lower_many_in_place(&self.l, m, &mut kq, p);
        let std = simd(|| {
            kq.chunks_exact(m)
                .map(|v| (sv - dot(v, v)).max(0.0).sqrt())
                .collect()
        });
        Ok((mean, Some(std)))
    }
}

/// The negative log marginal likelihood of centred outputs `r` as a function of the log
/// hyperparameters, for the minimizer.
struct NegativeLml<'a> {
    ws: Workspace,
    x: &'a [f64],
    r: &'a [f64],
    /// The hyperparameters of the last successful factorization.
    at: Option<Hyperparameters>,
}

impl Objective for NegativeLml<'_> {
    fn value(&mut self, theta: &[f64]) -> Option<f64> {
        let h = Hyperparameters::from_log(theta);
        self.at = None;
        let lml = self.ws.factor(self.x, self.r, &h)?;
        self.at = Some(h);
        Some(-lml)
    }
    fn gradient(&mut self) -> Vec<f64> {
        let h = self
            .at
            .as_ref()
            .expect("gradient asked before a successful value");
        self.ws.gradient(h).into_iter().map(|v| -v).collect()
    }
}

/// ML-II: minimizes the negative log marginal likelihood from the initial hyperparameters and
/// from `n_restarts` Halton points; keeps the best (the earliest on ties).
///
/// The restarts are spread over the part of the bounds where optima of typical data lie
/// (`plausible`: length scales 0.1-10 x the input range, signal 0.1-100 x var(y), noise
/// 1e-6-1 x var(y)) rather than over the whole box: the log marginal likelihood is often
/// multimodal, and starts at extreme corners (length scales of 1e-3 x range, say) mostly fall into
/// degenerate optima. In a dimension where that region misses the bounds, the bounds are used.
#[allow(clippy::too_many_arguments)] // the data, the box and the options of one optimization
fn optimize_hyperparameters(
    x: &[f64],
    n_dim: usize,
    r: &[f64],
    initial: &Hyperparameters,
    bounds: &HyperBounds,
    plausible: &HyperBounds,
    options: &GpOptions,
    cancel: &AtomicBool,
) -> Result<Hyperparameters> {
    let (lo, hi) = bounds.log_box();
    let (plo, phi) = plausible.log_box();
    let m = r.len();
    let (slo, shi): (Vec<f64>, Vec<f64>) = (0..lo.len())
        .map(|i| {
            let (a, b) = (plo[i].max(lo[i]), phi[i].min(hi[i]));
            if a <= b { (a, b) } else { (lo[i], hi[i]) }
        })
        .unzip();
    let dim = lo.len();
    let starts: Vec<Vec<f64>> = (0..=options.n_restarts)
        .map(|start| {
            if start == 0 {
                initial.to_log()
            } else {
                let u = halton(start as u64, dim);
                (0..dim)
                    .map(|i| slo[i] + u[i] * (shi[i] - slo[i]))
                    .collect()
            }
        })
        .collect();
    // The starts are independent: run them in parallel, each with its own workspace, and pick
    // the best in start order, so the result does not depend on the number of threads.
    let run = |x0: &Vec<f64>| {
        if cancel.load(Ordering::Relaxed) {
            return None;
        }
        let mut objective = NegativeLml {
            ws: Workspace::new(m, n_dim),
            x,
            r,
            at: None,
        };
        minimize_box(&mut objective, x0, &lo, &hi, &options.minimize)
    };
    // Small problems are faster on one thread than the cost of spreading them.
    let minima: Vec<_> = if m >= 40 {
        starts.par_iter().map(run).collect()
    } else {
        starts.iter().map(run).collect()
    };
    if cancel.load(Ordering::Relaxed) {
        return Err(Error::Cancelled {
            context: "Gaussian process hyperparameter optimization",
        });
    }
    let mut best: Option<(f64, Vec<f64>)> = None;
    for min in minima.into_iter().flatten() {
        if best.as_ref().is_none_or(|(f, _)| min.f < *f) {
            best = Some((min.f, min.x));
        }
    }
    let (_, theta) = best.ok_or_else(|| Error::Numerical {
        context: "Gaussian process hyperparameter optimization",
        detail: "the kernel matrix is not positive definite at any starting point; raise the noise_var bounds".into(),
    })?;
    Ok(Hyperparameters::from_log(&theta))
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{DMatrix, DVector};
    use proptest::prelude::*;

    /// The dense textbook formulas, with nalgebra, for an independent check.
    fn dense_lml(x: &DMatrix<f64>, r: &[f64], h: &Hyperparameters) -> f64 {
        let m = x.ncols();
        let k = DMatrix::from_fn(m, m, |a, b| {
            let s: f64 = (0..x.nrows())
                .map(|d| ((x[(d, a)] - x[(d, b)]) / h.length_scales[d]).powi(2))
                .sum();
            h.signal_var * (-0.5 * s).exp() + if a == b { h.noise_var } else { 0.0 }
        });
        let y = DVector::from_column_slice(r);
        let kinv = k.clone().try_inverse().unwrap();
        -0.5 * (y.transpose() * kinv * &y)[0]
            - 0.5 * k.determinant().ln()
            - 0.5 * m as f64 * LOG_2PI
    }

    fn data(m: usize, n: usize) -> DMatrix<f64> {
        DMatrix::from_fn(n, m, |d, j| {
            ((j * 37 + d * 11) % 23) as f64 / 7.0 + 0.1 * d as f64
        })
    }

    #[test]
    fn lml_matches_the_dense_formula() {
        let x = data(9, 2);
        let r: Vec<f64> = (0..9).map(|j| (j as f64 * 0.7).sin()).collect();
        let h = Hyperparameters {
            length_scales: vec![0.8, 2.0],
            signal_var: 1.3,
            noise_var: 0.05,
        };
        let xv: Vec<f64> = x.iter().copied().collect();
        let (lml, _) = log_marginal_likelihood(&xv, 2, &r, &h.to_log()).unwrap();
        assert!((lml - dense_lml(&x, &r, &h)).abs() < 1e-10, "{lml}");
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(40))]
        #[test]
        fn gradient_matches_central_differences(
            l0 in -1.0f64..1.0, l1 in -1.0f64..1.0, s in -1.0f64..1.0, nz in -5.0f64..-1.0, m in 2usize..12,
        ) {
            let x = data(m, 2);
            let xv: Vec<f64> = x.iter().copied().collect();
            let r: Vec<f64> = (0..m).map(|j| (j as f64 * 1.3).cos() + 0.2 * j as f64).collect();
            let theta = vec![l0, l1, s, nz];
            let (_, g) = log_marginal_likelihood(&xv, 2, &r, &theta).unwrap();
            for i in 0..4 {
                let h = 1e-5;
                let mut tp = theta.clone();
                tp[i] += h;
                let mut tm = theta.clone();
                tm[i] -= h;
                let fd = (log_marginal_likelihood(&xv, 2, &r, &tp).unwrap().0
                    - log_marginal_likelihood(&xv, 2, &r, &tm).unwrap().0) / (2.0 * h);
                prop_assert!((fd - g[i]).abs() <= 1e-5 * (1.0 + g[i].abs()), "i={} fd={} g={}", i, fd, g[i]);
            }
        }
    }

    #[test]
    fn noise_free_posterior_mean_interpolates_and_std_vanishes() {
        let x = data(7, 1);
        let y: Vec<f64> = x.iter().map(|v| v.sin() * 3.0 + 1.0).collect();
        let h = Hyperparameters {
            length_scales: vec![1.0],
            signal_var: 4.0,
            noise_var: 1e-12,
        };
        let opts = GpOptions {
            optimize: false,
            ..GpOptions::default()
        };
        let gp = GaussianProcess::fit(&x.as_view(), &y, Some(h), &opts).unwrap();
        let (mean, std) = gp.predict(&x.as_view(), true).unwrap();
        for j in 0..7 {
            assert!((mean[j] - y[j]).abs() < 1e-6, "{} vs {}", mean[j], y[j]);
            assert!((gp.predict_mean_at(&[x[(0, j)]]) - mean[j]).abs() < 1e-12);
            assert!(std.as_ref().unwrap()[j] < 1e-4);
        }
        // Far away the mean returns to the prior mean (the training mean), the std to signal.
        let far = DMatrix::from_element(1, 1, 1e3);
        let (mf, sf) = gp.predict(&far.as_view(), true).unwrap();
        assert!((mf[0] - gp.prior_mean()).abs() < 1e-12);
        assert!((sf.unwrap()[0] - 2.0).abs() < 1e-12);
    }

    #[test]
    fn one_point_and_batch_predictions_are_the_same_bits() {
        // 150 training points: more than one block of the one-point path.
        let x = data(150, 2);
        let y: Vec<f64> = (0..150)
            .map(|j| x[(0, j)].sin() + 0.2 * x[(1, j)])
            .collect();
        let h = Hyperparameters {
            length_scales: vec![0.7, 1.3],
            signal_var: 2.0,
            noise_var: 1e-3,
        };
        let opts = GpOptions {
            optimize: false,
            ..GpOptions::default()
        };
        let gp = GaussianProcess::fit(&x.as_view(), &y, Some(h), &opts).unwrap();
        let xq = DMatrix::from_fn(2, 9, |d, j| j as f64 * 0.4 - 1.5 + d as f64 * 0.1);
        let (mean, _) = gp.predict(&xq.as_view(), false).unwrap();
        let (mean_s, std) = gp.predict(&xq.as_view(), true).unwrap();
        assert_eq!(mean, mean_s, "asking for the std must not change the mean");
        assert_eq!(std.unwrap().len(), 9);
        for j in 0..9 {
            let q = [xq[(0, j)], xq[(1, j)]];
            assert_eq!(gp.predict_mean_at(&q).to_bits(), mean[j].to_bits());
        }
    }

    #[test]
    fn ml2_improves_on_the_start_and_on_a_grid() {
        let x = data(25, 1);
        let y: Vec<f64> = x
            .iter()
            .enumerate()
            .map(|(j, v)| (1.5 * v).sin() + 0.05 * ((j * 7 % 5) as f64 - 2.0))
            .collect();
        let gp = GaussianProcess::fit(&x.as_view(), &y, None, &GpOptions::default()).unwrap();
        let xv: Vec<f64> = x.iter().copied().collect();
        let mean = y.iter().sum::<f64>() / 25.0;
        let r: Vec<f64> = y.iter().map(|v| v - mean).collect();
        let mut grid_best = f64::NEG_INFINITY;
        for a in -10..=10 {
            for b in -10..=10 {
                for c in -12..=0 {
                    let theta = [a as f64 * 0.3, b as f64 * 0.4, c as f64];
                    if let Some((l, _)) = log_marginal_likelihood(&xv, 1, &r, &theta) {
                        grid_best = grid_best.max(l);
                    }
                }
            }
        }
        assert!(
            gp.log_marginal_likelihood() >= grid_best - 1e-6,
            "{} < {grid_best}",
            gp.log_marginal_likelihood()
        );
    }

    #[test]
    fn fits_are_bit_identical() {
        let x = data(30, 2);
        let y: Vec<f64> = (0..30).map(|j| (j as f64).sqrt()).collect();
        let a = GaussianProcess::fit(&x.as_view(), &y, None, &GpOptions::default()).unwrap();
        let b = GaussianProcess::fit(&x.as_view(), &y, None, &GpOptions::default()).unwrap();
        assert_eq!(a.hyperparameters(), b.hyperparameters());
        assert_eq!(
            a.log_marginal_likelihood().to_bits(),
            b.log_marginal_likelihood().to_bits()
        );
    }

    #[test]
    fn bad_input_is_an_error() {
        let x = data(4, 1);
        let opts = GpOptions::default();
        assert!(matches!(
            GaussianProcess::fit(&x.as_view(), &[1.0, 2.0], None, &opts),
            Err(Error::Shape { .. })
        ));
        assert!(matches!(
            GaussianProcess::fit(&x.as_view(), &[1.0, f64::NAN, 0.0, 0.0], None, &opts),
            Err(Error::NonFinite { .. })
        ));
        let h = Hyperparameters {
            length_scales: vec![1.0, 1.0],
            signal_var: 1.0,
            noise_var: 1.0,
        };
        assert!(matches!(
            GaussianProcess::fit(&x.as_view(), &[0.0; 4], Some(h), &opts),
            Err(Error::Shape { .. })
        ));
        let dup = DMatrix::from_element(1, 3, 2.0);
        let h = Hyperparameters {
            length_scales: vec![1.0],
            signal_var: 1.0,
            noise_var: 0.0,
        };
        assert!(GaussianProcess::fit(&dup.as_view(), &[1.0, 2.0, 3.0], Some(h), &opts).is_err());
    }
}
