//! A superlinear bracketing root finder for one-dimensional queries, beyond the paper: Illinois
//! regula falsi under a golden-section safeguard schedule.
//!
//! It is a drop-in replacement for golden-section error learning (`golden.rs`): it starts with
//! the pure generalization q0, needs limits [low, high] assumed to contain the root, and reads
//! the same eps (eps > 0: the query must increase, docs/method.md §5.3). Unlike golden section it
//! also uses |eps|:
//!
//! * with both ends of the bracket tried, the next query is the regula-falsi point, with the
//!   Illinois modification (halve the retained end's eps when the same end is kept twice), which
//!   converges superlinearly on smooth maps;
//! * with one end still an untried limit, it takes the error-learning step of eq. 16 with K = I
//!   (q + eps; slope from the last two trials when they give a usable secant, within the §5.2
//!   safeguard [0.1, 10]): exact when q_a = q, as for queries in outcome units.
//!
//! The guarantee — never more trials than golden section in its worst case — comes from a
//! schedule like the one ITP (Oliveira & Takahashi 2020) uses with bisection: after the m-th
//! trial the bracket must be no wider than W_1 * 0.618^(m-1), golden section's worst case from
//! the same first trial. Each candidate is projected onto the points that keep both possible
//! new brackets within that width. So whenever golden section would stop on bracket width,
//! this finder has stopped too; when interpolation works it stops much earlier.
//!
//! With `max_expansions > 0` it also expands a limit no trial has confirmed, as golden section's
//! robust mode does (docs/method.md §6.3 (b)): when a trial lands within 5 % of the first
//! bracket's width W0 of such a limit and eps still points past it, the limit moves out by
//! 1.618^k W0 on the k-th expansion of that side, and the golden schedule restarts from the new
//! bracket. So a root outside the demos' queries is found, not reported as `HitBound`.
//!
//! Stops: |eps| < tol (`Converged`); a bracket narrower than `q_tol` (`Bracketed`, or
//! `HitBound` when one end is an untried limit: the root lies outside [low, high] or the sign
//! convention is wrong, and the expansions are spent); the trial cap.

use crate::ask_tell::{AskTell, Record, Status, diverged_unless_finite};
use crate::bracket::{Expansion, Expansions, check_bracket};
use crate::error::Result;
use crate::golden::GOLDEN_HIGH;

#[derive(Debug, Clone)]
pub struct RootFinderConfig {
    /// Converged when |eps| < tol.
    pub tol: f64,
    /// Stop when the bracket is narrower than this (query units). None: 1e-4 times the width
    /// of [low, high].
    pub q_tol: Option<f64>,
    pub max_trials: usize,
    /// Expansions of an unconfirmed limit allowed per side (0: the limits are fixed).
    pub max_expansions: usize,
}

impl Default for RootFinderConfig {
    fn default() -> Self {
        Self {
            tol: 1e-3,
            q_tol: None,
            max_trials: 50,
            max_expansions: 0,
        }
    }
}

#[derive(Debug, Clone)]
pub struct IllinoisRootFinder {
    tol: f64,
    q_tol: f64,
    a: f64,
    b: f64,
    /// eps at a and b; None while that end is an untried limit.
    fa: Option<f64>,
    fb: Option<f64>,
    /// The Illinois-scaled values used for interpolation.
    ga: f64,
    gb: f64,
    /// Which end the last trial replaced (true: b).
    last_replaced_b: Option<bool>,
    /// The largest bracket width allowed after the next trial (the golden schedule).
    allowed: f64,
    next: f64,
    /// Of [low, high] widened to contain q0.
    expansions: Expansions,
    rec: Record,
}

impl IllinoisRootFinder {
    pub fn new(q0: f64, low: f64, high: f64, cfg: RootFinderConfig) -> Result<Self> {
        let q_tol = check_bracket(q0, low, high, cfg.tol, cfg.q_tol)?;
        // Like golden section's robust mode (a): the bracket contains q0.
        let (a, b) = (low.min(q0), high.max(q0));
        Ok(Self {
            tol: cfg.tol,
            q_tol,
            a,
            b,
            fa: None,
            fb: None,
            ga: 0.0,
            gb: 0.0,
            last_replaced_b: None,
            allowed: f64::INFINITY,
            next: q0,
            expansions: Expansions::new(b - a, cfg.max_expansions),
            rec: Record::new(cfg.max_trials)?,
        })
    }

    /// The current bracket [a, b].
    pub fn bracket(&self) -> (f64, f64) {
        (self.a, self.b)
    }

    /// The slope d eps/dq to assume when only one end is known: the secant of the last two
    /// trials if it is negative and within [0.1, 10] in magnitude, else -1 (q_a = q).
    fn assumed_slope(&self) -> f64 {
        let h = &self.rec.history;
        if h.len() >= 2 {
            let (p, c) = (&h[h.len() - 2], &h[h.len() - 1]);
            let dq = c.q[0] - p.q[0];
            if dq != 0.0 {
                let s = (c.feedback[0] - p.feedback[0]) / dq;
                if (-10.0..=-0.1).contains(&s) {
                    return s;
                }
            }
        }
        -1.0
    }

    /// The expansions of `(low, high)` so far.
    pub fn expansions(&self) -> (usize, usize) {
        self.expansions.used()
    }

    /// Moves an unconfirmed limit outwards when the trial at `q` lies next to it and its eps
    /// points past it (`up`: eps > 0, the root is above q). Returns whether it moved.
    fn expand(&mut self, q: f64, up: bool) -> bool {
        let (limit, untried) = if up {
            (&mut self.b, self.fb.is_none())
        } else {
            (&mut self.a, self.fa.is_none())
        };
        self.expansions.expand(q, up, limit, !untried) == Expansion::Moved
    }

    fn candidate(&self) -> f64 {
        match (self.fa, self.fb) {
            // ga > 0 >= gb: the regula-falsi point lies in [a, b].
            (Some(_), Some(_)) => self.a + self.ga * (self.b - self.a) / (self.ga - self.gb),
            (Some(fa), None) => self.a - fa / self.assumed_slope(),
            (None, Some(fb)) => self.b - fb / self.assumed_slope(),
            (None, None) => 0.5 * (self.a + self.b),
        }
    }

    /// Projects the candidate onto the points that keep the next bracket within the schedule,
    /// and a little away from the ends (a point on an end would tell nothing new).
    fn safeguard(&self, x: f64) -> f64 {
        let (a, b) = (self.a, self.b);
        let lo = a.max(b - self.allowed);
        let hi = b.min(a + self.allowed);
        let margin = (0.25 * self.q_tol).min(0.25 * (hi - lo));
        let (lo, hi) = (lo + margin, hi - margin);
        if lo <= hi {
            x.clamp(lo, hi)
        } else {
            0.5 * (a + b)
        }
    }
}

impl AskTell for IllinoisRootFinder {
    fn dim(&self) -> usize {
        1
    }

    fn ask(&mut self) -> Result<Vec<f64>> {
        self.rec.ask_with(|| vec![self.next])
    }

    fn tell(&mut self, q: &[f64], eps: &[f64]) -> Result<()> {
        self.rec.check_tell(q, eps, "eps", &[1])?;
        let (q, e) = (q[0], eps[0]);
        let first = self.rec.history.is_empty();
        self.rec.push(eps, e.abs())?;
        if e.abs() < self.tol {
            self.rec.finish_tell(Some(Status::Converged));
            return Ok(());
        }
        // The same sign rule as golden section (a tie goes to the upper end, §6.2 item 7).
        let replaced_b = e <= 0.0;
        if replaced_b {
            if self.last_replaced_b == Some(true) {
                self.ga *= 0.5; // Illinois: a kept twice
            }
            self.b = q;
            self.fb = Some(e);
            self.gb = e;
        } else {
            if self.last_replaced_b == Some(false) {
                self.gb *= 0.5; // Illinois: b kept twice
            }
            self.a = q;
            self.fa = Some(e);
            self.ga = e;
        }
        self.last_replaced_b = Some(replaced_b);
        // Golden section's worst case from the same first trial: W_1, then x 0.618 per trial.
        self.allowed = if first { self.b - self.a } else { self.allowed };
        self.allowed *= GOLDEN_HIGH;
        if self.expand(q, !replaced_b) {
            self.allowed = self.b - self.a; // the schedule restarts from the expanded bracket
        }

        let width = self.b - self.a;
        let stop = if width < self.q_tol {
            Some(match (self.fa, self.fb) {
                (_, None) => Status::HitBound {
                    high: true,
                    value: self.b,
                },
                (None, _) => Status::HitBound {
                    high: false,
                    value: self.a,
                },
                _ => Status::Bracketed,
            })
        } else {
            None
        };
        if stop.is_none() {
            self.next = self.safeguard(self.candidate());
        }
        self.rec
            .finish_tell(stop.or_else(|| diverged_unless_finite(&[self.next])));
        Ok(())
    }

    fn record(&self) -> &Record {
        &self.rec
    }
}
