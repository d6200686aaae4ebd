//! What a sequence of joint DMPs ([`crate::sequence`]) and one of Cartesian DMPs
//! ([`crate::cartesian_sequence`]) share: the movements one after the other on their own
//! steppers, the hand-over when the active one's phase has run out, the join's fading coupling
//! term, and the open-loop rollout that steps them (docs/method.md §2.9; the join is described
//! in [`crate::sequence`]'s module docs).
//!
//! The term lives on the coordinates of `tau dz/dt` (eq. 1): a joint DMP's DOFs, or a Cartesian
//! DMP's position and the three of its orientation's `tau d(eta)/dt`. On each,
//! `C_0 = tau_{k+1}^2 (ydd_k - ydd_{k+1})` with `ydd` the commanded linear or angular
//! acceleration, since both are `tau dz/dt / tau^2` at a constant time scale.

use crate::dmp::{DmpConfig, phase_clock};
use crate::error::{Error, Result, fmt_g};
use crate::rollout::{MAX_VALUES, REST_HORIZON_TAUS, check_values, check_work, max_steps, n_steps};

/// A stepper that can run as a movement of a sequence.
pub trait Movement: Clone {
    /// One control period with `coupling` added to `tau dz/dt` (the stepper's `step_coupled`).
    fn advance(&mut self, measured: Option<&[f64]>, coupling: Option<&[f64]>) -> Result<()>;
    /// That `measured` and `coupling` are well formed, so that a refused call changes nothing.
    fn check_inputs(&self, measured: Option<&[f64]>, coupling: Option<&[f64]>) -> Result<()>;
    /// Starts this movement from `from`'s state in motion (the stepper's `take_over`).
    fn take_over_from(&mut self, from: &Self) -> Result<()>;
    /// The last command's acceleration on the coordinates of `tau dz/dt`.
    fn acceleration(&self) -> &[f64];
    /// Back to the start (default: the DMP's) at rest.
    fn restart(&mut self, start: Option<&[f64]>) -> Result<()>;
    /// The phase the next step starts from.
    fn next_phase(&self) -> f64;
    fn config(&self) -> &DmpConfig;
    fn period(&self) -> f64;
    fn substeps_now(&self) -> usize;
    fn nominal(&self) -> f64;
    /// The time scale of the last command's period.
    fn scale(&self) -> f64;
    /// A new nominal tau (the stepper's `set_tau`).
    fn retime(&mut self, tau: f64) -> Result<()>;
    /// The phase of the last command.
    fn last_phase(&self) -> f64;
    fn step_count(&self) -> u64;
    fn at_rest(&self) -> bool;
    fn held(&self) -> bool;
    fn tolerance(&self) -> f64;
    /// Whether the DMP ends at a final velocity and so never rests (docs/method.md §2.8).
    fn moves_on(&self) -> bool;
}

/// The phase at or below which `s`'s movement hands over: its integrator's phase at
/// `t = tau - dt / 2` of the nominal tau (`phase_to_go(x) = dt / (2 tau)`).
fn hand_over_phase<M: Movement>(s: &M) -> f64 {
    let (tau, dt) = (s.nominal(), s.period());
    let clock = phase_clock(tau, s.config().alpha_x, dt / s.substeps_now() as f64);
    libm::exp((1.0 - 0.5 * dt / tau) / clock)
}

/// The fading of the join's coupling term over one period at time scale `tau`:
/// `exp(-alpha_z dt / (2 tau))` ([`crate::sequence`]'s module docs).
fn fading<M: Movement>(s: &M, tau: f64) -> f64 {
    libm::exp(-0.5 * s.config().alpha_z * s.period() / tau)
}

/// The movements of a sequence, stepped one control period at a time (module docs).
#[derive(Debug, Clone)]
pub struct Chain<M> {
    pub(crate) steppers: Vec<M>,
    pub(crate) active: usize,
    /// The join's coupling term, added to the active movement's `tau dz/dt` this period.
    pub(crate) correction: Vec<f64>,
    corrected: bool,
    /// The correction plus the caller's coupling term of this period.
    pub(crate) coupling: Vec<f64>,
    /// The active movement's hand-over phase and the nominal tau it is for.
    hand_over: (f64, f64),
    /// The correction's fading per period and the time scale it is for.
    fade: (f64, f64),
    steps: u64,
}

impl<M: Movement> Chain<M> {
    /// The chain of `steppers` (at least one), each with `n` coordinates of `tau dz/dt`; the
    /// first starts at its start, at rest.
    pub(crate) fn of(steppers: Vec<M>, n: usize) -> Result<Self> {
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

    /// Back to the first movement at `start` (default: its DMP's), at rest; goals set on the
    /// movements stay set.
    pub fn reset(&mut self, start: Option<&[f64]>) -> Result<()> {
        self.steppers[0].restart(start)?;
        self.active = 0;
        self.correction.fill(0.0);
        self.corrected = false;
        self.steps = 0;
        let first = &self.steppers[0];
        self.hand_over = (hand_over_phase(first), first.nominal());
        Ok(())
    }

    /// One control period, after handing over to the next movement if the active one's phase
    /// has run out; `measured` and `coupling` as for the movements' `step_coupled`.
    pub(crate) fn advance(
        &mut self,
        measured: Option<&[f64]>,
        coupling: Option<&[f64]>,
    ) -> Result<()> {
        // Checked before the hand-over, so that a refused call changes nothing.
        self.steppers[self.active].check_inputs(measured, coupling)?;
        if self.active + 1 < self.steppers.len() && self.phase_spent() {
            self.hand_over_to_next()?;
        }
        let stepper = &mut self.steppers[self.active];
        if !self.corrected {
            stepper.advance(measured, coupling)?;
        } else {
            self.coupling.copy_from_slice(&self.correction);
            if let Some(c) = coupling {
                for (t, c) in self.coupling.iter_mut().zip(c) {
                    *t += c;
                }
            }
            stepper.advance(measured, Some(&self.coupling))?;
            let tau = stepper.scale();
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
        Ok(())
    }

    /// Whether the active movement's next step starts at or past its nominal duration.
    fn phase_spent(&mut self) -> bool {
        let s = &self.steppers[self.active];
        if s.nominal() != self.hand_over.1 {
            // `set_tau` moved the end (and maybe the sub-steps).
            self.hand_over = (hand_over_phase(s), s.nominal());
        }
        s.step_count() > 0 && s.next_phase() <= self.hand_over.0
    }

    /// Starts the next movement from the active one's state, with the join's coupling term
    /// ([`crate::sequence`]'s module docs).
    fn hand_over_to_next(&mut self) -> Result<()> {
        let (done, rest) = self.steppers.split_at_mut(self.active + 1);
        let current = &done[self.active];
        let next = &mut rest[0];
        // What the current movement would command next, with its own join's term...
        let mut probe = current.clone();
        let own = self.corrected.then_some(self.correction.as_slice());
        probe.advance(None, own)?;
        next.take_over_from(current)?;
        // ... and what the next one commands first, unaided.
        let mut unaided = next.clone();
        unaided.advance(None, None)?;
        let tau = next.nominal();
        let (a_current, a_next) = (probe.acceleration(), unaided.acceleration());
        for ((c, a), b) in self.correction.iter_mut().zip(a_current).zip(a_next) {
            *c = tau * tau * (a - b);
        }
        self.corrected = true;
        self.fade = (fading(next, tau), tau);
        self.hand_over = (hand_over_phase(next), tau);
        self.active += 1;
        Ok(())
    }

    /// Refuses `until_rest` when the last movement never rests.
    pub(crate) fn check_until_rest(&self, until_rest: bool) -> Result<()> {
        if until_rest && self.steppers[self.steppers.len() - 1].moves_on() {
            return Err(Error::InvalidParameter {
                name: "until_rest",
                value: "true".into(),
                requirement: "must be false when the last DMP has a final velocity: it moves on \
                              at that velocity and never rests (docs/method.md §2.8)",
            });
        }
        Ok(())
    }

    /// The whole sequence open loop from the first start at rest, sampled every `dt` (the
    /// stepper's) for `duration` (default: until the last movement has run its tau), and with
    /// `until_rest` on until the last one rests at its goal. Resets first. `width` values a
    /// sample count towards the rollout's bound; `new_out(samples)` makes the output for that
    /// many samples and `record` appends the command of sample `j`.
    pub(crate) fn rollout_into<T>(
        &mut self,
        duration: Option<f64>,
        until_rest: bool,
        width: usize,
        context: &'static str,
        new_out: impl FnOnce(usize) -> T,
        mut record: impl FnMut(&mut T, &M, f64),
    ) -> Result<T> {
        self.check_until_rest(until_rest)?;
        let (n, dt) = (self.correction.len(), self.dt());
        let last = self.steppers.len() - 1;
        let last_tau = self.steppers[last].nominal();
        // Each movement hands over on the sample nearest its tau: at most its own rollout's.
        let steps = match duration {
            Some(d) => n_steps(d, dt),
            None => self
                .steppers
                .iter()
                .map(|s| n_steps(s.nominal(), dt) + 1.0)
                .sum(),
        };
        let max_steps = max_steps(steps, until_rest, last_tau, dt);
        check_values(steps, width, dt)?;
        let substeps = self.steppers.iter().map(M::substeps_now).max();
        let substeps = substeps.expect("at least one movement") as f64;
        check_work((steps + 1.0) * substeps, n, context)?;
        // The last movement's own rollout has samples 0..=N at t = 0..tau.
        let last_steps = n_steps(last_tau, dt) as u64;
        self.reset(None)?;
        let mut out = new_out(steps as usize + 1);
        let mut j = 0usize;
        loop {
            self.advance(None, None)?;
            let s = &self.steppers[self.active];
            record(&mut out, s, j as f64 * dt);
            let past_end = match duration {
                Some(_) => j as f64 >= steps,
                None => self.active == last && s.step_count() > last_steps,
            };
            if past_end && (!until_rest || self.done()) {
                break;
            }
            if past_end {
                check_work((j + 2) as f64 * substeps, n, context)?;
            }
            if j as f64 >= max_steps || (j + 1) * width >= MAX_VALUES {
                return Err(Error::Numerical {
                    context,
                    detail: format!(
                        "not at rest within {REST_HORIZON_TAUS} tau of the last DMP past the \
                         duration (rest_tol = {})",
                        fmt_g(self.steppers[last].tolerance())
                    ),
                });
            }
            j += 1;
        }
        Ok(out)
    }

    /// A new nominal tau (s) for the movement that runs now, from the next period on.
    pub fn set_tau(&mut self, tau: f64) -> Result<()> {
        self.steppers[self.active].retime(tau)
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
    /// Whether the last movement runs and its last command rests at its goal.
    pub fn done(&self) -> bool {
        self.active + 1 == self.steppers.len() && self.steppers[self.active].at_rest()
    }
    /// Whether the last movement runs and came to rest away from its goal; an earlier one
    /// hands over when its phase runs out, held or not.
    pub fn blocked(&self) -> bool {
        self.active + 1 == self.steppers.len() && self.steppers[self.active].held()
    }
    /// Always false: a sequence takes no acceleration limits.
    pub fn over_limit(&self) -> bool {
        false
    }
    /// Calls of `step` since the start or the last reset.
    pub fn steps(&self) -> u64 {
        self.steps
    }
    /// The active movement's phase of the last command.
    pub fn phase(&self) -> f64 {
        self.steppers[self.active].last_phase()
    }
    /// The active movement's time scale of the last command's period (s).
    pub fn tau(&self) -> f64 {
        self.steppers[self.active].scale()
    }
    /// The active movement's nominal tau (s).
    pub fn nominal_tau(&self) -> f64 {
        self.steppers[self.active].nominal()
    }
    /// The active movement's Euler sub-steps per period.
    pub fn substeps(&self) -> usize {
        self.steppers[self.active].substeps_now()
    }
    pub fn dt(&self) -> f64 {
        self.steppers[0].period()
    }
    /// The active movement's stepper.
    pub(crate) fn current(&self) -> &M {
        &self.steppers[self.active]
    }
    pub(crate) fn current_mut(&mut self) -> &mut M {
        &mut self.steppers[self.active]
    }
}

/// Implements [`Movement`] for a stepper type by its inherent methods of the same meaning
/// (`step_coupled`, `take_over`, `reset`, ...); `check_inputs` and `moves_on` follow, written
/// for the type.
macro_rules! movement_by_delegation {
    ($ty:ty; $($own:tt)*) => {
        impl $crate::chain::Movement for $ty {
            fn advance(&mut self, measured: Option<&[f64]>, coupling: Option<&[f64]>) -> Result<()> {
                self.step_coupled(measured, coupling).map(|_| ())
            }
            fn take_over_from(&mut self, from: &Self) -> Result<()> {
                self.take_over(from)
            }
            fn acceleration(&self) -> &[f64] {
                self.output().2
            }
            fn restart(&mut self, start: Option<&[f64]>) -> Result<()> {
                self.reset(start)
            }
            fn next_phase(&self) -> f64 {
                <$ty>::next_phase(self)
            }
            fn config(&self) -> &$crate::dmp::DmpConfig {
                self.dmp().config()
            }
            fn period(&self) -> f64 {
                self.dt()
            }
            fn substeps_now(&self) -> usize {
                self.substeps()
            }
            fn nominal(&self) -> f64 {
                self.nominal_tau()
            }
            fn scale(&self) -> f64 {
                self.tau()
            }
            fn retime(&mut self, tau: f64) -> Result<()> {
                self.set_tau(tau)
            }
            fn last_phase(&self) -> f64 {
                self.phase()
            }
            fn step_count(&self) -> u64 {
                self.steps()
            }
            fn at_rest(&self) -> bool {
                self.done()
            }
            fn held(&self) -> bool {
                self.blocked()
            }
            fn tolerance(&self) -> f64 {
                self.rest_tol()
            }
            $($own)*
        }
    };
}
pub(crate) use movement_by_delegation;

/// Helpers of the joint and the Cartesian sequence's tests.
#[cfg(test)]
pub(crate) mod testing {
    use super::{Chain, Movement};

    pub(crate) fn bits(v: &[f64]) -> Vec<u64> {
        v.iter().map(|v| v.to_bits()).collect()
    }

    /// The samples at which a movement after the first begins, found by stepping `s`.
    pub(crate) fn joins<M: Movement>(mut s: Chain<M>, samples: usize) -> Vec<usize> {
        let mut out = Vec::new();
        for j in 0..samples {
            let before = s.active();
            s.advance(None, None).unwrap();
            if s.active() != before {
                out.push(j);
            }
        }
        out
    }

    /// At each join of `s` (stepped `samples` times), the sample and the jump of the
    /// acceleration an unaided start would make: the join's term at its first sample, over
    /// `tau^2`.
    pub(crate) fn unaided_jumps<M: Movement>(
        mut s: Chain<M>,
        samples: usize,
    ) -> Vec<(usize, Vec<f64>)> {
        let mut out = Vec::new();
        for j in 0..samples {
            let before = s.active();
            s.advance(None, None).unwrap();
            if s.active() != before {
                let tau = s.nominal_tau();
                out.push((
                    j,
                    s.coupling.iter().map(|c| (c / (tau * tau)).abs()).collect(),
                ));
            }
        }
        out
    }

    /// That every jump of `after` (at `dt`) is half its counterpart of `before` (at `2 dt`):
    /// first order in dt.
    pub(crate) fn halved(before: &[f64], after: &[f64], dt: f64) {
        assert_eq!(before.len(), after.len());
        for (a, b) in before.iter().zip(after) {
            let ratio = a / b;
            assert!((1.7..2.3).contains(&ratio), "{a} -> {b} at dt {dt}");
        }
    }
}
