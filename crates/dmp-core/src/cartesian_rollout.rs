//! The Cartesian DMP's rollout (docs/cartesian.md): the [`CartesianStepper`] run open loop, its
//! samples written into the trajectory's arrays, so that a rollout and a stepper without
//! measurements, limits or goal changes are one code path and give the same bits.

use rayon::prelude::*;

use crate::cartesian::{CartesianDmp, CartesianTrajectory, N_COORDS, POSE_WIDTH};
use crate::cartesian_stepper::{CartesianRows, CartesianStepper, CartesianStepperOptions};
use crate::error::{Error, Result};
use crate::rollout::{
    MAX_VALUES, REST_HORIZON_TAUS, RolloutOptions, check_values, check_work, max_steps, n_steps,
};
use crate::stepper::StepperOptions;

impl CartesianDmp {
    /// Integrates the position and orientation equations with explicit Euler (module docs) and
    /// returns poses, velocities and accelerations at `t_j = j dt`. With `until_rest`, it goes
    /// on past `duration` until the position is within `rest_tol` (m) of its goal, the
    /// orientation within `rest_tol` (rad), both at rest to `rest_tol`, and the forcing term can
    /// no longer move them by more than that.
    ///
    /// With a final velocity both parts pull to their moving goals, `t` taken from the phase
    /// (docs/cartesian.md, "A final velocity"); such a movement never rests, so `until_rest` is
    /// refused for it.
    pub fn rollout(&self, opts: &RolloutOptions) -> Result<CartesianTrajectory> {
        if self.final_velocity().is_some() && opts.until_rest {
            return Err(Error::InvalidParameter {
                name: "until_rest",
                value: "true".into(),
                requirement: "must be false for a Cartesian DMP with a final velocity: it \
                              moves on at that velocity past tau and never rests \
                              (docs/method.md §2.8)",
            });
        }
        opts.validate()?;
        let tau = self.tau();
        let steps = n_steps(opts.duration.unwrap_or(tau), opts.dt);
        let max_steps = max_steps(steps, opts.until_rest, tau, opts.dt);
        check_values(steps, POSE_WIDTH, opts.dt)?;
        // The rollout is the stepper run open loop: no measurement, no goal filter, no limits.
        // Its sub-steps are the joint rollout's where `dt` is beyond explicit Euler's limit.
        let mut stepper = CartesianStepper::new(
            self,
            &CartesianStepperOptions {
                base: StepperOptions {
                    alpha_e: vec![],
                    goal_filter: None,
                    rest_tol: opts.rest_tol,
                    ..StepperOptions::new(opts.dt)
                },
                ..CartesianStepperOptions::new(opts.dt)
            },
        )?;
        let substeps = stepper.substeps();
        check_work(
            (steps + 1.0) * substeps as f64,
            N_COORDS,
            "Cartesian DMP rollout",
        )?;
        let mut out = PoseSamples::new(steps as usize + 1);
        let mut step = 0usize;
        loop {
            stepper.step_into(out.row(step, opts.dt))?;
            let past_end = step as f64 >= steps;
            if past_end && (!opts.until_rest || stepper.done()) {
                break;
            }
            if past_end {
                // Going on until rest: the work beyond `steps` was not bounded up front.
                check_work(
                    ((step + 2) * substeps) as f64,
                    N_COORDS,
                    "Cartesian DMP rollout",
                )?;
            }
            if step as f64 >= max_steps || (step + 1) * POSE_WIDTH >= MAX_VALUES {
                return Err(Error::Numerical {
                    context: "Cartesian DMP rollout",
                    detail: format!(
                        "not at rest within {REST_HORIZON_TAUS} tau past the duration (rest_tol = {})",
                        opts.rest_tol
                    ),
                });
            }
            step += 1;
        }
        let out = out.into_trajectory(step + 1);
        // An overflow persists to the last sample: checking it is enough to never return a
        // non-finite trajectory (a coarse `dt` is sub-stepped, so only an overflow is left).
        let last = [
            &out.position[3 * step..],
            &out.quaternion[4 * step..],
            &out.velocity[3 * step..],
            &out.angular_velocity[3 * step..],
            &out.acceleration[3 * step..],
            &out.angular_acceleration[3 * step..],
        ];
        if last.iter().any(|v| v.iter().any(|v| !v.is_finite())) {
            return Err(Error::Numerical {
                context: "Cartesian DMP rollout",
                detail: "the integration overflowed: the goal, start or weights are too large \
                         for f64"
                    .into(),
            });
        }
        Ok(out)
    }
}

/// A [`CartesianTrajectory`] being written sample by sample into arrays allocated up front (and
/// doubled if a rollout goes on until rest).
struct PoseSamples {
    out: CartesianTrajectory,
}

impl PoseSamples {
    fn new(capacity: usize) -> Self {
        let v = |width: usize| vec![0.0; width * capacity];
        Self {
            out: CartesianTrajectory {
                t: v(1),
                position: v(3),
                quaternion: v(4),
                velocity: v(3),
                acceleration: v(3),
                angular_velocity: v(3),
                angular_acceleration: v(3),
            },
        }
    }

    /// The trajectory's arrays, each with its width.
    fn fields(&mut self) -> [(&mut Vec<f64>, usize); 7] {
        let o = &mut self.out;
        [
            (&mut o.t, 1),
            (&mut o.position, 3),
            (&mut o.quaternion, 4),
            (&mut o.velocity, 3),
            (&mut o.acceleration, 3),
            (&mut o.angular_velocity, 3),
            (&mut o.angular_acceleration, 3),
        ]
    }

    /// Sample `j` (at `t = j dt`), to be written.
    fn row(&mut self, j: usize, dt: f64) -> CartesianRows<'_> {
        if j == self.out.t.len() {
            let grown = 2 * j.max(1);
            for (v, width) in self.fields() {
                v.resize(grown * width, 0.0);
            }
        }
        let o = &mut self.out;
        o.t[j] = j as f64 * dt;
        CartesianRows {
            position: &mut o.position[3 * j..3 * j + 3],
            quaternion: &mut o.quaternion[4 * j..4 * j + 4],
            velocity: &mut o.velocity[3 * j..3 * j + 3],
            acceleration: &mut o.acceleration[3 * j..3 * j + 3],
            angular_velocity: &mut o.angular_velocity[3 * j..3 * j + 3],
            angular_acceleration: &mut o.angular_acceleration[3 * j..3 * j + 3],
        }
    }

    /// The first `samples` samples.
    fn into_trajectory(mut self, samples: usize) -> CartesianTrajectory {
        for (v, width) in self.fields() {
            v.truncate(samples * width);
        }
        self.out
    }
}

/// Rolls out many Cartesian DMPs in parallel (rayon); bit-identical to one by one.
pub fn rollout_batch_cartesian(
    dmps: &[CartesianDmp],
    opts: &RolloutOptions,
) -> Result<Vec<CartesianTrajectory>> {
    opts.validate()?;
    dmps.par_iter().map(|d| d.rollout(opts)).collect()
}
