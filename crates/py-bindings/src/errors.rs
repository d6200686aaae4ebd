//! The one place where core errors become Python exceptions. The exception classes live in
//! `dmprs.errors` (they need multiple inheritance, e.g. `InvalidInputError(DmprsError, ValueError)`,
//! which is plain in Python); each is looked up there once, on its first use.
//!
//! Every core error is mapped by an exhaustive `match` to a [`PyErrorClass`], so a new error
//! variant in a core crate does not compile until it has chosen its Python class.

use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::PyType;

/// The classes of `dmprs.errors` the core raises.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PyErrorClass {
    InvalidInput,
    Extrapolation,
    Numerical,
    LearnerState,
    Adapter,
}

static INVALID_INPUT: PyOnceLock<Py<PyType>> = PyOnceLock::new();
static EXTRAPOLATION: PyOnceLock<Py<PyType>> = PyOnceLock::new();
static NUMERICAL: PyOnceLock<Py<PyType>> = PyOnceLock::new();
static LEARNER_STATE: PyOnceLock<Py<PyType>> = PyOnceLock::new();
static ADAPTER: PyOnceLock<Py<PyType>> = PyOnceLock::new();

impl PyErrorClass {
    fn cell_and_name(self) -> (&'static PyOnceLock<Py<PyType>>, &'static str) {
        match self {
            PyErrorClass::InvalidInput => (&INVALID_INPUT, "InvalidInputError"),
            PyErrorClass::Extrapolation => (&EXTRAPOLATION, "ExtrapolationError"),
            PyErrorClass::Numerical => (&NUMERICAL, "NumericalError"),
            PyErrorClass::LearnerState => (&LEARNER_STATE, "LearnerStateError"),
            PyErrorClass::Adapter => (&ADAPTER, "AdapterError"),
        }
    }

    /// `dmprs.errors.<class>(message)`.
    pub fn err(self, message: impl Into<String>) -> PyErr {
        let message = message.into();
        Python::attach(|py| {
            let (cell, name) = self.cell_and_name();
            match cell.import(py, "dmprs.errors", name) {
                Ok(class) => PyErr::from_type(class.clone(), message),
                Err(e) => PyRuntimeError::new_err(format!(
                    "{message} (and dmprs.errors.{name} is unusable: {e})"
                )),
            }
        })
    }
}

/// `InvalidInputError(message)`: the bindings' own argument checks.
pub fn invalid_input(message: impl Into<String>) -> PyErr {
    PyErrorClass::InvalidInput.err(message)
}

/// Bad input becomes `InvalidInputError` (a `ValueError`), a query the generalizer cannot reach
/// `ExtrapolationError` (an `InvalidInputError`), a failed computation `NumericalError`.
fn dmp_core_class(err: &dmp_core::Error) -> PyErrorClass {
    use dmp_core::Error as E;
    match err {
        E::Extrapolation { .. } => PyErrorClass::Extrapolation,
        // A cancelled computation is normally replaced by the KeyboardInterrupt that cancelled it
        // (gp.rs, `interruptible`); reaching Python on its own it is a failed computation.
        E::Numerical { .. } | E::Cancelled { .. } => PyErrorClass::Numerical,
        E::InOutput { source, .. } => dmp_core_class(source),
        E::InDemo { source, .. } => match dmp_core_class(source) {
            // A demonstration's data cannot be "too far from the demonstrations".
            PyErrorClass::Extrapolation => PyErrorClass::InvalidInput,
            c => c,
        },
        E::NonFinite { .. }
        | E::Shape { .. }
        | E::TooFewSamples { .. }
        | E::NotIncreasing { .. }
        | E::InvalidParameter { .. }
        | E::DemoCount { .. }
        | E::DuplicateQuery { .. }
        | E::DofMismatch { .. }
        | E::DegenerateQueries { .. }
        | E::Unsuited { .. }
        | E::Quaternion { .. } => PyErrorClass::InvalidInput,
    }
}

/// Bad input becomes `InvalidInputError`, calls in the wrong order (tell without ask, tell of
/// another query, ask after the stop) `LearnerStateError`, a failed computation `NumericalError`.
fn learner_class(err: &learners::LearnerError) -> PyErrorClass {
    match err.kind() {
        learners::ErrorKind::Input => PyErrorClass::InvalidInput,
        learners::ErrorKind::State => PyErrorClass::LearnerState,
        learners::ErrorKind::Numerical => PyErrorClass::Numerical,
    }
}

/// Every matchbox error is bad input (a bad configuration or fingertip trajectory).
fn matchbox_class(err: &matchbox::Error) -> PyErrorClass {
    match err {
        matchbox::Error::InvalidConfig(_) | matchbox::Error::InvalidTrajectory(_) => {
            PyErrorClass::InvalidInput
        }
    }
}

pub fn core_error(err: dmp_core::Error) -> PyErr {
    dmp_core_class(&err).err(err.to_string())
}

pub trait IntoPyResult<T> {
    fn py_err(self) -> PyResult<T>;
}

impl<T> IntoPyResult<T> for Result<T, dmp_core::Error> {
    fn py_err(self) -> PyResult<T> {
        self.map_err(core_error)
    }
}

impl<T> IntoPyResult<T> for Result<T, learners::LearnerError> {
    fn py_err(self) -> PyResult<T> {
        self.map_err(|e| learner_class(&e).err(e.to_string()))
    }
}

impl<T> IntoPyResult<T> for Result<T, matchbox::Error> {
    fn py_err(self) -> PyResult<T> {
        self.map_err(|e| matchbox_class(&e).err(e.to_string()))
    }
}
