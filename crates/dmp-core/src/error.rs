//! The one error type of `dmp-core`. Every variant says what was wrong and where, so that the
//! Python layer can pass the message through unchanged.

use thiserror::Error;

/// Errors raised by fitting, rollout and generalization.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum Error {
    /// A NaN or infinity in an input array or parameter.
    #[error("{name}{location} is {}: all values must be finite", fmt_g(*.value))]
    NonFinite {
        name: &'static str,
        /// An index such as `[12, 3]`, or empty for a scalar.
        location: String,
        value: f64,
    },
    /// Arrays whose shapes do not fit together.
    #[error("{name} has shape {got}, expected {expected}")]
    Shape {
        name: &'static str,
        expected: String,
        got: String,
    },
    /// Fewer samples than the method needs.
    #[error("{name} has {got} samples, but {needed} are needed ({why})")]
    TooFewSamples {
        name: &'static str,
        got: usize,
        needed: usize,
        why: &'static str,
    },
    /// Sample times that repeat or go backwards.
    #[error(
        "{name} must be strictly increasing, but {name}[{index}] = {} is not greater than {name}[{prev_index}] = {}",
        fmt_g(*.value),
        fmt_g(*.prev),
        prev_index = index - 1
    )]
    NotIncreasing {
        name: &'static str,
        index: usize,
        value: f64,
        prev: f64,
    },
    /// A scalar parameter outside its domain.
    #[error("{name} = {value} is invalid: {requirement}")]
    InvalidParameter {
        name: &'static str,
        value: String,
        requirement: &'static str,
    },
    /// A generalizer given a number of demonstrations its method cannot use.
    #[error("method '{method}' {requirement}, but there are {got} demonstrations")]
    DemoCount {
        method: &'static str,
        got: usize,
        requirement: String,
    },
    /// Two demonstrations at the same query: the generalization would be ill-defined there.
    #[error(
        "demonstrations {first} and {second} have the same query {query}; a generalizer cannot tell them apart"
    )]
    DuplicateQuery {
        first: usize,
        second: usize,
        query: String,
    },
    /// Demonstrations with different numbers of degrees of freedom.
    #[error(
        "demonstration {index} has {got} degrees of freedom, but demonstration 0 has {expected}"
    )]
    DofMismatch {
        index: usize,
        got: usize,
        expected: usize,
    },
    /// Demonstration queries whose geometry the method cannot use (e.g. collinear for "linear").
    #[error("the demonstration queries are degenerate: {detail}")]
    DegenerateQueries { detail: String },
    /// A query whose generalization would be invalid (e.g. tau <= 0 by extrapolation).
    #[error("cannot generalize to query {query}: {reason}")]
    Extrapolation { query: String, reason: String },
    /// An error in the data of one demonstration.
    #[error("demonstration {index}: {source}")]
    InDemo { index: usize, source: Box<Error> },
    /// The caller asked a long computation to stop (e.g. Ctrl-C in Python).
    #[error("{context} was cancelled")]
    Cancelled { context: &'static str },
    /// A quaternion that is not a rotation: zero, or (unless asked to normalize) not unit norm.
    #[error(
        "{name}[{index}] has the quaternion (w, x, y, z) = {value} of norm {norm}: {requirement}"
    )]
    Quaternion {
        name: &'static str,
        /// The sample (row) index.
        index: usize,
        value: String,
        norm: f64,
        requirement: &'static str,
    },
    /// Demonstrations a method cannot represent to its accuracy (e.g. outputs too rough for
    /// sparse GPs); `detail` says why and what to use instead.
    #[error("{method} cannot represent these demonstrations: {detail}")]
    Unsuited {
        method: &'static str,
        detail: String,
    },
    /// An error in the model of one of a generalizer's outputs (its tau, or one coordinate of
    /// its goal or start).
    #[error("the GP of {output}: {source}")]
    InOutput { output: String, source: Box<Error> },
    /// The input was valid but the computation failed (e.g. a matrix that is not positive definite).
    #[error("numerical failure in {context}: {detail}")]
    Numerical {
        context: &'static str,
        detail: String,
    },
}

impl Error {
    /// True when the caller's input was wrong (Python maps these to `ValueError` subclasses).
    pub fn is_input_error(&self) -> bool {
        match self {
            Error::Numerical { .. } | Error::Cancelled { .. } => false,
            Error::InDemo { source, .. } | Error::InOutput { source, .. } => {
                source.is_input_error()
            }
            _ => true,
        }
    }
}

pub type Result<T> = std::result::Result<T, Error>;

/// A number as `%g` would print it, to 6 significant digits: plain decimals for magnitudes in
/// `[1e-4, 1e6)`, exponent notation outside (so 1e300 is not printed with 300 digits).
pub fn fmt_g(v: f64) -> String {
    if !v.is_finite() {
        return if v.is_nan() {
            "NaN".into()
        } else if v > 0.0 {
            "inf".into()
        } else {
            "-inf".into()
        };
    }
    let a = v.abs();
    if a == 0.0 || (1e-4..1e6).contains(&a) {
        let digits = (5 - a.log10().floor().max(-5.0) as i32).max(0) as usize;
        let s = format!("{v:.digits$}");
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    } else {
        let s = format!("{v:.5e}");
        let (m, e) = s.split_once('e').unwrap_or((&s, "0"));
        let m = if m.contains('.') {
            m.trim_end_matches('0').trim_end_matches('.')
        } else {
            m
        };
        format!("{m}e{e}")
    }
}

/// Checks a scalar: finite and, if `positive`, strictly positive.
pub(crate) fn check_scalar(name: &'static str, value: f64, positive: bool) -> Result<()> {
    if !value.is_finite() {
        return Err(Error::NonFinite {
            name,
            location: String::new(),
            value,
        });
    }
    if positive && value <= 0.0 {
        return Err(Error::InvalidParameter {
            name,
            value: fmt_g(value),
            requirement: "must be > 0",
        });
    }
    Ok(())
}

/// Checks that every entry of a time-major `(T, D)` array (stored as the columns of a `D x T`
/// matrix) is finite, naming the first offender as `name[j, d]`.
pub(crate) fn check_finite_matrix(
    name: &'static str,
    values: &nalgebra::DMatrixView<'_, f64>,
) -> Result<()> {
    for (j, col) in values.column_iter().enumerate() {
        if let Some((d, &v)) = col.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(Error::NonFinite {
                name,
                location: format!("[{j}, {d}]"),
                value: v,
            });
        }
    }
    Ok(())
}

/// Checks that a 1-D array is finite and strictly increasing.
pub(crate) fn check_increasing(name: &'static str, t: &[f64]) -> Result<()> {
    if let Some((j, &v)) = t.iter().enumerate().find(|(_, v)| !v.is_finite()) {
        return Err(Error::NonFinite {
            name,
            location: format!("[{j}]"),
            value: v,
        });
    }
    for j in 1..t.len() {
        if t[j] <= t[j - 1] {
            return Err(Error::NotIncreasing {
                name,
                index: j,
                value: t[j],
                prev: t[j - 1],
            });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::fmt_g;

    #[test]
    fn numbers_print_like_percent_g() {
        for (v, want) in [
            (0.0, "0"),
            (48.0, "48"),
            (0.001, "0.001"),
            (1e-300, "1e-300"),
            (1e300, "1e300"),
            (123456.0, "123456"),
            (1234567.0, "1.23457e6"),
            (-2.5e-7, "-2.5e-7"),
            (f64::NAN, "NaN"),
        ] {
            assert_eq!(fmt_g(v), want, "{v}");
        }
    }
}
