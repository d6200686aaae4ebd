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

use crate::chain::{Chain, movement_by_delegation};
use crate::dmp::Dmp;
use crate::error::{Error, Result};
use crate::rollout::{RolloutOptions, Trajectory, check_trajectory};
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

movement_by_delegation! {
    Stepper;
    fn check_inputs(&self, measured: Option<&[f64]>, coupling: Option<&[f64]>) -> Result<()> {
        if let Some(m) = measured {
            check_coordinates("measured", m, self.n_dof())?;
        }
        if let Some(c) = coupling {
            check_coordinates("coupling", c, self.n_dof())?;
        }
        Ok(())
    }
    fn moves_on(&self) -> bool {
        self.dmp().final_velocity().is_some()
    }
}

/// The movements of a sequence of joint DMPs, stepped one control period at a time (module
/// docs).
pub type SequenceStepper = Chain<Stepper>;

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
        Chain::of(steppers, n)
    }

    /// One control period: the command `(y, yd, ydd)`, after handing over to the next movement
    /// if the active one's phase has run out; `measured` and `coupling` as for
    /// [`Stepper::step_coupled`].
    pub fn step_coupled(
        &mut self,
        measured: Option<&[f64]>,
        coupling: Option<&[f64]>,
    ) -> Result<(&[f64], &[f64], &[f64])> {
        self.advance(measured, coupling)?;
        Ok(self.output())
    }

    /// [`SequenceStepper::step_coupled`] without a coupling term.
    pub fn step(&mut self, measured: Option<&[f64]>) -> Result<(&[f64], &[f64], &[f64])> {
        self.step_coupled(measured, None)
    }

    /// The whole sequence open loop from the first start at rest, sampled every `dt` (the
    /// stepper's) for `duration` (default: until the last movement has run its tau), and with
    /// `until_rest` on until the last one rests at its goal. Resets this stepper first.
    pub fn rollout(&mut self, duration: Option<f64>, until_rest: bool) -> Result<Trajectory> {
        let n = self.n_dof();
        let out = self.rollout_into(
            duration,
            until_rest,
            n,
            "sequence rollout",
            |samples| Trajectory {
                t: Vec::with_capacity(samples),
                y: Vec::with_capacity(samples * n),
                yd: Vec::with_capacity(samples * n),
                ydd: Vec::with_capacity(samples * n),
                n_dof: n,
            },
            |out, s, t| {
                let (y, yd, ydd) = s.output();
                out.t.push(t);
                out.y.extend_from_slice(y);
                out.yd.extend_from_slice(yd);
                out.ydd.extend_from_slice(ydd);
            },
        )?;
        check_trajectory(&out, "sequence rollout")?;
        Ok(out)
    }

    /// A new goal for the movement that runs now (filtered as [`Stepper::set_goal`]).
    pub fn set_goal(&mut self, goal: &[f64]) -> Result<()> {
        self.current_mut().set_goal(goal)
    }
    /// The last command, `(y, yd, ydd)`.
    pub fn output(&self) -> (&[f64], &[f64], &[f64]) {
        self.current().output()
    }
    /// The active movement's goal (moving while filtered).
    pub fn goal(&self) -> &[f64] {
        self.current().goal()
    }
    pub fn goal_target(&self) -> &[f64] {
        self.current().goal_target()
    }
    pub fn n_dof(&self) -> usize {
        self.current().n_dof()
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
