//! The discrete Dynamic Movement Primitive of the paper (eqs. 1-4) and its batch least-squares fit
//! (docs/method.md §2.3):
//!
//! ```text
//! tau dz/dt = alpha_z (beta_z (g - y) - z) + f(x)      (1)
//! tau dy/dt = z                                        (2)
//! tau dx/dt = -alpha_x x                               (3)
//! f(x) = sum_k w_k Psi_k(x) / sum_k Psi_k(x) * x       (4)
//! ```
//!
//! There is no `(g - y0)` amplitude factor in `f`: weights are in the units of `y`, so weights of
//! demonstrations with different goals can be interpolated. Every degree of freedom has its own
//! weights and goal; the phase `x` and `tau` are shared.

use nalgebra::{DMatrix, DMatrixView, DVector};

use crate::basis::Basis;
use crate::design_matrix::{PreparedDemo, normal_equations, solve_ridge};
use crate::error::{Error, Result, check_scalar, fmt_g};

/// Relative ridge added to the normal equations of the fit. It keeps a kernel that no sample
/// activates at weight 0 instead of making the system singular, and changes well-posed fits by
/// about 1e-10 relative.
pub(crate) const FIT_RIDGE: f64 = 1e-10;

/// The most kernels a DMP may have (see [`DmpConfig::validate`]).
pub const MAX_BASIS: usize = 1000;

/// The most coordinates a primitive built from a count (not from arrays) may have.
pub const MAX_DOF: usize = 10_000;

/// Checks a count of coordinates given as a number: its state is allocated from it, so a
/// mistaken size must be an error, not an allocation the process cannot survive.
pub(crate) fn check_n_dof(n_dof: usize) -> Result<()> {
    if !(1..=MAX_DOF).contains(&n_dof) {
        return Err(Error::InvalidParameter {
            name: "n_dof",
            value: n_dof.to_string(),
            requirement: "must be from 1 to 10000: more coordinates than a robot has",
        });
    }
    Ok(())
}

/// The meta-parameters of a DMP: its constants and the size of its basis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DmpConfig {
    pub n_basis: usize,
    pub alpha_z: f64,
    pub beta_z: f64,
    pub alpha_x: f64,
    /// `h_k = width_factor / (c_{k+1} - c_k)^2`; 2 in the lab code, 1 in the lab's later papers.
    pub width_factor: f64,
}

impl Default for DmpConfig {
    /// The JSI lab's constants (docs/method.md §2.2): alpha_z = 48, beta_z = alpha_z / 4 (critically
    /// damped), alpha_x = 2, width factor 2; 25 kernels.
    fn default() -> Self {
        Self {
            n_basis: 25,
            alpha_z: 48.0,
            beta_z: 12.0,
            alpha_x: 2.0,
            width_factor: 2.0,
        }
    }
}

impl DmpConfig {
    pub fn validate(&self) -> Result<()> {
        check_scalar("alpha_z", self.alpha_z, true)?;
        check_scalar("beta_z", self.beta_z, true)?;
        check_scalar("alpha_x", self.alpha_x, true)?;
        check_scalar("width_factor", self.width_factor, true)?;
        if self.n_basis < 2 {
            return Err(Error::InvalidParameter {
                name: "n_basis",
                value: self.n_basis.to_string(),
                requirement: "must be at least 2",
            });
        }
        if self.n_basis > MAX_BASIS {
            return Err(Error::InvalidParameter {
                name: "n_basis",
                value: self.n_basis.to_string(),
                requirement: "must be at most 1000: the fit solves an n_basis x n_basis system \
                              (10000 kernels take minutes and gigabytes; 25-40 shape a movement)",
            });
        }
        Ok(())
    }

    /// [`Self::validate`], and the bound a fit adds on `alpha_x`: the phase at the end of the
    /// demonstration, `exp(-alpha_x)`, must stay above the design matrix's cut-off (1e-8). Beyond
    /// it the last samples' rows vanish, no weight is held to them, and the late kernels (centres
    /// below the cut-off) get weights of 1e7-1e9 that the rollout's explicit-Euler phase cannot
    /// follow: the movement is no longer reproduced.
    pub fn validate_for_fit(&self) -> Result<()> {
        self.validate()?;
        if self.alpha_x > MAX_FIT_ALPHA_X {
            return Err(Error::InvalidParameter {
                name: "alpha_x",
                value: fmt_g(self.alpha_x),
                requirement: "must be at most 18.42 (ln 1e8) to fit a demonstration: the phase at \
                              its end, exp(-alpha_x), falls below the design matrix's cut-off \
                              1e-8 beyond that, so the last samples hold no weight and the fitted \
                              movement is not reproduced (below about 12 rollouts are as accurate \
                              as with the default 2; docs/method.md §2.3)",
            });
        }
        Ok(())
    }
}

/// The largest `alpha_x` a fit accepts: `-ln` of the design matrix's cut-off, where the phase at
/// the end of the demonstration reaches it.
pub const MAX_FIT_ALPHA_X: f64 = 18.420_680_743_952_367;

/// Positions of a demonstration with optional measured derivatives, all `D x T` (one column per
/// sample; a C-ordered `(T, D)` numpy array is exactly this layout).
#[derive(Debug, Clone, Copy)]
pub struct Demonstration<'a> {
    pub t: &'a [f64],
    pub y: DMatrixView<'a, f64>,
    pub yd: Option<DMatrixView<'a, f64>>,
    pub ydd: Option<DMatrixView<'a, f64>>,
}

/// A multi-DOF discrete DMP.
#[derive(Debug, Clone, PartialEq)]
pub struct Dmp {
    config: DmpConfig,
    basis: Basis,
    /// `N x D`: column d holds the weights of DOF d.
    weights: DMatrix<f64>,
    goal: DVector<f64>,
    y0: DVector<f64>,
    tau: f64,
    /// The velocity `gd` at which the movement reaches its goal at `t = tau` (docs/method.md
    /// §2.8); `None` for zero, today's DMP.
    final_velocity: Option<DVector<f64>>,
}

/// Where a fit takes the final velocity from (docs/method.md §2.8).
#[derive(Debug, Clone, PartialEq)]
pub enum FinalVelocity {
    /// The demonstration's last velocity (measured, or its finite difference).
    FromDemo,
    /// A given velocity per DOF.
    Given(DVector<f64>),
}

/// The scaled time left until `t = tau`, `(tau - t) / tau`, recovered from the phase of eq. 3
/// as the integrator advances it: explicit Euler steps of `h` make `x_k = (1 - alpha_x h /
/// tau)^k`, so `t = k h = h ln(x) / ln(1 - alpha_x h / tau)` (`-tau ln(x) / alpha_x` as
/// `h -> 0`). Taken from the integrator's own phase, the moving goal arrives at `g` on the step
/// that reaches tau rather than about `alpha_x h / 2` early; taken from the phase rather than a
/// clock, phase stopping and a changed tau hold or stretch it with the rest of the movement
/// (docs/method.md §2.8).
///
/// `clock` is [`phase_clock`]`(tau, alpha_x, h)`, constant while tau and the step are.
#[inline]
pub(crate) fn phase_to_go(x: f64, clock: f64) -> f64 {
    1.0 - clock * libm::log(x)
}

/// `(h / tau) / ln(1 - alpha_x h / tau)`, which turns `ln(x)` into the scaled time `t / tau` of
/// the integrator's phase ([`phase_to_go`]).
#[inline]
pub(crate) fn phase_clock(tau: f64, alpha_x: f64, h: f64) -> f64 {
    h / tau / libm::log1p(-alpha_x * h / tau)
}

impl Dmp {
    /// Builds a DMP from its parameters, validating every one.
    pub fn new(
        config: DmpConfig,
        weights: DMatrix<f64>,
        goal: DVector<f64>,
        y0: DVector<f64>,
        tau: f64,
    ) -> Result<Self> {
        config.validate()?;
        let basis = Basis::new(config.n_basis, config.alpha_x, config.width_factor)?;
        if weights.nrows() != config.n_basis || weights.ncols() == 0 {
            return Err(Error::Shape {
                name: "weights",
                expected: format!("(n_dof >= 1, {}) (n_dof, n_basis)", config.n_basis),
                got: format!("({}, {})", weights.ncols(), weights.nrows()),
            });
        }
        let n_dof = weights.ncols();
        for (name, v) in [("goal", &goal), ("start", &y0)] {
            if v.len() != n_dof {
                return Err(Error::Shape {
                    name,
                    expected: format!("({n_dof},), one entry per DOF of the weights"),
                    got: format!("({},)", v.len()),
                });
            }
        }
        check_vector("goal", &goal)?;
        check_vector("start", &y0)?;
        check_scalar("tau", tau, true)?;
        for (k, w) in weights.column_iter().enumerate() {
            if let Some((n, &v)) = w.iter().enumerate().find(|(_, v)| !v.is_finite()) {
                return Err(Error::NonFinite {
                    name: "weights",
                    location: format!("[{k}, {n}]"),
                    value: v,
                });
            }
        }
        Ok(Self {
            config,
            basis,
            weights,
            goal,
            y0,
            tau,
            final_velocity: None,
        })
    }

    /// Fits a DMP to one demonstration by batch least squares (docs/method.md §2.3):
    /// `tau = t_T - t_1`, `g = y_T`, `y0 = y_1`, `x_j = exp(-alpha_x (t_j - t_1)/tau)`,
    /// `F_j = tau^2 ydd_j - alpha_z (beta_z (g - y_j) - tau yd_j)`, and `w = argmin |A w - F|`
    /// with `A_jk = Psi_k(x_j) x_j / sum_i Psi_i(x_j)`.
    ///
    /// Missing derivatives are computed with [`crate::finite_difference::gradient`] (second order, non-uniform grid).
    pub fn fit(demo: &Demonstration<'_>, config: DmpConfig) -> Result<Self> {
        Self::fit_prepared(PreparedDemo::new(demo)?, config)
    }

    /// [`Self::fit`] of a DMP that reaches its goal with a final velocity `gd` (docs/method.md
    /// §2.8): the targets become `F_j = tau^2 ydd_j - alpha_z (beta_z (g_m(t_j) - y_j) +
    /// tau (gd - yd_j))` with the moving goal `g_m(t) = g - gd (tau - t)`. A final velocity of
    /// zero is [`Self::fit`], bit for bit.
    pub fn fit_with_final_velocity(
        demo: &Demonstration<'_>,
        config: DmpConfig,
        final_velocity: FinalVelocity,
    ) -> Result<Self> {
        let mut prepared = PreparedDemo::new(demo)?;
        let gd = match final_velocity {
            FinalVelocity::FromDemo => prepared.yd.column(prepared.t.len() - 1).into_owned(),
            FinalVelocity::Given(v) => v,
        };
        prepared.final_velocity = nonzero(checked_final_velocity(gd, prepared.n_dof())?);
        Self::fit_prepared(prepared, config)
    }

    fn fit_prepared(prepared: PreparedDemo<'_>, config: DmpConfig) -> Result<Self> {
        config.validate_for_fit()?;
        let basis = Basis::new(config.n_basis, config.alpha_x, config.width_factor)?;
        let normal = normal_equations(&prepared, &basis, &config);
        let weights = solve_ridge(normal.ata, &normal.atf, FIT_RIDGE, "DMP fit")?;
        let PreparedDemo {
            goal,
            y0,
            tau,
            final_velocity,
            ..
        } = prepared;
        Ok(Self {
            config,
            basis,
            weights,
            goal,
            y0,
            tau,
            final_velocity,
        })
    }

    /// The same movement reaching its goal with velocity `gd` at `t = tau` (weights unchanged;
    /// docs/method.md §2.8). All zeros give today's DMP, bit for bit.
    pub fn with_final_velocity(&self, gd: DVector<f64>) -> Result<Self> {
        let gd = checked_final_velocity(gd, self.n_dof())?;
        Ok(Self {
            final_velocity: nonzero(gd),
            ..self.clone()
        })
    }

    /// The final velocity, `None` when it is zero.
    pub fn final_velocity(&self) -> Option<&DVector<f64>> {
        self.final_velocity.as_ref()
    }

    /// A DMP built by [`Self::new`] from this one's parameters keeps its final velocity.
    fn keeping_final_velocity(&self, built: Result<Self>) -> Result<Self> {
        built.map(|d| Self {
            final_velocity: self.final_velocity.clone(),
            ..d
        })
    }

    pub fn config(&self) -> &DmpConfig {
        &self.config
    }
    pub fn basis(&self) -> &Basis {
        &self.basis
    }
    /// `N x D`, column d = the weights of DOF d.
    pub fn weights(&self) -> &DMatrix<f64> {
        &self.weights
    }
    pub fn goal(&self) -> &DVector<f64> {
        &self.goal
    }
    pub fn y0(&self) -> &DVector<f64> {
        &self.y0
    }
    pub fn tau(&self) -> f64 {
        self.tau
    }
    pub fn n_dof(&self) -> usize {
        self.goal.len()
    }
    pub fn n_basis(&self) -> usize {
        self.config.n_basis
    }

    /// The same goal, start, tau and final velocity with other weights (the same shape changed).
    pub fn with_weights(&self, weights: DMatrix<f64>) -> Result<Self> {
        self.keeping_final_velocity(Self::new(
            self.config,
            weights,
            self.goal.clone(),
            self.y0.clone(),
            self.tau,
        ))
    }

    /// The same movement towards a new goal (weights unchanged).
    pub fn with_goal(&self, goal: DVector<f64>) -> Result<Self> {
        self.keeping_final_velocity(Self::new(
            self.config,
            self.weights.clone(),
            goal,
            self.y0.clone(),
            self.tau,
        ))
    }
    /// The same movement from a new start.
    pub fn with_start(&self, y0: DVector<f64>) -> Result<Self> {
        self.keeping_final_velocity(Self::new(
            self.config,
            self.weights.clone(),
            self.goal.clone(),
            y0,
            self.tau,
        ))
    }
    /// The same path at another speed: tau only scales time, so the final velocity scales by
    /// the old tau over the new (the moving goal covers the same path).
    pub fn with_tau(&self, tau: f64) -> Result<Self> {
        let scaled = Self::new(
            self.config,
            self.weights.clone(),
            self.goal.clone(),
            self.y0.clone(),
            tau,
        )?;
        Ok(Self {
            final_velocity: self.final_velocity.as_ref().map(|gd| gd * (self.tau / tau)),
            ..scaled
        })
    }
}

/// A final velocity with one finite entry per DOF.
fn checked_final_velocity(gd: DVector<f64>, n_dof: usize) -> Result<DVector<f64>> {
    if gd.len() != n_dof {
        return Err(Error::Shape {
            name: "final_velocity",
            expected: format!("({n_dof},), one entry per DOF"),
            got: format!("({},)", gd.len()),
        });
    }
    check_vector("final_velocity", &gd)?;
    Ok(gd)
}

/// `None` for a zero final velocity, so that it is today's DMP in every respect.
pub(crate) fn nonzero(gd: DVector<f64>) -> Option<DVector<f64>> {
    gd.iter().any(|&v| v != 0.0).then_some(gd)
}

fn check_vector(name: &'static str, v: &DVector<f64>) -> Result<()> {
    match v.iter().enumerate().find(|(_, x)| !x.is_finite()) {
        Some((i, &x)) => Err(Error::NonFinite {
            name,
            location: format!("[{i}]"),
            value: x,
        }),
        None => Ok(()),
    }
}
