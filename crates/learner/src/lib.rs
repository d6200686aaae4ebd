//! # learner
//!
//! Learners in the query space of Nemec, Vuga and Ude (2013) — error learning (eqs. 16, 17),
//! golden-section error learning, constrained-domain policy gradient (eq. 12) — the full-parameter
//! baselines PoWER and PI², and the Rapier matchbox flip-up simulation. Filled in by the learners
//! and matchbox issues; for now it only re-exports the DMP types it will build on.

pub use dmp_core::{Dmp, DmpConfig, Trajectory};
pub mod matchbox;
