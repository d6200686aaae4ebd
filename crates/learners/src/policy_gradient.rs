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

use crate::ask_tell::{AskTell, Record, Status, max_abs};
use crate::bounds::Bounds;
use crate::error::{LearnerError, Result, check_scalar, check_vector};

/// Spall's decay exponent for the SPSA/Kiefer-Wolfowitz gain sequence.
pub const DECAY: f64 = 0.602;

#[derive(Debug, Clone)]
pub struct PolicyGradientConfig {
    /// alpha0 in alpha_m = alpha0 / (m+1)^decay. alpha0 = s^2 / 2 makes the first step a Newton
    /// step on the ideal map q_a = q.
    pub alpha0: f64,
    pub decay: f64,
    /// The finite-difference step d (query units).
    pub delta: f64,
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

#[derive(Debug, Clone)]
pub struct PolicyGradient {
    n: usize,
    cfg: PolicyGradientConfig,
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
        if n == 0 {
            return Err(LearnerError::Dimension {
                name: "q0",
                expected: "at least 1 entry".into(),
                got: "0 entries".into(),
            });
        }
        check_vector("q0", q0, n)?;
        check_scalar("alpha0", cfg.alpha0, true)?;
        check_scalar("decay", cfg.decay, true)?;
        if cfg.decay > 1.0 || cfg.decay <= 0.5 {
            // Robbins-Monro: sum alpha diverges only for decay <= 1, sum alpha^2 converges only for decay > 1/2.
            return Err(crate::error::invalid(
                "decay",
                cfg.decay,
                "must lie in (0.5, 1] (Robbins-Monro)",
            ));
        }
        check_scalar("delta", cfg.delta, true)?;
        check_scalar("scale", cfg.scale, true)?;
        check_scalar("tol", cfg.tol, true)?;
        let bounds = Bounds::new(cfg.low.as_deref(), cfg.high.as_deref(), n, cfg.pin_limit)?;
        if let Some(b) = &bounds {
            b.check_inside("q0", q0)?;
        }
        let rec = Record::new(cfg.max_trials)?;
        let mut pg = Self {
            n,
            cfg,
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
        self.cfg.alpha0 / ((m + 1) as f64).powf(self.cfg.decay)
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
                q[i] += sign * self.cfg.delta;
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
        if let Some(q) = self.rec.pending_or_running()? {
            return Ok(q);
        }
        let q = self.plan[self.costs.len()].as_slice().to_vec();
        Ok(self.rec.set_pending(q))
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
        self.rec.finish_tell(stop);
        Ok(())
    }

    fn record(&self) -> &Record {
        &self.rec
    }
}
