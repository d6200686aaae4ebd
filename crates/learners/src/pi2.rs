//! PI², policy improvement with path integrals, over the flat DMP weight vector (Theodorou,
//! Buchli, Schaal 2010 and Schaal's `runPI2Learning.m`; docs/method.md §7.2).
//!
//! One update = 1 noiseless evaluation rollout + K rollouts (after the first update, K - n_reuse
//! new ones and the n_reuse best of the previous batch):
//! ```text
//! theta_k      = theta + eps_k,  eps_k ~ N(0, (sigma * max(0.1, (U - u)/U))^2)   linear annealing
//! S_{i,k}      = sum_{j >= i} r_{j,k}            cost-to-go (a terminal cost phi_k: S_{i,k} = phi_k)
//! P_{i,k}      = exp(-h (S_{i,k} - min_k S_{i,k}) / (max_k S_{i,k} - min_k S_{i,k})), normalized over k
//! dtheta_i     = sum_k P_{i,k} M_i eps_k,   M_i = g_i g_i^T / (g_i^T g_i)   (projection; optional)
//! g_i          = Psi(x_i) x_i / sum Psi(x_i)   the basis vector of paper eq. 4 at step i
//! [dtheta]_j   = sum_i (T - i) Psi_j(x_i) [dtheta_i]_j / sum_i (T - i) Psi_j(x_i)   time averaging
//! theta       += dtheta
//! ```
//! Decisions \[D\]: the exploration noise is constant during a rollout (Kober's and Stulp's
//! episodic setting; the costs can still vary per step); a reused rollout's eps is recomputed
//! against the current theta (it executed theta_k, so eps_k = theta_k - theta); the weights are
//! laid out DOF-major, theta[d * N + j] = w_{d, j} (a (D, N) array flattened in C order), and
//! all DOFs share the phase x_i = exp(-alpha_x i / (T - 1)), i = 0..T-1.
//!
//! With a terminal-only cost S_{i,k} = phi_k for all i, so P_{i,k} = P_k, and without the
//! projection the time average of identical dtheta_i is dtheta itself: the update is
//! theta += sum_k P_k eps_k, PI^BB (Stulp & Sigaud 2012) — tested. With the projection on it is
//! not: M_i is not the identity, so each weight receives a kernel-weighted blend of the
//! neighbouring components of sum_k P_k eps_k (docs/method.md §7.2 states the reduction without this
//! caveat).
//!
//! `tell(theta, costs)`: one terminal cost, or T costs r_0..r_{T-1} (the last includes any
//! terminal cost). Converged once an evaluation rollout's total cost is <= `cost_tol`.

use dmp_core::Basis;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use crate::ask_tell::{AskTell, Record, Status, diverged_unless_finite};
use crate::error::{LearnerError, Result, check_scalar, check_vector, invalid};
use crate::power::per_parameter;

#[derive(Debug, Clone)]
pub struct Pi2Config {
    /// K, rollouts per update.
    pub n_rollouts: usize,
    pub n_reuse: usize,
    /// h, the temperature of the exponentiated cost.
    pub h: f64,
    /// U, the annealing horizon in updates.
    pub n_updates: usize,
    pub n_dof: usize,
    /// T, the time steps per rollout.
    pub n_steps: usize,
    pub alpha_x: f64,
    pub width_factor: f64,
    pub projection: bool,
    pub cost_tol: Option<f64>,
    pub max_trials: usize,
    pub seed: u64,
}

impl Default for Pi2Config {
    fn default() -> Self {
        Self {
            n_rollouts: 10,
            n_reuse: 5,
            h: 10.0,
            n_updates: 20,
            n_dof: 1,
            n_steps: 100,
            alpha_x: 2.0,
            width_factor: 2.0,
            projection: true,
            cost_tol: None,
            max_trials: 200,
            seed: 0,
        }
    }
}

/// The largest n_steps x n_basis accepted: PI² keeps two tables of that many floats (g_i and
/// the time-averaging weights) and walks them on every update. 10^7 entries (160 MB) is far
/// beyond any rollout a robot executes (10^5 steps of 1 ms with 100 kernels), and refusing
/// larger sizes turns an allocation abort or minutes of work into a clear error.
pub const MAX_TABLE_ENTRIES: usize = 10_000_000;

/// The reference code's floor on the annealed noise.
const MIN_NOISE_MULT: f64 = 0.1;

#[derive(Debug, Clone)]
struct Rollout {
    theta: Vec<f64>,
    /// S_{i}, the cost-to-go per time step.
    cost_to_go: Vec<f64>,
}

#[derive(Debug, Clone)]
pub struct Pi2 {
    theta: Vec<f64>,
    sigma: Vec<f64>,
    cfg: Pi2Config,
    n_basis: usize,
    /// g_i per time step (length N each).
    g: Vec<Vec<f64>>,
    /// (T - i) Psi_j(x_i): time-averaging weights, [i][j].
    time_w: Vec<Vec<f64>>,
    batch: Vec<Rollout>,
    /// Rollouts of this update told so far (reused ones included).
    need_eval: bool,
    pending_is_eval: bool,
    update: usize,
    rng: ChaCha8Rng,
    rec: Record,
}

impl Pi2 {
    /// `sigma`: the exploration standard deviation, one entry or one per weight.
    pub fn new(theta0: &[f64], sigma: &[f64], cfg: Pi2Config) -> Result<Self> {
        let dim = theta0.len();
        if cfg.n_dof == 0 {
            return Err(invalid("n_dof", 0, "must be at least 1"));
        }
        if dim == 0 || !dim.is_multiple_of(cfg.n_dof) || dim / cfg.n_dof < 2 {
            return Err(LearnerError::Dimension {
                name: "theta0",
                expected: format!(
                    "n_dof * n_basis entries with n_dof = {} and n_basis >= 2",
                    cfg.n_dof
                ),
                got: format!("{dim} entries"),
            });
        }
        check_vector("theta0", theta0, dim)?;
        let sigma = per_parameter(sigma, dim)?;
        if cfg.n_rollouts < 2 {
            return Err(invalid("n_rollouts", cfg.n_rollouts, "must be at least 2"));
        }
        if cfg.n_reuse >= cfg.n_rollouts {
            return Err(invalid(
                "n_reuse",
                cfg.n_reuse,
                &format!("must be < n_rollouts = {}", cfg.n_rollouts),
            ));
        }
        check_scalar("h", cfg.h, true)?;
        if cfg.n_updates == 0 {
            return Err(invalid("n_updates", 0, "must be at least 1"));
        }
        if cfg.n_steps < 2 {
            return Err(invalid("n_steps", cfg.n_steps, "must be at least 2"));
        }
        let n_basis = dim / cfg.n_dof;
        if cfg.n_steps.saturating_mul(n_basis) > MAX_TABLE_ENTRIES {
            return Err(invalid(
                "n_steps",
                cfg.n_steps,
                &format!(
                    "n_steps x n_basis = {} x {n_basis} exceeds {MAX_TABLE_ENTRIES}: PI² tabulates \
                     the basis at every time step, and no rollout has that many steps",
                    cfg.n_steps
                ),
            ));
        }
        if let Some(t) = cfg.cost_tol {
            check_scalar("cost_tol", t, false)?;
        }
        let basis = Basis::new(n_basis, cfg.alpha_x, cfg.width_factor)
            .map_err(|e| invalid("basis", e, "alpha_x and width_factor must be > 0"))?;
        let t = cfg.n_steps;
        let mut g = Vec::with_capacity(t);
        let mut time_w = Vec::with_capacity(t);
        for i in 0..t {
            let x = (-cfg.alpha_x * i as f64 / (t - 1) as f64).exp();
            let mut psi = vec![0.0; n_basis];
            let range = basis.normalized_activations(x, &mut psi);
            for (j, p) in psi.iter_mut().enumerate() {
                if !range.contains(&j) {
                    *p = 0.0;
                }
            }
            g.push(psi.iter().map(|p| p * x).collect());
            time_w.push(psi.iter().map(|p| (t - i) as f64 * p).collect());
        }
        Ok(Self {
            theta: theta0.to_vec(),
            sigma,
            n_basis,
            g,
            time_w,
            batch: Vec::new(),
            need_eval: true,
            pending_is_eval: false,
            update: 0,
            rng: ChaCha8Rng::seed_from_u64(cfg.seed),
            rec: Record::new(cfg.max_trials)?,
            cfg,
        })
    }

    /// The current theta.
    pub fn theta(&self) -> &[f64] {
        &self.theta
    }

    /// Updates completed.
    pub fn n_updates_done(&self) -> usize {
        self.update
    }

    /// Whether the query `ask` returned last is an update's noiseless evaluation rollout (of the
    /// current theta) rather than an exploration rollout.
    pub fn asked_evaluation(&self) -> bool {
        self.pending_is_eval
    }

    fn noise_mult(&self) -> f64 {
        let u = self.cfg.n_updates as f64;
        ((u - self.update as f64) / u).max(MIN_NOISE_MULT)
    }

    fn cost_to_go(&self, costs: &[f64]) -> Vec<f64> {
        let t = self.cfg.n_steps;
        if costs.len() == 1 {
            return vec![costs[0]; t];
        }
        let mut s = vec![0.0; t];
        let mut acc = 0.0;
        for i in (0..t).rev() {
            acc += costs[i];
            s[i] = acc;
        }
        s
    }

    /// The PI² update from the current batch (the formulas of the module docs).
    fn improve(&mut self) {
        let (t, n, k) = (self.cfg.n_steps, self.n_basis, self.batch.len());
        let eps: Vec<Vec<f64>> = self
            .batch
            .iter()
            .map(|r| {
                r.theta
                    .iter()
                    .zip(&self.theta)
                    .map(|(a, b)| a - b)
                    .collect()
            })
            .collect();
        let mut num = vec![0.0; self.theta.len()];
        let mut den = vec![0.0; self.theta.len()];
        let mut p = vec![0.0; k];
        for i in 0..t {
            let s: Vec<f64> = self.batch.iter().map(|r| r.cost_to_go[i]).collect();
            let (lo, hi) = s
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
                    (l.min(v), h.max(v))
                });
            for (pk, sk) in p.iter_mut().zip(&s) {
                *pk = if hi > lo {
                    (-self.cfg.h * (sk - lo) / (hi - lo)).exp()
                } else {
                    1.0
                };
            }
            let total: f64 = p.iter().sum();
            for d in 0..self.cfg.n_dof {
                // v = sum_k P_k eps_k for this DOF; M_i is linear, so M_i v = sum_k P_k M_i eps_k.
                let mut v = vec![0.0; n];
                for (kk, e) in eps.iter().enumerate() {
                    for j in 0..n {
                        v[j] += p[kk] / total * e[d * n + j];
                    }
                }
                if self.cfg.projection {
                    let gi = &self.g[i];
                    let gg: f64 = gi.iter().map(|x| x * x).sum();
                    let gv: f64 = gi.iter().zip(&v).map(|(a, b)| a * b).sum();
                    for j in 0..n {
                        v[j] = if gg > 0.0 { gi[j] * gv / gg } else { 0.0 };
                    }
                }
                for j in 0..n {
                    num[d * n + j] += self.time_w[i][j] * v[j];
                    den[d * n + j] += self.time_w[i][j];
                }
            }
        }
        for (th, (a, b)) in self.theta.iter_mut().zip(num.iter().zip(&den)) {
            if *b > 0.0 {
                *th += a / b;
            }
        }
        // Keep the n_reuse cheapest rollouts (by total cost S_0) for the next batch.
        let mut batch = std::mem::take(&mut self.batch);
        batch.sort_by(|a, b| a.cost_to_go[0].total_cmp(&b.cost_to_go[0]));
        batch.truncate(self.cfg.n_reuse);
        self.batch = batch;
        self.update += 1;
    }
}

impl AskTell for Pi2 {
    fn dim(&self) -> usize {
        self.theta.len()
    }

    fn ask(&mut self) -> Result<Vec<f64>> {
        let mult = self.noise_mult();
        let (theta, sigma, rng) = (&self.theta, &self.sigma, &mut self.rng);
        let (need_eval, pending_is_eval) = (self.need_eval, &mut self.pending_is_eval);
        self.rec.ask_with(|| {
            *pending_is_eval = need_eval;
            if need_eval {
                return theta.clone();
            }
            (0..theta.len())
                .map(|p| {
                    let z: f64 = StandardNormal.sample(rng);
                    theta[p] + sigma[p] * mult * z
                })
                .collect()
        })
    }

    fn tell(&mut self, theta: &[f64], costs: &[f64]) -> Result<()> {
        self.rec
            .check_tell(theta, costs, "costs", &[1, self.cfg.n_steps])?;
        let cost_to_go = self.cost_to_go(costs);
        self.rec.push(costs, cost_to_go[0])?;
        let mut stop = None;
        if self.pending_is_eval {
            self.need_eval = false;
            if self.cfg.cost_tol.is_some_and(|tol| cost_to_go[0] <= tol) {
                stop = Some(Status::Converged);
            }
        } else {
            self.batch.push(Rollout {
                theta: theta.to_vec(),
                cost_to_go,
            });
            if self.batch.len() == self.cfg.n_rollouts {
                self.improve();
                self.need_eval = true;
            }
        }
        self.rec
            .finish_tell(stop.or_else(|| diverged_unless_finite(&self.theta)));
        Ok(())
    }

    fn record(&self) -> &Record {
        &self.rec
    }
}
