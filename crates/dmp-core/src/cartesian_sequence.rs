//! Cartesian DMPs joined end to start without stopping: the joint sequence's join
//! ([`crate::sequence`], docs/method.md §2.9) for a pose (docs/cartesian.md).
//!
//! Movement `k + 1` starts where `k`'s integrator has arrived, position and quaternion, with
//! `k`'s linear velocity (`z = tau_{k+1} v`) and angular velocity (`eta = tau_{k+1} omega`)
//! (`CartesianStepper::take_over`). The join's coupling term is added to the position's
//! `tau dz/dt` and to the orientation's
//! `tau d(eta)/dt = alpha_z (beta_z 2 log(g_o * conj(q)) - eta) + f_o + C`, with
//! `C_0 = tau_{k+1}^2 (a_k - a_{k+1})` on the linear and the angular acceleration alike, fading
//! as `exp(-alpha_z s / 2)`: both accelerations are continuous at the join to the integrator's
//! order. The hand-over and the fading are the joint sequence's ([`crate::chain`]).
//!
//! The rollout steps the stepper. A sequence of one movement is that DMP's rollout, bit for bit.

use crate::cartesian::{CartesianDmp, CartesianTrajectory, POSE_WIDTH};
use crate::cartesian_stepper::{CartesianStepper, CartesianStepperOptions, check_pose};
use crate::chain::{Chain, movement_by_delegation};
use crate::error::{Error, Result};
use crate::rollout::RolloutOptions;
use crate::stepper::{StepperOptions, check_coordinates, moving_start_refused};

/// The coordinates of `tau dz/dt`: x, y, z, then the three of the orientation.
const N: usize = 6;

fn check_dmps(dmps: &[CartesianDmp]) -> Result<()> {
    if dmps.is_empty() {
        return Err(Error::InvalidParameter {
            name: "dmps",
            value: "[]".into(),
            requirement: "must hold at least one Cartesian DMP",
        });
    }
    Ok(())
}

movement_by_delegation! {
    CartesianStepper;
    fn check_inputs(&self, measured: Option<&[f64]>, coupling: Option<&[f64]>) -> Result<()> {
        if let Some(m) = measured {
            check_pose("measured", m)?;
        }
        if let Some(c) = coupling {
            check_coordinates("coupling", c, N)?;
        }
        Ok(())
    }
    fn moves_on(&self) -> bool {
        self.dmp().final_velocity().is_some()
    }
}

/// The movements of a sequence of Cartesian DMPs, stepped one control period at a time
/// (module docs).
pub type CartesianSequenceStepper = Chain<CartesianStepper>;

impl CartesianSequenceStepper {
    /// A stepper for `dmps` (at least one), each with `opts`; the first starts at its start, at
    /// rest. Velocity and acceleration limits are refused, as by
    /// [`crate::sequence::SequenceStepper::new`].
    pub fn new(dmps: &[CartesianDmp], opts: &CartesianStepperOptions) -> Result<Self> {
        check_dmps(dmps)?;
        if opts.base.velocity_max.is_some() || opts.base.acceleration_max.is_some() {
            return Err(moving_start_refused());
        }
        let steppers = dmps
            .iter()
            .map(|d| CartesianStepper::new(d, opts))
            .collect::<Result<Vec<_>>>()?;
        Chain::of(steppers, N)
    }

    /// One control period: the command `(pose, [v, omega], [a, omegadot])`, after handing over
    /// to the next movement if the active one's phase has run out; `measured` (a pose) and
    /// `coupling` (6 values) as for [`CartesianStepper::step_coupled`].
    pub fn step_coupled(
        &mut self,
        measured: Option<&[f64]>,
        coupling: Option<&[f64]>,
    ) -> Result<(&[f64; POSE_WIDTH], &[f64; N], &[f64; N])> {
        self.advance(measured, coupling)?;
        Ok(self.output())
    }

    /// [`CartesianSequenceStepper::step_coupled`] without a coupling term.
    pub fn step(
        &mut self,
        measured: Option<&[f64]>,
    ) -> Result<(&[f64; POSE_WIDTH], &[f64; N], &[f64; N])> {
        self.step_coupled(measured, None)
    }

    /// The whole sequence open loop (as [`crate::sequence::SequenceStepper::rollout`]).
    pub fn rollout(
        &mut self,
        duration: Option<f64>,
        until_rest: bool,
    ) -> Result<CartesianTrajectory> {
        self.rollout_into(
            duration,
            until_rest,
            POSE_WIDTH,
            "Cartesian sequence rollout",
            |samples| CartesianTrajectory {
                t: Vec::with_capacity(samples),
                position: Vec::with_capacity(3 * samples),
                quaternion: Vec::with_capacity(4 * samples),
                velocity: Vec::with_capacity(3 * samples),
                acceleration: Vec::with_capacity(3 * samples),
                angular_velocity: Vec::with_capacity(3 * samples),
                angular_acceleration: Vec::with_capacity(3 * samples),
            },
            |out, s, t| {
                let (pose, v, a) = s.output();
                out.t.push(t);
                out.position.extend_from_slice(&pose[..3]);
                out.quaternion.extend_from_slice(&pose[3..]);
                out.velocity.extend_from_slice(&v[..3]);
                out.angular_velocity.extend_from_slice(&v[3..]);
                out.acceleration.extend_from_slice(&a[..3]);
                out.angular_acceleration.extend_from_slice(&a[3..]);
            },
        )
    }

    /// A new goal pose for the movement that runs now ([`CartesianStepper::set_goal`]).
    pub fn set_goal(&mut self, goal: &[f64]) -> Result<()> {
        self.current_mut().set_goal(goal)
    }
    /// The last command, `(pose, [v, omega], [a, omegadot])`.
    pub fn output(&self) -> (&[f64; POSE_WIDTH], &[f64; N], &[f64; N]) {
        self.current().output()
    }
    /// The active movement's goal pose (moving while filtered).
    pub fn goal(&self) -> [f64; POSE_WIDTH] {
        self.current().goal()
    }
    pub fn goal_target(&self) -> [f64; POSE_WIDTH] {
        self.current().goal_target()
    }
    /// The obstacles every movement avoids.
    pub fn obstacles(&self) -> &[crate::coupling::SphereObstacle] {
        self.current().obstacles()
    }
}

/// The sequence of `dmps` rolled out open loop ([`CartesianSequenceStepper::rollout`]; `opts`
/// as for [`CartesianDmp::rollout`]). A sequence of one is that DMP's rollout.
pub fn rollout(dmps: &[CartesianDmp], opts: &RolloutOptions) -> Result<CartesianTrajectory> {
    opts.validate()?;
    check_dmps(dmps)?;
    if let [dmp] = dmps {
        return dmp.rollout(opts);
    }
    let stepper_opts = CartesianStepperOptions {
        base: StepperOptions {
            goal_filter: None,
            rest_tol: opts.rest_tol,
            ..StepperOptions::new(opts.dt)
        },
        ..CartesianStepperOptions::new(opts.dt)
    };
    CartesianSequenceStepper::new(dmps, &stepper_opts)?.rollout(opts.duration, opts.until_rest)
}

#[cfg(test)]
#[path = "cartesian_sequence_tests.rs"]
mod tests;
