//! The one error type of `learner`. Every variant says what was wrong and where, so that the
//! Python layer can pass the message through unchanged (crates/py-bindings/src/errors.rs).

use thiserror::Error;

/// Errors raised by the learners' constructors, `ask` and `tell`.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum LearnerError {
    /// A NaN or infinity in an argument (a query, an error, a cost, a parameter).
    #[error("{name}{location} is {value}: all values must be finite")]
    NonFinite {
        name: &'static str,
        /// An index such as `[2]`, or empty for a scalar.
        location: String,
        value: f64,
    },
    /// A vector or matrix of the wrong size.
    #[error("{name} has {got}, expected {expected}")]
    Dimension {
        name: &'static str,
        expected: String,
        got: String,
    },
    /// A parameter outside its domain (a gain that is not positive, low >= high, ...).
    #[error("{name} = {value} is invalid: {requirement}")]
    InvalidParameter {
        name: &'static str,
        value: String,
        requirement: String,
    },
    /// `tell` without a pending `ask`.
    #[error(
        "tell() was called without a pending ask(): call q = learner.ask(), run the trial, then learner.tell(q, ...)"
    )]
    NotAsked,
    /// `tell` of a query other than the one `ask` returned.
    #[error(
        "tell() got the query {got:?}, but the pending ask() returned {expected:?}: pass back the query you executed"
    )]
    UnexpectedQuery { expected: Vec<f64>, got: Vec<f64> },
    /// `ask` after the learner stopped.
    #[error("the learner has stopped ({status}); read learner.best, or start a new learner")]
    Finished { status: String },
    /// Valid input, failed computation.
    #[error("numerical failure in {context}: {detail}")]
    Numerical {
        context: &'static str,
        detail: String,
    },
}

/// What kind of mistake an error is: the bindings map each kind to one Python class.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ErrorKind {
    /// The caller's input was wrong (Python: `InvalidInputError`).
    Input,
    /// The calls came in the wrong order (Python: `LearnerStateError`).
    State,
    /// Valid input, failed computation (Python: `NumericalError`).
    Numerical,
}

impl LearnerError {
    /// The kind of this error (an exhaustive match: a new variant must choose its kind).
    pub fn kind(&self) -> ErrorKind {
        match self {
            LearnerError::NonFinite { .. }
            | LearnerError::Dimension { .. }
            | LearnerError::InvalidParameter { .. } => ErrorKind::Input,
            LearnerError::NotAsked
            | LearnerError::UnexpectedQuery { .. }
            | LearnerError::Finished { .. } => ErrorKind::State,
            LearnerError::Numerical { .. } => ErrorKind::Numerical,
        }
    }

    /// True when the caller's input was wrong.
    pub fn is_input_error(&self) -> bool {
        self.kind() == ErrorKind::Input
    }

    /// True when the call came in the wrong order.
    pub fn is_state_error(&self) -> bool {
        self.kind() == ErrorKind::State
    }
}

pub type Result<T> = std::result::Result<T, LearnerError>;

/// A finite scalar parameter, strictly positive if `positive`.
pub(crate) fn check_scalar(name: &'static str, value: f64, positive: bool) -> Result<()> {
    if !value.is_finite() {
        return Err(LearnerError::NonFinite {
            name,
            location: String::new(),
            value,
        });
    }
    if positive && value <= 0.0 {
        return Err(invalid(name, value, "must be > 0"));
    }
    Ok(())
}

/// A vector of `len` finite entries; names the first offender as `name[i]`.
pub(crate) fn check_vector(name: &'static str, values: &[f64], len: usize) -> Result<()> {
    if values.len() != len {
        return Err(LearnerError::Dimension {
            name,
            expected: format!("{len} entries"),
            got: format!("{} entries", values.len()),
        });
    }
    check_finite(name, values)
}

pub(crate) fn check_finite(name: &'static str, values: &[f64]) -> Result<()> {
    match values.iter().enumerate().find(|(_, v)| !v.is_finite()) {
        Some((i, &v)) => Err(LearnerError::NonFinite {
            name,
            location: format!("[{i}]"),
            value: v,
        }),
        None => Ok(()),
    }
}

pub(crate) fn invalid(
    name: &'static str,
    value: impl std::fmt::Display,
    requirement: &str,
) -> LearnerError {
    LearnerError::InvalidParameter {
        name,
        value: value.to_string(),
        requirement: requirement.to_string(),
    }
}

/// `max_trials >= 1`.
pub(crate) fn check_max_trials(max_trials: usize) -> Result<()> {
    if max_trials == 0 {
        return Err(invalid("max_trials", 0, "must be at least 1"));
    }
    Ok(())
}

/// A query vector of at least one entry, all finite.
pub(crate) fn check_query(name: &'static str, q: &[f64]) -> Result<()> {
    if q.is_empty() {
        return Err(LearnerError::Dimension {
            name,
            expected: "at least 1 entry".into(),
            got: "0 entries".into(),
        });
    }
    check_finite(name, q)
}

/// The one entry of a one-dimensional query (or limit) given as a slice: the bindings pass
/// every query as a 1-D array, the bracketing learners take a scalar.
pub fn scalar_entry(name: &'static str, values: &[f64]) -> Result<f64> {
    match values {
        [v] => Ok(*v),
        _ => Err(LearnerError::Dimension {
            name,
            expected: "1 entry (this learner searches a one-dimensional query)".into(),
            got: format!("{} entries", values.len()),
        }),
    }
}
