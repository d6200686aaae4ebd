//! The one place where core errors become Python exceptions. The exception classes live in
//! `dmprs.errors` (they need multiple inheritance, e.g. `InvalidInputError(DmprsError, ValueError)`,
//! which is plain in Python), so they are looked up there when an error is raised.

use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;
use pyo3::types::PyType;

/// Raises `dmprs.errors.<class_name>(message)`.
pub fn raise(class_name: &str, message: String) -> PyErr {
    Python::attach(|py| {
        let class = py
            .import("dmprs.errors")
            .and_then(|m| m.getattr(class_name))
            .and_then(|c| c.cast_into::<PyType>().map_err(PyErr::from));
        match class {
            Ok(class) => PyErr::from_type(class, message),
            Err(e) => {
                PyRuntimeError::new_err(format!("{message} (and dmprs.errors is unusable: {e})"))
            }
        }
    })
}

/// Bad input becomes `InvalidInputError` (a `ValueError`), a query the generalizer cannot reach
/// `ExtrapolationError` (an `InvalidInputError`), a failed computation `NumericalError`.
pub fn core_error(err: dmp_core::Error) -> PyErr {
    let class = match &err {
        dmp_core::Error::Extrapolation { .. } => "ExtrapolationError",
        e if e.is_input_error() => "InvalidInputError",
        _ => "NumericalError",
    };
    raise(class, err.to_string())
}

pub trait IntoPyResult<T> {
    fn py_err(self) -> PyResult<T>;
}

impl<T> IntoPyResult<T> for Result<T, dmp_core::Error> {
    fn py_err(self) -> PyResult<T> {
        self.map_err(core_error)
    }
}

/// Bad input becomes `InvalidInputError`, calls in the wrong order (tell without ask, tell of
/// another query, ask after the stop) `LearnerStateError`, a failed computation `NumericalError`.
pub fn learner_error(err: learners::LearnerError) -> PyErr {
    let class = if err.is_input_error() {
        "InvalidInputError"
    } else if err.is_state_error() {
        "LearnerStateError"
    } else {
        "NumericalError"
    };
    raise(class, err.to_string())
}

impl<T> IntoPyResult<T> for Result<T, learners::LearnerError> {
    fn py_err(self) -> PyResult<T> {
        self.map_err(learner_error)
    }
}

/// Every matchbox error is bad input (a bad configuration or fingertip trajectory).
impl<T> IntoPyResult<T> for Result<T, matchbox::Error> {
    fn py_err(self) -> PyResult<T> {
        self.map_err(|e| raise("InvalidInputError", e.to_string()))
    }
}
