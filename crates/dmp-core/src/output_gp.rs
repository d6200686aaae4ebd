//! The Gaussian processes of the generalizer's scalar parameters, tau, goal and start (Ude et
//! al. 2010; docs/method.md §3.2): one GP per parameter over the demos' queries, either over
//! every demo (exact), over the `k` demos nearest to each query (local), or over every demo
//! through a low-rank factor (sparse).
//!
//! The exact GPs cost `M^3` per step of the hyperparameter search and `M^2` of memory, which
//! rules them out for databases of thousands of demos. The local ones fit their hyperparameters
//! once, by the same ML-II, on the `k` demos nearest to the most central demo (a neighbourhood
//! like the ones predictions use), and condition a GP with those hyperparameters on the `k`
//! demos nearest to each query: `k^3` per prediction, whatever `M`. A GP's prediction at `q` is
//! dominated by the training points within a few length scales of `q`, so for a neighbourhood
//! wider than that the two agree closely (docs/growing.md measures how closely); with `k >= M`
//! they are the same computation, bit for bit.
//!
//! The sparse ones fit their hyperparameters by the same ML-II on at most [`SPARSE_FIT_DEMOS`]
//! demos spread over the query space (every demo when there are no more, so the exact GPs'
//! hyperparameters, bit for bit), and condition on every demo through a pivoted Cholesky factor
//! of the kernel matrix ([`crate::low_rank_gp`]). ML-II length scales are long against the
//! demos' spread when tau, goal and start vary smoothly with the query, and then the factor
//! needs few demos and the mean is the exact one to within the factor's tolerance.

use nalgebra::{DMatrix, DVector};

use crate::error::{Error, Result, fmt_g};
use crate::gp::{
    GaussianProcess, GpOptions, HyperBounds, Hyperparameters, data_scales, query_ranges,
};
use crate::linalg::argmax_first;
use crate::low_rank_gp::{LowRankGp, SPARSE_GPS};

/// The fewest neighbours a local GP takes: ML-II needs at least 4 points (docs/method.md §3.2).
pub const MIN_NEIGHBOURS: usize = 4;

/// The most demos the sparse GPs fit their hyperparameters on: ML-II over them takes about a
/// second for the 15 parameters of a 7-DOF DMP.
pub const SPARSE_FIT_DEMOS: usize = 200;

/// The most demos a sparse GP's factor may keep: its memory is `M` times this, and its cost `M`
/// times its square.
pub const SPARSE_MAX_RANK: usize = 1000;

/// The prior mean of the GPs of tau, goal and start.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GpMean {
    Constant,
    Affine,
}

/// How the GPs are fitted (the `gp_*` fields of [`crate::LwrGpOptions`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct GpSettings {
    pub noise: f64,
    pub optimize: Option<bool>,
    pub restarts: usize,
    pub mean: GpMean,
    pub neighbours: Option<usize>,
    pub sparse: bool,
}

/// A GP over what an optional affine trend `c_0 + sum_d c_d q_d` leaves of the outputs.
#[derive(Debug, Clone)]
pub(crate) struct TrendGp {
    trend: Option<Vec<f64>>,
    gp: GaussianProcess,
}

/// One parameter of the local GPs: its trend, what the trend leaves at every demo, and the
/// hyperparameters fitted on the neighbourhood of the most central demo.
#[derive(Debug, Clone)]
pub(crate) struct LocalOutput {
    trend: Option<Vec<f64>>,
    residuals: Vec<f64>,
    hyper: Hyperparameters,
}

/// One parameter of the sparse GPs: its trend and the GP of what the trend leaves.
#[derive(Debug, Clone)]
pub(crate) struct SparseOutput {
    trend: Option<Vec<f64>>,
    gp: LowRankGp,
}

/// The GPs of every scalar parameter.
#[derive(Debug, Clone)]
pub(crate) enum OutputGps {
    Exact(Vec<TrendGp>),
    Sparse(Vec<SparseOutput>),
    Local {
        k: usize,
        /// Every demo's query, `n x M`.
        x: DMatrix<f64>,
        outputs: Vec<LocalOutput>,
    },
}

/// A GP's mean `gp` at `q` with the trend added back.
fn with_trend(trend: &Option<Vec<f64>>, q: &[f64], gp: f64) -> f64 {
    match trend {
        None => gp,
        Some(c) => c[0] + c[1..].iter().zip(q).map(|(c, q)| c * q).sum::<f64>() + gp,
    }
}

/// The least-squares affine fit of `y` over the queries (columns of `x`, `n x m`), or None when
/// the queries do not span the query space (fewer than n + 1 affinely independent).
fn affine_trend(x: &DMatrix<f64>, y: &[f64]) -> Option<Vec<f64>> {
    let (n, m) = x.shape();
    if m < n + 1 {
        return None;
    }
    let a = DMatrix::from_fn(m, n + 1, |k, j| if j == 0 { 1.0 } else { x[(j - 1, k)] });
    let svd = a.svd(true, true);
    let (smax, smin) = (svd.singular_values.max(), svd.singular_values.min());
    if smin.is_nan() || smin <= 1e-10 * smax {
        return None;
    }
    let c = svd.solve(&DVector::from_column_slice(y), 0.0).ok()?;
    c.iter()
        .all(|v| v.is_finite())
        .then(|| c.iter().copied().collect())
}

/// The trend of `y` (by `mean`) and what it leaves at each demo.
fn detrend(x: &DMatrix<f64>, y: Vec<f64>, mean: GpMean) -> (Option<Vec<f64>>, Vec<f64>) {
    let (n, m) = x.shape();
    let trend = match mean {
        GpMean::Constant => None,
        GpMean::Affine => affine_trend(x, &y),
    };
    let r = match &trend {
        None => y,
        Some(c) => (0..m)
            .map(|k| y[k] - c[0] - (0..n).map(|d| c[1 + d] * x[(d, k)]).sum::<f64>())
            .collect(),
    };
    (trend, r)
}

/// The GP of `y` over the queries `x` (`n x m`): noise `noise x std(y)` held fixed, length
/// scales and signal variance by ML-II within 1e-2..1e2 x the query range and 1e-4..1e4 x
/// var(y), from the range and the variance.
fn fit_gp(x: &DMatrix<f64>, y: &[f64], s: &GpSettings) -> Result<GaussianProcess> {
    let (ranges, var) = data_scales(&x.as_view(), y);
    let noise = s.noise * s.noise * var;
    if !(noise > 0.0 && noise.is_finite()) {
        return Err(Error::InvalidParameter {
            name: "gp_noise",
            value: fmt_g(s.noise),
            requirement: "gives a noise variance gp_noise^2 x var outside the range of f64",
        });
    }
    let initial = Hyperparameters {
        length_scales: ranges.clone(),
        signal_var: var,
        noise_var: noise,
    };
    let bounds = HyperBounds {
        length_scales: ranges.iter().map(|r| (1e-2 * r, 1e2 * r)).collect(),
        signal_var: (1e-4 * var, 1e4 * var),
        noise_var: (noise, noise),
    };
    let gp_opts = GpOptions {
        // docs/method.md §3.2: with M <= 3, ML-II is ill-posed.
        optimize: s.optimize.unwrap_or(x.ncols() >= 4),
        n_restarts: s.restarts,
        bounds: Some(bounds),
        ..GpOptions::default()
    };
    GaussianProcess::fit(&x.as_view(), y, Some(initial), &gp_opts)
}

/// `result`, its error said to be in the GP of output `name`.
fn in_output<T>(name: &str, result: Result<T>) -> Result<T> {
    result.map_err(|e| Error::InOutput {
        output: name.to_string(),
        source: Box::new(e),
    })
}

/// The sparse GP of the residuals `r` over the demos `x`: hyperparameters by ML-II on the demos
/// `sample` (at `xs`), then conditioned on every demo, and checked against them if the sample
/// left some out (with every demo in it, the hyperparameters are the exact GP's own, and so is
/// the fit).
fn sparse_gp(
    x: &DMatrix<f64>,
    xs: &DMatrix<f64>,
    sample: &[usize],
    r: &[f64],
    s: &GpSettings,
) -> Result<LowRankGp> {
    let rs: Vec<f64> = sample.iter().map(|&i| r[i]).collect();
    let hyper = fit_gp(xs, &rs, s)?.hyperparameters().clone();
    let gp = LowRankGp::condition(x, r, &hyper, SPARSE_MAX_RANK)?;
    if sample.len() < x.ncols() {
        check_fit(x, r, &gp, hyper.noise_var)?;
    }
    Ok(gp)
}

/// How far, in noise standard deviations, a sparse GP may miss a demo's value: the GP's own
/// noise model puts nearly every demo within a few.
const MAX_MISFIT: f64 = 10.0;

/// Fails if the sparse GP `gp` misses a demo's value `r` (at `x`) by more than [`MAX_MISFIT`]
/// noise standard deviations: its hyperparameters, fitted on a sample of the demos, are then too
/// smooth for the demos between the sample's, and its predictions would be off where the exact
/// GPs' are not.
fn check_fit(x: &DMatrix<f64>, r: &[f64], gp: &LowRankGp, noise_var: f64) -> Result<()> {
    let sd = noise_var.sqrt();
    let misses: Vec<f64> = r
        .iter()
        .enumerate()
        .map(|(i, v)| (gp.mean_at(x.column(i).as_slice()) - v).abs())
        .collect();
    let (i, miss) = argmax_first(&misses);
    if miss.is_finite() && miss <= MAX_MISFIT * sd {
        return Ok(());
    }
    Err(Error::Unsuited {
        method: SPARSE_GPS,
        detail: format!(
            "the GP misses demo {i} by {} noise standard deviations (at most {MAX_MISFIT}): \
             its hyperparameters, fitted on {SPARSE_FIT_DEMOS} demos spread over the query space, \
             are too smooth for the demos between those; use local GPs (gp_neighbours) instead",
            fmt_g(miss / sd)
        ),
    })
}

/// The indices, ascending, of `k` demos spread over the query space (`x`, `n x M`): from the one
/// nearest to the queries' mean, each next the one farthest from those taken (in range-scaled
/// distance; the first of equals). Every demo when `M <= k`.
fn spread_sample(x: &DMatrix<f64>, k: usize) -> Vec<usize> {
    let m = x.ncols();
    if m <= k {
        return (0..m).collect();
    }
    let ranges = query_ranges(&x.as_view());
    let dist = |a: &[f64], j: usize| -> f64 {
        (0..x.nrows())
            .map(|d| ((x[(d, j)] - a[d]) / ranges[d]).powi(2))
            .sum()
    };
    let centre: Vec<f64> = x.column_mean().iter().copied().collect();
    let to_centre: Vec<f64> = (0..m).map(|j| -dist(&centre, j)).collect();
    let mut taken = vec![argmax_first(&to_centre).0];
    let mut gap: Vec<f64> = vec![f64::INFINITY; m];
    while taken.len() < k {
        let last: Vec<f64> = x.column(*taken.last().unwrap()).iter().copied().collect();
        gap.iter_mut()
            .enumerate()
            .for_each(|(j, g)| *g = g.min(dist(&last, j)));
        taken.push(argmax_first(&gap).0);
    }
    taken.sort_unstable();
    taken
}

impl OutputGps {
    /// The GPs of each of `outputs` (a name for errors, and one value per demo) over the demo
    /// queries `x` (`n x M`); `nearest(q, k)` gives the indices of the `k` demos nearest to `q`
    /// (for local GPs).
    pub(crate) fn fit(
        x: &DMatrix<f64>,
        outputs: Vec<(String, Vec<f64>)>,
        s: &GpSettings,
        nearest: impl Fn(&[f64], usize) -> Vec<usize>,
    ) -> Result<Self> {
        let m = x.ncols();
        if s.sparse {
            if let Some(k) = s.neighbours {
                return Err(Error::InvalidParameter {
                    name: "gp_neighbours",
                    value: k.to_string(),
                    requirement: "cannot be combined with gp_sparse (local or sparse GPs, not both)",
                });
            }
            return Self::fit_sparse(x, outputs, s);
        }
        match s.neighbours {
            Some(k) if k < MIN_NEIGHBOURS => Err(Error::InvalidParameter {
                name: "gp_neighbours",
                value: k.to_string(),
                requirement: "must be at least 4 (the GPs' hyperparameters are fitted on that many demos)",
            }),
            Some(k) if k < m => {
                // The k demos nearest to the most central one: a neighbourhood like those the
                // predictions condition on, so the length scales found suit them.
                let centre: Vec<f64> = x.column_mean().iter().copied().collect();
                let central = nearest(&centre, 1)[0];
                let sample = nearest(x.column(central).as_slice(), k);
                let xs = x.select_columns(&sample);
                let outputs = outputs
                    .into_iter()
                    .map(|(name, y)| {
                        let (trend, residuals) = detrend(x, y, s.mean);
                        let rs: Vec<f64> = sample.iter().map(|&i| residuals[i]).collect();
                        let hyper = in_output(&name, fit_gp(&xs, &rs, s))?
                            .hyperparameters()
                            .clone();
                        Ok(LocalOutput {
                            trend,
                            residuals,
                            hyper,
                        })
                    })
                    .collect::<Result<_>>()?;
                Ok(Self::Local {
                    k,
                    x: x.clone(),
                    outputs,
                })
            }
            _ => outputs
                .into_iter()
                .map(|(name, y)| {
                    let (trend, r) = detrend(x, y, s.mean);
                    Ok(TrendGp {
                        trend,
                        gp: in_output(&name, fit_gp(x, &r, s))?,
                    })
                })
                .collect::<Result<_>>()
                .map(Self::Exact),
        }
    }

    /// The sparse GPs: hyperparameters by ML-II on a spread sample of the demos, then each GP
    /// conditioned on every demo through its low-rank factor.
    fn fit_sparse(
        x: &DMatrix<f64>,
        outputs: Vec<(String, Vec<f64>)>,
        s: &GpSettings,
    ) -> Result<Self> {
        let sample = spread_sample(x, SPARSE_FIT_DEMOS);
        let xs = x.select_columns(&sample);
        outputs
            .into_iter()
            .map(|(name, y)| {
                let (trend, r) = detrend(x, y, s.mean);
                let gp = in_output(&name, sparse_gp(x, &xs, &sample, &r, s))?;
                Ok(SparseOutput { trend, gp })
            })
            .collect::<Result<_>>()
            .map(Self::Sparse)
    }

    /// How many neighbours a prediction needs ([`Self::means_at`]); None: every demo.
    pub(crate) fn neighbours(&self) -> Option<usize> {
        match self {
            Self::Exact(_) | Self::Sparse(_) => None,
            Self::Local { k, .. } => Some(*k),
        }
    }

    /// The posterior mean of every parameter at `q`; `nearest` (indices of the
    /// [`Self::neighbours`] demos nearest to `q`) is read by the local GPs only.
    pub(crate) fn means_at(&self, q: &[f64], nearest: &[usize]) -> Result<Vec<f64>> {
        match self {
            Self::Exact(gps) => Ok(gps
                .iter()
                .map(|g| with_trend(&g.trend, q, g.gp.predict_mean_at(q)))
                .collect()),
            Self::Sparse(gps) => Ok(gps
                .iter()
                .map(|g| with_trend(&g.trend, q, g.gp.mean_at(q)))
                .collect()),
            Self::Local { x, outputs, .. } => {
                let xn = x.select_columns(nearest);
                let fixed = GpOptions {
                    optimize: false,
                    ..GpOptions::default()
                };
                outputs
                    .iter()
                    .map(|o| {
                        let r: Vec<f64> = nearest.iter().map(|&i| o.residuals[i]).collect();
                        let gp =
                            GaussianProcess::fit(&xn.as_view(), &r, Some(o.hyper.clone()), &fixed)?;
                        Ok(with_trend(&o.trend, q, gp.predict_mean_at(q)))
                    })
                    .collect()
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_affine_trend_needs_queries_that_span_the_query_space() {
        let x = DMatrix::from_row_slice(2, 3, &[0.0, 1.0, 2.0, 0.0, 1.0, 2.0]); // on a line
        assert!(affine_trend(&x, &[1.0, 2.0, 3.0]).is_none());
        let x = DMatrix::from_row_slice(2, 3, &[0.0, 1.0, 0.0, 0.0, 0.0, 1.0]);
        let c = affine_trend(&x, &[1.0, 3.0, 0.0]).unwrap();
        assert!(
            (c[0] - 1.0).abs() < 1e-12 && (c[1] - 2.0).abs() < 1e-12 && (c[2] + 1.0).abs() < 1e-12
        );
    }

    #[test]
    fn an_outputs_error_names_the_output_and_keeps_its_class() {
        let x = DMatrix::from_fn(1, 6, |_, j| j as f64);
        // A spread so large that the noise variance, a fraction of its variance, is not a f64.
        let wild: Vec<f64> = (0..6)
            .map(|j| if j % 2 == 0 { 1e300 } else { -1e300 })
            .collect();
        let outputs = vec![
            ("tau".to_string(), vec![1.0, 1.1, 1.2, 1.1, 1.0, 0.9]),
            ("goal[2]".to_string(), wild),
        ];
        for sparse in [false, true] {
            let s = GpSettings {
                noise: 1e-2,
                optimize: Some(false),
                restarts: 0,
                mean: GpMean::Constant,
                neighbours: None,
                sparse,
            };
            let err = OutputGps::fit(&x, outputs.clone(), &s, |_, _| vec![]).unwrap_err();
            assert!(
                matches!(&err, Error::InOutput { output, source }
                    if output == "goal[2]" && matches!(**source, Error::InvalidParameter { name: "gp_noise", .. })),
                "{err:?}"
            );
            assert!(err.is_input_error());
            assert!(
                err.to_string().starts_with("the GP of goal[2]: gp_noise"),
                "{err}"
            );
        }
    }

    #[test]
    fn a_sparse_gp_too_smooth_for_its_demos_is_refused() {
        // Values that alternate from demo to demo, and a length scale ten times their span.
        let x = DMatrix::from_fn(1, 40, |_, j| j as f64);
        let r: Vec<f64> = (0..40)
            .map(|j| if j % 2 == 0 { 1.0 } else { -1.0 })
            .collect();
        let h = Hyperparameters {
            length_scales: vec![400.0],
            signal_var: 1.0,
            noise_var: 1e-8,
        };
        let gp = LowRankGp::condition(&x, &r, &h, SPARSE_MAX_RANK).unwrap();
        let err = check_fit(&x, &r, &gp, h.noise_var).unwrap_err();
        assert!(matches!(err, Error::Unsuited { .. }) && err.is_input_error());
        let err = err.to_string();
        assert!(
            err.contains("misses demo") && err.contains("gp_neighbours"),
            "{err}"
        );
        // the same values with a length scale that suits them
        let h = Hyperparameters {
            length_scales: vec![0.3],
            ..h
        };
        let gp = LowRankGp::condition(&x, &r, &h, SPARSE_MAX_RANK).unwrap();
        assert!(check_fit(&x, &r, &gp, h.noise_var).is_ok());
    }

    #[test]
    fn the_spread_sample_is_every_demo_or_reaches_the_corners() {
        let x = DMatrix::from_fn(2, 100, |d, j| {
            if d == 0 {
                (j % 10) as f64
            } else {
                (j / 10) as f64
            }
        });
        assert_eq!(spread_sample(&x, 100), (0..100).collect::<Vec<_>>());
        let s = spread_sample(&x, 5);
        // the most central demo (the first of the four at the centre), then the four corners
        assert_eq!(s, vec![0, 9, 44, 90, 99]);
    }
}
