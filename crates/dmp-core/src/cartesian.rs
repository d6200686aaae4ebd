//! Cartesian-space DMPs: the position by the discrete DMP of eqs. 1-4, the orientation by the
//! unit-quaternion DMP of Ude, Nemec, Petrič and Morimoto (ICRA 2014, "Orientation in Cartesian
//! space dynamic movement primitives"), both on one phase `x`, one basis and one `tau`:
//!
//! ```text
//! tau d(eta)/dt = alpha_z (beta_z 2 log(g_o * conj(q)) - eta) + f_o(x)
//! tau dq/dt     = 1/2 eta * q
//! f_o(x)        = sum_k w_k Psi_k(x) / sum_k Psi_k(x) * x,    w_k in R^3   (eq. 4)
//! ```
//!
//! with `eta = tau omega` (`omega` the angular velocity in the world frame), `*` the quaternion
//! product and `log` the quaternion logarithm (half the rotation vector; [`crate::quaternion`]).
//! `2 log(g_o * conj(q))` is the rotation vector that takes `q` to the goal `g_o`.
//!
//! **Fit.** The least-squares target of the orientation (Ude et al. 2014, eq. 20),
//! `F_j = tau^2 omegadot_j - alpha_z (beta_z 2 log(g_o * conj(q_j)) - tau omega_j)`, is the target
//! of the position fit, `tau^2 ydd_j - alpha_z (beta_z (g - y_j) - tau yd_j)`, written for the
//! coordinates `y_j = -2 log(g_o * conj(q_j))`, `yd_j = omega_j`, `ydd_j = omegadot_j`, whose goal
//! `y_T` is exactly 0. So a pose demonstration becomes a 6-coordinate demonstration (x, y, z and
//! these three) and is fitted by the discrete DMP's least squares ([`crate::design_matrix`]); a
//! [`CartesianDmp`] is that 6-DOF [`Dmp`] (orientation goal and start 0) plus the goal and start
//! quaternions.
//!
//! Angular velocities, when not given, are computed from the quaternion samples with the
//! second-order scheme of [`crate::finite_difference`] applied in the tangent space at each sample:
//! `omega_j = sum_i c_ji 2 log(q_i * conj(q_j))` with the weights `c_ji` of
//! `numpy.gradient(., t, edge_order=2)`; for a rotation about a fixed axis by `theta(t)` this is
//! exactly that scheme applied to `theta`. Angular accelerations are the scheme applied to
//! `omega` (a vector in the fixed world frame).
//!
//! **Rollout.** Explicit Euler at step `dt`, from `x = 1`, rest, `q = q_0`:
//! `q <- exp(dt / (2 tau) eta) * q`, which keeps `q` on the unit sphere (a product of unit
//! quaternions; the rounding drift, ~1e-16 per step, is removed by one Newton step for `1/|q|`).
//! For a rotation about one fixed axis this is the discrete DMP of the angle, step for step.

use nalgebra::{DMatrix, DMatrixView, DVector};

use crate::dmp::{Demonstration, Dmp, DmpConfig, FinalVelocity};
use crate::error::{Error, Result, check_finite_matrix, check_increasing, fmt_g};
use crate::finite_difference as diff;
use crate::quaternion::{self, Quaternion};

/// A pose is `[x, y, z, qw, qx, qy, qz]`: position (m), then a scalar-first unit quaternion.
pub const POSE_WIDTH: usize = 7;
/// Quaternions whose norm is farther than this from 1 are refused unless the caller asks for
/// them to be normalized: such a sample is more likely a bug than rounding.
pub const UNIT_TOLERANCE: f64 = 1e-6;
/// The coordinates of the underlying DMP: x, y, z, then the three of the orientation.
pub(crate) const N_COORDS: usize = 6;

/// A pose demonstration: `pose` is `7 x T` (one column per sample; a C-ordered `(T, 7)` numpy
/// array is exactly this layout), derivatives `3 x T` when measured.
#[derive(Debug, Clone, Copy)]
pub struct CartesianDemonstration<'a> {
    pub t: &'a [f64],
    pub pose: DMatrixView<'a, f64>,
    pub velocity: Option<DMatrixView<'a, f64>>,
    pub acceleration: Option<DMatrixView<'a, f64>>,
    pub angular_velocity: Option<DMatrixView<'a, f64>>,
    pub angular_acceleration: Option<DMatrixView<'a, f64>>,
    /// Scale every quaternion to unit norm instead of refusing those off by more than
    /// [`UNIT_TOLERANCE`] (the zero quaternion is refused either way).
    pub normalize: bool,
}

/// A validated pose demonstration as the 6-coordinate demonstration of the module docs.
#[derive(Debug, Clone)]
pub(crate) struct PreparedPose {
    /// `6 x T`: position, then `-2 log(g_o * conj(q_j))`.
    pub y: DMatrix<f64>,
    pub yd: DMatrix<f64>,
    pub ydd: DMatrix<f64>,
    /// Unit, sign-continuous quaternions, one per sample.
    pub quaternions: Vec<Quaternion>,
}

impl PreparedPose {
    pub fn new(demo: &CartesianDemonstration<'_>) -> Result<Self> {
        let (t, pose) = (demo.t, demo.pose);
        if pose.nrows() != POSE_WIDTH {
            return Err(Error::Shape {
                name: "pose",
                expected: "(T, 7): x, y, z, qw, qx, qy, qz per sample".into(),
                got: format!("({}, {})", pose.ncols(), pose.nrows()),
            });
        }
        if pose.ncols() != t.len() {
            return Err(Error::Shape {
                name: "pose",
                expected: format!("({}, 7) with one row per entry of t", t.len()),
                got: format!("({}, 7)", pose.ncols()),
            });
        }
        if t.len() < diff::MIN_SAMPLES {
            return Err(Error::TooFewSamples {
                name: "t",
                got: t.len(),
                needed: diff::MIN_SAMPLES,
                why: "second-order finite differences need 3",
            });
        }
        check_increasing("t", t)?;
        check_finite_matrix("pose", &pose)?;
        let derivative = |name: &'static str, d: &Option<DMatrixView<'_, f64>>| -> Result<()> {
            if let Some(d) = d {
                if d.shape() != (3, t.len()) {
                    return Err(Error::Shape {
                        name,
                        expected: format!("({}, 3), one row per entry of t", t.len()),
                        got: format!("({}, {})", d.ncols(), d.nrows()),
                    });
                }
                check_finite_matrix(name, d)?;
            }
            Ok(())
        };
        derivative("velocity", &demo.velocity)?;
        derivative("acceleration", &demo.acceleration)?;
        derivative("angular_velocity", &demo.angular_velocity)?;
        derivative("angular_acceleration", &demo.angular_acceleration)?;

        let quaternions = unit_quaternions("pose", &pose, demo.normalize)?;
        let n = t.len();
        let goal = quaternions[n - 1];
        let mut y = DMatrix::zeros(N_COORDS, n);
        y.rows_mut(0, 3).copy_from(&pose.rows(0, 3));
        for (j, q) in quaternions.iter().enumerate() {
            let e = quaternion::log(&quaternion::product(&goal, &quaternion::conjugate(q)));
            for d in 0..3 {
                y[(3 + d, j)] = -2.0 * e[d];
            }
        }
        let position = pose.rows(0, 3);
        let velocity = match demo.velocity {
            Some(v) => v.into_owned(),
            None => diff::gradient(t, &position),
        };
        let acceleration = match demo.acceleration {
            Some(a) => a.into_owned(),
            None => diff::gradient(t, &velocity.as_view()),
        };
        let omega = match demo.angular_velocity {
            Some(w) => w.into_owned(),
            None => angular_velocity(t, &quaternions),
        };
        let omega_dot = match demo.angular_acceleration {
            Some(a) => a.into_owned(),
            None => diff::gradient(t, &omega.as_view()),
        };
        let mut yd = DMatrix::zeros(N_COORDS, n);
        let mut ydd = DMatrix::zeros(N_COORDS, n);
        yd.rows_mut(0, 3).copy_from(&velocity);
        yd.rows_mut(3, 3).copy_from(&omega);
        ydd.rows_mut(0, 3).copy_from(&acceleration);
        ydd.rows_mut(3, 3).copy_from(&omega_dot);
        Ok(Self {
            y,
            yd,
            ydd,
            quaternions,
        })
    }

    /// The 6-coordinate demonstration the discrete DMP's fit and the generalizers take.
    pub fn demonstration<'a>(&'a self, t: &'a [f64]) -> Demonstration<'a> {
        Demonstration {
            t,
            y: self.y.as_view(),
            yd: Some(self.yd.as_view()),
            ydd: Some(self.ydd.as_view()),
        }
    }

    pub fn start(&self) -> Quaternion {
        self.quaternions[0]
    }

    /// The orientation coordinates of a fit with the final angular velocity `omega_g`
    /// (docs/cartesian.md, "A final velocity"): `y_j = -2 log(g_m(t_j) * conj(q_j)) - omega_g
    /// (tau - t_j)`, with `g_m(t) = exp(-(tau - t)/2 omega_g) * g_o`, so that the joint fit's
    /// moving-goal target `beta_z (g - gd (tau - t_j) - y_j)` (goal 0, `gd = omega_g`) is the
    /// orientation's `beta_z 2 log(g_m(t_j) * conj(q_j))`. `y_T` is still exactly 0.
    ///
    /// The logarithm's range is a full turn: where the moving goal gets a full turn or more
    /// from the demonstration, `log` jumps to the other way round ([`quaternion::log_wrapped`]),
    /// and the targets, the fitted forcing term and the rollout's spring would jump with it.
    /// That is refused, naming the final velocity and the time.
    fn move_goal(&mut self, t: &[f64], omega_g: &[f64; 3]) -> Result<()> {
        let (t0, tau) = (t[0], t[t.len() - 1] - t[0]);
        let goal = self.goal();
        let mut last: Option<[f64; 3]> = None;
        for (j, q) in self.quaternions.iter().enumerate() {
            let to_go = tau - (t[j] - t0);
            let g_m = moving_goal(&goal, omega_g, -0.5 * to_go);
            let e = quaternion::log(&quaternion::product(&g_m, &quaternion::conjugate(q)));
            if last.is_some_and(|l| quaternion::log_wrapped(&l, &e)) {
                return Err(Error::InvalidParameter {
                    name: "final_velocity",
                    value: format!(
                        "(wx, wy, wz) = ({}, {}, {}) rad/s (its goal turns {} rad over the movement, a full turn from the demonstrated orientation at t = {} s)",
                        fmt_g(omega_g[0]),
                        fmt_g(omega_g[1]),
                        fmt_g(omega_g[2]),
                        fmt_g(tau * omega_g.iter().map(|w| w * w).sum::<f64>().sqrt()),
                        fmt_g(t[j]),
                    ),
                    requirement: "the goal turning at the final angular velocity must stay within a full turn of the demonstrated orientation (the range of the quaternion logarithm; docs/cartesian.md, \"A final velocity\")",
                });
            }
            last = Some(e);
            for d in 0..3 {
                self.y[(3 + d, j)] = -2.0 * e[d] - omega_g[d] * to_go;
            }
        }
        Ok(())
    }

    pub fn goal(&self) -> Quaternion {
        self.quaternions[self.quaternions.len() - 1]
    }

    /// The orientation coordinates of a fit whose goal turns at `omega_g`: taken relative to
    /// the moving goal ([`Self::move_goal`]), or, for a still goal (`omega_g` zero), kept and
    /// checked to stay within a full turn of it ([`Self::within_a_turn_of_the_goal`]).
    pub fn toward_goal_turning_at(&mut self, t: &[f64], omega_g: &[f64; 3]) -> Result<()> {
        if omega_g.iter().any(|&w| w != 0.0) {
            self.move_goal(t, omega_g)
        } else {
            self.within_a_turn_of_the_goal(t)
        }
    }

    /// That the orientation coordinates (`-2 log(g_o * conj(q_j))`, from the goal) stay within
    /// a full turn of the goal ([`within_a_turn`]).
    pub fn within_a_turn_of_the_goal(&self, t: &[f64]) -> Result<()> {
        within_a_turn(
            &self.y.rows(3, 3),
            t,
            "a Cartesian DMP",
            "the goal orientation",
            "every orientation of a discrete movement must be less than a full turn from its \
             goal; make a longer turn a dmprs.Sequence of movements of less than a full turn each",
        )
    }
}

/// The quaternions of rows 3..7 of a `7 x T` pose matrix: checked, scaled to unit norm, and
/// with the sign of each chosen on the side of the one before (q and -q are the same rotation,
/// but only a sign-continuous sequence has meaningful differences).
fn unit_quaternions(
    name: &'static str,
    pose: &DMatrixView<'_, f64>,
    normalize: bool,
) -> Result<Vec<Quaternion>> {
    let mut out: Vec<Quaternion> = Vec::with_capacity(pose.ncols());
    for (j, col) in pose.column_iter().enumerate() {
        let q = [col[3], col[4], col[5], col[6]];
        let q = checked_unit(name, j, &q, normalize)?;
        out.push(match out.last() {
            Some(prev) => quaternion::same_hemisphere(&q, prev),
            None => q,
        });
    }
    Ok(out)
}

/// That the rotation vectors `v` (`3 x T`, a demonstration's orientations relative to one
/// orientation, `from`, as `2 log` or `-2 log` gives them) never wrap
/// ([`quaternion::log_wrapped`]): an orientation a full turn or more from `from` is beyond the
/// range of the quaternion logarithm, and the coordinates, the forcing term and the rollout of
/// `kind` would jump there. `need` says what the demonstration must do instead.
pub(crate) fn within_a_turn(
    v: &DMatrixView<'_, f64>,
    t: &[f64],
    kind: &'static str,
    from: &str,
    need: &str,
) -> Result<()> {
    let half = |j: usize| [0, 1, 2].map(|d| 0.5 * v[(d, j)]);
    match (1..v.ncols()).find(|&j| quaternion::log_wrapped(&half(j - 1), &half(j))) {
        None => Ok(()),
        Some(j) => Err(Error::Unsuited {
            method: kind,
            detail: format!(
                "the demonstration's orientation at t = {} s is a full turn or more from {from} \
                 (the range of the quaternion logarithm): {need}",
                fmt_g(t[j])
            ),
        }),
    }
}

/// `q / |q|`, refusing the zero quaternion and, unless `normalize`, a norm off by more than
/// [`UNIT_TOLERANCE`]. A quaternion already unit to rounding is returned unchanged, so that a
/// DMP rebuilt from its own parameters is bit-identical.
fn checked_unit(
    name: &'static str,
    index: usize,
    q: &Quaternion,
    normalize: bool,
) -> Result<Quaternion> {
    let n = quaternion::norm(q);
    let bad = |requirement| Error::Quaternion {
        name,
        index,
        value: format!("[{}, {}, {}, {}]", q[0], q[1], q[2], q[3]),
        norm: n,
        requirement,
    };
    if n == 0.0 {
        return Err(bad(
            "the zero quaternion is not a rotation and cannot be normalized",
        ));
    }
    if !normalize && (n - 1.0).abs() > UNIT_TOLERANCE {
        return Err(bad(
            "orientations must be unit quaternions (|norm - 1| <= 1e-6); pass normalize=True to scale them",
        ));
    }
    if (n - 1.0).abs() <= 1e-15 {
        return Ok(*q);
    }
    Ok(q.map(|c| c / n))
}

/// `omega_j = sum_i c_ji 2 log(q_i * conj(q_j))` (module docs), `3 x T`.
fn angular_velocity(t: &[f64], q: &[Quaternion]) -> DMatrix<f64> {
    let mut out = DMatrix::zeros(3, t.len());
    for j in 0..t.len() {
        let (i, c) = diff::stencil(t, j);
        let inv = quaternion::conjugate(&q[j]);
        for (m, &cm) in c.iter().enumerate() {
            if i + m == j {
                continue; // log(q_j * conj(q_j)) = 0
            }
            let r = quaternion::log(&quaternion::product(&q[i + m], &inv));
            for d in 0..3 {
                out[(d, j)] += 2.0 * cm * r[d];
            }
        }
    }
    out
}

/// A pose `[x, y, z, qw, qx, qy, qz]` split into position and checked unit quaternion.
pub(crate) fn split_pose(
    name: &'static str,
    pose: &[f64; POSE_WIDTH],
) -> Result<([f64; 3], Quaternion)> {
    if let Some((i, &v)) = pose.iter().enumerate().find(|(_, v)| !v.is_finite()) {
        return Err(Error::NonFinite {
            name,
            location: format!("[{i}]"),
            value: v,
        });
    }
    let q = checked_unit(name, 0, &[pose[3], pose[4], pose[5], pose[6]], false)?;
    Ok(([pose[0], pose[1], pose[2]], q))
}

pub(crate) fn join_pose(p: &[f64], q: &Quaternion) -> [f64; POSE_WIDTH] {
    [p[0], p[1], p[2], q[0], q[1], q[2], q[3]]
}

/// `exp(k omega) * g`: the goal `g` turned by the rotation vector `2 k omega` in the world frame.
/// With `k = -(tau - t)/2` it is the orientation's moving goal `g_m(t)`, which turns at `omega`
/// (`d g_m/dt = 1/2 omega * g_m`, the rollout's `tau dq/dt = 1/2 eta * q` with `eta = tau
/// omega`) and is `g` at `t = tau` (docs/cartesian.md, "A final velocity").
#[inline]
pub(crate) fn moving_goal(g: &Quaternion, omega: &[f64; 3], k: f64) -> Quaternion {
    quaternion::product(&quaternion::exp(&omega.map(|c| c * k)), g)
}

/// A given final velocity: `vx, vy, vz, wx, wy, wz`, finite.
fn checked_twist(v: DVector<f64>) -> Result<DVector<f64>> {
    if v.len() != N_COORDS {
        return Err(Error::Shape {
            name: "final_velocity",
            expected: "(6,): vx, vy, vz (m/s), then wx, wy, wz (rad/s, world frame)".into(),
            got: format!("({},)", v.len()),
        });
    }
    if let Some((i, &x)) = v.iter().enumerate().find(|(_, x)| !x.is_finite()) {
        return Err(Error::NonFinite {
            name: "final_velocity",
            location: format!("[{i}]"),
            value: x,
        });
    }
    Ok(v)
}

/// A Cartesian DMP: position and orientation on one phase (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct CartesianDmp {
    /// 6 coordinates: x, y, z, then the orientation's (goal and start 0).
    dmp: Dmp,
    goal: Quaternion,
    start: Quaternion,
}

/// A sampled pose trajectory, time-major: `position[3 j + d]`, `quaternion[4 j + c]`.
#[derive(Debug, Clone, PartialEq)]
pub struct CartesianTrajectory {
    pub t: Vec<f64>,
    pub position: Vec<f64>,
    /// `[w, x, y, z]` per sample, unit norm.
    pub quaternion: Vec<f64>,
    pub velocity: Vec<f64>,
    pub acceleration: Vec<f64>,
    /// World frame (rad/s).
    pub angular_velocity: Vec<f64>,
    pub angular_acceleration: Vec<f64>,
}

impl CartesianTrajectory {
    pub fn n_samples(&self) -> usize {
        self.t.len()
    }
}

impl CartesianDmp {
    /// Builds a Cartesian DMP from its parameters: `weights` `N x 6` (columns x, y, z, then the
    /// three orientation coordinates), goal and start poses, tau. Quaternions must be unit to
    /// [`UNIT_TOLERANCE`] (they are then scaled to unit norm).
    pub fn new(
        config: DmpConfig,
        weights: DMatrix<f64>,
        goal: &[f64; POSE_WIDTH],
        start: &[f64; POSE_WIDTH],
        tau: f64,
    ) -> Result<Self> {
        if weights.ncols() != N_COORDS {
            return Err(Error::Shape {
                name: "weights",
                expected: format!("(6, {}): x, y, z, then 3 orientation rows", config.n_basis),
                got: format!("({}, {})", weights.ncols(), weights.nrows()),
            });
        }
        let (gp, gq) = split_pose("goal", goal)?;
        let (sp, sq) = split_pose("start", start)?;
        let pad = |p: [f64; 3]| DVector::from_row_slice(&[p[0], p[1], p[2], 0.0, 0.0, 0.0]);
        let dmp = Dmp::new(config, weights, pad(gp), pad(sp), tau)?;
        Ok(Self {
            dmp,
            goal: gq,
            start: sq,
        })
    }

    /// Fits position and orientation to one pose demonstration by batch least squares (module
    /// docs): `tau = t_T - t_1`, goal and start = the last and first pose.
    pub fn fit(demo: &CartesianDemonstration<'_>, config: DmpConfig) -> Result<Self> {
        config.validate_for_fit()?;
        let prepared = PreparedPose::new(demo)?;
        prepared.within_a_turn_of_the_goal(demo.t)?;
        let dmp = Dmp::fit(&prepared.demonstration(demo.t), config)?;
        Self::from_coordinates(dmp, prepared.goal(), prepared.start())
    }

    /// [`Self::fit`] of a Cartesian DMP that reaches its goal pose with a final linear and
    /// angular velocity (docs/cartesian.md, "A final velocity"): `final_velocity` given as the
    /// six entries `vx, vy, vz` (m/s), `wx, wy, wz` (rad/s, world frame), or the demonstration's
    /// last ones. The position is fitted as [`Dmp::fit_with_final_velocity`]; the orientation's
    /// coordinates are taken relative to the moving goal (`PreparedPose::move_goal`), which
    /// turns the same least squares into the fit of the orientation's moving-goal equation. A
    /// final velocity of zero is [`Self::fit`], bit for bit.
    pub fn fit_with_final_velocity(
        demo: &CartesianDemonstration<'_>,
        config: DmpConfig,
        final_velocity: FinalVelocity,
    ) -> Result<Self> {
        config.validate_for_fit()?;
        let mut prepared = PreparedPose::new(demo)?;
        let twist = match final_velocity {
            FinalVelocity::FromDemo => prepared.yd.column(demo.t.len() - 1).into_owned(),
            FinalVelocity::Given(v) => checked_twist(v)?,
        };
        let omega_g = [twist[3], twist[4], twist[5]];
        prepared.toward_goal_turning_at(demo.t, &omega_g)?;
        let dmp = Dmp::fit_with_final_velocity(
            &prepared.demonstration(demo.t),
            config,
            FinalVelocity::Given(twist),
        )?;
        Self::from_coordinates(dmp, prepared.goal(), prepared.start())
    }

    /// From the 6-coordinate DMP of a fit or a generalization: the orientation coordinates'
    /// start (`-2 log(g_o * conj(q_0))` in a fit) is carried by the start quaternion instead.
    /// Its final velocity is kept.
    pub(crate) fn from_coordinates(dmp: Dmp, goal: Quaternion, start: Quaternion) -> Result<Self> {
        let mut goal_p = dmp.goal().clone();
        let mut start_p = dmp.y0().clone();
        goal_p.rows_mut(3, 3).fill(0.0);
        start_p.rows_mut(3, 3).fill(0.0);
        let rebuilt = Dmp::new(
            *dmp.config(),
            dmp.weights().clone(),
            goal_p,
            start_p,
            dmp.tau(),
        )?;
        let dmp = match dmp.final_velocity() {
            Some(v) => rebuilt.with_final_velocity(v.clone())?,
            None => rebuilt,
        };
        Ok(Self { dmp, goal, start })
    }

    /// The same movement reaching its goal pose with linear velocity `linear` (m/s) and angular
    /// velocity `angular` (rad/s, world frame) at `t = tau` (weights unchanged; docs/cartesian.md,
    /// "A final velocity"). All zeros give today's Cartesian DMP, bit for bit.
    pub fn with_final_velocity(&self, linear: [f64; 3], angular: [f64; 3]) -> Result<Self> {
        let twist = DVector::from_iterator(6, linear.into_iter().chain(angular));
        Ok(Self {
            dmp: self.dmp.with_final_velocity(twist)?,
            ..self.clone()
        })
    }

    /// The final velocity `[vx, vy, vz, wx, wy, wz]` (m/s, then rad/s in the world frame);
    /// `None` when it is zero.
    pub fn final_velocity(&self) -> Option<[f64; N_COORDS]> {
        self.dmp
            .final_velocity()
            .map(|v| [0, 1, 2, 3, 4, 5].map(|d| v[d]))
    }

    /// A Cartesian DMP built by [`Self::new`] from this one's parameters keeps its final velocity.
    fn keeping_final_velocity(&self, built: Result<Self>) -> Result<Self> {
        let built = built?;
        match self.dmp.final_velocity() {
            Some(v) => Ok(Self {
                dmp: built.dmp.with_final_velocity(v.clone())?,
                ..built
            }),
            None => Ok(built),
        }
    }

    pub fn config(&self) -> &DmpConfig {
        self.dmp.config()
    }
    pub fn basis(&self) -> &crate::basis::Basis {
        self.dmp.basis()
    }
    /// `N x 6`: columns x, y, z (m), then the orientation's three (rad).
    pub fn weights(&self) -> &DMatrix<f64> {
        self.dmp.weights()
    }
    pub fn tau(&self) -> f64 {
        self.dmp.tau()
    }
    pub fn n_basis(&self) -> usize {
        self.dmp.n_basis()
    }
    pub fn goal_quaternion(&self) -> Quaternion {
        self.goal
    }
    pub fn start_quaternion(&self) -> Quaternion {
        self.start
    }
    /// `[x, y, z, qw, qx, qy, qz]`.
    pub fn goal(&self) -> [f64; POSE_WIDTH] {
        join_pose(self.dmp.goal().as_slice(), &self.goal)
    }
    pub fn start(&self) -> [f64; POSE_WIDTH] {
        join_pose(self.dmp.y0().as_slice(), &self.start)
    }

    /// The same movement towards a new goal pose. Its quaternion is taken on the side of the
    /// current goal (`q` and `-q` are one rotation), so the sign the caller happens to pass
    /// cannot turn the movement into the long way round.
    pub fn with_goal(&self, goal: &[f64; POSE_WIDTH]) -> Result<Self> {
        let (_, q) = split_pose("goal", goal)?;
        let q = quaternion::same_hemisphere(&q, &self.goal);
        self.keeping_final_velocity(Self::new(
            *self.config(),
            self.weights().clone(),
            &join_pose(goal, &q),
            &self.start(),
            self.tau(),
        ))
    }
    /// The same movement from a new start pose (quaternion on the side of the current start).
    pub fn with_start(&self, start: &[f64; POSE_WIDTH]) -> Result<Self> {
        let (_, q) = split_pose("start", start)?;
        let q = quaternion::same_hemisphere(&q, &self.start);
        self.keeping_final_velocity(Self::new(
            *self.config(),
            self.weights().clone(),
            &self.goal(),
            &join_pose(start, &q),
            self.tau(),
        ))
    }
    /// The same path at another speed (a final velocity scales by the old tau over the new).
    pub fn with_tau(&self, tau: f64) -> Result<Self> {
        Ok(Self {
            dmp: self.dmp.with_tau(tau)?,
            goal: self.goal,
            start: self.start,
        })
    }
}
