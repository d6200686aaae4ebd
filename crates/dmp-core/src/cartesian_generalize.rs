//! Generalization of pose demonstrations (paper eq. 6 for [`CartesianDmp`]s): the shape weights
//! and tau exactly as [`Generalizer`] does for joint demonstrations, the goal and start
//! orientations in the tangent space of a reference orientation.
//!
//! Demonstration k is flipped as a whole (all its quaternions, `q -> -q`: the same rotations) so
//! that its goal `g_k` is on the side of demonstration 0's goal `g_ref`; its start `s_k` then has
//! the tangent coordinates `v_k = 2 log(s_k * conj(s_ref))` and its goal
//! `u_k = 2 log(g_k * conj(g_ref))` (rotation vectors, |u_k| <= pi), with `s_ref` demo 0's start.
//! These six numbers are generalized like a joint DMP's goal and start: affinely (`"linear"`, so
//! for two demos `g(q) = exp(a u_2 / 2) * g_1`, the slerp from `g_1` to `g_2`), or by one Gaussian
//! process each (`"lwr-gp"`); and `g(q) = exp(u(q) / 2) * g_ref`, `s(q) = exp(v(q) / 2) * s_ref`.
//!
//! All of it runs through one [`Generalizer`] over 9-coordinate demonstrations:
//!
//! * 0..3: the position;
//! * 3..6: `u_k - 2 log(g_k * conj(q_j))`: the orientation coordinates of [`crate::cartesian`]
//!   shifted by the constant `u_k`. The shift leaves their force targets, which only see
//!   `goal - y_j`, and so the fitted weights unchanged, and makes their goal `y_T = u_k`;
//! * 6..9: the constant `v_k` (zero velocity and acceleration): weights exactly 0, start `v_k`.
//!
//! So LWR, the GPs, the tau check and the Jacobian are the joint generalizer's, unchanged.
//!
//! With final velocities ([`CartesianGeneralizer::with_final_velocity`], docs/cartesian.md, "A
//! final velocity"), each demo's orientation coordinates are taken relative to its moving goal
//! (`PreparedPose::move_goal` with the demo's last angular velocity), as
//! [`CartesianDmp::fit_with_final_velocity`] takes them, and the inner generalizer is the joint
//! one with final velocities: the last linear and angular velocity join the generalized scalars
//! (coordinates 6..9 end at rest, so their final velocity is 0).

use nalgebra::{DMatrix, DVector};

use crate::cartesian::{CartesianDemonstration, CartesianDmp, PreparedPose};
use crate::dmp::{Demonstration, DmpConfig};
use crate::error::{Error, Result};
use crate::generalize::{Generalizer, Method};
use crate::quaternion::{self, Quaternion};

/// Coordinates of the inner generalizer: position, orientation, start tangent.
const N_INNER: usize = 9;

/// A generalizer over M pose demonstrations.
#[derive(Debug, Clone)]
pub struct CartesianGeneralizer {
    inner: Generalizer,
    goal_ref: Quaternion,
    start_ref: Quaternion,
    demo_dmps: Vec<CartesianDmp>,
}

impl CartesianGeneralizer {
    pub fn new(
        queries: &[Vec<f64>],
        demos: &[CartesianDemonstration<'_>],
        config: DmpConfig,
        method: Method,
    ) -> Result<Self> {
        Self::build(queries, demos, config, method, false)
    }

    /// [`Self::new`] for pose demonstrations that end in motion: each is fitted as
    /// [`CartesianDmp::fit_with_final_velocity`] with its last linear and angular velocity, and
    /// both join the generalized scalars (module docs).
    pub fn with_final_velocity(
        queries: &[Vec<f64>],
        demos: &[CartesianDemonstration<'_>],
        config: DmpConfig,
        method: Method,
    ) -> Result<Self> {
        Self::build(queries, demos, config, method, true)
    }

    fn build(
        queries: &[Vec<f64>],
        demos: &[CartesianDemonstration<'_>],
        config: DmpConfig,
        method: Method,
        final_velocity: bool,
    ) -> Result<Self> {
        config.validate_for_fit()?;
        let mut prepared = Vec::with_capacity(demos.len());
        for (k, demo) in demos.iter().enumerate() {
            let in_demo = |e| Error::InDemo {
                index: k,
                source: Box::new(e),
            };
            let mut p = PreparedPose::new(demo).map_err(in_demo)?;
            let last = p.yd.column(demo.t.len() - 1);
            let omega_g = if final_velocity {
                [last[3], last[4], last[5]]
            } else {
                [0.0; 3]
            };
            p.toward_goal_turning_at(demo.t, &omega_g)
                .map_err(in_demo)?;
            prepared.push(p);
        }
        let Some(first) = prepared.first() else {
            return Err(Error::DemoCount {
                method: method.name(),
                got: 0,
                requirement: "needs at least 2 demonstrations".into(),
            });
        };
        let (goal_ref, start_ref) = (first.goal(), first.start());
        let mut inner_demos = Vec::with_capacity(prepared.len());
        let mut demo_dmps = Vec::with_capacity(prepared.len());
        for p in &prepared {
            // The sign that puts this demo's goal on the side of the reference goal.
            let sign = if quaternion::dot(&p.goal(), &goal_ref) < 0.0 {
                -1.0
            } else {
                1.0
            };
            let (goal, start) = (p.goal().map(|c| sign * c), p.start().map(|c| sign * c));
            let u = tangent(&goal, &goal_ref);
            let v = tangent(&start, &start_ref);
            let n = p.y.ncols();
            let mut y = DMatrix::zeros(N_INNER, n);
            let mut yd = DMatrix::zeros(N_INNER, n);
            let mut ydd = DMatrix::zeros(N_INNER, n);
            y.rows_mut(0, 6).copy_from(&p.y);
            yd.rows_mut(0, 6).copy_from(&p.yd);
            ydd.rows_mut(0, 6).copy_from(&p.ydd);
            for d in 0..3 {
                y.row_mut(3 + d).add_scalar_mut(u[d]);
                y.row_mut(6 + d).fill(v[d]);
            }
            inner_demos.push((y, yd, ydd));
            demo_dmps.push((goal, start));
        }
        let views: Vec<Demonstration<'_>> = inner_demos
            .iter()
            .zip(demos)
            .map(|((y, yd, ydd), d)| Demonstration {
                t: d.t,
                y: y.as_view(),
                yd: Some(yd.as_view()),
                ydd: Some(ydd.as_view()),
            })
            .collect();
        let inner = if final_velocity {
            Generalizer::with_final_velocity(queries, &views, config, method)?
        } else {
            Generalizer::new(queries, &views, config, method)?
        };
        // Each demo's own DMP: the inner one's first six coordinates, with its quaternions and
        // final velocity.
        let demo_dmps = inner
            .demo_dmps()
            .iter()
            .zip(demo_dmps)
            .map(|(d, (goal, start))| {
                let w = d.weights().columns(0, 6).into_owned();
                let pose =
                    |p: &DVector<f64>, q: &Quaternion| [p[0], p[1], p[2], q[0], q[1], q[2], q[3]];
                let dmp = CartesianDmp::new(
                    config,
                    w,
                    &pose(d.goal(), &goal),
                    &pose(d.y0(), &start),
                    d.tau(),
                )?;
                with_twist(dmp, d.final_velocity())
            })
            .collect::<Result<_>>()?;
        Ok(Self {
            inner,
            goal_ref,
            start_ref,
            demo_dmps,
        })
    }

    /// The Cartesian DMP for query `q`; [`Error::Extrapolation`] if its tau would leave
    /// [`Self::tau_bounds`]. With `"linear"`, a demo's own query returns that demo's DMP exactly.
    pub fn predict(&self, q: &[f64]) -> Result<CartesianDmp> {
        let d = self.inner.predict(q)?;
        if self.inner.method() == "linear"
            && let Some(k) = self
                .inner
                .queries()
                .iter()
                .position(|qk| qk.as_slice() == q)
        {
            return Ok(self.demo_dmps[k].clone());
        }
        let (goal, y0) = (d.goal(), d.y0());
        let g = at_tangent(&[goal[3], goal[4], goal[5]], &self.goal_ref);
        let s = at_tangent(&[goal[6], goal[7], goal[8]], &self.start_ref);
        let dmp = CartesianDmp::new(
            *d.config(),
            d.weights().columns(0, 6).into_owned(),
            &[goal[0], goal[1], goal[2], g[0], g[1], g[2], g[3]],
            &[y0[0], y0[1], y0[2], s[0], s[1], s[2], s[3]],
            d.tau(),
        )?;
        with_twist(dmp, d.final_velocity())
    }

    /// Rows of the inner generalizer's flat parameters that make up ours:
    /// `[w (6 x N, coordinate-major), tau, goal position (3), goal tangent u (3),
    /// start position (3), start tangent v (3)]`, then with final velocities the final linear
    /// (3) and angular (3) velocity.
    fn rows(&self) -> Vec<usize> {
        let nw = N_INNER * self.inner.config().n_basis;
        let goal = nw + 1;
        let y0 = goal + N_INNER;
        let mut rows: Vec<usize> = (0..6 * self.inner.config().n_basis).collect();
        rows.push(nw);
        rows.extend(goal..goal + 6);
        rows.extend(y0..y0 + 3);
        rows.extend(goal + 6..goal + 9);
        if self.has_final_velocity() {
            let gd = y0 + N_INNER;
            rows.extend(gd..gd + 6);
        }
        rows
    }

    /// The generalized parameters at `q` (layout of `rows`), without the tau check.
    pub fn parameters(&self, q: &[f64]) -> Result<DVector<f64>> {
        let all = self.inner.parameters(q)?;
        Ok(DVector::from_iterator(
            self.n_parameters(),
            self.rows().into_iter().map(|r| all[r]),
        ))
    }

    /// Central-difference Jacobian of [`Self::parameters`] (`n_parameters x n`), as
    /// [`Generalizer::jacobian`].
    pub fn jacobian(&self, q: &[f64], rel_step: f64) -> Result<DMatrix<f64>> {
        let all = self.inner.jacobian(q, rel_step)?;
        Ok(all.select_rows(self.rows().iter()))
    }

    pub fn method(&self) -> &'static str {
        self.inner.method()
    }
    pub fn n_query(&self) -> usize {
        self.inner.n_query()
    }
    pub fn n_demos(&self) -> usize {
        self.inner.n_demos()
    }
    pub fn config(&self) -> &DmpConfig {
        self.inner.config()
    }
    /// `6 N + 1 + 12`, `+ 6` with final velocities.
    pub fn n_parameters(&self) -> usize {
        6 * self.inner.config().n_basis + 1 + if self.has_final_velocity() { 18 } else { 12 }
    }
    /// Whether the final velocities are generalized ([`Self::with_final_velocity`]).
    pub fn has_final_velocity(&self) -> bool {
        self.inner.has_final_velocity()
    }
    pub fn tau_bounds(&self) -> (f64, f64) {
        self.inner.tau_bounds()
    }
    pub fn demo_dmps(&self) -> &[CartesianDmp] {
        &self.demo_dmps
    }
    /// The reference orientations of the tangent spaces (demonstration 0's goal and start).
    pub fn references(&self) -> (Quaternion, Quaternion) {
        (self.goal_ref, self.start_ref)
    }
}

/// `dmp` reaching its goal with the first six entries of the inner DMP's final velocity
/// `[v (3), omega (3), 0 (3)]`; unchanged without one.
fn with_twist(dmp: CartesianDmp, gd: Option<&DVector<f64>>) -> Result<CartesianDmp> {
    match gd {
        Some(v) => dmp.with_final_velocity([v[0], v[1], v[2]], [v[3], v[4], v[5]]),
        None => Ok(dmp),
    }
}

/// `2 log(q * conj(reference))`: the rotation vector taking `reference` to `q`.
fn tangent(q: &Quaternion, reference: &Quaternion) -> [f64; 3] {
    quaternion::log(&quaternion::product(q, &quaternion::conjugate(reference))).map(|c| 2.0 * c)
}

/// Inverse of [`tangent`]: `exp(v / 2) * reference`.
fn at_tangent(v: &[f64; 3], reference: &Quaternion) -> Quaternion {
    quaternion::product(&quaternion::exp(&v.map(|c| 0.5 * c)), reference)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dmp::FinalVelocity;
    use crate::generalize::LwrGpOptions;

    const N: usize = 300;

    /// A pose demo whose position, turn and duration depend on the query.
    fn demo(q: f64) -> (Vec<f64>, DMatrix<f64>) {
        let tau = 1.0 + 0.3 * q;
        let t: Vec<f64> = (0..N).map(|j| tau * j as f64 / (N - 1) as f64).collect();
        let pose = DMatrix::from_fn(7, N, |r, j| {
            let s = j as f64 / (N - 1) as f64;
            let a = 10.0 * s.powi(3) - 15.0 * s.powi(4) + 6.0 * s.powi(5);
            let turn = [0.3 * q * a, 0.1, (1.0 + q) * a];
            let h = quaternion::exp(&turn.map(|c| 0.5 * c));
            match r {
                0 => (1.0 + q) * a,
                1 => 0.2 * q,
                2 => 0.5 * a * (3.0 * s).sin(),
                // Sign flips between demos must not matter.
                c => h[c - 3] * if q > 0.5 { -1.0 } else { 1.0 },
            }
        });
        (t, pose)
    }

    fn build(qs: &[f64], method: Method) -> CartesianGeneralizer {
        let data: Vec<_> = qs.iter().map(|&q| demo(q)).collect();
        let demos: Vec<_> = data
            .iter()
            .map(|(t, pose)| CartesianDemonstration {
                t,
                pose: pose.as_view(),
                velocity: None,
                acceleration: None,
                angular_velocity: None,
                angular_acceleration: None,
                normalize: false,
            })
            .collect();
        let queries: Vec<Vec<f64>> = qs.iter().map(|&q| vec![q]).collect();
        let config = DmpConfig {
            n_basis: 15,
            ..DmpConfig::default()
        };
        CartesianGeneralizer::new(&queries, &demos, config, method).unwrap()
    }

    fn angle(a: &Quaternion, b: &Quaternion) -> f64 {
        let d = quaternion::product(a, &quaternion::conjugate(b));
        let d = quaternion::same_hemisphere(&d, &quaternion::IDENTITY);
        2.0 * quaternion::norm(&[0.0, d[1], d[2], d[3]]).atan2(d[0])
    }

    #[test]
    fn linear_reproduces_the_demos_and_slerps_between_two() {
        let g = build(&[0.0, 1.0], Method::Linear);
        for k in 0..2 {
            let (t, pose) = demo(k as f64);
            let own = CartesianDmp::fit(
                &CartesianDemonstration {
                    t: &t,
                    pose: pose.as_view(),
                    velocity: None,
                    acceleration: None,
                    angular_velocity: None,
                    angular_acceleration: None,
                    normalize: false,
                },
                *g.config(),
            )
            .unwrap();
            // The same DMP up to the sign of its quaternions and rounding.
            let got = g.predict(&[k as f64]).unwrap();
            assert!(angle(&got.goal_quaternion(), &own.goal_quaternion()) < 1e-15);
            assert!(angle(&got.start_quaternion(), &own.start_quaternion()) < 1e-15);
            assert!((got.weights() - own.weights()).amax() < 1e-11 * own.weights().amax());
            assert_eq!((&got.goal()[..3], got.tau()), (&own.goal()[..3], own.tau()));
        }
        // Slerp: the goal at a is exp(a log(g2 conj(g1))) g1, independently of the chart.
        let (g1, g2) = (
            g.demo_dmps()[0].goal_quaternion(),
            g.demo_dmps()[1].goal_quaternion(),
        );
        let g2 = quaternion::same_hemisphere(&g2, &g1);
        for a in [0.25, 0.5, 1.7] {
            let rel = quaternion::log(&quaternion::product(&g2, &quaternion::conjugate(&g1)));
            let want = quaternion::product(&quaternion::exp(&rel.map(|c| a * c)), &g1);
            let got = g.predict(&[a]).unwrap().goal_quaternion();
            assert!(angle(&got, &want) < 1e-12, "a={a}");
        }
    }

    #[test]
    /// To the GP noise (1e-4 x the outputs' std, docs/method.md §3.2).
    fn lwr_gp_reproduces_each_demo() {
        let qs = [0.0, 0.4, 1.0, 1.5];
        let g = build(&qs, Method::LwrGp(LwrGpOptions::default()));
        for (k, &q) in qs.iter().enumerate() {
            let got = g.predict(&[q]).unwrap();
            let want = &g.demo_dmps()[k];
            let (eg, es) = (
                angle(&got.goal_quaternion(), &want.goal_quaternion()),
                angle(&got.start_quaternion(), &want.start_quaternion()),
            );
            assert!(
                eg < 1e-4 && es < 1e-4,
                "k={k}: goal {eg} rad, start {es} rad"
            );
            let scale = want.weights().amax();
            assert!((got.weights() - want.weights()).amax() < 1e-5 * scale);
            assert!((got.tau() - want.tau()).abs() < 1e-5);
        }
    }

    /// Like [`demo`], but ending in motion: the profile's end slope is `end_rate` per unit of
    /// `s`, so the pose ends with a query-dependent linear and angular velocity.
    fn moving_demo(q: f64) -> (Vec<f64>, DMatrix<f64>) {
        let tau = 1.0 + 0.3 * q;
        let end_rate = 0.8 + 0.5 * q;
        let t: Vec<f64> = (0..N).map(|j| tau * j as f64 / (N - 1) as f64).collect();
        let pose = DMatrix::from_fn(7, N, |r, j| {
            let s = j as f64 / (N - 1) as f64;
            let a = 10.0 * s.powi(3) - 15.0 * s.powi(4)
                + 6.0 * s.powi(5)
                + end_rate * (s.powi(5) - s.powi(4));
            let turn = [0.3 * q * a, 0.1, (1.0 + q) * a];
            let h = quaternion::exp(&turn.map(|c| 0.5 * c));
            match r {
                0 => (1.0 + q) * a,
                1 => 0.2 * q,
                2 => 0.5 * a,
                c => h[c - 3] * if q > 0.5 { -1.0 } else { 1.0 },
            }
        });
        (t, pose)
    }

    fn pose_demo<'a>(t: &'a [f64], pose: &'a DMatrix<f64>) -> CartesianDemonstration<'a> {
        CartesianDemonstration {
            t,
            pose: pose.as_view(),
            velocity: None,
            acceleration: None,
            angular_velocity: None,
            angular_acceleration: None,
            normalize: false,
        }
    }

    #[test]
    fn with_final_velocity_reproduces_each_demos_own_fit_and_interpolates_the_twist() {
        let qs = [0.0, 1.0];
        let data: Vec<_> = qs.iter().map(|&q| moving_demo(q)).collect();
        let demos: Vec<_> = data.iter().map(|(t, p)| pose_demo(t, p)).collect();
        let queries: Vec<Vec<f64>> = qs.iter().map(|&q| vec![q]).collect();
        let config = DmpConfig {
            n_basis: 15,
            ..DmpConfig::default()
        };
        let g = CartesianGeneralizer::with_final_velocity(&queries, &demos, config, Method::Linear)
            .unwrap();
        assert!(g.has_final_velocity());
        assert_eq!(g.n_parameters(), 6 * 15 + 1 + 18);
        let mut twists = Vec::new();
        for (k, demo) in demos.iter().enumerate() {
            let own = CartesianDmp::fit_with_final_velocity(demo, config, FinalVelocity::FromDemo)
                .unwrap();
            let got = g.predict(&[qs[k]]).unwrap();
            let (want_v, got_v) = (own.final_velocity().unwrap(), got.final_velocity().unwrap());
            assert_eq!(want_v, got_v, "demo {k}");
            assert!(
                want_v[3..].iter().any(|w| w.abs() > 0.1),
                "the demo turns at its end"
            );
            // The orientation weights are fitted against the moving goal, as the own fit's.
            assert!((got.weights() - own.weights()).amax() < 1e-11 * own.weights().amax());
            assert!(angle(&got.goal_quaternion(), &own.goal_quaternion()) < 1e-15);
            twists.push(want_v);
        }
        // "linear" is affine in the query: halfway, the mean twist, also in the parameters.
        let mid = g.predict(&[0.5]).unwrap().final_velocity().unwrap();
        let params = g.parameters(&[0.5]).unwrap();
        for d in 0..6 {
            let want = 0.5 * (twists[0][d] + twists[1][d]);
            assert!((mid[d] - want).abs() < 1e-12, "coordinate {d}");
            assert!(
                (params[6 * 15 + 13 + d] - want).abs() < 1e-12,
                "parameter {d}"
            );
        }
        // Without final velocities the layout and the orientation weights are today's.
        let plain = CartesianGeneralizer::new(&queries, &demos, config, Method::Linear).unwrap();
        assert_eq!(plain.n_parameters(), 6 * 15 + 13);
        assert!(plain.predict(&[0.5]).unwrap().final_velocity().is_none());
    }

    #[test]
    fn the_jacobian_of_linear_is_the_parameter_difference() {
        let g = build(&[0.0, 2.0], Method::Linear);
        let jac = g.jacobian(&[0.7], 1e-3).unwrap();
        let want = (g.parameters(&[2.0]).unwrap() - g.parameters(&[0.0]).unwrap()) / 2.0;
        assert_eq!(jac.nrows(), g.n_parameters());
        assert!((jac.column(0) - want).amax() < 1e-8);
    }
}
