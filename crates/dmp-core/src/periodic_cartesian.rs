//! The periodic Cartesian DMP: a rhythmic pose, the position by the periodic DMP of
//! [`crate::periodic`] and the orientation by its unit-quaternion counterpart (Abu-Dakka, Saveriano
//! and Kyrki 2021, on the quaternion itself), on one phase and one `tau` (docs/method.md §12.4):
//!
//! ```text
//! tau d(eta)/dt = alpha_z (beta_z 2 log(g_o * conj(q)) - eta) + r_o f_o(phi)
//! tau dq/dt     = 1/2 eta * q
//! ```
//!
//! with `eta = tau omega`, `g_o` the baseline orientation the rhythm turns about, `r_o` the
//! amplitude per axis and `f_o` the von Mises forcing term of eq. P4 with weights in R^3. As for
//! the discrete [`crate::cartesian::CartesianDmp`], the orientation's coordinates
//! `y_o = -2 log(g_o * conj(q))` make its equation the position's with baseline 0, so a
//! [`PeriodicCartesianDmp`] is a 6-coordinate [`PeriodicDmp`] (orientation baseline and start 0)
//! plus the baseline and start quaternions, and one integrator serves both: the coordinates'
//! acceleration ([`PeriodicDmp::acceleration`], `y_o` taken from `q`), their semi-implicit step
//! ([`PeriodicDmp::advance`]), and `q <- exp(h / (2 tau) eta) * q` with the new `eta` on the sphere.
//! For a rotation about one fixed axis this is the 1-D periodic DMP of the angle.
//!
//! **Fit.** The baseline orientation is the middle of the demonstration's range, taken in the
//! rotation vectors `v_j = 2 log(q_j * conj(q_1))` relative to the first sample (component-wise
//! `(min + max) / 2`, as the position's baseline), `g_o = exp(v_mid / 2) * q_1`; the amplitude per
//! axis is the half range of `y_o`. Then the least squares of the periodic fit.

use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;

use crate::cartesian::{
    CartesianDemonstration, CartesianTrajectory, POSE_WIDTH, PreparedPose, join_pose, split_pose,
    within_a_turn,
};
use crate::design_matrix::PreparedDemo;
use crate::error::{Error, Result, fmt_g};
use crate::periodic::{PeriodicConfig, PeriodicDmp, baseline_and_amplitude};
use crate::quaternion::{self, Quaternion};

/// What refuses an orientation beyond a full turn, and what it needs ([`within_a_turn`]).
const PERIODIC: &str = "a periodic orientation DMP";
const SWING: &str = "a rhythmic orientation must swing less than a full turn about its baseline";

/// x, y, z, then the three orientation coordinates.
const N_COORDS: usize = 6;

/// A periodic pose: position and orientation on one periodic phase (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct PeriodicCartesianDmp {
    /// 6 coordinates; the orientation's baseline and start are 0.
    coords: PeriodicDmp,
    goal: Quaternion,
    start: Quaternion,
}

impl PeriodicCartesianDmp {
    /// Builds one from its parameters: `weights` `N x 6`, baseline and start poses
    /// `[x, y, z, qw, qx, qy, qz]` (unit quaternions), `amplitude` per coordinate (6), tau.
    pub fn new(
        config: PeriodicConfig,
        weights: DMatrix<f64>,
        goal: &[f64; POSE_WIDTH],
        amplitude: DVector<f64>,
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
        if amplitude.len() != N_COORDS {
            return Err(Error::Shape {
                name: "amplitude",
                expected: "(6,): x, y, z, then the 3 orientation axes".into(),
                got: format!("({},)", amplitude.len()),
            });
        }
        let (gp, gq) = split_pose("goal", goal)?;
        let (sp, sq) = split_pose("start", start)?;
        let pad = |p: [f64; 3]| DVector::from_row_slice(&[p[0], p[1], p[2], 0.0, 0.0, 0.0]);
        let coords = PeriodicDmp::new(config, weights, pad(gp), amplitude, pad(sp), tau)?;
        Ok(Self {
            coords,
            goal: gq,
            start: sq,
        })
    }

    /// Fits one to a pose demonstration of one or more whole periods (module docs).
    pub fn fit(
        demo: &CartesianDemonstration<'_>,
        period: Option<f64>,
        config: PeriodicConfig,
    ) -> Result<Self> {
        let pose = PreparedPose::new(demo)?;
        let q1 = pose.quaternions[0];
        let n = pose.quaternions.len();
        // rotation vectors from the first sample, and the middle of their range
        let mut v = DMatrix::zeros(3, n);
        for (j, q) in pose.quaternions.iter().enumerate() {
            let e = quaternion::log(&quaternion::product(q, &quaternion::conjugate(&q1)));
            for d in 0..3 {
                v[(d, j)] = 2.0 * e[d];
            }
        }
        within_a_turn(
            &v.as_view(),
            demo.t,
            PERIODIC,
            "the first orientation",
            SWING,
        )?;
        let (mid, _) = baseline_and_amplitude(&v.as_view());
        let goal_q = quaternion::renormalize(&quaternion::product(
            &quaternion::exp(&[0.5 * mid[0], 0.5 * mid[1], 0.5 * mid[2]]),
            &q1,
        ));
        let mut y = pose.y.clone();
        for (j, q) in pose.quaternions.iter().enumerate() {
            let e = quaternion::log(&quaternion::product(&goal_q, &quaternion::conjugate(q)));
            for d in 0..3 {
                y[(3 + d, j)] = -2.0 * e[d];
            }
        }
        within_a_turn(
            &y.rows(3, 3),
            demo.t,
            PERIODIC,
            "the baseline orientation",
            SWING,
        )?;
        let prepared = PreparedDemo::new(&crate::dmp::Demonstration {
            t: demo.t,
            y: y.as_view(),
            yd: Some(pose.yd.as_view()),
            ydd: Some(pose.ydd.as_view()),
        })?;
        let (mut goal, amplitude) = baseline_and_amplitude(&prepared.y);
        goal.rows_mut(3, 3).fill(0.0);
        let mut coords = PeriodicDmp::fit_about(&prepared, period, config, goal, amplitude)?;
        // the start's orientation is the first quaternion itself, not a coordinate
        let mut y0 = coords.y0().clone();
        y0.rows_mut(3, 3).fill(0.0);
        coords = coords.with_start(y0)?;
        Ok(Self {
            coords,
            goal: goal_q,
            start: q1,
        })
    }

    pub fn config(&self) -> &PeriodicConfig {
        self.coords.config()
    }
    /// The 6 coordinates' periodic DMP (orientation baseline and start 0).
    pub fn coordinates(&self) -> &PeriodicDmp {
        &self.coords
    }
    pub fn tau(&self) -> f64 {
        self.coords.tau()
    }
    pub fn goal(&self) -> [f64; POSE_WIDTH] {
        join_pose(self.coords.goal().as_slice(), &self.goal)
    }
    pub fn start(&self) -> [f64; POSE_WIDTH] {
        join_pose(self.coords.y0().as_slice(), &self.start)
    }

    /// The same rhythm about another baseline pose.
    pub fn with_goal(&self, goal: &[f64; POSE_WIDTH]) -> Result<Self> {
        let (p, q) = split_pose("goal", goal)?;
        let mut g = self.coords.goal().clone();
        g.rows_mut(0, 3).copy_from_slice(&p);
        Ok(Self {
            coords: self.coords.with_goal(g)?,
            goal: q,
            start: self.start,
        })
    }
    /// The same rhythm started (at rest) from another pose.
    pub fn with_start(&self, start: &[f64; POSE_WIDTH]) -> Result<Self> {
        let (p, q) = split_pose("start", start)?;
        let mut s = self.coords.y0().clone();
        s.rows_mut(0, 3).copy_from_slice(&p);
        Ok(Self {
            coords: self.coords.with_start(s)?,
            goal: self.goal,
            start: q,
        })
    }
    /// The same rhythm scaled per coordinate (x, y, z, then the three orientation axes).
    pub fn with_amplitude(&self, amplitude: DVector<f64>) -> Result<Self> {
        if amplitude.len() != N_COORDS {
            return Err(Error::Shape {
                name: "amplitude",
                expected: "(6,): x, y, z, then the 3 orientation axes".into(),
                got: format!("({},)", amplitude.len()),
            });
        }
        Ok(Self {
            coords: self.coords.with_amplitude(amplitude)?,
            ..self.clone()
        })
    }
    /// The same rhythm at another frequency.
    pub fn with_tau(&self, tau: f64) -> Result<Self> {
        Ok(Self {
            coords: self.coords.with_tau(tau)?,
            ..self.clone()
        })
    }

    /// Integrates the position and the orientation from the start at rest at phase `phi0` and
    /// samples them at `t_j = j dt` up to `duration` (default one period).
    pub fn rollout(
        &self,
        dt: f64,
        duration: Option<f64>,
        phi0: f64,
    ) -> Result<CartesianTrajectory> {
        let c = &self.coords;
        let (cap, substeps) = c.plan(
            dt,
            duration,
            phi0,
            POSE_WIDTH,
            "periodic Cartesian DMP rollout",
        )?;
        let mut out = CartesianTrajectory {
            t: Vec::with_capacity(cap),
            position: Vec::with_capacity(3 * cap),
            quaternion: Vec::with_capacity(4 * cap),
            velocity: Vec::with_capacity(3 * cap),
            acceleration: Vec::with_capacity(3 * cap),
            angular_velocity: Vec::with_capacity(3 * cap),
            angular_acceleration: Vec::with_capacity(3 * cap),
        };
        let (tau, h) = (c.tau(), dt / substeps as f64);
        let (inv_tau, inv_tau2) = (1.0 / tau, 1.0 / (tau * tau));
        let (goal, amplitude) = (c.goal().as_slice(), c.amplitude().as_slice());
        let mut state = c.initial_state(phi0);
        let mut q = self.start;
        let mut ws = c.workspace();
        let mut dz = [0.0; N_COORDS];
        for j in 0..cap {
            self.acceleration(&mut state, &q, goal, amplitude, &mut ws, &mut dz);
            out.t.push(j as f64 * dt);
            out.position.extend_from_slice(&state.y[..3]);
            out.quaternion.extend_from_slice(&q);
            for d in 0..3 {
                out.velocity.push(state.z[d] * inv_tau);
                out.acceleration.push(dz[d] * inv_tau2);
                out.angular_velocity.push(state.z[3 + d] * inv_tau);
                out.angular_acceleration.push(dz[3 + d] * inv_tau2);
            }
            if j + 1 == cap {
                break;
            }
            for sub in 0..substeps {
                if sub > 0 {
                    self.acceleration(&mut state, &q, goal, amplitude, &mut ws, &mut dz);
                }
                Self::advance(&mut state, &mut q, &dz, tau, h);
            }
        }
        let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
        if !(finite(&state.y) && finite(&state.z) && finite(&q)) {
            return Err(Error::Numerical {
                context: "periodic Cartesian DMP rollout",
                detail: format!(
                    "the integration diverged (dt = {} s, tau = {} s)",
                    fmt_g(dt),
                    fmt_g(tau)
                ),
            });
        }
        Ok(out)
    }

    /// `tau d(eta)/dt` and the position's `tau dz/dt` at `state` and orientation `q` (whose
    /// coordinates `-2 log(g_o * conj(q))` it writes into the state first).
    pub fn acceleration(
        &self,
        state: &mut crate::periodic::PeriodicState,
        q: &Quaternion,
        goal: &[f64],
        amplitude: &[f64],
        ws: &mut crate::periodic::Workspace,
        dz: &mut [f64],
    ) {
        let e = quaternion::log(&quaternion::product(&self.goal, &quaternion::conjugate(q)));
        for (y, e) in state.y[3..].iter_mut().zip(e) {
            *y = -2.0 * e;
        }
        self.coords.acceleration(state, goal, amplitude, ws, dz);
    }

    /// One step of length `h`: the coordinates' semi-implicit step, then the quaternion turned
    /// by the new `eta` (`q <- exp(h / (2 tau) eta) * q`), kept on the unit sphere.
    pub fn advance(
        state: &mut crate::periodic::PeriodicState,
        q: &mut Quaternion,
        dz: &[f64],
        tau: f64,
        h: f64,
    ) {
        PeriodicDmp::advance(state, dz, tau, h);
        let k = 0.5 * h / tau;
        let turn = quaternion::exp(&[k * state.z[3], k * state.z[4], k * state.z[5]]);
        *q = quaternion::renormalize(&quaternion::product(&turn, q));
    }
}

/// Rolls out many periodic Cartesian DMPs in parallel (rayon); the same bits as one by one.
pub fn rollout_batch_periodic_cartesian(
    dmps: &[PeriodicCartesianDmp],
    dt: f64,
    duration: Option<f64>,
    phi0: f64,
) -> Result<Vec<CartesianTrajectory>> {
    dmps.par_iter()
        .map(|d| d.rollout(dt, duration, phi0))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::TAU as TWO_PI;

    fn axis_angle(axis: [f64; 3], angle: f64) -> Quaternion {
        let (s, c) = (0.5 * angle).sin_cos();
        [c, s * axis[0], s * axis[1], s * axis[2]]
    }

    /// A pose rocking about one fixed axis: theta(t) = 0.3 + 0.4 sin(t / tau) + 0.1 cos(2 t / tau).
    fn rocking(axis: [f64; 3], tau: f64, n: usize) -> (Vec<f64>, DMatrix<f64>, Vec<f64>) {
        let t: Vec<f64> = (0..=n)
            .map(|j| j as f64 * TWO_PI * tau / n as f64)
            .collect();
        let theta: Vec<f64> = t
            .iter()
            .map(|t| 0.3 + 0.4 * (t / tau).sin() + 0.1 * (2.0 * t / tau).cos())
            .collect();
        let mut pose = DMatrix::zeros(7, t.len());
        for (j, th) in theta.iter().enumerate() {
            let q = axis_angle(axis, *th);
            pose[(0, j)] = 0.1 * th;
            for c in 0..4 {
                pose[(3 + c, j)] = q[c];
            }
        }
        (t, pose, theta)
    }

    #[test]
    fn a_rotation_about_one_axis_is_the_one_dimensional_periodic_dmp_of_its_angle() {
        let s = 1.0 / 3.0_f64.sqrt();
        let axis = [s, -s, s];
        let (t, pose, theta) = rocking(axis, 0.2, 2000);
        let cfg = PeriodicConfig {
            n_basis: 30,
            ..PeriodicConfig::default()
        };
        let demo = CartesianDemonstration {
            t: &t,
            pose: pose.as_view(),
            velocity: None,
            acceleration: None,
            angular_velocity: None,
            angular_acceleration: None,
            normalize: false,
        };
        let dmp = PeriodicCartesianDmp::fit(&demo, None, cfg).unwrap();
        let th = DMatrix::from_row_slice(1, theta.len(), &theta);
        let angle = PeriodicDmp::fit(
            &crate::dmp::Demonstration {
                t: &t,
                y: th.as_view(),
                yd: None,
                ydd: None,
            },
            None,
            cfg,
        )
        .unwrap();
        let a = dmp.rollout(1e-3, Some(1.0), 0.0).unwrap();
        let b = angle.rollout(1e-3, Some(1.0), 0.0).unwrap();
        for j in 0..a.n_samples() {
            let q: Quaternion = a.quaternion[4 * j..4 * j + 4].try_into().unwrap();
            assert!((quaternion::norm(&q) - 1.0).abs() < 1e-15);
            // the orientation is the angle's rotation about the axis
            let want = axis_angle(axis, b.y[j]);
            let d = quaternion::dot(&q, &want).abs();
            assert!(1.0 - d < 1e-12, "sample {j}: {q:?} vs {want:?}");
            for (w, axis) in a.angular_velocity[3 * j..3 * j + 3].iter().zip(axis) {
                assert!((w - axis * b.yd[j]).abs() < 1e-8, "{w} {}", b.yd[j]);
            }
        }
    }

    #[test]
    fn bad_parameters_are_named() {
        let cfg = PeriodicConfig::default();
        let pose = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0];
        let w = DMatrix::zeros(cfg.n_basis, 5);
        let err =
            PeriodicCartesianDmp::new(cfg, w, &pose, DVector::from_element(6, 1.0), &pose, 1.0);
        assert!(err.unwrap_err().to_string().contains("weights"));
        let w = DMatrix::zeros(cfg.n_basis, 6);
        let bad = [0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0];
        let err =
            PeriodicCartesianDmp::new(cfg, w, &bad, DVector::from_element(6, 1.0), &pose, 1.0);
        assert!(err.unwrap_err().to_string().contains("goal"));
    }
}
