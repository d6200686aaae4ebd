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
//!   Expansion step \[D\]: docs/method.md §6.3 writes q_h <- q_h + 1.618 (q_h - q_l), but by the time a
//!   trial is within 5 % of q_h the bracket [q_l, q_h] has shrunk to about 7 % of W0, so that
//!   step barely moves the limit (three expansions reach only 0.25 W0 past it). The k-th
//!   expansion on a side instead adds 1.618^k W0, the geometric growth of classical bracket
//!   search (Numerical Recipes' `mnbrak`): k expansions reach up to 1.618 + ... + 1.618^k W0.
//!
//! Under measurement noise a single reading of the wrong sign would move a limit past the root,
//! and the box never looks at a limit again: the root is outside the bracket for good. With
//! `noise = Some(sigma)` (the standard deviation of eps; either mode, off by default) two
//! guards keep one noisy sign from corrupting the bracket (docs/method.md §6.5):
//!
//! 1. *Doubtful signs are repeated.* A reading of the wrong sign needs noise larger than the
//!    true |eps|, so one with |eps| >= 2 sigma is wrong in at most 2.3 % of trials, and one
//!    nearer 0 far more often. Such a reading does not move a limit: the same q is asked again
//!    and the sign taken is that of the mean of its readings, once |mean| >= 2 sigma / sqrt(n)
//!    or after `max_repeats` readings.
//! 2. *A limit is re-checked before the search settles next to it.* A wrong sign shows itself
//!    only through where it sends the search: every later trial lies on the root's side of the
//!    wrong limit, so their signs all point towards it. After 3 consecutive readings of the same
//!    sign the limit they point to, if a trial set it and no re-check has confirmed it, is asked
//!    again. A reading at a limit that contradicts it re-opens the limit: it goes back to the
//!    one it replaced (every limit remembers it), and the reading enters the box as any other.
//!    A stop that rests on a limit (`HitBound`, `Bracketed`) re-checks it first in the same way.
//!    One wrong sign of any size therefore costs about 4 trials, not the run; a correct bracket
//!    costs a re-check only when the root is near one of its limits, or before it stops.
//!
//! eps > 0 means the query must increase (docs/method.md §5.3).

use crate::ask_tell::{AskTell, Record, Status, diverged_unless_finite};
use crate::bracket::{Expansion, Expansions, check_bracket};
use crate::error::{Result, check_scalar, invalid};

/// The paper's constants: the next point sits at 0.618 (eps > 0) or 0.382 (eps <= 0) of the
/// new bracket.
pub const GOLDEN_HIGH: f64 = 0.618;
pub const GOLDEN_LOW: f64 = 0.382;
/// Paper mode: a bracket narrower than this fraction of the first one has collapsed.
const COLLAPSE: f64 = 1e-9;
/// Noise guard 1: a mean of n readings with |mean| < DOUBT_SIGMAS sigma / sqrt(n) has a doubtful sign.
const DOUBT_SIGMAS: f64 = 2.0;
/// Noise guard 2: consecutive readings of one sign after which the limit they point to is re-checked.
const RECHECK_STREAK: usize = 3;

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
    /// The standard deviation of a reading of eps; `Some` turns on the noise guards (module doc).
    pub noise: Option<f64>,
    /// Noise guard 1: readings at one q before its sign is taken from their mean regardless.
    pub max_repeats: usize,
}

impl Default for GoldenConfig {
    fn default() -> Self {
        Self {
            mode: GoldenMode::Paper,
            tol: 1e-3,
            q_tol: None,
            max_trials: 50,
            max_expansions: 4,
            noise: None,
            max_repeats: 3,
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
    expansions: Expansions,
    noise: Option<f64>,
    max_repeats: usize,
    /// Noise guard 1: the readings so far at the q being repeated (q, sum of eps, count).
    readings: Option<(f64, f64, usize)>,
    /// Noise guard 2: per side (low, high), the (limit, confirmed) pairs each trial replaced.
    replaced: [Vec<(f64, bool)>; 2],
    /// Noise guard 2: per side, whether a re-check has confirmed the current limit.
    verified: [bool; 2],
    /// Noise guard 2: the sign of the latest readings (eps > 0) and how many in a row.
    streak: (bool, usize),
    /// Noise guard 2: how many limits were re-opened.
    reopened: usize,
    rec: Record,
}

impl GoldenSection {
    pub fn new(q0: f64, low: f64, high: f64, cfg: GoldenConfig) -> Result<Self> {
        let q_tol = check_bracket(q0, low, high, cfg.tol, cfg.q_tol)?;
        if let Some(sigma) = cfg.noise {
            check_scalar("noise", sigma, true)?;
        }
        if cfg.max_repeats == 0 {
            return Err(invalid("max_repeats", 0, "must be >= 1 (1: never repeat)"));
        }
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
            // W0 is the width after widening to contain q0.
            expansions: Expansions::new(qh - ql, cfg.max_expansions),
            noise: cfg.noise,
            max_repeats: cfg.max_repeats,
            readings: None,
            replaced: [Vec::new(), Vec::new()],
            verified: [false, false],
            streak: (false, 0),
            reopened: 0,
            rec: Record::new(cfg.max_trials)?,
        })
    }

    /// The current search limits (q_l, q_h).
    pub fn bracket(&self) -> (f64, f64) {
        (self.ql, self.qh)
    }

    /// How many limits the noise guard re-opened (module doc, guard 2).
    pub fn reopened(&self) -> usize {
        self.reopened
    }

    /// Side 0 (low) or 1 (high): the limit and whether a trial set it.
    fn limit(&self, side: usize) -> (f64, bool) {
        if side == 0 {
            (self.ql, self.low_confirmed)
        } else {
            (self.qh, self.high_confirmed)
        }
    }

    /// Noise guard 1: the sign-bearing eps for this reading, or None to ask q again.
    fn reading(&mut self, q: f64, e: f64, sigma: f64) -> Option<f64> {
        let (sum, n) = match self.readings {
            Some((q_r, sum, n)) if q_r == q => (sum + e, n + 1),
            _ => (e, 1),
        };
        let mean = sum / n as f64;
        if mean.abs() < DOUBT_SIGMAS * sigma / (n as f64).sqrt() && n < self.max_repeats {
            self.readings = Some((q, sum, n));
            return None;
        }
        self.readings = None;
        Some(mean)
    }

    /// Noise guard 2, before the box: a reading at a limit a trial set either confirms it
    /// (`up`, eps > 0, agrees with the low limit) or re-opens it to the limit it replaced.
    fn recheck_reading(&mut self, q: f64, up: bool) {
        for side in [0, 1] {
            let (limit, confirmed) = self.limit(side);
            if q != limit || !confirmed {
                continue;
            }
            if up == (side == 0) {
                self.verified[side] = true;
            } else if let Some((previous, was_confirmed)) = self.replaced[side].pop() {
                if side == 0 {
                    (self.ql, self.low_confirmed) = (previous, was_confirmed);
                } else {
                    (self.qh, self.high_confirmed) = (previous, was_confirmed);
                }
                self.verified[side] = false;
                self.reopened += 1;
            }
        }
    }

    /// Noise guard 2, after the box: the limit to re-check after a streak of one sign, if any.
    fn recheck_due(&mut self, up: bool) -> Option<f64> {
        self.streak = if self.streak.0 == up && self.streak.1 > 0 {
            (up, self.streak.1 + 1)
        } else {
            (up, 1)
        };
        // eps > 0 readings raise q_l and point towards q_h.
        let side = usize::from(up);
        let (limit, confirmed) = self.limit(side);
        if self.streak.1 < RECHECK_STREAK || !confirmed || self.verified[side] {
            return None;
        }
        self.streak.1 = 0;
        Some(limit)
    }

    /// Noise guard 2, before stopping with `status`: the limit that status rests on, if a
    /// trial set it and no re-check has confirmed it (`HitBound` high rests on q_l, low on q_h,
    /// `Bracketed` on both).
    fn recheck_before(&mut self, status: &Status) -> Option<f64> {
        let sides: &[usize] = match status {
            Status::HitBound { high: true, .. } => &[0],
            Status::HitBound { high: false, .. } => &[1],
            Status::Bracketed => &[0, 1],
            _ => &[],
        };
        for &side in sides {
            let (limit, confirmed) = self.limit(side);
            if confirmed && !self.verified[side] {
                self.streak = (false, 0);
                return Some(limit);
            }
        }
        None
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
        let (limit, confirmed) = if up {
            (&mut self.qh, self.high_confirmed)
        } else {
            (&mut self.ql, self.low_confirmed)
        };
        match self.expansions.expand(q, up, limit, confirmed) {
            Expansion::Spent => Some(Status::HitBound {
                high: up,
                value: *limit,
            }),
            Expansion::NotNeeded | Expansion::Moved => None,
        }
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
        let e = match self.noise {
            None => e,
            Some(sigma) => match self.reading(q, e, sigma) {
                Some(mean) => {
                    self.recheck_reading(q, mean > 0.0);
                    mean
                }
                None => {
                    // Guard 1: ask the same q again; the bracket does not move.
                    self.next = q;
                    self.rec.finish_tell(None);
                    return Ok(());
                }
            },
        };
        let mut stop = None;
        if self.mode == GoldenMode::Robust {
            stop = self.expand(q, e > 0.0);
        }
        // The algorithm box.
        if e > 0.0 {
            if q != self.ql {
                self.replaced[0].push((self.ql, self.low_confirmed));
                self.verified[0] = false;
            }
            self.ql = q;
            self.low_confirmed = true;
            self.next = self.ql + (self.qh - self.ql) * GOLDEN_HIGH;
        } else {
            if q != self.qh {
                self.replaced[1].push((self.qh, self.high_confirmed));
                self.verified[1] = false;
            }
            self.qh = q;
            self.high_confirmed = true;
            self.next = self.ql + (self.qh - self.ql) * GOLDEN_LOW;
        }
        if self.noise.is_some()
            && let Some(limit) = self.recheck_due(e > 0.0)
        {
            self.next = limit;
        }
        let width = (self.qh - self.ql).abs();
        if stop.is_none() {
            stop = match self.mode {
                GoldenMode::Robust => (width < self.q_tol).then(|| self.spent()),
                GoldenMode::Paper => {
                    (width <= COLLAPSE * self.expansions.first_width()).then(|| self.spent())
                }
            };
        }
        if self.noise.is_some()
            && let Some(limit) = stop.as_ref().and_then(|s| self.recheck_before(s))
        {
            // Guard 2: a stop that rests on a limit one reading set waits for its re-check.
            self.next = limit;
            stop = None;
        }
        self.rec
            .finish_tell(stop.or_else(|| diverged_unless_finite(&[self.next])));
        Ok(())
    }

    fn record(&self) -> &Record {
        &self.rec
    }
}
