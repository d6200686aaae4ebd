//! PoWER, episodic reward-weighted policy search over the flat DMP weight vector (Kober & Peters
//! 2008/2011; docs/method.md §7.1, the simplifications of Kober's sample code): constant exploration
//! during a rollout, the return instead of the state-action value, importance sampling over the
//! `n_best` best rollouts so far.
//!
//! ```text
//! theta_i     = theta_mean + N(0, diag(var))                    one rollout per ask
//! best        = the n_best rollouts with the highest return among all so far
//! theta_mean += sum_j W_j R_j (theta_j - theta_mean) / (sum_j W_j R_j + 1e-10),  W_j = 1/var_j
//! [adaptive]  var = sum R_j (theta_j - theta_mean)^2 / sum R_j over the best `window`,
//!             clipped to [0.1, 10] x var0
//! ```
//! `tell(theta, [R])` takes the rollout's return R, which must be > 0 (reward-weighted EM; for
//! an error eps use e.g. R = exp(-(eps/s)^2), docs/method.md §7.1). Deterministic for a seed
//! (ChaCha8). A baseline: the paper reports no PoWER numbers (docs/method.md §7).

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use crate::ask_tell::{AskTell, Record, Status, diverged_unless_finite};
use crate::error::{LearnerError, Result, check_query, check_scalar, invalid};

#[derive(Debug, Clone)]
pub struct PowerConfig {
    pub n_best: usize,
    pub adapt_variance: bool,
    pub variance_window: usize,
    /// Converged once a rollout's return reaches this.
    pub target_return: Option<f64>,
    pub max_trials: usize,
    pub seed: u64,
}

impl Default for PowerConfig {
    fn default() -> Self {
        Self {
            n_best: 10,
            adapt_variance: false,
            variance_window: 100,
            target_return: None,
            max_trials: 200,
            seed: 0,
        }
    }
}

/// Kober's code: the adaptive variance stays within [0.1, 10] times the initial one.
const VAR_CLIP: (f64, f64) = (0.1, 10.0);

#[derive(Debug, Clone)]
pub struct Power {
    mean: Vec<f64>,
    var: Vec<f64>,
    var0: Vec<f64>,
    /// (theta, R, the variance it was sampled with)
    rollouts: Vec<(Vec<f64>, f64, Vec<f64>)>,
    n_best: usize,
    adapt: bool,
    window: usize,
    target: Option<f64>,
    rng: ChaCha8Rng,
    rec: Record,
}

/// One sigma for all parameters, or one per parameter.
pub(crate) fn per_parameter(sigma: &[f64], dim: usize) -> Result<Vec<f64>> {
    let s = match sigma.len() {
        1 => vec![sigma[0]; dim],
        n if n == dim => sigma.to_vec(),
        n => {
            return Err(LearnerError::Dimension {
                name: "sigma",
                expected: format!("1 or {dim} entries"),
                got: format!("{n} entries"),
            });
        }
    };
    for (i, &v) in s.iter().enumerate() {
        if !v.is_finite() {
            return Err(LearnerError::NonFinite {
                name: "sigma",
                location: format!("[{i}]"),
                value: v,
            });
        }
        if v <= 0.0 {
            return Err(invalid(
                "sigma",
                format!("{v} (at index {i})"),
                "must be > 0",
            ));
        }
    }
    Ok(s)
}

impl Power {
    /// `sigma`: the exploration standard deviation, one entry or one per weight.
    pub fn new(theta0: &[f64], sigma: &[f64], cfg: PowerConfig) -> Result<Self> {
        check_query("theta0", theta0)?;
        let sigma = per_parameter(sigma, theta0.len())?;
        let var0: Vec<f64> = sigma.iter().map(|s| s * s).collect();
        if let Some(i) = var0.iter().position(|v| !v.is_finite()) {
            return Err(invalid(
                "sigma",
                format!("{:e} (at index {i})", sigma[i]),
                "its square, the exploration variance, overflows",
            ));
        }
        if cfg.n_best == 0 {
            return Err(invalid("n_best", 0, "must be at least 1"));
        }
        if cfg.variance_window == 0 {
            return Err(invalid("variance_window", 0, "must be at least 1"));
        }
        if let Some(t) = cfg.target_return {
            check_scalar("target_return", t, true)?;
        }
        Ok(Self {
            mean: theta0.to_vec(),
            var: var0.clone(),
            var0,
            rollouts: Vec::new(),
            n_best: cfg.n_best,
            adapt: cfg.adapt_variance,
            window: cfg.variance_window,
            target: cfg.target_return,
            rng: ChaCha8Rng::seed_from_u64(cfg.seed),
            rec: Record::new(cfg.max_trials)?,
        })
    }

    /// The current mean theta.
    pub fn mean(&self) -> &[f64] {
        &self.mean
    }

    /// The current exploration variance per parameter.
    pub fn variance(&self) -> &[f64] {
        &self.var
    }

    /// Indices of rollouts by decreasing return (ties: earlier first).
    fn ranked(&self) -> Vec<usize> {
        let mut idx: Vec<usize> = (0..self.rollouts.len()).collect();
        idx.sort_by(|&i, &j| self.rollouts[j].1.total_cmp(&self.rollouts[i].1));
        idx
    }

    fn update(&mut self) {
        let ranked = self.ranked();
        // The update is a ratio of return-weighted sums, so dividing every return by one
        // constant changes nothing but overflow: returns above 1 (a user's R up to 1e308) are
        // divided by the largest, returns of at most 1 (exp(-(eps/s)^2)) are used as they are.
        let scale = self.rollouts[ranked[0]].1.max(1.0);
        for p in 0..self.mean.len() {
            let (mut num, mut den) = (0.0, 0.0);
            for &j in ranked.iter().take(self.n_best) {
                let (theta, r, var) = &self.rollouts[j];
                let (w, r) = (1.0 / var[p], r / scale);
                num += w * r * (theta[p] - self.mean[p]);
                den += w * r;
            }
            self.mean[p] += num / (den + 1e-10);
        }
        if self.adapt {
            for p in 0..self.mean.len() {
                let (mut num, mut den) = (0.0, 0.0);
                for &j in ranked.iter().take(self.window) {
                    let (theta, r, _) = &self.rollouts[j];
                    let r = r / scale;
                    num += r * (theta[p] - self.mean[p]).powi(2);
                    den += r;
                }
                let v = num / den;
                self.var[p] = v.clamp(VAR_CLIP.0 * self.var0[p], VAR_CLIP.1 * self.var0[p]);
            }
        }
    }
}

impl AskTell for Power {
    fn dim(&self) -> usize {
        self.mean.len()
    }

    fn ask(&mut self) -> Result<Vec<f64>> {
        let (mean, var, rng) = (&self.mean, &self.var, &mut self.rng);
        self.rec.ask_with(|| {
            (0..mean.len())
                .map(|p| {
                    let z: f64 = StandardNormal.sample(rng);
                    mean[p] + var[p].sqrt() * z
                })
                .collect()
        })
    }

    fn tell(&mut self, theta: &[f64], ret: &[f64]) -> Result<()> {
        self.rec.check_tell(theta, ret, "return", &[1])?;
        let r = ret[0];
        if r <= 0.0 {
            return Err(invalid(
                "return",
                r,
                "must be > 0: PoWER weights rollouts by their return (e.g. R = exp(-(eps/s)^2))",
            ));
        }
        self.rec.push(ret, -r)?;
        self.rollouts.push((theta.to_vec(), r, self.var.clone()));
        self.update();
        let done = self.target.is_some_and(|t| r >= t);
        // A huge return (or rollout) can overflow the weighted means.
        let diverged =
            diverged_unless_finite(&self.mean).or_else(|| diverged_unless_finite(&self.var));
        self.rec
            .finish_tell(done.then_some(Status::Converged).or(diverged));
        Ok(())
    }

    fn record(&self) -> &Record {
        &self.rec
    }
}
