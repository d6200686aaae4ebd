//! The Gaussian processes of the generalizer's scalar parameters, tau, goal and start (Ude et
//! al. 2010; docs/method.md §3.2): one GP per parameter over the demos' queries, either over
//! every demo (exact) or over the `k` demos nearest to each query (local).
//!
//! The exact GPs cost `M^3` per step of the hyperparameter search and `M^2` of memory, which
//! rules them out for databases of thousands of demos. The local ones fit their hyperparameters
//! once, by the same ML-II, on the `k` demos nearest to the most central demo (a neighbourhood
//! like the ones predictions use), and condition a GP with those hyperparameters on the `k`
//! demos nearest to each query: `k^3` per prediction, whatever `M`. A GP's prediction at `q` is
//! dominated by the training points within a few length scales of `q`, so for a neighbourhood
//! wider than that the two agree closely (docs/growing.md measures how closely); with `k >= M`
//! they are the same computation, bit for bit.

use nalgebra::{DMatrix, DVector};

use crate::error::{Error, Result, fmt_g};
use crate::gp::{GaussianProcess, GpOptions, HyperBounds, Hyperparameters, data_scales};

/// The fewest neighbours a local GP takes: ML-II needs at least 4 points (docs/method.md §3.2).
pub const MIN_NEIGHBOURS: usize = 4;

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

/// The GPs of every scalar parameter.
#[derive(Debug, Clone)]
pub(crate) enum OutputGps {
    Exact(Vec<TrendGp>),
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

impl OutputGps {
    /// The GPs of each of `outputs` (one value per demo) over the demo queries `x` (`n x M`);
    /// `nearest(q, k)` gives the indices of the `k` demos nearest to `q` (for local GPs).
    pub(crate) fn fit(
        x: &DMatrix<f64>,
        outputs: Vec<Vec<f64>>,
        s: &GpSettings,
        nearest: impl Fn(&[f64], usize) -> Vec<usize>,
    ) -> Result<Self> {
        let m = x.ncols();
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
                    .map(|y| {
                        let (trend, residuals) = detrend(x, y, s.mean);
                        let rs: Vec<f64> = sample.iter().map(|&i| residuals[i]).collect();
                        let hyper = fit_gp(&xs, &rs, s)?.hyperparameters().clone();
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
                .map(|y| {
                    let (trend, r) = detrend(x, y, s.mean);
                    Ok(TrendGp {
                        trend,
                        gp: fit_gp(x, &r, s)?,
                    })
                })
                .collect::<Result<_>>()
                .map(Self::Exact),
        }
    }

    /// How many neighbours a prediction needs ([`Self::means_at`]); None: every demo.
    pub(crate) fn neighbours(&self) -> Option<usize> {
        match self {
            Self::Exact(_) => None,
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
}
