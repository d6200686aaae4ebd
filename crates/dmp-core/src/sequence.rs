//! DMPs joined end to start without stopping (docs/method.md §2.9; after Nemec and Ude,
//! "Action sequencing using dynamic movement primitives", Robotica 30(5), 2012).
//!
//! Each movement runs on its own [`Stepper`] until its phase has run out: until the state the
//! next step starts from is at `t >= tau - dt / 2` of its own clock, read from the phase as the
//! integrator advances it ([`crate::dmp`]'s `phase_to_go`), so that unslowed the hand-over comes
//! on the sample at `t = tau`, and later when phase stopping held the movement. Then movement
//! `k + 1` starts where `k`'s integrator has arrived, with `k`'s velocity (`z = tau_{k+1} yd`):
//! position and velocity go on as one Euler step of `k` would have taken them. To its
//! `tau dz/dt` (eq. 1) a coupling term is added that makes its first acceleration the one `k`
//! would have commanded next, and then fades at the spring's own rate (critical damping:
//! `alpha_z / 2` per unit of scaled time):
//!
//! ```text
//! C(s) = C_0 exp(-alpha_z s / 2),   C_0 = tau_{k+1}^2 (ydd_k - ydd_{k+1}),   s = t / tau_{k+1}
//! ```
//!
//! with `ydd_k` movement `k`'s next command and `ydd_{k+1}` movement `k + 1`'s first unaided.
//! `s` is scaled time, so phase stopping holds the fading with the rest of the movement. By
//! `s = 1` the term and the start's transient have faded (docs/method.md §2.9), and movement
//! `k + 1` ends where its DMP's own rollout from rest at the same start ends (tested). The start
//! of a later movement's DMP is not used: it starts where the one before hands over.
//!
//! The rollout steps the stepper: one integrator for both. A sequence of one movement has no
//! join, so its stepper is that DMP's stepper and its rollout that DMP's rollout, bit for bit.

use crate::dmp::{Dmp, phase_clock};
use crate::error::{Error, Result, fmt_g};
use crate::rollout::{
    MAX_VALUES, REST_HORIZON_TAUS, RolloutOptions, Trajectory, check_trajectory, check_work,
    n_steps,
};
use crate::stepper::{Stepper, StepperOptions, check_coordinates, moving_start_refused};

/// The number of coordinates of `dmps`: at least one DMP, all with the same number.
fn check_dmps(dmps: &[Dmp]) -> Result<usize> {
    let Some(first) = dmps.first() else {
        return Err(Error::InvalidParameter {
            name: "dmps",
            value: "[]".into(),
            requirement: "must hold at least one DMP",
        });
    };
    let n = first.n_dof();
    match dmps.iter().position(|d| d.n_dof() != n) {
        Some(k) => Err(Error::Shape {
            name: "dmps",
            expected: format!("{n} DOFs in every DMP, as dmps[0] has"),
            got: format!("{} DOFs in dmps[{k}]", dmps[k].n_dof()),
        }),
        None => Ok(n),
    }
}

/// The phase at or below which `s`'s movement hands over: its integrator's phase at
/// `t = tau - dt / 2` of the nominal tau (`phase_to_go(x) = dt / (2 tau)`).
fn hand_over_phase(s: &Stepper) -> f64 {
    let (tau, dt) = (s.nominal_tau(), s.dt());
    let clock = phase_clock(tau, s.dmp().config().alpha_x, dt / s.substeps() as f64);
    libm::exp((1.0 - 0.5 * dt / tau) / clock)
}

/// The fading of the join's coupling term over one period at time scale `tau`:
/// `exp(-alpha_z dt / (2 tau))` (module docs).
fn fading(s: &Stepper, tau: f64) -> f64 {
    libm::exp(-0.5 * s.dmp().config().alpha_z * s.dt() / tau)
}

/// The movements of a sequence, stepped one control period at a time (module docs).
#[derive(Debug, Clone)]
pub struct SequenceStepper {
    steppers: Vec<Stepper>,
    active: usize,
    /// The join's coupling term, added to the active movement's `tau dz/dt` this period.
    correction: Vec<f64>,
    corrected: bool,
    /// The correction plus the caller's coupling term of this period.
    coupling: Vec<f64>,
    /// The active movement's hand-over phase and the nominal tau it is for.
    hand_over: (f64, f64),
    /// The correction's fading per period and the time scale it is for.
    fade: (f64, f64),
    steps: u64,
}

impl SequenceStepper {
    /// A stepper for `dmps` (at least one, all with the same number of DOFs), each with `opts`;
    /// the first starts at its start, at rest. Velocity and acceleration limits are refused:
    /// their temporal coupling assumes a start at rest.
    pub fn new(dmps: &[Dmp], opts: &StepperOptions) -> Result<Self> {
        let n = check_dmps(dmps)?;
        if opts.velocity_max.is_some() || opts.acceleration_max.is_some() {
            return Err(moving_start_refused());
        }
        let steppers = dmps
            .iter()
            .map(|d| Stepper::new(d, opts))
            .collect::<Result<Vec<_>>>()?;
        let mut s = Self {
            steppers,
            active: 0,
            correction: vec![0.0; n],
            corrected: false,
            coupling: vec![0.0; n],
            hand_over: (0.0, 0.0),
            fade: (0.0, 0.0),
            steps: 0,
        };
        s.reset(None)?;
        Ok(s)
    }

    /// Back to the first movement at `start` (default: its DMP's), at rest; goals set with
    /// [`SequenceStepper::set_goal`] stay set.
    pub fn reset(&mut self, start: Option<&[f64]>) -> Result<()> {
        self.steppers[0].reset(start)?;
        self.active = 0;
        self.correction.fill(0.0);
        self.corrected = false;
        self.steps = 0;
        let first = &self.steppers[0];
        self.hand_over = (hand_over_phase(first), first.nominal_tau());
        Ok(())
    }

    /// One control period: the command `(y, yd, ydd)`, after handing over to the next movement
    /// if the active one's phase has run out; `measured` and `coupling` as for
    /// [`Stepper::step_coupled`].
    pub fn step_coupled(
        &mut self,
        measured: Option<&[f64]>,
        coupling: Option<&[f64]>,
    ) -> Result<(&[f64], &[f64], &[f64])> {
        let n = self.n_dof();
        // Checked before the hand-over, so that a refused call changes nothing.
        if let Some(m) = measured {
            check_coordinates("measured", m, n)?;
        }
        if let Some(c) = coupling {
            check_coordinates("coupling", c, n)?;
        }
        if self.active + 1 < self.steppers.len() && self.phase_spent() {
            self.hand_over_to_next()?;
        }
        let stepper = &mut self.steppers[self.active];
        if !self.corrected {
            stepper.step_coupled(measured, coupling)?;
        } else {
            self.coupling.copy_from_slice(&self.correction);
            if let Some(c) = coupling {
                for (t, c) in self.coupling.iter_mut().zip(c) {
                    *t += c;
                }
            }
            stepper.step_coupled(measured, Some(&self.coupling))?;
            let tau = stepper.tau();
            if tau != self.fade.1 {
                self.fade = (fading(stepper, tau), tau);
            }
            let mut spent = true;
            for c in &mut self.correction {
                *c *= self.fade.0;
                spent &= c.abs() < f64::MIN_POSITIVE;
            }
            // Once it would only add subnormals (slow, and nothing), the term is over.
            if spent {
                self.correction.fill(0.0);
                self.corrected = false;
            }
        }
        self.steps += 1;
        Ok(self.output())
    }

    /// [`SequenceStepper::step_coupled`] without a coupling term.
    pub fn step(&mut self, measured: Option<&[f64]>) -> Result<(&[f64], &[f64], &[f64])> {
        self.step_coupled(measured, None)
    }

    /// Whether the active movement's next step starts at or past its nominal duration.
    fn phase_spent(&mut self) -> bool {
        let s = &self.steppers[self.active];
        if s.nominal_tau() != self.hand_over.1 {
            // `set_tau` moved the end (and maybe the sub-steps).
            self.hand_over = (hand_over_phase(s), s.nominal_tau());
        }
        s.steps() > 0 && s.next_phase() <= self.hand_over.0
    }

    /// Starts the next movement from the active one's state, with the join's coupling term
    /// (module docs).
    fn hand_over_to_next(&mut self) -> Result<()> {
        let (done, rest) = self.steppers.split_at_mut(self.active + 1);
        let current = &done[self.active];
        let next = &mut rest[0];
        // What the current movement would command next, with its own join's term...
        let mut probe = current.clone();
        let own = self.corrected.then_some(self.correction.as_slice());
        probe.step_coupled(None, own)?;
        next.take_over(current)?;
        // ... and what the next one commands first, unaided.
        let mut unaided = next.clone();
        unaided.step(None)?;
        let tau = next.nominal_tau();
        let (ydd_current, ydd_next) = (probe.output().2, unaided.output().2);
        for ((c, a), b) in self.correction.iter_mut().zip(ydd_current).zip(ydd_next) {
            *c = tau * tau * (a - b);
        }
        self.corrected = true;
        self.fade = (fading(next, tau), tau);
        self.hand_over = (hand_over_phase(next), tau);
        self.active += 1;
        Ok(())
    }

    /// The whole sequence open loop from the first start at rest, sampled every `dt` (the
    /// stepper's) for `duration` (default: until the last movement has run its tau), and with
    /// `until_rest` on until the last one rests at its goal. Resets this stepper first.
    pub fn rollout(&mut self, duration: Option<f64>, until_rest: bool) -> Result<Trajectory> {
        let (n, dt) = (self.n_dof(), self.dt());
        let last = self.steppers.len() - 1;
        let last_tau = self.steppers[last].nominal_tau();
        if until_rest && self.steppers[last].dmp().final_velocity().is_some() {
            return Err(Error::InvalidParameter {
                name: "until_rest",
                value: "true".into(),
                requirement: "must be false when the last DMP has a final velocity: it moves on \
                              at that velocity and never rests (docs/method.md §2.8)",
            });
        }
        // Each movement hands over on the sample nearest its tau: at most its own rollout's.
        let steps = match duration {
            Some(d) => n_steps(d, dt),
            None => self
                .steppers
                .iter()
                .map(|s| n_steps(s.nominal_tau(), dt) + 1.0)
                .sum(),
        };
        let max_steps = if until_rest {
            steps + n_steps(REST_HORIZON_TAUS * last_tau, dt)
        } else {
            steps
        };
        let values = (steps + 1.0) * n as f64;
        if values.is_nan() || values > MAX_VALUES as f64 {
            return Err(Error::InvalidParameter {
                name: "dt",
                value: fmt_g(dt),
                requirement: "is too small for the duration: the rollout would exceed 20 million values",
            });
        }
        let substeps = self.steppers.iter().map(Stepper::substeps).max();
        let substeps = substeps.expect("at least one movement") as f64;
        check_work((steps + 1.0) * substeps, n, "sequence rollout")?;
        // The last movement's own rollout has samples 0..=N at t = 0..tau.
        let last_steps = n_steps(last_tau, dt) as u64;
        self.reset(None)?;
        let capacity = (steps as usize + 1) * n;
        let mut out = Trajectory {
            t: Vec::with_capacity(steps as usize + 1),
            y: Vec::with_capacity(capacity),
            yd: Vec::with_capacity(capacity),
            ydd: Vec::with_capacity(capacity),
            n_dof: n,
        };
        let mut j = 0usize;
        loop {
            let (y, yd, ydd) = self.step(None)?;
            out.t.push(j as f64 * dt);
            out.y.extend_from_slice(y);
            out.yd.extend_from_slice(yd);
            out.ydd.extend_from_slice(ydd);
            let past_end = match duration {
                Some(_) => j as f64 >= steps,
                None => self.active == last && self.steppers[last].steps() > last_steps,
            };
            if past_end && (!until_rest || self.done()) {
                break;
            }
            if past_end {
                check_work((j + 2) as f64 * substeps, n, "sequence rollout")?;
            }
            if j as f64 >= max_steps || out.y.len() >= MAX_VALUES {
                return Err(Error::Numerical {
                    context: "sequence rollout",
                    detail: format!(
                        "not at rest within {REST_HORIZON_TAUS} tau of the last DMP past the \
                         duration (rest_tol = {})",
                        fmt_g(self.steppers[last].rest_tol())
                    ),
                });
            }
            j += 1;
        }
        check_trajectory(&out, "sequence rollout")?;
        Ok(out)
    }

    /// A new goal for the movement that runs now (filtered as [`Stepper::set_goal`]).
    pub fn set_goal(&mut self, goal: &[f64]) -> Result<()> {
        self.steppers[self.active].set_goal(goal)
    }
    /// A new nominal tau (s) for the movement that runs now, from the next period on.
    pub fn set_tau(&mut self, tau: f64) -> Result<()> {
        self.steppers[self.active].set_tau(tau)
    }
    /// Which movement runs (0-based).
    pub fn active(&self) -> usize {
        self.active
    }
    /// How many movements the sequence has.
    pub fn len(&self) -> usize {
        self.steppers.len()
    }
    /// Never: a sequence holds at least one movement.
    pub fn is_empty(&self) -> bool {
        false
    }
    /// Whether the last movement runs and its last command rests at its goal
    /// ([`Stepper::done`]).
    pub fn done(&self) -> bool {
        self.active + 1 == self.steppers.len() && self.steppers[self.active].done()
    }
    /// Whether the last movement runs and came to rest away from its goal
    /// ([`Stepper::blocked`]); an earlier one hands over when its phase runs out, held or not.
    pub fn blocked(&self) -> bool {
        self.active + 1 == self.steppers.len() && self.steppers[self.active].blocked()
    }
    /// Always false: a sequence takes no acceleration limits.
    pub fn over_limit(&self) -> bool {
        false
    }
    /// Calls of `step` since the start or the last reset.
    pub fn steps(&self) -> u64 {
        self.steps
    }
    /// The last command, `(y, yd, ydd)`.
    pub fn output(&self) -> (&[f64], &[f64], &[f64]) {
        self.steppers[self.active].output()
    }
    /// The active movement's phase of the last command.
    pub fn phase(&self) -> f64 {
        self.steppers[self.active].phase()
    }
    /// The active movement's time scale of the last command's period (s).
    pub fn tau(&self) -> f64 {
        self.steppers[self.active].tau()
    }
    /// The active movement's nominal tau (s).
    pub fn nominal_tau(&self) -> f64 {
        self.steppers[self.active].nominal_tau()
    }
    /// The active movement's goal (moving while filtered).
    pub fn goal(&self) -> &[f64] {
        self.steppers[self.active].goal()
    }
    pub fn goal_target(&self) -> &[f64] {
        self.steppers[self.active].goal_target()
    }
    /// The active movement's Euler sub-steps per period.
    pub fn substeps(&self) -> usize {
        self.steppers[self.active].substeps()
    }
    pub fn dt(&self) -> f64 {
        self.steppers[0].dt()
    }
    pub fn n_dof(&self) -> usize {
        self.correction.len()
    }
}

/// The sequence of `dmps` rolled out open loop ([`SequenceStepper::rollout`]; `opts` as for
/// [`Dmp::rollout`], `duration` from the first start). A sequence of one is that DMP's rollout.
pub fn rollout(dmps: &[Dmp], opts: &RolloutOptions) -> Result<Trajectory> {
    opts.validate()?;
    check_dmps(dmps)?;
    if let [dmp] = dmps {
        return dmp.rollout(opts);
    }
    let stepper_opts = StepperOptions {
        goal_filter: None,
        rest_tol: opts.rest_tol,
        ..StepperOptions::new(opts.dt)
    };
    SequenceStepper::new(dmps, &stepper_opts)?.rollout(opts.duration, opts.until_rest)
}

#[cfg(test)]
#[path = "sequence_tests.rs"]
mod tests;
