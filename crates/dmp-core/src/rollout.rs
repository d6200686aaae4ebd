//! Integration of the DMP (docs/method.md §2.4): explicit Euler at a fixed step from `x = 1`,
//! `y = y0`, `z = 0` (the movement starts at rest), for one DMP or many in parallel. A rollout
//! is the [`Stepper`] run open loop, its samples written in place into the arrays it returns.

use rayon::prelude::*;

use crate::dmp::Dmp;
use crate::error::{Error, Result, check_scalar, fmt_g};
use crate::euler::{MAX_SUBSTEPS, STABILITY_MARGIN, stable_step, substeps_needed};
use crate::stepper::{Rows, Stepper, StepperOptions};

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

/// A [`Trajectory`] being written sample by sample, its arrays allocated for a number of
/// samples up front (and doubled if a rollout goes on until rest), so that each sample is
/// written in place: no allocation per sample, no copy on the way out.
struct Samples {
    t: Vec<f64>,
    y: Vec<f64>,
    yd: Vec<f64>,
    ydd: Vec<f64>,
    n_dof: usize,
}

impl Samples {
    fn new(capacity: usize, n_dof: usize) -> Self {
        Self {
            t: vec![0.0; capacity],
            y: vec![0.0; capacity * n_dof],
            yd: vec![0.0; capacity * n_dof],
            ydd: vec![0.0; capacity * n_dof],
            n_dof,
        }
    }

    /// Sample `j` (at `t = j dt`), to be written.
    #[inline(always)]
    fn row(&mut self, j: usize, dt: f64) -> Rows<'_> {
        if j == self.t.len() {
            let grown = 2 * j.max(1);
            self.t.resize(grown, 0.0);
            for v in [&mut self.y, &mut self.yd, &mut self.ydd] {
                v.resize(grown * self.n_dof, 0.0);
            }
        }
        self.t[j] = j as f64 * dt;
        // the row and the rows after it, which are written later (see `Rows`)
        let from = j * self.n_dof;
        Rows {
            y: &mut self.y[from..],
            yd: &mut self.yd[from..],
            ydd: &mut self.ydd[from..],
        }
    }

    /// The first `samples` samples.
    fn into_trajectory(mut self, samples: usize) -> Trajectory {
        self.t.truncate(samples);
        for v in [&mut self.y, &mut self.yd, &mut self.ydd] {
            v.truncate(samples * self.n_dof);
        }
        Trajectory {
            t: self.t,
            y: self.y,
            yd: self.yd,
            ydd: self.ydd,
            n_dof: self.n_dof,
        }
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

/// The most work a rollout may take, in state updates: each Euler (sub-)step updates the phase
/// with its kernel activations and every DOF, `n_dof + 1` of them. Like [`MAX_VALUES`] for
/// memory, it bounds the time (a few seconds on one core) of a mistyped duration or of a stiff
/// DMP at a coarse `dt`; every rollout within [`MAX_VALUES`] without sub-steps stays within it.
pub const MAX_WORK: f64 = 5e7;

/// Refuses a rollout of `steps` steps (`steps + 1` samples) of `width` values each beyond
/// [`MAX_VALUES`] per array (and a NaN step count): `dt` is too small for its duration.
pub(crate) fn check_values(steps: f64, width: usize, dt: f64) -> Result<()> {
    let values = (steps + 1.0) * width as f64;
    if values.is_nan() || values > MAX_VALUES as f64 {
        return Err(Error::InvalidParameter {
            name: "dt",
            value: fmt_g(dt),
            requirement: "is too small for the duration: the rollout would exceed 20 million values",
        });
    }
    Ok(())
}

/// The most steps a rollout of `steps` steps may take: with `until_rest`, on to
/// [`REST_HORIZON_TAUS`] times `tau` more.
pub(crate) fn max_steps(steps: f64, until_rest: bool, tau: f64, dt: f64) -> f64 {
    if until_rest {
        steps + n_steps(REST_HORIZON_TAUS * tau, dt)
    } else {
        steps
    }
}

/// Refuses a rollout of `steps` Euler (sub-)steps of `n_dof` DOFs beyond [`MAX_WORK`];
/// `context` names the rollout.
pub(crate) fn check_work(steps: f64, n_dof: usize, context: &'static str) -> Result<()> {
    let work = steps * (n_dof + 1) as f64;
    if work.is_nan() || work > MAX_WORK {
        return Err(Error::Numerical {
            context,
            detail: format!(
                "the rollout would take {} Euler steps of {} DOFs, more than the {} state updates \
                 a rollout may take (a few seconds); use a larger dt or a shorter duration, or a \
                 larger tau or smaller alpha_z, which need fewer sub-steps",
                fmt_g(steps),
                n_dof,
                fmt_g(MAX_WORK)
            ),
        });
    }
    Ok(())
}

impl Dmp {
    /// Integrates eqs. 1-3 with explicit Euler and returns positions, velocities `z / tau` and
    /// accelerations `dz/dt / tau` at `t_j = j dt`.
    ///
    /// When `dt` is beyond the stability limit of explicit Euler for this DMP ([`stable_step`]),
    /// each sample interval is integrated in the fewest equal sub-steps that are stable; at most
    /// [`MAX_SUBSTEPS`], beyond which the rollout is refused. Within the limit nothing changes.
    /// A trajectory that still overflows (a goal of 1e308, say) is an error, never returned.
    ///
    /// A DMP with a final velocity (docs/method.md §2.8) pulls to the moving goal `g_m = g - gd
    /// (tau - t)`, `t` taken from the phase, and damps towards `z = tau gd`; it never rests, so
    /// `until_rest` is refused for it.
    pub fn rollout(&self, opts: &RolloutOptions) -> Result<Trajectory> {
        if self.final_velocity().is_some() && opts.until_rest {
            return Err(Error::InvalidParameter {
                name: "until_rest",
                value: "true".into(),
                requirement: "must be false for a DMP with a final velocity: it moves on at \
                              that velocity past tau and never rests (docs/method.md §2.8)",
            });
        }
        opts.validate()?;
        let duration = opts.duration.unwrap_or(self.tau());
        let steps = n_steps(duration, opts.dt);
        let n = self.n_dof();
        let max_steps = max_steps(steps, opts.until_rest, self.tau(), opts.dt);
        check_values(steps, n, opts.dt)?;
        let substeps = self.substeps(opts.dt)?;
        check_work((steps + 1.0) * substeps as f64, n, "DMP rollout")?;
        // The rollout is the stepper run open loop: no measurement, no goal filter, no limits.
        let mut stepper = Stepper::new(
            self,
            &StepperOptions {
                substeps: Some(substeps),
                alpha_e: vec![],
                goal_filter: None,
                rest_tol: opts.rest_tol,
                ..StepperOptions::new(opts.dt)
            },
        )?;
        let mut out = Samples::new(steps as usize + 1, n);
        let mut step = 0usize;
        loop {
            let row = out.row(step, opts.dt);
            stepper.step_into(row)?;
            let past_end = step as f64 >= steps;
            if past_end && (!opts.until_rest || stepper.done()) {
                break;
            }
            if past_end {
                // Going on until rest: the work beyond `steps` was not bounded up front.
                check_work(((step + 2) * substeps) as f64, n, "DMP rollout")?;
            }
            if step as f64 >= max_steps || (step + 1) * n >= MAX_VALUES {
                return Err(Error::Numerical {
                    context: "DMP rollout",
                    detail: format!(
                        "not at rest within {REST_HORIZON_TAUS} tau past the duration (rest_tol = {})",
                        fmt_g(opts.rest_tol)
                    ),
                });
            }
            step += 1;
        }
        let out = out.into_trajectory(step + 1);
        check_trajectory(&out, "DMP rollout")?;
        Ok(out)
    }

    /// Euler sub-steps per sample that keep the integration stable (1 when `dt` already is).
    fn substeps(&self, dt: f64) -> Result<usize> {
        let k = substeps_needed(self.config(), self.tau(), dt);
        if k.is_nan() || k > MAX_SUBSTEPS as f64 {
            return Err(self.too_coarse(dt, k, "at most 1000 are taken"));
        }
        Ok(k as usize)
    }

    fn too_coarse(&self, dt: f64, substeps: f64, why: &str) -> Error {
        let cfg = self.config();
        Error::Numerical {
            context: "DMP rollout",
            detail: format!(
                "dt = {} is too coarse for tau = {}, alpha_z = {}, beta_z = {} and alpha_x = {}: \
                 explicit Euler is stable only for steps below {} s, which needs {} sub-steps per \
                 sample ({why}); use a smaller dt, a larger tau or a smaller alpha_z",
                fmt_g(dt),
                fmt_g(self.tau()),
                fmt_g(cfg.alpha_z),
                fmt_g(cfg.beta_z),
                fmt_g(cfg.alpha_x),
                fmt_g(
                    stable_step(cfg.alpha_z, cfg.beta_z, cfg.alpha_x) * self.tau()
                        / STABILITY_MARGIN
                ),
                fmt_g(substeps),
            ),
        }
    }
}

/// A rollout whose values overflowed (a huge goal or weights) is an error, not a result.
///
/// Only the last sample needs a look: the recurrence only adds and multiplies, so once a state
/// is NaN or infinite every later one is too. The first offender is searched for the message.
pub(crate) fn check_trajectory(tr: &Trajectory, context: &'static str) -> Result<()> {
    let last = tr.y.len() - tr.n_dof;
    let finite = |v: &Vec<f64>| v[last..].iter().all(|v| v.is_finite());
    if finite(&tr.y) && finite(&tr.yd) && finite(&tr.ydd) {
        return Ok(());
    }
    for (name, v) in [("y", &tr.y), ("yd", &tr.yd), ("ydd", &tr.ydd)] {
        if let Some(i) = v.iter().position(|v| !v.is_finite()) {
            let (j, d) = (i / tr.n_dof, i % tr.n_dof);
            return Err(Error::Numerical {
                context,
                detail: format!(
                    "{name}[{j}, {d}] at t = {} is {}: the goal, start or weights are too large for f64",
                    fmt_g(tr.t[j]),
                    fmt_g(v[i])
                ),
            });
        }
    }
    Ok(())
}

/// Rolls out many DMPs in parallel (rayon). Each rollout is independent, so the result is the
/// same, bit for bit, as rolling them out one by one.
pub fn rollout_batch(dmps: &[Dmp], opts: &RolloutOptions) -> Result<Vec<Trajectory>> {
    opts.validate()?;
    dmps.par_iter().map(|d| d.rollout(opts)).collect()
}

#[cfg(test)]
mod final_velocity_tests {
    use nalgebra::{DMatrix, DVector};

    use super::*;
    use crate::dmp::{Demonstration, DmpConfig, FinalVelocity};
    use crate::stepper::{Stepper, StepperOptions};

    fn shaped(n_dof: usize) -> Dmp {
        let cfg = DmpConfig::default();
        let w = DMatrix::from_fn(cfg.n_basis, n_dof, |k, d| {
            40.0 * libm::sin(0.7 * k as f64 + d as f64)
        });
        let goal = DVector::from_fn(n_dof, |d, _| 1.0 - 0.3 * d as f64);
        Dmp::new(cfg, w, goal, DVector::zeros(n_dof), 0.8).unwrap()
    }

    /// The last sample's distance from the goal and from the final velocity, largest over DOFs.
    fn final_errors(dmp: &Dmp, dt: f64) -> (f64, f64) {
        let tr = dmp.rollout(&RolloutOptions::new(dt)).unwrap();
        let last = tr.y.len() - tr.n_dof;
        let gd = dmp.final_velocity().unwrap();
        (0..tr.n_dof).fold((0.0f64, 0.0f64), |(ep, ev), d| {
            (
                ep.max((tr.y[last + d] - dmp.goal()[d]).abs()),
                ev.max((tr.yd[last + d] - gd[d]).abs()),
            )
        })
    }

    #[test]
    fn a_zero_final_velocity_is_todays_dmp() {
        let dmp = shaped(3);
        let same = dmp.with_final_velocity(DVector::zeros(3)).unwrap();
        assert_eq!(same, dmp);
        assert!(same.final_velocity().is_none());
    }

    /// Without a forcing term the spring alone tracks the moving goal: its transient from rest,
    /// `(1 + a) e^-a` with `a = alpha_z / 2` at tau, is below 1e-9, and Euler tracks a ramp with
    /// its velocity fed forward exactly, so the request is met to rounding at any dt.
    #[test]
    fn the_spring_alone_meets_the_request() {
        let cfg = DmpConfig::default();
        let goal = DVector::from_vec(vec![1.0, -0.5]);
        let dmp = Dmp::new(
            cfg,
            DMatrix::zeros(cfg.n_basis, 2),
            goal,
            DVector::zeros(2),
            0.8,
        )
        .unwrap()
        .with_final_velocity(DVector::from_vec(vec![0.8, -1.5]))
        .unwrap();
        for dt in [1e-3, 4e-3, 0.02] {
            let (position, velocity) = final_errors(&dmp, dt);
            assert!(
                position < 1e-8 && velocity < 1e-7,
                "{position} {velocity} at {dt}"
            );
        }
    }

    #[test]
    fn a_demonstration_ending_in_motion_is_reproduced() {
        // Min-jerk from rest at 0 to 1 plus v T (s^5 - s^4), s = t / T: the end position is
        // still 1, the end velocity v (closed form, no integrator involved).
        let (big_t, v, n) = (1.2, 0.9, 1201);
        let t: Vec<f64> = (0..n).map(|j| big_t * j as f64 / (n - 1) as f64).collect();
        let pos = |s: f64| {
            let s3 = s * s * s;
            10.0 * s3 - 15.0 * s3 * s + 6.0 * s3 * s * s + v * big_t * (s3 * s * s - s3 * s)
        };
        let y = DMatrix::from_fn(1, n, |_, j| pos(t[j] / big_t));
        let demo = Demonstration {
            t: &t,
            y: y.as_view(),
            yd: None,
            ydd: None,
        };
        let cfg = DmpConfig {
            n_basis: 40,
            ..DmpConfig::default()
        };
        let given = FinalVelocity::Given(DVector::from_element(1, v));
        let dmp = Dmp::fit_with_final_velocity(&demo, cfg, given).unwrap();
        let from_demo = Dmp::fit_with_final_velocity(&demo, cfg, FinalVelocity::FromDemo).unwrap();
        assert!((from_demo.final_velocity().unwrap()[0] - v).abs() < 1e-4);
        let tr = dmp.rollout(&RolloutOptions::new(1e-3)).unwrap();
        let worst = (0..n)
            .map(|j| (tr.y[j] - y[(0, j)]).abs())
            .fold(0.0, f64::max);
        assert!(worst < 1e-2, "largest reproduction error {worst}");
        assert!(
            (tr.yd[n - 1] - v).abs() < 2e-2,
            "final velocity {}",
            tr.yd[n - 1]
        );
    }

    /// Bit for bit, as without a final velocity: the rollout is the stepper run open loop.
    #[test]
    fn the_stepper_is_the_rollout() {
        let dmp = shaped(3)
            .with_final_velocity(DVector::from_vec(vec![0.5, 0.0, -2.0]))
            .unwrap();
        for dt in [1e-3, 0.02] {
            let tr = dmp
                .rollout(&RolloutOptions {
                    duration: Some(1.5 * dmp.tau()),
                    ..RolloutOptions::new(dt)
                })
                .unwrap();
            let opts = StepperOptions {
                goal_filter: None,
                ..StepperOptions::new(dt)
            };
            let mut stepper = Stepper::new(&dmp, &opts).unwrap();
            for j in 0..tr.n_samples() {
                let (y, yd, _) = stepper.step(None).unwrap();
                for d in 0..3 {
                    assert_eq!(
                        y[d].to_bits(),
                        tr.y[j * 3 + d].to_bits(),
                        "sample {j} at {dt}"
                    );
                    assert_eq!(
                        yd[d].to_bits(),
                        tr.yd[j * 3 + d].to_bits(),
                        "sample {j} at {dt}"
                    );
                }
            }
        }
    }

    #[test]
    fn until_rest_is_refused_by_name() {
        let dmp = shaped(1)
            .with_final_velocity(DVector::from_element(1, 1.0))
            .unwrap();
        let opts = RolloutOptions {
            until_rest: true,
            ..RolloutOptions::new(1e-3)
        };
        let err = dmp.rollout(&opts).unwrap_err().to_string();
        assert!(err.contains("until_rest"), "{err}");
        let bad = dmp.with_final_velocity(DVector::from_element(2, 1.0));
        assert!(bad.unwrap_err().to_string().contains("final_velocity"));
    }
}
