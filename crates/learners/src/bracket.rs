//! The checks the bracketing learners (golden section, the Illinois root finder) share: a finite
//! start q0, finite limits low < high whose width is representable, and the stopping tolerances.

use crate::error::{Result, check_scalar, invalid};

/// The default `q_tol`: this fraction of the width of [low, high].
pub const DEFAULT_Q_TOL_FRACTION: f64 = 1e-4;

/// Validates q0, [low, high], `tol` and `q_tol`; returns `q_tol` (the default when None).
pub(crate) fn check_bracket(
    q0: f64,
    low: f64,
    high: f64,
    tol: f64,
    q_tol: Option<f64>,
) -> Result<f64> {
    check_scalar("q0", q0, false)?;
    check_scalar("low", low, false)?;
    check_scalar("high", high, false)?;
    if low >= high {
        return Err(invalid("low", low, &format!("must be < high = {high}")));
    }
    // The learners search [min(low, q0), max(high, q0)] (robust mode widens it to contain q0).
    if !(high.max(q0) - low.min(q0)).is_finite() {
        return Err(invalid(
            "[low, high]",
            format!("[{low:e}, {high:e}] with q0 = {q0:e}"),
            "the bracket's width overflows: give limits (and q0) whose differences are finite",
        ));
    }
    check_scalar("tol", tol, true)?;
    match q_tol {
        Some(q_tol) => {
            check_scalar("q_tol", q_tol, true)?;
            Ok(q_tol)
        }
        None => Ok(DEFAULT_Q_TOL_FRACTION * (high - low)),
    }
}
