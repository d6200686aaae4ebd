//! Constrained-domain policy gradient (paper eq. 12; docs/method.md §4) with central finite
//! differences in the query space.
//!
//! ```text
//! J(q)      = ||eps(q) / s||^2                       the cost of reward (1), eq. 14 (s: task scale)
//! g_i       = (J(q + d e_i) - J(q - d e_i)) / (2 d)    2n perturbed trials per update
//! q_{m+1}   = q_m - alpha_m g,   alpha_m = alpha0 / (m + 1)^0.602
//! ```
//! The step sizes satisfy Robbins-Monro (sum alpha = inf, sum alpha^2 < inf; docs/method.md §4, the
//! garbled condition of the paper read as intended); 0.602 is Spall's SPSA exponent. Every
//! perturbed trial is a trial (it is asked, executed and told), and so is the evaluation of the
//! centre q_m that starts each update when `evaluate_center` (the first one is the pure
//! generalization q0, as for the other learners).
//!
//! Its `tell` takes eps like the other query learners (eps > 0: the query must increase,
//! docs/method.md §5.3) and forms the scalar cost itself, so it is a drop-in replacement; any told
//! query with every |eps_i| < tol ends the run (`Converged`; it is the best trial).

use nalgebra::DVector;

use crate::ask_tell::{AskTell, Record, Status, diverged_unless_finite, max_abs};
use crate::bounds::Bounds;
use crate::error::{Result, check_query, check_scalar, invalid};

/// Spall's decay exponent for the SPSA/Kiefer-Wolfowitz gain sequence.
pub const DECAY: f64 = 0.602;

#[derive(Debug, Clone)]
pub struct PolicyGradientConfig {
    /// alpha0 in alpha_m = alpha0 / (m+1)^decay. None: s^2 / 2, which makes the first step a
    /// Newton step on the ideal map q_a = q.
    pub alpha0: Option<f64>,
    pub decay: f64,
    /// The finite-difference step d (query units). None: 0.05 s.
    pub delta: Option<f64>,
    /// The task scale s of the cost.
    pub scale: f64,
    pub evaluate_center: bool,
    pub low: Option<Vec<f64>>,
    pub high: Option<Vec<f64>>,
    pub tol: f64,
    pub max_trials: usize,
    /// Consecutive updates pinned at a limit before `HitBound`.
    pub pin_limit: usize,
}

impl Default for PolicyGradientConfig {
    fn default() -> Self {
        Self {
            alpha0: None,
            decay: DECAY,
            delta: None,
            scale: 1.0,
            evaluate_center: true,
            low: None,
            high: None,
            tol: 1e-3,
            max_trials: 100,
            pin_limit: 3,
        }
    }
}

/// The default finite-difference step as a fraction of the task scale s.
const DELTA_PER_SCALE: f64 = 0.05;

#[derive(Debug, Clone)]
pub struct PolicyGradient {
    n: usize,
    cfg: PolicyGradientConfig,
    /// alpha0 and delta with their defaults resolved.
    alpha0: f64,
    delta: f64,
    bounds: Option<Bounds>,
    center: DVector<f64>,
    /// The queries of the current update, in order: [centre,] +e_0, -e_0, +e_1, ...
    plan: Vec<DVector<f64>>,
    /// Costs told so far in this update.
    costs: Vec<f64>,
    update: usize,
    rec: Record,
}

impl PolicyGradient {
    pub fn new(q0: &[f64], cfg: PolicyGradientConfig) -> Result<Self> {
        let n = q0.len();
        check_query("q0", q0)?;
        check_scalar("scale", cfg.scale, true)?;
        let alpha0 = cfg.alpha0.unwrap_or(0.5 * cfg.scale * cfg.scale);
        check_scalar("alpha0", alpha0, true)?;
        check_scalar("decay", cfg.decay, true)?;
        if cfg.decay > 1.0 || cfg.decay <= 0.5 {
            // Robbins-Monro: sum alpha diverges only for decay <= 1, sum alpha^2 converges only for decay > 1/2.
            return Err(invalid(
                "decay",
                cfg.decay,
                "must lie in (0.5, 1] (Robbins-Monro)",
            ));
        }
        let delta = cfg.delta.unwrap_or(DELTA_PER_SCALE * cfg.scale);
        check_scalar("delta", delta, true)?;
        check_scalar("tol", cfg.tol, true)?;
        let bounds = Bounds::new(cfg.low.as_deref(), cfg.high.as_deref(), n, cfg.pin_limit)?;
        if let Some(b) = &bounds {
            b.check_inside("q0", q0)?;
        }
        let rec = Record::new(cfg.max_trials)?;
        let mut pg = Self {
            n,
            cfg,
            alpha0,
            delta,
            bounds,
            center: DVector::from_column_slice(q0),
            plan: Vec::new(),
            costs: Vec::new(),
            update: 0,
            rec,
        };
        pg.plan = pg.plan_update();
        Ok(pg)
    }

    /// The step size of update m.
    pub fn alpha(&self, m: usize) -> f64 {
        self.alpha0 / ((m + 1) as f64).powf(self.cfg.decay)
    }

    /// The current iterate q_m.
    pub fn center(&self) -> &[f64] {
        self.center.as_slice()
    }

    fn clipped(&self, mut q: DVector<f64>) -> DVector<f64> {
        if let Some(b) = &self.bounds {
            b.clip(q.as_mut_slice());
        }
        q
    }

    fn plan_update(&self) -> Vec<DVector<f64>> {
        let mut plan = Vec::with_capacity(2 * self.n + 1);
        if self.cfg.evaluate_center {
            plan.push(self.center.clone());
        }
        for i in 0..self.n {
            for sign in [1.0, -1.0] {
                let mut q = self.center.clone();
                q[i] += sign * self.delta;
                plan.push(self.clipped(q));
            }
        }
        plan
    }

    fn cost(&self, eps: &[f64]) -> f64 {
        eps.iter().map(|e| (e / self.cfg.scale).powi(2)).sum()
    }
}

impl AskTell for PolicyGradient {
    fn dim(&self) -> usize {
        self.n
    }

    fn ask(&mut self) -> Result<Vec<f64>> {
        self.rec
            .ask_with(|| self.plan[self.costs.len()].as_slice().to_vec())
    }

    fn tell(&mut self, q: &[f64], eps: &[f64]) -> Result<()> {
        self.rec.check_tell(q, eps, "eps", &[self.n])?;
        self.rec.push(eps, max_abs(eps))?;
        if max_abs(eps) < self.cfg.tol {
            self.rec.finish_tell(Some(Status::Converged));
            return Ok(());
        }
        self.costs.push(self.cost(eps));
        let mut stop = None;
        if self.costs.len() == self.plan.len() {
            let off = usize::from(self.cfg.evaluate_center);
            let grad = DVector::from_fn(self.n, |i, _| {
                let (p, m) = (&self.plan[off + 2 * i], &self.plan[off + 2 * i + 1]);
                let h = p[i] - m[i]; // 2 delta unless a limit clipped a probe
                if h > 0.0 {
                    (self.costs[off + 2 * i] - self.costs[off + 2 * i + 1]) / h
                } else {
                    0.0
                }
            });
            let alpha = self.alpha(self.update);
            self.center = self.clipped(&self.center - alpha * &grad);
            self.update += 1;
            if let Some(b) = &mut self.bounds {
                let push: Vec<f64> = grad.iter().map(|g| -g).collect();
                stop = b.observe(self.center.as_slice(), &push);
            }
            self.costs.clear();
            self.plan = self.plan_update();
        }
        let next = self.plan[self.costs.len()].as_slice();
        self.rec
            .finish_tell(stop.or_else(|| diverged_unless_finite(next)));
        Ok(())
    }

    fn record(&self) -> &Record {
        &self.rec
    }
}
