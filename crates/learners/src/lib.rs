//! # learners
//!
//! Learners of Nemec, Vuga and Ude (2013) in the query space — error learning (eqs. 16, 17),
//! golden-section error learning, a superlinear bracketing root finder (beyond the paper),
//! constrained-domain policy gradient (eq. 12) — and the full-parameter baselines PoWER and PI²,
//! all behind one ask/tell interface (`AskTell`). Pure Rust: no Python, no physics (the matchbox
//! simulation is the `matchbox` crate).

pub mod ask_tell;
pub mod bounds;
pub mod bracket;
pub mod error;
pub mod error_learning;
pub mod golden;
pub mod pi2;
pub mod policy_gradient;
pub mod power;
pub mod root;

pub use ask_tell::{AskTell, Record, Status, Trial};
pub use dmp_core::{Dmp, DmpConfig, Trajectory};
pub use error::{ErrorKind, LearnerError, Result, scalar_entry};
pub use error_learning::{
    DEFAULT_FD_DELTA, ErrorLearning, ErrorLearningConfig, Jacobian, SquareMatrix,
};
pub use golden::{GoldenConfig, GoldenMode, GoldenSection};
pub use pi2::{Pi2, Pi2Config};
pub use policy_gradient::{PolicyGradient, PolicyGradientConfig};
pub use power::{Power, PowerConfig};
pub use root::{IllinoisRootFinder, RootFinderConfig};
