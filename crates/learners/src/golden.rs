//! Golden-section error learning (the paper's algorithm box; docs/method.md §6).
//!
//! A sign-driven bracketing root finder for one-dimensional queries: each trial moves 61.8 % of
//! the way from the current q towards the limit that sign(eps) points to, so the bracket shrinks
//! by 0.382 or 0.618 per trial (§6.2 item 3). Two modes (§6.3):
//!
//! * `Paper`: the algorithm box verbatim, plus fix 1 (stop on |eps| < tol, not eps < tol),
//!   fix 2 (the learned query is the last *executed* q, `best`) and fix 6 (`max_trials`).
//!   A tie eps = 0 takes the `else` branch (item 7); q0 outside [low, high] is left as the paper
//!   has it (item 5: the bracket can invert). The only addition that does not change the
//!   iterates: once the bracket has collapsed onto a limit no trial confirmed, the search cannot
//!   move any more and stops with `HitBound` instead of running into the trial cap.
//! * `Robust`: also (a) widens the bracket to contain q0, (b) expands an unconfirmed limit when a
//!   trial lands within 5 % (of the initial bracket width W0) of it and eps still points past it
//!   (at most `max_expansions` times per side, then `HitBound`), (c) stops when the bracket is
//!   narrower than `q_tol` (`Bracketed`).
//!
//!   Expansion step [D]: docs/method.md §6.3 writes q_h <- q_h + 1.618 (q_h - q_l), but by the time a
//!   trial is within 5 % of q_h the bracket [q_l, q_h] has shrunk to about 7 % of W0, so that
//!   step barely moves the limit (three expansions reach only 0.25 W0 past it). The k-th
//!   expansion on a side instead adds 1.618^k W0, the geometric growth of classical bracket
//!   search (Numerical Recipes' `mnbrak`): k expansions reach up to 1.618 + ... + 1.618^k W0.
//!
//! eps > 0 means the query must increase (docs/method.md §5.3).

use crate::ask_tell::{AskTell, Record, Status, diverged_unless_finite};
use crate::bracket::check_bracket;
use crate::error::Result;

/// The paper's constants: the next point sits at 0.618 (eps > 0) or 0.382 (eps <= 0) of the
/// new bracket.
pub const GOLDEN_HIGH: f64 = 0.618;
pub const GOLDEN_LOW: f64 = 0.382;
/// §6.3 (b): expand when q is within this fraction of the reference width of an unconfirmed limit.
const EXPAND_WINDOW: f64 = 0.05;
/// §6.3 (b): the expansion factor.
const EXPAND_FACTOR: f64 = 1.618;
/// Paper mode: a bracket narrower than this fraction of the first one has collapsed.
const COLLAPSE: f64 = 1e-9;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GoldenMode {
    Paper,
    Robust,
}

#[derive(Debug, Clone)]
pub struct GoldenConfig {
    pub mode: GoldenMode,
    /// Converged when |eps| < tol.
    pub tol: f64,
    /// Robust mode: stop when the bracket is narrower than this (query units). None: 1e-4 times
    /// the width of [low, high].
    pub q_tol: Option<f64>,
    pub max_trials: usize,
    /// Robust mode: expansions allowed per side before `HitBound`.
    pub max_expansions: usize,
}

impl Default for GoldenConfig {
    fn default() -> Self {
        Self {
            mode: GoldenMode::Paper,
            tol: 1e-3,
            q_tol: None,
            max_trials: 50,
            max_expansions: 4,
        }
    }
}

#[derive(Debug, Clone)]
pub struct GoldenSection {
    mode: GoldenMode,
    tol: f64,
    q_tol: f64,
    ql: f64,
    qh: f64,
    next: f64,
    /// A trial with eps > 0 (resp. eps <= 0) has set the lower (resp. upper) end.
    low_confirmed: bool,
    high_confirmed: bool,
    /// W0, the bracket width at the start (after widening to contain q0).
    first_width: f64,
    expansions: [usize; 2],
    max_expansions: usize,
    rec: Record,
}

impl GoldenSection {
    pub fn new(q0: f64, low: f64, high: f64, cfg: GoldenConfig) -> Result<Self> {
        let q_tol = check_bracket(q0, low, high, cfg.tol, cfg.q_tol)?;
        let (ql, qh) = match cfg.mode {
            GoldenMode::Paper => (low, high),
            GoldenMode::Robust => (low.min(q0), high.max(q0)), // §6.3 (a)
        };
        Ok(Self {
            mode: cfg.mode,
            tol: cfg.tol,
            q_tol,
            ql,
            qh,
            next: q0, // §6.2 item 8: the first trial is the pure generalization
            low_confirmed: false,
            high_confirmed: false,
            first_width: qh - ql,
            expansions: [0, 0],
            max_expansions: cfg.max_expansions,
            rec: Record::new(cfg.max_trials)?,
        })
    }

    /// The current search limits (q_l, q_h).
    pub fn bracket(&self) -> (f64, f64) {
        (self.ql, self.qh)
    }

    /// `HitBound` at an unconfirmed limit, else `Bracketed` (used when the bracket is spent).
    fn spent(&self) -> Status {
        if !self.high_confirmed {
            Status::HitBound {
                high: true,
                value: self.qh,
            }
        } else if !self.low_confirmed {
            Status::HitBound {
                high: false,
                value: self.ql,
            }
        } else {
            Status::Bracketed
        }
    }

    /// Robust mode §6.3 (b). `up`: eps > 0 at q. Returns `HitBound` when expansions are spent.
    fn expand(&mut self, q: f64, up: bool) -> Option<Status> {
        let window = EXPAND_WINDOW * self.first_width;
        let (near, confirmed, side) = if up {
            (self.qh - q <= window, self.high_confirmed, 1)
        } else {
            (q - self.ql <= window, self.low_confirmed, 0)
        };
        if !near || confirmed {
            return None;
        }
        if self.expansions[side] >= self.max_expansions {
            return Some(if up {
                Status::HitBound {
                    high: true,
                    value: self.qh,
                }
            } else {
                Status::HitBound {
                    high: false,
                    value: self.ql,
                }
            });
        }
        self.expansions[side] += 1;
        let step = EXPAND_FACTOR.powi(self.expansions[side] as i32) * self.first_width;
        if up {
            self.qh += step;
        } else {
            self.ql -= step;
        }
        None
    }
}

impl AskTell for GoldenSection {
    fn dim(&self) -> usize {
        1
    }

    fn ask(&mut self) -> Result<Vec<f64>> {
        self.rec.ask_with(|| vec![self.next])
    }

    fn tell(&mut self, q: &[f64], eps: &[f64]) -> Result<()> {
        self.rec.check_tell(q, eps, "eps", &[1])?;
        let (q, e) = (q[0], eps[0]);
        self.rec.push(eps, e.abs())?;
        if e.abs() < self.tol {
            // §6.2 fixes 1 and 2: |eps|, and the executed q is the answer.
            self.rec.finish_tell(Some(Status::Converged));
            return Ok(());
        }
        let mut stop = None;
        if self.mode == GoldenMode::Robust {
            stop = self.expand(q, e > 0.0);
        }
        // The algorithm box.
        if e > 0.0 {
            self.ql = q;
            self.low_confirmed = true;
            self.next = self.ql + (self.qh - self.ql) * GOLDEN_HIGH;
        } else {
            self.qh = q;
            self.high_confirmed = true;
            self.next = self.ql + (self.qh - self.ql) * GOLDEN_LOW;
        }
        let width = (self.qh - self.ql).abs();
        if stop.is_none() {
            stop = match self.mode {
                GoldenMode::Robust => (width < self.q_tol).then(|| self.spent()),
                GoldenMode::Paper => (width <= COLLAPSE * self.first_width).then(|| self.spent()),
            };
        }
        self.rec
            .finish_tell(stop.or_else(|| diverged_unless_finite(&[self.next])));
        Ok(())
    }

    fn record(&self) -> &Record {
        &self.rec
    }
}
