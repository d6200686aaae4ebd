//! PyO3 bindings: the module `dmprs._core`. Thin wrappers only; the algorithms live in
//! `dmp-core`, `learners`, `matchbox` and `ros2-robot`, the user-facing classes and docs in `python/dmprs`.

mod cartesian;
mod dmp;
mod errors;
mod generalize;
mod gp;
mod learners;
mod matchbox;
mod oscillator;
mod periodic;
mod periodic_stepper;
mod portable;
mod primitive;
mod ros2_robot;
mod sequence;
mod stepper;

use pyo3::prelude::*;

#[pymodule]
mod _core {
    #[pymodule_export]
    use super::cartesian::{PyCartesianDmp, PyCartesianGeneralizer, py_rollout_batch_cartesian};
    #[pymodule_export]
    use super::dmp::PyDmp;
    #[pymodule_export]
    use super::dmp::py_rollout_batch;
    #[pymodule_export]
    use super::generalize::PyGeneralizer;
    #[pymodule_export]
    use super::gp::PyGaussianProcess;
    #[pymodule_export]
    use super::learners::{
        PyErrorLearning, PyGoldenSection, PyIllinoisRootFinder, PyPi2, PyPolicyGradient, PyPower,
    };
    #[pymodule_export]
    use super::matchbox::{
        PyMatchboxConfig, matchbox_check, matchbox_simulate, matchbox_simulate_batch,
    };
    #[pymodule_export]
    use super::oscillator::PyAdaptiveOscillator;
    #[pymodule_export]
    use super::periodic::{
        PyPeriodicCartesianDmp, PyPeriodicDmp, PyPeriodicGeneralizer, PyPeriodicOnlineFit,
        py_rollout_batch_periodic, py_rollout_batch_periodic_cartesian,
    };
    #[pymodule_export]
    use super::periodic_stepper::PyPeriodicStepper;
    #[pymodule_export]
    use super::portable::{dls_step, portable_binary, portable_norm, portable_unary};
    #[pymodule_export]
    use super::sequence::{
        PyCartesianSequenceStepper, PySequenceStepper, py_cartesian_sequence_rollout,
        py_sequence_rollout,
    };
    #[pymodule_export]
    use super::stepper::{PyCartesianStepper, PyStepper};

    #[pymodule_export]
    use super::ros2_robot::{
        PyRobotGoal, PyRobotNode, PyRobotTrajectory, PyRos2GoalClient, PyRos2JointStateListener,
    };

    #[pymodule_init]
    fn init(m: &pyo3::Bound<'_, pyo3::types::PyModule>) -> pyo3::PyResult<()> {
        use pyo3::types::PyModuleMethods;
        m.add("__version__", env!("CARGO_PKG_VERSION"))?;
        // The one unit-norm tolerance of quaternions, which the Python side checks with too.
        m.add("UNIT_TOLERANCE", dmp_core::cartesian::UNIT_TOLERANCE)?;
        // The fewest demos a local GP takes, which the Python side validates with first.
        m.add("MIN_GP_NEIGHBOURS", dmp_core::output_gp::MIN_NEIGHBOURS)
    }
}
