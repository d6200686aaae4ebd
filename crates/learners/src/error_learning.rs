//! Error learning in the query space (paper eqs. 16, 17; docs/method.md §5).
//!
//! ```text
//! eps_m   = q0 - q_a(q_m)                                   (13)  told by the caller
//! q_{m+1} = q_m + w_m K J_m^{-1} eps_m                      (16), (17)
//! w_m     = 1                         fixed gain            (16)
//! w_m     = exp(-||eps_m / s||^2)     weighted, task scale s (17), docs/method.md §5.1 [D]
//! ```
//! `K` is the user's gain (eq. 16's K; identity by default). `J_m` estimates dq_a/dq and turns
//! the step into a Newton step (docs/method.md §5.2, the Newton reading of "K ≈ d(G⁻¹∘G)/dq"):
//! identity (the paper's matchbox setting), a fixed matrix, a secant/Broyden estimate, or a
//! finite-difference estimate at q0 bought with n extra trials. Every estimate passes the §5.2
//! safeguard (slope in [0.1, 10] and positive) or is replaced by I.
//!
//! For n-D queries (docs/method.md §5.4) any starting J (a fixed one, or the finite differences)
//! can be refined by Broyden's update from every later trial (`broyden`), and the step can be
//! held inside a trust region (`trust_radius`, in units of `scale`): a trial that reduces ||eps||
//! doubles the radius (up to 10x its start), one that does not halves it and the next step starts
//! again from the best trial, so a map that is far from linear cannot throw the iterate away.
//!
//! Sign convention (docs/method.md §5.3): eps > 0 means the query must increase. With q_a increasing
//! in q and eps = q0 - q_a this holds; a task whose outcome decreases with q must flip the sign
//! of its error. A wrong sign makes the iterates walk away from the root: with `low`/`high` the
//! learner then stops with `HitBound`, without them with `Diverged`.

use nalgebra::{DMatrix, DVector};

use crate::ask_tell::{AskTell, Record, Status, diverged_unless_finite, max_abs};
use crate::bounds::Bounds;
use crate::error::{LearnerError, Result, check_finite, check_query, check_scalar, invalid};

/// An n x n matrix given as a scalar (times I), a diagonal, or in full.
#[derive(Debug, Clone, PartialEq)]
pub enum SquareMatrix {
    Scalar(f64),
    Diagonal(Vec<f64>),
    Full(DMatrix<f64>),
}

impl SquareMatrix {
    /// The n x n matrix; every entry finite.
    fn to_matrix(&self, name: &'static str, n: usize) -> Result<DMatrix<f64>> {
        let m = match self {
            SquareMatrix::Scalar(g) => DMatrix::from_diagonal_element(n, n, *g),
            SquareMatrix::Diagonal(d) if d.len() == n => {
                DMatrix::from_diagonal(&DVector::from_column_slice(d))
            }
            SquareMatrix::Diagonal(d) => {
                return Err(LearnerError::Dimension {
                    name,
                    expected: format!("a scalar, {n} diagonal entries or shape ({n}, {n})"),
                    got: format!("{} diagonal entries", d.len()),
                });
            }
            SquareMatrix::Full(m) if m.shape() == (n, n) => m.clone(),
            SquareMatrix::Full(m) => {
                return Err(LearnerError::Dimension {
                    name,
                    expected: format!("shape ({n}, {n})"),
                    got: format!("shape {:?}", m.shape()),
                });
            }
        };
        check_finite(name, m.as_slice())?;
        Ok(m)
    }
}

impl From<f64> for SquareMatrix {
    fn from(g: f64) -> Self {
        SquareMatrix::Scalar(g)
    }
}

impl From<DMatrix<f64>> for SquareMatrix {
    fn from(m: DMatrix<f64>) -> Self {
        SquareMatrix::Full(m)
    }
}

/// How J_m (the estimate of dq_a/dq) is obtained.
#[derive(Debug, Clone, PartialEq)]
pub enum Jacobian {
    /// J = I: the step is K eps (eq. 16 as in the paper's matchbox experiment).
    Identity,
    /// A fixed, user-supplied n x n estimate of dq_a/dq (must be invertible).
    Fixed(SquareMatrix),
    /// Secant (n = 1) / Broyden (n > 1) update from consecutive trials, starting at J = I.
    Secant,
    /// Forward differences at q0 with step `delta`: trials q0 + delta e_j, j = 1..n, after the
    /// first trial at q0 (docs/method.md §5.2 item 4). The probes count as trials.
    FiniteDifference { delta: f64 },
}

/// The finite-difference step of `Jacobian::FiniteDifference` unless the caller chooses one.
pub const DEFAULT_FD_DELTA: f64 = 0.01;

#[derive(Debug, Clone)]
pub struct ErrorLearningConfig {
    /// K of eq. 16 (n x n).
    pub gain: SquareMatrix,
    /// Eq. 17 instead of eq. 16.
    pub weighted: bool,
    /// The task scale s in exp(-||eps/s||^2) (units of eps).
    pub scale: f64,
    pub jacobian: Jacobian,
    pub low: Option<Vec<f64>>,
    pub high: Option<Vec<f64>>,
    /// Converged when every |eps_i| < tol.
    pub tol: f64,
    pub max_trials: usize,
    /// Consecutive trials pinned at a limit before `HitBound`.
    pub pin_limit: usize,
    /// Refine J by Broyden's update after every trial, whatever J started from (always on for
    /// `Jacobian::Secant`).
    pub broyden: bool,
    /// The trust region's starting radius in units of `scale` (None: no trust region).
    pub trust_radius: Option<f64>,
}

/// Eq. 16 with K = I, no limits.
impl Default for ErrorLearningConfig {
    fn default() -> Self {
        Self {
            gain: SquareMatrix::Scalar(1.0),
            weighted: false,
            scale: 1.0,
            jacobian: Jacobian::Identity,
            low: None,
            high: None,
            tol: 1e-3,
            max_trials: 50,
            pin_limit: 3,
            broyden: false,
            trust_radius: None,
        }
    }
}

/// Bounds of the §5.2 safeguard on the slope estimate.
const MIN_SLOPE: f64 = 0.1;
const MAX_SLOPE: f64 = 10.0;
/// Divergence: |eps| grew in this many consecutive trials ...
const GROWTH_TRIALS: usize = 4;
/// ... to more than this multiple of the first |eps|.
const GROWTH_FACTOR: f64 = 2.0;
/// With a trust region: stop as diverged when the best ||eps|| improved by less than this
/// fraction over the last `STALL_TRIALS` trials (a map without a root, or one out of reach).
const STALL_FRACTION: f64 = 0.01;
const STALL_TRIALS: usize = 6;

#[derive(Debug, Clone)]
pub struct ErrorLearning {
    n: usize,
    q0: DVector<f64>,
    gain: DMatrix<f64>,
    weighted: bool,
    scale: f64,
    mode: Jacobian,
    /// The current estimate J_m.
    jac: DMatrix<f64>,
    bounds: Option<Bounds>,
    tol: f64,
    next: DVector<f64>,
    /// Previous (q, eps) for the secant update.
    prev: Option<(DVector<f64>, DVector<f64>)>,
    /// eps at q0, kept while the finite-difference probes run.
    eps_at_q0: Option<DVector<f64>>,
    growth: usize,
    broyden: bool,
    /// (current radius, starting radius) of the trust region, in query units.
    trust: Option<(f64, f64)>,
    /// The trial with the smallest ||eps|| so far: (q, eps).
    best: Option<(DVector<f64>, DVector<f64>)>,
    rec: Record,
}

impl ErrorLearning {
    pub fn new(q0: &[f64], cfg: ErrorLearningConfig) -> Result<Self> {
        let n = q0.len();
        check_query("q0", q0)?;
        let gain = cfg.gain.to_matrix("gain", n)?;
        check_scalar("scale", cfg.scale, true)?;
        check_scalar("tol", cfg.tol, true)?;
        let jac = match &cfg.jacobian {
            Jacobian::Fixed(j) => {
                let j = j.to_matrix("jacobian", n)?;
                if j.clone().lu().try_inverse().is_none() {
                    let rows: Vec<String> = j
                        .row_iter()
                        .map(|r| format!("{:?}", r.iter().collect::<Vec<_>>()))
                        .collect();
                    return Err(invalid(
                        "jacobian",
                        format!("[{}]", rows.join(", ")),
                        "must be invertible",
                    ));
                }
                j
            }
            Jacobian::FiniteDifference { delta } => {
                check_scalar("delta", *delta, true)?;
                DMatrix::identity(n, n)
            }
            _ => DMatrix::identity(n, n),
        };
        let bounds = Bounds::new(cfg.low.as_deref(), cfg.high.as_deref(), n, cfg.pin_limit)?;
        if let Some(b) = &bounds {
            b.check_inside("q0", q0)?;
        }
        if let Some(r) = cfg.trust_radius {
            check_scalar("trust_radius", r, true)?;
        }
        let trust = cfg.trust_radius.map(|r| (r * cfg.scale, r * cfg.scale));
        let broyden = cfg.broyden || cfg.jacobian == Jacobian::Secant;
        let q0 = DVector::from_column_slice(q0);
        Ok(Self {
            n,
            next: q0.clone(),
            q0,
            gain,
            weighted: cfg.weighted,
            scale: cfg.scale,
            mode: cfg.jacobian,
            jac,
            bounds,
            tol: cfg.tol,
            prev: None,
            eps_at_q0: None,
            growth: 0,
            broyden,
            trust,
            best: None,
            rec: Record::new(cfg.max_trials)?,
        })
    }

    /// The current estimate of dq_a/dq (I unless secant, finite-difference or fixed).
    pub fn jacobian(&self) -> &DMatrix<f64> {
        &self.jac
    }

    /// The eq. 16/17 step w K J^-1 eps (before clipping to the limits).
    fn step(&self, eps: &DVector<f64>) -> DVector<f64> {
        let w = if self.weighted {
            (-(eps / self.scale).norm_squared()).exp()
        } else {
            1.0
        };
        // A J that passed the safeguard is invertible; fall back to I rather than panic.
        let newton = self
            .jac
            .clone()
            .lu()
            .solve(eps)
            .unwrap_or_else(|| eps.clone());
        let step = w * (&self.gain * newton);
        match self.trust {
            Some((radius, _)) if step.norm() > radius => step.scale(radius / step.norm()),
            _ => step,
        }
    }

    fn clipped(&self, mut q: DVector<f64>) -> DVector<f64> {
        if let Some(b) = &self.bounds {
            b.clip(q.as_mut_slice());
        }
        q
    }

    /// The finite-difference probe after `k` told trials (k = 1..=n), or None when done.
    fn probe(&self, k: usize) -> Option<DVector<f64>> {
        let Jacobian::FiniteDifference { delta } = self.mode else {
            return None;
        };
        (k <= self.n).then(|| {
            let mut q = self.q0.clone();
            q[k - 1] += self.probe_step(k - 1, delta);
            q
        })
    }

    /// +delta, or -delta where +delta would leave the limits.
    fn probe_step(&self, j: usize, delta: f64) -> f64 {
        let mut q = self.q0.clone();
        q[j] += delta;
        match &self.bounds {
            Some(b) => {
                let mut c = q.clone();
                b.clip(c.as_mut_slice());
                if c[j] != q[j] { -delta } else { delta }
            }
            None => delta,
        }
    }
}

/// The §5.2 safeguard, generalized to n > 1: the symmetric part positive definite (the slope
/// has the sign the convention assumes) and all singular values within [0.1, 10].
fn slope_is_safe(j: &DMatrix<f64>) -> bool {
    if j.iter().any(|v| !v.is_finite()) {
        return false;
    }
    let sym = (j + j.transpose()) * 0.5;
    let pos = sym.symmetric_eigenvalues().iter().all(|&l| l > 0.0);
    let sv = j.singular_values();
    pos && sv.iter().all(|&s| (MIN_SLOPE..=MAX_SLOPE).contains(&s))
}

impl AskTell for ErrorLearning {
    fn dim(&self) -> usize {
        self.n
    }

    fn ask(&mut self) -> Result<Vec<f64>> {
        self.rec.ask_with(|| self.next.as_slice().to_vec())
    }

    fn tell(&mut self, q: &[f64], eps: &[f64]) -> Result<()> {
        self.rec.check_tell(q, eps, "eps", &[self.n])?;
        let score = max_abs(eps);
        let k = self.rec.push(eps, score)? + 1; // trials told so far
        if score < self.tol {
            self.rec.finish_tell(Some(Status::Converged));
            return Ok(());
        }
        let qv = DVector::from_column_slice(q);
        let ev = DVector::from_column_slice(eps);

        let mut stop = None;
        if let Jacobian::FiniteDifference { delta } = self.mode
            && k <= self.n + 1
        {
            // Trial 1 is q0 itself; trials 2..=n+1 probe one coordinate each.
            if k == 1 {
                self.eps_at_q0 = Some(ev.clone());
            } else {
                let j = k - 2;
                let e0 = self.eps_at_q0.clone().unwrap_or_else(|| ev.clone());
                // q_a = q0 - eps, so d q_a = -(eps - eps0).
                let col = -(&ev - &e0) / self.probe_step(j, delta);
                self.jac.set_column(j, &col);
            }
            match self.probe(k) {
                Some(p) => self.next = p,
                None => {
                    if !slope_is_safe(&self.jac) {
                        self.jac = DMatrix::identity(self.n, self.n);
                    }
                    let e0 = self.eps_at_q0.clone().unwrap_or_else(|| ev.clone());
                    self.next = self.clipped(&self.q0 + self.step(&e0));
                }
            }
        } else {
            if self.broyden
                && let Some((qp, ep)) = &self.prev
            {
                let dq = &qv - qp;
                let dqa = -(&ev - ep);
                let dq2 = dq.norm_squared();
                if dq2 > 0.0 {
                    // Broyden's "good" update; for n = 1 it is the secant slope itself.
                    let update = (&dqa - &self.jac * &dq) * dq.transpose() / dq2;
                    self.jac += update;
                }
                if !slope_is_safe(&self.jac) {
                    self.jac = DMatrix::identity(self.n, self.n);
                }
            }
            // Trust region: grow after progress, shrink and restart from the best trial otherwise.
            let (from, e_from) = match (&mut self.trust, &self.best) {
                (Some((radius, start)), Some((qb, eb))) => {
                    if ev.norm() < eb.norm() {
                        *radius = (2.0 * *radius).min(10.0 * *start);
                        (qv.clone(), ev.clone())
                    } else {
                        *radius *= 0.5;
                        (qb.clone(), eb.clone())
                    }
                }
                _ => (qv.clone(), ev.clone()),
            };
            let step = self.step(&e_from);
            self.next = self.clipped(&from + &step);
            // Pinned: q sits on a limit and the step (not eps: K and J may rotate it) points past it.
            if let Some(b) = &mut self.bounds {
                stop = b.observe(q, step.as_slice());
            }
        }
        if self
            .best
            .as_ref()
            .is_none_or(|(_, eb)| ev.norm() < eb.norm())
        {
            self.best = Some((qv.clone(), ev.clone()));
        }
        self.prev = Some((qv, ev));

        // Divergence: |eps| grows trial after trial, far beyond where it started.
        let h = &self.rec.history;
        if h.len() >= 2 && score > h[h.len() - 2].score {
            self.growth += 1;
        } else {
            self.growth = 0;
        }
        if stop.is_none() && self.growth >= GROWTH_TRIALS && score > GROWTH_FACTOR * h[0].score {
            stop = Some(Status::Diverged);
        }
        if stop.is_none() && self.trust.is_some() && h.len() > STALL_TRIALS {
            let best = |trials: &[_]| -> f64 {
                trials
                    .iter()
                    .map(|t: &crate::ask_tell::Trial| t.score)
                    .fold(f64::INFINITY, f64::min)
            };
            let before = best(&h[..h.len() - STALL_TRIALS]);
            if best(h) > (1.0 - STALL_FRACTION) * before {
                stop = Some(Status::Diverged);
            }
        }
        self.rec
            .finish_tell(stop.or_else(|| diverged_unless_finite(self.next.as_slice())));
        Ok(())
    }

    fn record(&self) -> &Record {
        &self.rec
    }
}
