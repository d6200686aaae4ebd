//! The design matrix of the batch least-squares fit (docs/method.md §2.3) and its normal equations,
//! shared by the one-demonstration fit ([`crate::Dmp::fit`]) and the locally weighted regression
//! over many demonstrations ([`crate::lwr`], docs/method.md §3.2).
//!
//! For a demonstration with duration `tau`, goal `g = y_T` and samples `(t_j, y_j, yd_j, ydd_j)`:
//!
//! ```text
//! x_j    = exp(-alpha_x (t_j - t_1) / tau)
//! F_j    = tau^2 ydd_j - alpha_z (beta_z (g - y_j) - tau yd_j)
//! A[j,k] = Psi_k(x_j) x_j / sum_i Psi_i(x_j)          (0 if below 1e-8, as in the lab code)
//! ```
//!
//! Every demonstration keeps its own `tau` and `g`: it is mapped onto the common phase interval
//! `[exp(-alpha_x), 1]`, which is what lets one least-squares problem span several of them.

use nalgebra::{DMatrix, DMatrixView, DVector};

use crate::basis::{Basis, phase};
use crate::dmp::{Demonstration, DmpConfig};
use crate::error::{Error, Result, check_finite_matrix, check_increasing};
use crate::finite_difference;

/// Design-matrix entries below this are set to zero, as in the lab's fitting code.
pub(crate) const DESIGN_CUTOFF: f64 = 1e-8;

/// A validated demonstration with its derivatives and the DMP parameters read off it directly.
#[derive(Debug, Clone)]
pub struct PreparedDemo<'a> {
    pub t: &'a [f64],
    pub y: DMatrixView<'a, f64>,
    /// `D x T`, measured or computed with [`finite_difference::gradient`].
    pub yd: DMatrix<f64>,
    pub ydd: DMatrix<f64>,
    /// `t_T - t_1`.
    pub tau: f64,
    /// `y_T`.
    pub goal: DVector<f64>,
    /// `y_1`.
    pub y0: DVector<f64>,
    /// The velocity the fitted DMP reaches its goal with (docs/method.md §2.8); `None`: zero.
    pub final_velocity: Option<DVector<f64>>,
}

impl<'a> PreparedDemo<'a> {
    /// Validates shapes, sample times and finiteness; computes missing derivatives with
    /// second-order finite differences on the (possibly non-uniform) grid.
    pub fn new(demo: &Demonstration<'a>) -> Result<Self> {
        let (t, y) = (demo.t, demo.y);
        let n_dof = y.nrows();
        if n_dof == 0 {
            return Err(Error::Shape {
                name: "y",
                expected: "at least one column".into(),
                got: format!("({}, 0)", t.len()),
            });
        }
        if y.ncols() != t.len() {
            return Err(Error::Shape {
                name: "y",
                expected: format!("({}, {n_dof}) with one row per entry of t", t.len()),
                got: format!("({}, {n_dof})", y.ncols()),
            });
        }
        if t.len() < finite_difference::MIN_SAMPLES {
            return Err(Error::TooFewSamples {
                name: "t",
                got: t.len(),
                needed: finite_difference::MIN_SAMPLES,
                why: "second-order finite differences need 3",
            });
        }
        check_increasing("t", t)?;
        check_finite_matrix("y", &y)?;
        for (name, d) in [("yd", &demo.yd), ("ydd", &demo.ydd)] {
            if let Some(d) = d {
                if d.shape() != y.shape() {
                    return Err(Error::Shape {
                        name,
                        expected: format!("({}, {n_dof}) like y", t.len()),
                        got: format!("({}, {})", d.ncols(), d.nrows()),
                    });
                }
                check_finite_matrix(name, d)?;
            }
        }
        let yd = match demo.yd {
            Some(v) => v.into_owned(),
            None => finite_difference::gradient(t, &y),
        };
        let ydd = match demo.ydd {
            Some(v) => v.into_owned(),
            None => finite_difference::gradient(t, &yd.as_view()),
        };
        Ok(Self {
            t,
            y,
            yd,
            ydd,
            tau: t[t.len() - 1] - t[0],
            goal: y.column(t.len() - 1).into_owned(),
            y0: y.column(0).into_owned(),
            final_velocity: None,
        })
    }

    pub fn n_dof(&self) -> usize {
        self.y.nrows()
    }
}

/// The normal equations `A^T A w = A^T F` of one demonstration: `ata` is `N x N`, `atf` is
/// `N x D` (column d for DOF d).
#[derive(Debug, Clone, PartialEq)]
pub struct NormalEquations {
    pub ata: DMatrix<f64>,
    pub atf: DMatrix<f64>,
}

/// Accumulates `A^T A` and `A^T F` row by row. Each row of `A` has only a handful of entries above
/// the cut-off, so this costs O(T) instead of O(T N^2).
pub fn normal_equations(
    demo: &PreparedDemo<'_>,
    basis: &Basis,
    config: &DmpConfig,
) -> NormalEquations {
    let n = basis.len();
    let n_dof = demo.n_dof();
    let (t, y, tau) = (demo.t, &demo.y, demo.tau);
    let t0 = t[0];
    let mut ata = DMatrix::<f64>::zeros(n, n);
    let mut atf = DMatrix::<f64>::zeros(n, n_dof);
    let mut psi = vec![0.0; n];
    let mut force = vec![0.0; n_dof];
    for (j, &tj) in t.iter().enumerate() {
        let x = phase(tj - t0, tau, config.alpha_x);
        let range = basis.normalized_activations(x, &mut psi);
        // Row j of the design matrix, with the lab code's cut-off; only its non-zero span
        // (about six kernels) enters the normal equations.
        let mut nz = range.end..range.start;
        for k in range {
            psi[k] *= x;
            if psi[k] < DESIGN_CUTOFF {
                psi[k] = 0.0;
            } else {
                nz.start = nz.start.min(k);
                nz.end = k + 1;
            }
        }
        // A row whose every entry fell below the cut-off (a large alpha_x leaves the late
        // samples' phase far past the last centre) adds nothing; `nz` is still inverted there.
        if nz.is_empty() {
            continue;
        }
        let yj = y.column(j);
        for d in 0..n_dof {
            force[d] = match &demo.final_velocity {
                None => {
                    tau * tau * demo.ydd[(d, j)]
                        - config.alpha_z
                            * (config.beta_z * (demo.goal[d] - yj[d]) - tau * demo.yd[(d, j)])
                }
                // docs/method.md §2.8: the spring pulls to the moving goal g - gd (tau - t) and
                // damps towards the velocity gd.
                Some(gd) => {
                    let moving_goal = demo.goal[d] - gd[d] * (tau - (tj - t0));
                    tau * tau * demo.ydd[(d, j)]
                        - config.alpha_z
                            * (config.beta_z * (moving_goal - yj[d])
                                + tau * (gd[d] - demo.yd[(d, j)]))
                }
            };
        }
        accumulate_row(&mut ata, &mut atf, &psi, nz, &force);
    }
    NormalEquations { ata, atf }
}

/// Adds one row of the design matrix to `A^T A` and `A^T F`: `row[k]` for `k` in `nz` (zero
/// elsewhere) and its targets `force[d]`. Only the non-zero span is touched, and the column-major
/// slices of the rows `nz` are contiguous, so the updates vectorize.
pub(crate) fn accumulate_row(
    ata: &mut DMatrix<f64>,
    atf: &mut DMatrix<f64>,
    row: &[f64],
    nz: std::ops::Range<usize>,
    force: &[f64],
) {
    let n = ata.nrows();
    let span = &row[nz.clone()];
    for l in nz.clone() {
        let col = &mut ata.as_mut_slice()[l * n + nz.start..l * n + nz.end];
        for (c, a) in col.iter_mut().zip(span) {
            *c += a * row[l];
        }
    }
    for (d, &f) in force.iter().enumerate() {
        let col = &mut atf.as_mut_slice()[d * n + nz.start..d * n + nz.end];
        for (c, a) in col.iter_mut().zip(span) {
            *c += a * f;
        }
    }
}

/// Solves `(ata + lambda I) w = atf` with `lambda = relative_ridge * trace(ata) / N` (or
/// `relative_ridge` itself when the trace is 0). The ridge keeps a kernel that no sample activates
/// at weight 0 instead of making the system singular.
pub fn solve_ridge(
    mut ata: DMatrix<f64>,
    atf: &DMatrix<f64>,
    relative_ridge: f64,
    context: &'static str,
) -> Result<DMatrix<f64>> {
    let n = ata.nrows();
    let ridge = relative_ridge * ata.trace() / n as f64;
    let ridge = if ridge > 0.0 { ridge } else { relative_ridge };
    for k in 0..n {
        ata[(k, k)] += ridge;
    }
    let chol = ata.cholesky().ok_or_else(|| Error::Numerical {
        context,
        detail: "the normal equations are not positive definite".into(),
    })?;
    let weights = chol.solve(atf);
    if weights.iter().any(|w| !w.is_finite()) {
        return Err(Error::Numerical {
            context,
            detail: "non-finite weights".into(),
        });
    }
    Ok(weights)
}
