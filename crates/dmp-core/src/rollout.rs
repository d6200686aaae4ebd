//! Integration of the DMP (method.md §2.4): explicit Euler at a fixed step from `x = 1`,
//! `y = y0`, `z = 0` (the movement starts at rest), for one DMP or many in parallel.

use rayon::prelude::*;

use crate::dmp::Dmp;
use crate::error::{Error, Result, check_scalar};

/// Rollouts longer than this many values per array (samples x DOFs) are refused rather than
/// exhausting memory on a mistyped `dt`.
pub const MAX_VALUES: usize = 20_000_000;
/// How far past `duration` an `until_rest` rollout may run, in units of tau. The spring settles
/// with time constant tau / 24 and the forcing decays as exp(-alpha_x t / tau), so rest within the
/// default tolerance comes long before this.
pub(crate) const REST_HORIZON_TAUS: f64 = 50.0;

/// When and how finely to integrate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RolloutOptions {
    /// Integration and sampling step (s).
    pub dt: f64,
    /// Length of the rollout (s); `None` means tau.
    pub duration: Option<f64>,
    /// Keep integrating past `duration` until the system is at rest: for every DOF
    /// `|g - y| <= rest_tol`, `|tau * yd| <= rest_tol`, and the forcing term can no longer move
    /// it by more than `rest_tol` (`x max|w| / (alpha_z beta_z) <= rest_tol`).
    pub until_rest: bool,
    /// Position tolerance for `until_rest`, in the units of y.
    pub rest_tol: f64,
}

impl RolloutOptions {
    pub fn new(dt: f64) -> Self {
        Self {
            dt,
            duration: None,
            until_rest: false,
            rest_tol: 1e-4,
        }
    }

    pub fn validate(&self) -> Result<()> {
        check_scalar("dt", self.dt, true)?;
        if let Some(d) = self.duration {
            check_scalar("duration", d, true)?;
        }
        check_scalar("rest_tol", self.rest_tol, true)
    }
}

/// A sampled trajectory, time-major: `y[j * n_dof + d]` is DOF d at `t[j]`.
#[derive(Debug, Clone, PartialEq)]
pub struct Trajectory {
    pub t: Vec<f64>,
    pub y: Vec<f64>,
    pub yd: Vec<f64>,
    pub ydd: Vec<f64>,
    pub n_dof: usize,
}

impl Trajectory {
    pub fn n_samples(&self) -> usize {
        self.t.len()
    }
}

/// Number of Euler steps covering `duration`: `duration / dt` rounded when it is an integer up to
/// rounding error, else rounded up, so the rollout never stops short.
pub(crate) fn n_steps(duration: f64, dt: f64) -> f64 {
    let r = duration / dt;
    if (r - r.round()).abs() <= 1e-9 * r.max(1.0) {
        r.round()
    } else {
        r.ceil()
    }
}

impl Dmp {
    /// Integrates eqs. 1-3 with explicit Euler and returns positions, velocities `z / tau` and
    /// accelerations `dz/dt / tau` at `t_j = j dt`.
    pub fn rollout(&self, opts: &RolloutOptions) -> Result<Trajectory> {
        opts.validate()?;
        let duration = opts.duration.unwrap_or(self.tau());
        let steps = n_steps(duration, opts.dt);
        let n_dof = self.n_dof();
        let max_steps = if opts.until_rest {
            steps + n_steps(REST_HORIZON_TAUS * self.tau(), opts.dt)
        } else {
            steps
        };
        let values = (steps + 1.0) * n_dof as f64;
        // Also catches a NaN step count.
        if values.is_nan() || values > MAX_VALUES as f64 {
            return Err(Error::InvalidParameter {
                name: "dt",
                value: opts.dt.to_string(),
                requirement: "is too small for the duration: the rollout would exceed 20 million values",
            });
        }
        let capacity = (steps as usize + 1) * n_dof;
        let mut out = Trajectory {
            t: Vec::with_capacity(steps as usize + 1),
            y: Vec::with_capacity(capacity),
            yd: Vec::with_capacity(capacity),
            ydd: Vec::with_capacity(capacity),
            n_dof,
        };

        let cfg = *self.config();
        let (dt, inv_tau) = (opts.dt, 1.0 / self.tau());
        let n = cfg.n_basis;
        let goal = self.goal().as_slice();
        // N x D column-major: the weights of DOF d are the contiguous slice w[d n .. (d+1) n].
        let w = self.weights().as_slice();
        let max_w = w.iter().fold(0.0f64, |m, w| m.max(w.abs()));
        let mut y: Vec<f64> = self.y0().iter().copied().collect();
        let mut z = vec![0.0; n_dof];
        let mut x = 1.0;
        let mut psi = vec![0.0; n];
        let mut step = 0usize;
        loop {
            // The phase and its activations are shared by every DOF: once per step.
            let range = self.basis().normalized_activations(x, &mut psi);
            let psi = &psi[range.clone()];
            out.t.push(step as f64 * dt);
            let mut at_rest = x * max_w / (cfg.alpha_z * cfg.beta_z) <= opts.rest_tol;
            for d in 0..n_dof {
                let wd = &w[d * n + range.start..d * n + range.end];
                let f = x * wd.iter().zip(psi).map(|(w, p)| w * p).sum::<f64>();
                let dz = (cfg.alpha_z * (cfg.beta_z * (goal[d] - y[d]) - z[d]) + f) * inv_tau;
                let yd = z[d] * inv_tau;
                out.y.push(y[d]);
                out.yd.push(yd);
                out.ydd.push(dz * inv_tau);
                at_rest &= (goal[d] - y[d]).abs() <= opts.rest_tol && z[d].abs() <= opts.rest_tol;
                y[d] += yd * dt;
                z[d] += dz * dt;
            }
            let past_end = step as f64 >= steps;
            if past_end && (!opts.until_rest || at_rest) {
                break;
            }
            if step as f64 >= max_steps || out.y.len() >= MAX_VALUES {
                return Err(Error::Numerical {
                    context: "DMP rollout",
                    detail: format!(
                        "not at rest within {REST_HORIZON_TAUS} tau past the duration (rest_tol = {})",
                        opts.rest_tol
                    ),
                });
            }
            x -= cfg.alpha_x * x * inv_tau * dt;
            step += 1;
        }
        Ok(out)
    }
}

/// Rolls out many DMPs in parallel (rayon). Each rollout is independent, so the result is the
/// same, bit for bit, as rolling them out one by one.
pub fn rollout_batch(dmps: &[Dmp], opts: &RolloutOptions) -> Result<Vec<Trajectory>> {
    opts.validate()?;
    dmps.par_iter().map(|d| d.rollout(opts)).collect()
}
