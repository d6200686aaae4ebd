//! The ask/tell shape every learner shares (the convention of cma, optuna and nevergrad):
//!
//! ```text
//! while learner.status() == Status::Running {
//!     let q = learner.ask()?;          // the query (or weight vector) to execute next
//!     let feedback = run_trial(&q);    // one physical trial
//!     learner.tell(&q, &feedback)?;    // what came out of it
//! }
//! ```
//!
//! What `feedback` is depends on the learner family; each constructor documents it:
//! * query learners (error learning, golden section, the root finder, policy gradient): the
//!   signed error `eps = q0 - q_a` (n entries), with the convention of docs/method.md §5.3:
//!   **eps > 0 means the query must increase**;
//! * PoWER: one return R > 0 (maximized);
//! * PI²: the costs of one rollout, either one terminal cost or one cost per time step.
//!
//! `Record` holds the bookkeeping they all share: the pending query, the history, the best
//! trial, the trial cap and the reason for stopping.

use crate::error::{LearnerError, Result, check_finite};

/// Why a learner is (not) running.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Status {
    Running,
    /// The last trial met the learner's tolerance (|eps| < tol, or the cost/return target).
    Converged,
    /// A bracketing learner narrowed the root to an interval shorter than its `q_tol` without
    /// any trial meeting |eps| < tol (e.g. an error that jumps across zero, paper Fig. 2c).
    Bracketed,
    /// `max_trials` trials were told without converging.
    TrialCap,
    /// The iterates ran into a search limit and stayed there: the root lies outside the limits,
    /// or the sign convention of eps is wrong (docs/method.md §5.3, §6.2 item 4).
    HitBound {
        high: bool,
        value: f64,
    },
    /// |eps| grew in several consecutive trials to well above its first value: the gain is
    /// too high or the sign convention is wrong.
    Diverged,
}

impl Status {
    pub fn is_running(&self) -> bool {
        matches!(self, Status::Running)
    }

    /// A short machine-readable name ("running", "converged", ...), used by the Python API.
    pub fn name(&self) -> &'static str {
        match self {
            Status::Running => "running",
            Status::Converged => "converged",
            Status::Bracketed => "bracketed",
            Status::TrialCap => "trial-cap",
            Status::HitBound { .. } => "hit-bound",
            Status::Diverged => "diverged",
        }
    }
}

impl std::fmt::Display for Status {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Status::HitBound { high, value } => {
                write!(
                    f,
                    "hit-bound: pinned at the {} limit {value}",
                    if *high { "upper" } else { "lower" }
                )
            }
            s => f.write_str(s.name()),
        }
    }
}

/// One executed trial: the query (or weights) and what was told about it.
#[derive(Debug, Clone, PartialEq)]
pub struct Trial {
    pub q: Vec<f64>,
    /// eps, a return, or costs, as told.
    pub feedback: Vec<f64>,
    /// The learner's figure of merit, lower is better (|eps|, a cost, or -R).
    pub score: f64,
}

/// The interface of every learner.
pub trait AskTell {
    /// The length of the vectors `ask` returns.
    fn dim(&self) -> usize;
    /// The next query to execute. Asking again before `tell` returns the same query.
    fn ask(&mut self) -> Result<Vec<f64>>;
    /// Reports the outcome of executing `q`, which must be the pending query from `ask`.
    fn tell(&mut self, q: &[f64], feedback: &[f64]) -> Result<()>;
    fn record(&self) -> &Record;

    fn status(&self) -> Status {
        self.record().status
    }
    fn converged(&self) -> bool {
        self.record().status == Status::Converged
    }
    /// The executed trial with the lowest score.
    fn best(&self) -> Option<&Trial> {
        self.record().best()
    }
    fn history(&self) -> &[Trial] {
        &self.record().history
    }
    fn n_told(&self) -> usize {
        self.record().history.len()
    }
}

/// Shared bookkeeping: pending query, history, best trial, trial cap, status.
#[derive(Debug, Clone)]
pub struct Record {
    pub(crate) pending: Option<Vec<f64>>,
    pub(crate) history: Vec<Trial>,
    best: Option<usize>,
    pub(crate) max_trials: usize,
    pub(crate) status: Status,
}

impl Record {
    pub(crate) fn new(max_trials: usize) -> Result<Self> {
        crate::error::check_max_trials(max_trials)?;
        Ok(Self {
            pending: None,
            history: Vec::new(),
            best: None,
            max_trials,
            status: Status::Running,
        })
    }

    pub fn best(&self) -> Option<&Trial> {
        self.best.map(|i| &self.history[i])
    }

    pub fn history(&self) -> &[Trial] {
        &self.history
    }

    /// Every learner's `ask`: refuses after a stop, repeats a pending query, else makes `next()`
    /// the pending query. A non-finite query is never asked: the learner stops as `Diverged`
    /// (its `tell` normally notices first, see [`diverged_unless_finite`]).
    pub(crate) fn ask_with(&mut self, next: impl FnOnce() -> Vec<f64>) -> Result<Vec<f64>> {
        if !self.status.is_running() {
            return Err(LearnerError::Finished {
                status: self.status.to_string(),
            });
        }
        if let Some(q) = &self.pending {
            return Ok(q.clone());
        }
        let q = next();
        if diverged_unless_finite(&q).is_some() {
            self.status = Status::Diverged;
            return Err(LearnerError::Finished {
                status: self.status.to_string(),
            });
        }
        self.pending = Some(q.clone());
        Ok(q)
    }

    /// The start of every `tell`: the order of calls, the query, and the feedback's size and
    /// finiteness. `feedback_lens` lists the accepted lengths.
    pub(crate) fn check_tell(
        &self,
        q: &[f64],
        feedback: &[f64],
        feedback_name: &'static str,
        feedback_lens: &[usize],
    ) -> Result<()> {
        let Some(expected) = &self.pending else {
            if !self.status.is_running() {
                return Err(LearnerError::Finished {
                    status: self.status.to_string(),
                });
            }
            return Err(LearnerError::NotAsked);
        };
        check_finite("q", q)?;
        // Equal up to rounding: the caller may have passed the query through another float
        // representation (a list, a JSON log) and back.
        let same = q.len() == expected.len()
            && q.iter()
                .zip(expected)
                .all(|(a, b)| (a - b).abs() <= 1e-12 * (1.0 + b.abs()));
        if !same {
            return Err(LearnerError::UnexpectedQuery {
                expected: expected.clone(),
                got: q.to_vec(),
            });
        }
        if !feedback_lens.contains(&feedback.len()) {
            let expected = feedback_lens
                .iter()
                .map(|n| n.to_string())
                .collect::<Vec<_>>()
                .join(" or ");
            return Err(LearnerError::Dimension {
                name: feedback_name,
                expected: format!("{expected} entries"),
                got: format!("{} entries", feedback.len()),
            });
        }
        check_finite(feedback_name, feedback)
    }

    /// Appends a told trial (the pending query) and applies the trial cap. Returns its index.
    pub(crate) fn push(&mut self, feedback: &[f64], score: f64) -> Result<usize> {
        let q = self.pending.take().ok_or(LearnerError::NotAsked)?;
        self.history.push(Trial {
            q,
            feedback: feedback.to_vec(),
            score,
        });
        let i = self.history.len() - 1;
        if self.best.is_none_or(|b| score < self.history[b].score) {
            self.best = Some(i);
        }
        Ok(i)
    }

    /// Sets the status after a tell: `stop` if the learner decided to stop, else the trial cap.
    pub(crate) fn finish_tell(&mut self, stop: Option<Status>) {
        if let Some(s) = stop {
            self.status = s;
        } else if self.history.len() >= self.max_trials {
            self.status = Status::TrialCap;
        }
    }
}

/// The max-norm of eps: every component must be within `tol` for convergence, so that the
/// criterion of a vector query reads like the paper's |eps| < precision for n = 1.
pub(crate) fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0_f64, |m, x| m.max(x.abs()))
}

/// `Some(Diverged)` when a learner's next query (or the state it samples it from) is not finite:
/// a huge gain, step, exploration or return overflowed. A learner never asks such a query.
pub(crate) fn diverged_unless_finite(next: &[f64]) -> Option<Status> {
    (!next.iter().all(|v| v.is_finite())).then_some(Status::Diverged)
}
