//! Optional box limits on the query for the unbracketed learners (error learning, policy
//! gradient), and the detection of a run that is stuck at one of them.
//!
//! A wrong sign convention of eps (docs/method.md §5.3) or a target outside the reachable range makes
//! these learners walk away from the root; with limits they clip at a limit and stay there. After
//! `pin_limit` consecutive trials at a limit whose eps still points outwards, the learner stops
//! with `Status::HitBound` instead of looping until the trial cap.

use crate::ask_tell::Status;
use crate::error::{Result, check_finite, check_vector, invalid};

#[derive(Debug, Clone)]
pub struct Bounds {
    low: Vec<f64>,
    high: Vec<f64>,
    pin_limit: usize,
    pinned: usize,
}

impl Bounds {
    /// `low`/`high` may be absent (then -inf/+inf); present ones must have `n` finite entries
    /// with low < high.
    pub fn new(
        low: Option<&[f64]>,
        high: Option<&[f64]>,
        n: usize,
        pin_limit: usize,
    ) -> Result<Option<Self>> {
        if low.is_none() && high.is_none() {
            return Ok(None);
        }
        if pin_limit == 0 {
            return Err(invalid("pin_limit", 0, "must be at least 1"));
        }
        let side = |v: Option<&[f64]>, name: &'static str, fill: f64| -> Result<Vec<f64>> {
            match v {
                Some(v) => {
                    check_vector(name, v, n)?;
                    Ok(v.to_vec())
                }
                None => Ok(vec![fill; n]),
            }
        };
        let low = side(low, "low", f64::NEG_INFINITY)?;
        let high = side(high, "high", f64::INFINITY)?;
        if let Some(i) = (0..n).find(|&i| low[i] >= high[i]) {
            return Err(invalid(
                "low",
                format!("{} (at index {i}, with high = {})", low[i], high[i]),
                "must be < high",
            ));
        }
        Ok(Some(Self {
            low,
            high,
            pin_limit,
            pinned: 0,
        }))
    }

    /// Checks that a start query lies inside the limits.
    pub fn check_inside(&self, name: &'static str, q: &[f64]) -> Result<()> {
        check_finite(name, q)?;
        if let Some(i) = (0..q.len()).find(|&i| q[i] < self.low[i] || q[i] > self.high[i]) {
            return Err(invalid(
                name,
                format!("{} (at index {i})", q[i]),
                &format!(
                    "must lie within [low, high] = [{}, {}]",
                    self.low[i], self.high[i]
                ),
            ));
        }
        Ok(())
    }

    pub fn clip(&self, q: &mut [f64]) {
        for (i, x) in q.iter_mut().enumerate() {
            *x = x.clamp(self.low[i], self.high[i]);
        }
    }

    /// Called after each told trial; returns `HitBound` once the learner has been pinned for
    /// `pin_limit` consecutive trials. `push[i] > 0` means the learner wants to increase q_i.
    pub fn observe(&mut self, q: &[f64], push: &[f64]) -> Option<Status> {
        let at = (0..q.len()).find_map(|i| {
            if q[i] >= self.high[i] && push[i] > 0.0 {
                Some(Status::HitBound {
                    high: true,
                    value: self.high[i],
                })
            } else if q[i] <= self.low[i] && push[i] < 0.0 {
                Some(Status::HitBound {
                    high: false,
                    value: self.low[i],
                })
            } else {
                None
            }
        });
        match at {
            Some(s) => {
                self.pinned += 1;
                (self.pinned >= self.pin_limit).then_some(s)
            }
            None => {
                self.pinned = 0;
                None
            }
        }
    }
}
