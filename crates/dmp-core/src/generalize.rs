//! The generalizer `G(q; Z) -> [w, tau, g, y0]` of the paper (eq. 6; docs/method.md §3): from M
//! demonstrations, each with a task query `q_k` in R^n, to a DMP for any query.
//!
//! * [`Method::Linear`] (docs/method.md §3.3, the paper's matchbox setting): affine interpolation and
//!   extrapolation of every parameter. For two demos and a scalar query this is the paper's
//!   `theta(q) = (1 - a) theta_1 + a theta_2`, `a = (q - q_1)/(q_2 - q_1)`. For n-D queries it
//!   uses the barycentric coordinates of `q` with respect to the demo queries, which must be
//!   affinely independent (at most n + 1 of them): exact at every demo, affine in `q`, and, when
//!   M < n + 1, constant along directions orthogonal to the demos' affine hull (the least-squares
//!   projection onto it). More than n + 1 demos would make "linear" a regression that no longer
//!   reproduces its demos, so it is refused: use `LwrGp`.
//! * [`Method::LwrGp`] (Ude et al. 2010, docs/method.md §3.2): shape weights by locally weighted
//!   regression over all demo data ([`crate::lwr`]), and tau, goal and start by one Gaussian
//!   process per scalar ([`crate::gp`]). The start y0 is not in the paper's theta = [w, tau, g];
//!   we generalize it like g so that the result is a complete DMP that reproduces each demo.
//!
//! Either way tau must stay positive: a query whose tau falls outside
//! `(0.2 min tau_k, 5 max tau_k)` (docs/method.md §3.3) is refused with [`Error::Extrapolation`].

use nalgebra::{DMatrix, DVector};

use crate::basis::Basis;
use crate::design_matrix::{NormalEquations, PreparedDemo, normal_equations, solve_ridge};
use crate::dmp::{Demonstration, Dmp, DmpConfig, FIT_RIDGE, nonzero};
use crate::error::{Error, Result, check_scalar};
use crate::lwr::{Lwr, LwrOptions};
use crate::output_gp::{GpMean, GpSettings, OutputGps};

/// tau(q) must lie strictly inside `(TAU_LOW x min tau_k, TAU_HIGH x max tau_k)` (docs/method.md §3.3).
pub const TAU_LOW: f64 = 0.2;
pub const TAU_HIGH: f64 = 5.0;

/// Options of the Ude-2010 generalizer.
#[derive(Debug, Clone, PartialEq)]
pub struct LwrGpOptions {
    pub lwr: LwrOptions,
    /// Noise standard deviation of each GP relative to the standard deviation of its outputs.
    /// Held fixed: a small value makes the GP reproduce the demos (docs/method.md §10). Default 1e-4
    /// (docs/method.md §3.2 suggests 1e-3; 1e-4 reproduces demos about 100 x more closely and still
    /// keeps the kernel matrix well conditioned for distinct queries).
    pub gp_noise: f64,
    /// Fit length scales and signal variances by ML-II. `None`: only with at least 4 demos
    /// (docs/method.md §3.2: with M <= 3, ML-II is ill-posed; then l = query range, signal = var).
    pub gp_optimize: Option<bool>,
    pub gp_restarts: usize,
    /// The GPs' prior mean: the outputs' mean (the default), or their least-squares affine fit
    /// in the query, so that tau, goal and start extrapolate affinely (the GP models what the
    /// affine fit leaves). Needs n + 1 demos whose queries span the query space; with fewer
    /// the mean stays constant.
    pub gp_mean: GpMean,
    /// `Some(k)`: local GPs, over the `k` demos nearest to each query (range-scaled query
    /// distance), with hyperparameters fitted on the `k` demos around the most central one
    /// ([`crate::output_gp`]); their cost does not grow with the number of demos. `None` (the
    /// default): the exact GPs over every demo. With `k >= M` both are the same.
    pub gp_neighbours: Option<usize>,
    /// Sparse GPs: hyperparameters fitted on at most 200 demos spread over the query space,
    /// each GP conditioned on every demo through a low-rank factor of its kernel matrix
    /// ([`crate::output_gp`]). Not with `gp_neighbours`.
    pub gp_sparse: bool,
}

impl Default for LwrGpOptions {
    fn default() -> Self {
        Self {
            lwr: LwrOptions::default(),
            gp_noise: 1e-4,
            gp_optimize: None,
            gp_restarts: 4,
            gp_mean: GpMean::Constant,
            gp_neighbours: None,
            gp_sparse: false,
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
pub enum Method {
    Linear,
    LwrGp(LwrGpOptions),
}

impl Method {
    pub fn name(&self) -> &'static str {
        match self {
            Method::Linear => "linear",
            Method::LwrGp(_) => "lwr-gp",
        }
    }
}

#[derive(Debug, Clone)]
enum Model {
    Linear(Linear),
    LwrGp(Box<LwrGp>),
}

/// Affine interpolation: `theta(q) = sum_k lambda_k(q) theta_k` with barycentric coordinates
/// `lambda_{2..M} = pinv(Delta) (q - q_1)`, `lambda_1 = 1 - sum`, `Delta = [q_k - q_1]`.
#[derive(Debug, Clone)]
struct Linear {
    /// `(M-1) x n`.
    pinv: DMatrix<f64>,
    /// Flattened parameters of each demo: its weights, then its scalars.
    thetas: Vec<DVector<f64>>,
}

#[derive(Debug, Clone)]
struct LwrGp {
    lwr: Lwr,
    /// One GP per scalar parameter, in the order the scalars were given.
    gps: OutputGps,
}

/// What every generalizer shares once each demonstration is fitted: the map from a query to the
/// shape weights (`N x D`) and to the scalar parameters of the primitive (tau, goals, starts,
/// ...), affinely ([`Method::Linear`]) or by LWR on the demos' normal equations and one GP per
/// scalar ([`Method::LwrGp`]). The kind of primitive only decides which scalars there are.
#[derive(Debug, Clone)]
pub(crate) struct ParameterMap {
    method: &'static str,
    n_basis: usize,
    n_dof: usize,
    queries: Vec<Vec<f64>>,
    model: Model,
}

fn format_query(q: &[f64]) -> String {
    let parts: Vec<String> = q.iter().map(|v| format!("{v}")).collect();
    format!("[{}]", parts.join(", "))
}

/// Flattened parameters `[w (D x N, DOF-major), scalars]`.
fn flatten(weights: &DMatrix<f64>, scalars: &[f64]) -> DVector<f64> {
    // The weights are N x D column-major, i.e. already DOF-major.
    let w = weights.as_slice();
    let mut v = Vec::with_capacity(w.len() + scalars.len());
    v.extend_from_slice(w);
    v.extend_from_slice(scalars);
    DVector::from_vec(v)
}

/// A DMP's scalar parameters `[tau, g (D), y0 (D)]`, then its final velocity `gd (D)` when the
/// generalizer has them (docs/method.md §2.8; zeros for a demonstration ending at rest).
fn dmp_scalars(dmp: &Dmp, final_velocity: bool) -> Vec<f64> {
    let mut v = vec![dmp.tau()];
    v.extend(dmp.goal().iter());
    v.extend(dmp.y0().iter());
    if final_velocity {
        match dmp.final_velocity() {
            Some(gd) => v.extend(gd.iter()),
            None => v.extend(std::iter::repeat_n(0.0, dmp.n_dof())),
        }
    }
    v
}

/// Checks the demonstration queries (one per demo, at least 2, all of one length >= 1, finite,
/// distinct) and returns their dimension.
pub(crate) fn check_queries(queries: &[Vec<f64>], m: usize, method: &'static str) -> Result<usize> {
    if queries.len() != m {
        return Err(Error::Shape {
            name: "queries",
            expected: format!("one per demonstration ({m})"),
            got: queries.len().to_string(),
        });
    }
    if m < 2 {
        return Err(Error::DemoCount {
            method,
            got: m,
            requirement: "needs at least 2 demonstrations".into(),
        });
    }
    let n_dim = queries[0].len();
    if n_dim == 0 {
        return Err(Error::Shape {
            name: "queries",
            expected: "(M, n) with n >= 1".into(),
            got: format!("({m}, 0)"),
        });
    }
    for (k, q) in queries.iter().enumerate() {
        if q.len() != n_dim {
            return Err(Error::Shape {
                name: "queries",
                expected: format!("query {k} of length {n_dim} like query 0"),
                got: q.len().to_string(),
            });
        }
        if let Some((d, &v)) = q.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(Error::NonFinite {
                name: "queries",
                location: format!("[{k}, {d}]"),
                value: v,
            });
        }
        if let Some(j) = queries[..k].iter().position(|p| p == q) {
            return Err(Error::DuplicateQuery {
                first: j,
                second: k,
                query: format_query(q),
            });
        }
    }
    Ok(n_dim)
}

/// The interval tau(q) must lie strictly inside, from the demos' taus (docs/method.md §3.3).
pub(crate) fn tau_range(taus: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = taus.fold((f64::INFINITY, 0.0_f64), |(lo, hi), t| {
        (lo.min(t), hi.max(t))
    });
    (TAU_LOW * lo, TAU_HIGH * hi)
}

impl ParameterMap {
    /// `queries` checked by [`check_queries`]; per demo its normal equations (for LWR), its
    /// fitted weights `N x D` and its scalars; `names` the scalars' names (for the GPs' errors).
    pub(crate) fn new(
        queries: &[Vec<f64>],
        normal: Vec<NormalEquations>,
        weights: &[&DMatrix<f64>],
        scalars: &[Vec<f64>],
        names: &[String],
        method: &Method,
    ) -> Result<Self> {
        let (n_basis, n_dof) = weights[0].shape();
        let model = match method {
            Method::Linear => Model::Linear(Self::linear_model(queries, weights, scalars)?),
            Method::LwrGp(opts) => Model::LwrGp(Box::new(Self::lwr_gp_model(
                queries, normal, scalars, names, opts,
            )?)),
        };
        Ok(Self {
            method: method.name(),
            n_basis,
            n_dof,
            queries: queries.to_vec(),
            model,
        })
    }

    fn linear_model(
        queries: &[Vec<f64>],
        weights: &[&DMatrix<f64>],
        scalars: &[Vec<f64>],
    ) -> Result<Linear> {
        let (m, n) = (queries.len(), queries[0].len());
        if m > n + 1 {
            return Err(Error::DemoCount {
                method: "linear",
                got: m,
                requirement: format!(
                    "interpolates between at most n + 1 = {} demonstrations for a {n}-D query (use method 'lwr-gp' for more)",
                    n + 1
                ),
            });
        }
        let delta = DMatrix::from_fn(n, m - 1, |d, k| queries[k + 1][d] - queries[0][d]);
        // Independence is judged scale-free: each dimension in units of its own range over the
        // demos, so that a dimension measured in small units is not mistaken for a missing one.
        let span = |d: usize| {
            let (lo, hi) = queries
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), q| {
                    (lo.min(q[d]), hi.max(q[d]))
                });
            if hi > lo { hi - lo } else { 1.0 }
        };
        let spans: Vec<f64> = (0..n).map(span).collect();
        let scaled = DMatrix::from_fn(n, m - 1, |d, k| delta[(d, k)] / spans[d]);
        let sv = scaled.singular_values();
        let (smax, smin) = (sv.max(), sv.min());
        let svd = delta.clone().svd(true, true);
        if smin.is_nan() || smin <= 1e-10 * smax {
            return Err(Error::DegenerateQueries {
                detail: format!(
                    "method 'linear' needs affinely independent demo queries (a segment, triangle, ...), \
                     but {} lie in a lower-dimensional subspace",
                    queries
                        .iter()
                        .map(|q| format_query(q))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            });
        }
        let pinv = svd.pseudo_inverse(0.0).map_err(|e| Error::Numerical {
            context: "linear generalizer",
            detail: e.to_string(),
        })?;
        Ok(Linear {
            pinv,
            thetas: weights
                .iter()
                .zip(scalars)
                .map(|(w, s)| flatten(w, s))
                .collect(),
        })
    }

    fn lwr_gp_model(
        queries: &[Vec<f64>],
        normal: Vec<NormalEquations>,
        scalars: &[Vec<f64>],
        names: &[String],
        opts: &LwrGpOptions,
    ) -> Result<LwrGp> {
        check_scalar("gp_noise", opts.gp_noise, true)?;
        if opts.gp_restarts > crate::gp::MAX_RESTARTS {
            return Err(Error::InvalidParameter {
                name: "gp_restarts",
                value: opts.gp_restarts.to_string(),
                requirement: "must be at most 1000 (each restart is a full optimization of each GP)",
            });
        }
        let lwr = Lwr::new(queries, normal, opts.lwr)?;
        let (m, n) = (queries.len(), queries[0].len());
        let x = DMatrix::from_fn(n, m, |d, k| queries[k][d]);
        let outputs = names
            .iter()
            .enumerate()
            .map(|(i, name)| (name.clone(), scalars.iter().map(|s| s[i]).collect()))
            .collect();
        let settings = GpSettings {
            noise: opts.gp_noise,
            optimize: opts.gp_optimize,
            restarts: opts.gp_restarts,
            mean: opts.gp_mean,
            neighbours: opts.gp_neighbours,
            sparse: opts.gp_sparse,
        };
        let gps = OutputGps::fit(&x, outputs, &settings, |q, k| lwr.nearest(q, k))?;
        Ok(LwrGp { lwr, gps })
    }

    pub(crate) fn method(&self) -> &'static str {
        self.method
    }
    pub(crate) fn n_query(&self) -> usize {
        self.queries[0].len()
    }
    pub(crate) fn queries(&self) -> &[Vec<f64>] {
        &self.queries
    }

    /// Checks a query against the demonstrations' (its length, finite values).
    pub(crate) fn check_query(&self, q: &[f64]) -> Result<()> {
        let n_dim = self.n_query();
        if q.len() != n_dim {
            return Err(Error::Shape {
                name: "q",
                expected: format!("({n_dim},), the dimension of the demonstration queries"),
                got: format!("({},)", q.len()),
            });
        }
        if let Some((d, &v)) = q.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(Error::NonFinite {
                name: "q",
                location: format!("[{d}]"),
                value: v,
            });
        }
        Ok(())
    }

    /// The weights (`N x D`) and the scalars at `q` (checked by the caller).
    pub(crate) fn at(&self, q: &[f64]) -> Result<(DMatrix<f64>, Vec<f64>)> {
        match &self.model {
            Model::Linear(lin) => {
                let theta = if let Some(k) = self.queries.iter().position(|qk| qk.as_slice() == q) {
                    // At a vertex the barycentric coordinates are exactly e_k; take them so,
                    // rather than through the rounding of the pseudo-inverse.
                    lin.thetas[k].clone()
                } else {
                    let dq = DVector::from_fn(self.n_query(), |d, _| q[d] - self.queries[0][d]);
                    let lam = &lin.pinv * dq;
                    let lam0 = 1.0 - lam.sum();
                    let mut theta = &lin.thetas[0] * lam0;
                    for (k, l) in lam.iter().enumerate() {
                        theta.axpy(*l, &lin.thetas[k + 1], 1.0);
                    }
                    theta
                };
                let nw = self.n_basis * self.n_dof;
                let w =
                    DMatrix::from_column_slice(self.n_basis, self.n_dof, &theta.as_slice()[..nw]);
                Ok((w, theta.as_slice()[nw..].to_vec()))
            }
            Model::LwrGp(model) => {
                let w = model.lwr.weights_at(q)?;
                let nearest = match model.gps.neighbours() {
                    Some(k) => model.lwr.nearest(q, k),
                    None => Vec::new(),
                };
                Ok((w, model.gps.means_at(q, &nearest)?))
            }
        }
    }

    /// The flattened parameters `[w (D x N, DOF-major), scalars]` at `q`.
    pub(crate) fn flat_at(&self, q: &[f64]) -> Result<DVector<f64>> {
        self.check_query(q)?;
        let (w, scalars) = self.at(q)?;
        Ok(flatten(&w, &scalars))
    }

    /// Refuses a tau outside `tau_valid` for the query `q` (docs/method.md §3.3).
    pub(crate) fn check_tau(&self, q: &[f64], tau: f64, tau_valid: (f64, f64)) -> Result<()> {
        let (lo, hi) = tau_valid;
        if tau > lo && tau < hi {
            return Ok(());
        }
        Err(Error::Extrapolation {
            query: format_query(q),
            reason: format!(
                "the '{}' generalization gives tau = {tau} s, outside the valid range ({lo}, {hi}) s \
                 (0.2 x the shortest and 5 x the longest demonstration); the query is too far from the demonstrations",
                self.method
            ),
        })
    }

    /// Central-difference Jacobian of [`Self::flat_at`] with respect to `q`
    /// (`n_parameters x n`), for learners that need a gain (docs/method.md §5.2). The step in
    /// dimension d is `rel_step x` the range of the demo queries in d (or `max(|q_d|, 1)` where
    /// they do not vary). Exact up to rounding for the linear generalizer, which is affine.
    pub(crate) fn jacobian(&self, q: &[f64], rel_step: f64) -> Result<DMatrix<f64>> {
        self.check_query(q)?;
        check_scalar("rel_step", rel_step, true)?;
        let n_dim = self.n_query();
        let mut jac: Option<DMatrix<f64>> = None;
        let mut qp = q.to_vec();
        for d in 0..n_dim {
            let (lo, hi) = self
                .queries
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                    (a.min(v[d]), b.max(v[d]))
                });
            let scale = if hi > lo {
                hi - lo
            } else {
                q[d].abs().max(1.0)
            };
            let h = rel_step * scale;
            qp[d] = q[d] + h;
            let plus = self.flat_at(&qp)?;
            qp[d] = q[d] - h;
            let minus = self.flat_at(&qp)?;
            qp[d] = q[d];
            let jac = jac.get_or_insert_with(|| DMatrix::zeros(plus.len(), n_dim));
            jac.set_column(d, &((plus - minus) / (2.0 * h)));
        }
        Ok(jac.unwrap_or_else(|| DMatrix::zeros(0, 0)))
    }
}

/// A generalizer over M demonstrations.
#[derive(Debug, Clone)]
pub struct Generalizer {
    config: DmpConfig,
    n_dof: usize,
    demo_dmps: Vec<Dmp>,
    tau_valid: (f64, f64),
    map: ParameterMap,
    /// Whether the final velocity is among the generalized scalars ([`Self::with_final_velocity`]).
    final_velocity: bool,
}

/// The names of a DMP's scalar parameters, in [`dmp_scalars`]' order.
fn dmp_scalar_names(n_dof: usize, final_velocity: bool) -> Vec<String> {
    let mut names = vec!["tau".to_string()];
    names.extend((0..n_dof).map(|i| format!("goal[{i}]")));
    names.extend((0..n_dof).map(|i| format!("start[{i}]")));
    if final_velocity {
        names.extend((0..n_dof).map(|i| format!("final_velocity[{i}]")));
    }
    names
}

impl Generalizer {
    /// Fits one DMP per demonstration (docs/method.md §2.3, each on its own tau and goal) and
    /// precomputes what `method` needs for fast queries.
    pub fn new(
        queries: &[Vec<f64>],
        demos: &[Demonstration<'_>],
        config: DmpConfig,
        method: Method,
    ) -> Result<Self> {
        Self::build(queries, demos, config, method, false)
    }

    /// [`Self::new`] for demonstrations that end in motion (docs/method.md §2.8): each is fitted
    /// with its last velocity as its final velocity, and the final velocity joins the
    /// generalized scalars, after the starts.
    pub fn with_final_velocity(
        queries: &[Vec<f64>],
        demos: &[Demonstration<'_>],
        config: DmpConfig,
        method: Method,
    ) -> Result<Self> {
        Self::build(queries, demos, config, method, true)
    }

    fn build(
        queries: &[Vec<f64>],
        demos: &[Demonstration<'_>],
        config: DmpConfig,
        method: Method,
        final_velocity: bool,
    ) -> Result<Self> {
        config.validate_for_fit()?;
        let m = demos.len();
        check_queries(queries, m, method.name())?;
        let basis = Basis::new(config.n_basis, config.alpha_x, config.width_factor)?;
        let mut normal = Vec::with_capacity(m);
        let mut demo_dmps = Vec::with_capacity(m);
        let mut n_dof = 0;
        for (k, demo) in demos.iter().enumerate() {
            let in_demo = |e: Error| Error::InDemo {
                index: k,
                source: Box::new(e),
            };
            let mut prepared = PreparedDemo::new(demo).map_err(in_demo)?;
            if final_velocity {
                prepared.final_velocity =
                    nonzero(prepared.yd.column(prepared.t.len() - 1).into_owned());
            }
            if k == 0 {
                n_dof = prepared.n_dof();
            } else if prepared.n_dof() != n_dof {
                return Err(Error::DofMismatch {
                    index: k,
                    got: prepared.n_dof(),
                    expected: n_dof,
                });
            }
            let ne = normal_equations(&prepared, &basis, &config);
            // Exactly what Dmp::fit (with_final_velocity) computes: the demo's own DMP, bit
            // for bit.
            let w = solve_ridge(ne.ata.clone(), &ne.atf, FIT_RIDGE, "DMP fit").map_err(in_demo)?;
            let dmp = Dmp::new(
                config,
                w,
                prepared.goal.clone(),
                prepared.y0.clone(),
                prepared.tau,
            )
            .map_err(in_demo)?;
            demo_dmps.push(match &prepared.final_velocity {
                Some(gd) => dmp.with_final_velocity(gd.clone()).map_err(in_demo)?,
                None => dmp,
            });
            normal.push(ne);
        }
        let tau_valid = tau_range(demo_dmps.iter().map(|d| d.tau()));
        let weights: Vec<&DMatrix<f64>> = demo_dmps.iter().map(|d| d.weights()).collect();
        let scalars: Vec<Vec<f64>> = demo_dmps
            .iter()
            .map(|d| dmp_scalars(d, final_velocity))
            .collect();
        let map = ParameterMap::new(
            queries,
            normal,
            &weights,
            &scalars,
            &dmp_scalar_names(n_dof, final_velocity),
            &method,
        )?;
        Ok(Self {
            config,
            n_dof,
            demo_dmps,
            tau_valid,
            map,
            final_velocity,
        })
    }

    pub fn method(&self) -> &'static str {
        self.map.method()
    }
    pub fn n_query(&self) -> usize {
        self.map.n_query()
    }
    pub fn n_dof(&self) -> usize {
        self.n_dof
    }
    pub fn n_demos(&self) -> usize {
        self.demo_dmps.len()
    }
    pub fn config(&self) -> &DmpConfig {
        &self.config
    }
    /// The DMP fitted to each demonstration.
    pub fn demo_dmps(&self) -> &[Dmp] {
        &self.demo_dmps
    }
    pub fn queries(&self) -> &[Vec<f64>] {
        self.map.queries()
    }
    /// Length of the flattened parameter vector: `D N + 1 + 2 D`, `+ D` with final velocities.
    pub fn n_parameters(&self) -> usize {
        let scalars = if self.final_velocity { 3 } else { 2 } * self.n_dof;
        self.n_dof * self.config.n_basis + 1 + scalars
    }
    /// Whether the final velocity is generalized ([`Self::with_final_velocity`]).
    pub fn has_final_velocity(&self) -> bool {
        self.final_velocity
    }
    /// The interval tau(q) must lie strictly inside.
    pub fn tau_bounds(&self) -> (f64, f64) {
        self.tau_valid
    }

    /// The DMP for query `q` (paper eq. 6). Fails with [`Error::Extrapolation`] if its tau would
    /// leave `(0.2 min tau_k, 5 max tau_k)`.
    pub fn predict(&self, q: &[f64]) -> Result<Dmp> {
        self.map.check_query(q)?;
        let (w, s) = self.map.at(q)?;
        let n = self.n_dof;
        self.map.check_tau(q, s[0], self.tau_valid)?;
        let goal = DVector::from_column_slice(&s[1..1 + n]);
        let y0 = DVector::from_column_slice(&s[1 + n..1 + 2 * n]);
        let dmp = Dmp::new(self.config, w, goal, y0, s[0])?;
        if !self.final_velocity {
            return Ok(dmp);
        }
        dmp.with_final_velocity(DVector::from_column_slice(&s[1 + 2 * n..1 + 3 * n]))
    }

    /// Flattened parameters `[w (D x N, DOF-major), tau, g (D), y0 (D)]` at `q`, then
    /// `gd (D)` with final velocities; without the tau check.
    pub fn parameters(&self, q: &[f64]) -> Result<DVector<f64>> {
        self.map.flat_at(q)
    }

    /// Central-difference Jacobian of [`Self::parameters`] with respect to `q`
    /// (`n_parameters x n`), for learners that need a gain (docs/method.md §5.2).
    pub fn jacobian(&self, q: &[f64], rel_step: f64) -> Result<DMatrix<f64>> {
        self.map.jacobian(q, rel_step)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lwr::LocalModel;

    fn flat(dmp: &Dmp) -> DVector<f64> {
        flatten(dmp.weights(), &dmp_scalars(dmp, false))
    }

    /// A 2-DOF demo whose amplitude, goal and duration depend on the query.
    fn demo(q: f64) -> (Vec<f64>, DMatrix<f64>) {
        let tau = 1.0 + 0.3 * q;
        let t: Vec<f64> = (0..300).map(|j| tau * j as f64 / 299.0).collect();
        let y = DMatrix::from_fn(2, 300, |d, j| {
            let s = j as f64 / 299.0;
            let mj = 10.0 * s.powi(3) - 15.0 * s.powi(4) + 6.0 * s.powi(5);
            if d == 0 {
                (1.0 + q) * mj
            } else {
                0.2 * q + (0.5 - q) * mj + 0.1 * (3.0 * s).sin() * q
            }
        });
        (t, y)
    }

    fn build(qs: &[f64], method: Method) -> Result<Generalizer> {
        build_from(qs, demo, method)
    }

    fn build_from(
        qs: &[f64],
        demo: impl Fn(f64) -> (Vec<f64>, DMatrix<f64>),
        method: Method,
    ) -> Result<Generalizer> {
        let data: Vec<_> = qs.iter().map(|&q| demo(q)).collect();
        let demos: Vec<Demonstration> = data
            .iter()
            .map(|(t, y)| Demonstration {
                t,
                y: y.as_view(),
                yd: None,
                ydd: None,
            })
            .collect();
        let queries: Vec<Vec<f64>> = qs.iter().map(|&q| vec![q]).collect();
        Generalizer::new(
            &queries,
            &demos,
            DmpConfig {
                n_basis: 15,
                ..DmpConfig::default()
            },
            method,
        )
    }

    #[test]
    fn linear_is_exact_at_both_demos_and_affine_in_q() {
        let g = build(&[0.0, 1.0], Method::Linear).unwrap();
        for k in 0..2 {
            assert_eq!(&g.predict(&[k as f64]).unwrap(), &g.demo_dmps()[k]);
        }
        let p = |q: f64| g.parameters(&[q]).unwrap();
        for (a, b) in [(0.2, 0.7), (-0.5, 1.5), (1.2, 2.0)] {
            let mid = p(0.5 * (a + b));
            let avg = (p(a) + p(b)) * 0.5;
            assert!((mid - avg).amax() < 1e-9);
        }
        // The paper's formula at a = 0.25.
        let expect = g.demo_dmps().iter().map(flat).collect::<Vec<_>>();
        assert!((p(0.25) - (&expect[0] * 0.75 + &expect[1] * 0.25)).amax() < 1e-12);
    }

    #[test]
    fn both_methods_agree_at_the_demo_queries() {
        let lin = build(&[0.0, 1.0], Method::Linear).unwrap();
        let ude = build(&[0.0, 1.0], Method::LwrGp(LwrGpOptions::default())).unwrap();
        for q in [0.0, 1.0] {
            let (a, b) = (lin.parameters(&[q]).unwrap(), ude.parameters(&[q]).unwrap());
            let scale = a.amax();
            assert!((a - b).amax() < 1e-5 * scale, "q={q}");
        }
    }

    #[test]
    fn lwr_gp_reproduces_each_of_several_demos() {
        let qs = [0.0, 0.4, 1.0, 1.5, 2.2];
        let g = build(&qs, Method::LwrGp(LwrGpOptions::default())).unwrap();
        for (k, &q) in qs.iter().enumerate() {
            let got = g.parameters(&[q]).unwrap();
            let want = flat(&g.demo_dmps()[k]);
            assert!(
                (&got - &want).amax() < 1e-5 * want.amax(),
                "k={k}: {}",
                (&got - &want).amax()
            );
        }
    }

    /// One DOF whose data are affine in q on one time grid, so its fitted weights are too.
    fn affine_demo(q: f64) -> (Vec<f64>, DMatrix<f64>) {
        let t: Vec<f64> = (0..300).map(|j| j as f64 / 299.0).collect();
        let y = DMatrix::from_fn(1, 300, |_, j| {
            let s = j as f64 / 299.0;
            let mj = 10.0 * s.powi(3) - 15.0 * s.powi(4) + 6.0 * s.powi(5);
            (1.0 + q) * mj + 0.1 * q * (3.0 * s).sin()
        });
        (t, y)
    }

    fn build_affine(qs: &[f64], affine: bool) -> Generalizer {
        let mut options = LwrGpOptions::default();
        if affine {
            options.lwr.local_model = LocalModel::Linear;
            options.gp_mean = GpMean::Affine;
        }
        build_from(qs, affine_demo, Method::LwrGp(options)).unwrap()
    }

    #[test]
    fn an_affine_trend_extrapolates_affine_parameters_and_keeps_the_demos() {
        let qs = [0.0, 0.5, 1.0, 1.5];
        let (aff, cst) = (build_affine(&qs, true), build_affine(&qs, false));
        let nw = 15;
        let w = |g: &Generalizer, q: f64| g.parameters(&[q]).unwrap().rows(0, nw).into_owned();
        // at the demos: the constant model's weights, bit for bit (its demo fits), and the
        // demos' tau, goal and start to the GP noise
        for (k, &q) in qs.iter().enumerate() {
            assert_eq!(w(&aff, q), w(&cst, q), "q={q}");
            let (got, want) = (aff.parameters(&[q]).unwrap(), flat(&aff.demo_dmps()[k]));
            assert!((got - &want).amax() < 1e-6 * want.amax(), "q={q}");
        }
        // beyond and between them: the DMP of the demo that would be there (weights by
        // first-order LWR, tau, goal and start by the GPs' affine mean)
        let fit = |q: f64| flat(&build_affine(&[q, q + 1.0], false).demo_dmps()[0]);
        for q in [2.5, -0.8, 0.75] {
            let want = fit(q);
            let err = (aff.parameters(&[q]).unwrap() - &want).amax();
            assert!(err < 1e-6 * want.amax(), "q={q}: {err} of {}", want.amax());
        }
        // the constant model cannot extrapolate: it stays near the last demo
        let want = fit(2.5);
        assert!((cst.parameters(&[2.5]).unwrap() - &want).amax() > 0.1 * want.amax());
    }

    fn lwr_gp(neighbours: Option<usize>) -> Method {
        lwr_gp_with(neighbours, false)
    }

    fn lwr_gp_with(neighbours: Option<usize>, sparse: bool) -> Method {
        Method::LwrGp(LwrGpOptions {
            gp_neighbours: neighbours,
            gp_sparse: sparse,
            ..LwrGpOptions::default()
        })
    }

    #[test]
    fn local_gps_over_every_demo_are_the_exact_ones_bit_for_bit() {
        let qs: Vec<f64> = (0..12).map(|k| 0.2 * k as f64).collect();
        let exact = build(&qs, lwr_gp(None)).unwrap();
        for k in [12, 50] {
            let local = build(&qs, lwr_gp(Some(k))).unwrap();
            for q in [0.0, 0.3, 1.17, 2.2, 2.9] {
                assert_eq!(
                    local.parameters(&[q]).unwrap(),
                    exact.parameters(&[q]).unwrap()
                );
            }
        }
    }

    #[test]
    fn local_gps_reproduce_the_demos_and_stay_near_the_exact_ones() {
        let qs: Vec<f64> = (0..40).map(|k| 0.05 * k as f64).collect();
        let exact = build(&qs, lwr_gp(None)).unwrap();
        let local = build(&qs, lwr_gp(Some(10))).unwrap();
        let nw = exact.config().n_basis * exact.n_dof();
        for (k, &q) in qs.iter().enumerate() {
            let got = local.parameters(&[q]).unwrap();
            let want = flat(&local.demo_dmps()[k]);
            let err = (got.rows(nw, want.len() - nw) - want.rows(nw, want.len() - nw)).amax();
            assert!(err < 1e-5 * want.amax(), "demo {k}: {err}");
        }
        for q in [0.025, 0.51, 1.333, 1.96] {
            let (a, b) = (
                local.parameters(&[q]).unwrap(),
                exact.parameters(&[q]).unwrap(),
            );
            // the weights are the LWR's, which both share
            assert_eq!(a.rows(0, nw), b.rows(0, nw));
            let err = (a.rows(nw, a.len() - nw) - b.rows(nw, b.len() - nw)).amax();
            assert!(err < 1e-4 * b.amax(), "q={q}: {err}");
        }
    }

    #[test]
    fn sparse_gps_give_the_exact_gps_parameters() {
        // Fewer demos than the sparse GPs fit on: the same hyperparameters, and a factor that
        // leaves out less than the noise.
        let qs: Vec<f64> = (0..40).map(|k| 0.05 * k as f64).collect();
        let (exact, sparse) = (
            build(&qs, lwr_gp(None)).unwrap(),
            build(&qs, lwr_gp_with(None, true)).unwrap(),
        );
        let nw = exact.config().n_basis * exact.n_dof();
        for q in [0.0, 0.025, 0.51, 1.333, 1.96] {
            let (a, b) = (
                sparse.parameters(&[q]).unwrap(),
                exact.parameters(&[q]).unwrap(),
            );
            assert_eq!(a.rows(0, nw), b.rows(0, nw));
            let err = (a.rows(nw, a.len() - nw) - b.rows(nw, b.len() - nw)).amax();
            assert!(err < 1e-6 * b.amax(), "q={q}: {err}");
        }
        let err = build(&qs, lwr_gp_with(Some(10), true)).unwrap_err();
        assert!(err.to_string().contains("gp_sparse"), "{err}");
    }

    #[test]
    fn fewer_than_four_neighbours_are_refused() {
        let qs: Vec<f64> = (0..8).map(|k| 0.2 * k as f64).collect();
        let err = build(&qs, lwr_gp(Some(3))).unwrap_err();
        assert!(
            matches!(
                err,
                Error::InvalidParameter {
                    name: "gp_neighbours",
                    ..
                }
            ),
            "{err}"
        );
    }

    #[test]
    fn the_jacobian_of_linear_is_the_demo_difference() {
        let g = build(&[0.0, 2.0], Method::Linear).unwrap();
        let jac = g.jacobian(&[0.7], 1e-3).unwrap();
        let want = (flat(&g.demo_dmps()[1]) - flat(&g.demo_dmps()[0])) / 2.0;
        assert!((jac.column(0) - want).amax() < 1e-8);
    }

    #[test]
    fn extrapolating_tau_below_its_floor_is_refused() {
        // tau = 1 + 0.3 q: tau(q) <= 0.2 for q <= -2.67.
        let g = build(&[0.0, 1.0], Method::Linear).unwrap();
        assert!(g.predict(&[-2.0]).is_ok());
        let err = g.predict(&[-3.0]).unwrap_err();
        assert!(matches!(err, Error::Extrapolation { .. }), "{err}");
        assert!(err.to_string().contains("[-3]"), "{err}");
    }

    #[test]
    fn bad_demo_sets_are_errors() {
        assert!(matches!(
            build(&[0.0], Method::Linear),
            Err(Error::DemoCount { .. })
        ));
        assert!(matches!(
            build(&[0.0, 1.0, 2.0], Method::Linear),
            Err(Error::DemoCount { .. })
        ));
        assert!(matches!(
            build(&[0.0, 1.0, 0.0], Method::LwrGp(LwrGpOptions::default())),
            Err(Error::DuplicateQuery {
                first: 0,
                second: 2,
                ..
            })
        ));
        let g = build(&[0.0, 1.0], Method::Linear).unwrap();
        assert!(matches!(g.predict(&[0.0, 1.0]), Err(Error::Shape { .. })));
        assert!(matches!(
            g.predict(&[f64::NAN]),
            Err(Error::NonFinite { .. })
        ));
    }
}
