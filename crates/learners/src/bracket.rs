//! What the bracketing learners (golden section, the Illinois root finder) share: the checks of a
//! finite start q0, finite limits low < high whose width is representable and the stopping
//! tolerances; and the robust rule that moves a limit out when the root lies beyond it.

use crate::error::{Result, check_scalar, invalid};

/// The default `q_tol`: this fraction of the width of [low, high].
pub const DEFAULT_Q_TOL_FRACTION: f64 = 1e-4;
/// §6.3 (b): expand when q is within this fraction of the reference width of an unconfirmed limit.
const EXPAND_WINDOW: f64 = 0.05;
/// §6.3 (b): the expansion factor.
const EXPAND_FACTOR: f64 = 1.618;

/// What [`Expansions::expand`] did to a limit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Expansion {
    /// The trial was not next to an unconfirmed limit: nothing to do.
    NotNeeded,
    /// It was, and the side's expansions are spent: the limit stays.
    Spent,
    /// The limit moved out.
    Moved,
}

/// §6.3 (b), golden section's robust rule: when a trial lies within `EXPAND_WINDOW W0` of a limit
/// no trial has confirmed and its eps points past that limit, the limit moves out by
/// `EXPAND_FACTOR^k W0` at the side's k-th expansion, at most `max` times per side; W0 is the
/// bracket's width at the start.
#[derive(Debug, Clone)]
pub(crate) struct Expansions {
    first_width: f64,
    max: usize,
    /// So far, of the low and the high limit.
    used: [usize; 2],
}

impl Expansions {
    pub(crate) fn new(first_width: f64, max: usize) -> Self {
        Self {
            first_width,
            max,
            used: [0, 0],
        }
    }

    /// W0, the bracket's width at the start.
    pub(crate) fn first_width(&self) -> f64 {
        self.first_width
    }

    /// The expansions of `(low, high)` so far.
    pub(crate) fn used(&self) -> (usize, usize) {
        (self.used[0], self.used[1])
    }

    /// Moves `limit` out if the trial at `q` calls for it: `up` says eps points above q (so
    /// `limit` is the upper one), `confirmed` that a trial has confirmed `limit`.
    pub(crate) fn expand(
        &mut self,
        q: f64,
        up: bool,
        limit: &mut f64,
        confirmed: bool,
    ) -> Expansion {
        let gap = if up { *limit - q } else { q - *limit };
        let near = gap <= EXPAND_WINDOW * self.first_width;
        if !near || confirmed {
            return Expansion::NotNeeded;
        }
        let side = usize::from(up);
        if self.used[side] >= self.max {
            return Expansion::Spent;
        }
        self.used[side] += 1;
        let step = EXPAND_FACTOR.powi(self.used[side] as i32) * self.first_width;
        if up {
            *limit += step;
        } else {
            *limit -= step;
        }
        Expansion::Moved
    }
}

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
