//! # dmp-core
//!
//! The numerical core of dmprs: the Dynamic Movement Primitives of Nemec, Vuga and Ude,
//! "Efficient sensorimotor learning from multiple demonstrations" (2013), eqs. 1-4, their fit
//! from demonstrations and their rollout, and their generalization over a database of
//! demonstrations (paper eq. 6: Gaussian processes, locally weighted regression, linear
//! interpolation), and the Cartesian (position + unit quaternion) DMP of Ude, Nemec, Petrič and
//! Morimoto (2014) on the same phase and basis, and both executed online one control period at a
//! time (steppers with phase stopping, a goal filter, temporal coupling for limits and coupling
//! terms), joint and Cartesian DMPs also joined end to start in sequences. Pure Rust on
//! nalgebra; no Python, no learners.

pub mod basis;
pub mod cartesian;
pub mod cartesian_generalize;
pub mod cartesian_rollout;
pub mod cartesian_sequence;
pub mod cartesian_stepper;
pub mod chain;
pub mod coupling;
pub mod design_matrix;
pub mod dmp;
pub mod error;
pub mod euler;
pub mod exp;
pub mod finite_difference;
mod forcing;
pub mod generalize;
pub mod gp;
pub mod linalg;
pub mod low_rank_gp;
pub mod lwr;
pub mod online_fit;
pub mod optimize;
pub mod oscillator;
pub mod output_gp;
pub mod periodic;
pub mod periodic_cartesian;
mod periodic_forcing;
pub mod periodic_generalize;
pub mod periodic_rollout;
pub mod periodic_stepper;
pub mod portable;
pub mod quaternion;
pub mod rollout;
pub mod sequence;
pub mod stepper;
pub mod temporal_coupling;
pub mod via_points;

pub use basis::Basis;
pub use cartesian::{CartesianDemonstration, CartesianDmp, CartesianTrajectory};
pub use cartesian_generalize::CartesianGeneralizer;
pub use cartesian_rollout::rollout_batch_cartesian;
pub use cartesian_sequence::CartesianSequenceStepper;
pub use cartesian_stepper::{CartesianStepper, CartesianStepperOptions};
pub use dmp::{Demonstration, Dmp, DmpConfig, FinalVelocity};
pub use error::{Error, Result};
pub use generalize::{Generalizer, LwrGpOptions, Method};
pub use gp::{GaussianProcess, GpOptions, HyperBounds, Hyperparameters};
pub use lwr::{Kernel, LocalModel, LwrOptions};
pub use online_fit::OnlineFit;
pub use oscillator::{AdaptiveOscillator, OscillatorGains};
pub use output_gp::GpMean;
pub use periodic::{PeriodicConfig, PeriodicDmp};
pub use periodic_cartesian::{PeriodicCartesianDmp, rollout_batch_periodic_cartesian};
pub use periodic_generalize::PeriodicGeneralizer;
pub use periodic_rollout::rollout_batch_periodic;
pub use periodic_stepper::{PeriodicStepper, PeriodicStepperOptions};
pub use rollout::{RolloutOptions, Trajectory, rollout_batch};
pub use sequence::SequenceStepper;
pub use stepper::{Stepper, StepperOptions};
pub use via_points::through_via_points;
