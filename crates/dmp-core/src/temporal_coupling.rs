//! Velocity and acceleration limits met by slowing the DMP's clock instead of clipping its
//! command: the temporal coupling of Dahlin and Karayiannidis, "Temporal coupling of dynamical
//! movement primitives for constrained velocities and accelerations", IEEE RA-L 6(2), 2021
//! (docs/method.md §2.5.4).
//!
//! With a time-varying `tau` the DMP of eqs. 1-3 reads, per coordinate,
//!
//! ```text
//! tau dz/dt = h(x, y, z)      tau dy/dt = z      tau dx/dt = -alpha_x x
//! yd  = z / tau
//! ydd = (h - taud z) / tau^2          (taud = dtau/dt)
//! ```
//!
//! so every state derivative is divided by the same `tau`: in the clock `s` with `ds/dt = 1/tau`
//! the system does not depend on `tau` at all, and any `tau(t)` traces the same path. The
//! coupling chooses `taud` each control period:
//!
//! ```text
//! taud = gamma_n (tau_min - tau) + tau sigma,   sigma = gamma_a sum_d a_d^2 / max(1 - a_d^2, gamma_a eps),
//!                                              a_d = h_d / (tau^2 ydd_max,d)
//! ```
//!
//! saturated so that `|ydd_k| <= ydd_max` (`taud` in `[max_d L_d, min_d U_d]` with
//! `L_d, U_d = h_d / z_d -+ ydd_max,d tau^2 / |z_d|`), and raised, if needed, to the lower bounds
//! that the next sample needs: `tau_{k+1} >= |z_{k+1,d}| / yd_max,d` (its velocity within the
//! limit, exactly, since explicit Euler's `z_{k+1}` does not depend on `taud`),
//! `tau_{k+1} >= tau_min`, and `tau_{k+1}^2 >= (p_i - p_j) / (q_i + q_j)` for every pair of
//! coordinates with `p = h / z`, `q = ydd_max / |z|` at k+1 (then the acceleration bounds of the
//! next sample have a common solution; `tau^2 >= |h_d| / ydd_max,d` where `z_d = 0`). The lower
//! bounds win over the acceleration's upper bound: velocities are never exceeded, accelerations
//! are met whenever those bounds leave room (the paper's feasibility condition).

use crate::error::{Error, Result, fmt_g};

/// The gains of the coupling, defaults those of the authors' published experiments (their
/// Matlab and ROS code: `gamma_nominal = 1`, `gamma_a = 0.5`, `eps = 1e-3`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TemporalCouplingGains {
    /// Rate (1/s) at which `tau` returns to its nominal value once the limits allow it.
    pub nominal: f64,
    /// Weight of the potential `sigma` that starts slowing down before an acceleration reaches
    /// its limit (0 switches it off).
    pub potential: f64,
    /// Floor of `1 - a_d^2` in `sigma` (relative to `potential`), keeping it finite at the limit.
    pub eps: f64,
}

impl Default for TemporalCouplingGains {
    fn default() -> Self {
        Self {
            nominal: 1.0,
            potential: 0.5,
            eps: 1e-3,
        }
    }
}

/// Velocity and (optionally) acceleration limits per coordinate, and the coupling's gains.
#[derive(Debug, Clone, PartialEq)]
pub struct TemporalCoupling {
    velocity_max: Vec<f64>,
    acceleration_max: Vec<f64>,
    has_acceleration: bool,
    gains: TemporalCouplingGains,
    /// Scratch for the feasibility bound: `p = h / z` and `q = a / |z|` per coordinate.
    p: Vec<f64>,
    q: Vec<f64>,
}

impl TemporalCoupling {
    /// `velocity_max` and `acceleration_max` have one entry per coordinate (`+inf`: no limit
    /// on that coordinate), or are `None`.
    pub fn new(
        n: usize,
        velocity_max: Option<&[f64]>,
        acceleration_max: Option<&[f64]>,
        gains: TemporalCouplingGains,
    ) -> Result<Self> {
        let limits = |name: &'static str, v: Option<&[f64]>| -> Result<Vec<f64>> {
            let Some(v) = v else {
                return Ok(vec![f64::INFINITY; n]);
            };
            if v.len() != n {
                return Err(Error::Shape {
                    name,
                    expected: format!("({n},), one limit per coordinate"),
                    got: format!("({},)", v.len()),
                });
            }
            for (i, &l) in v.iter().enumerate() {
                if l.is_nan() || l <= 0.0 {
                    return Err(Error::InvalidParameter {
                        name,
                        value: format!("{} at [{i}]", fmt_g(l)),
                        requirement: "must be > 0 (inf for no limit)",
                    });
                }
            }
            Ok(v.to_vec())
        };
        for (name, g, positive) in [
            ("gamma_nominal", gains.nominal, true),
            ("gamma_a", gains.potential, false),
            ("eps", gains.eps, true),
        ] {
            crate::error::check_scalar(name, g, positive)?;
            if g < 0.0 {
                return Err(Error::InvalidParameter {
                    name,
                    value: fmt_g(g),
                    requirement: "must be >= 0",
                });
            }
        }
        let acceleration_max = limits("acceleration_max", acceleration_max)?;
        let has_acceleration = acceleration_max.iter().any(|a| a.is_finite());
        Ok(Self {
            velocity_max: limits("velocity_max", velocity_max)?,
            acceleration_max,
            has_acceleration,
            gains,
            p: vec![0.0; n],
            q: vec![0.0; n],
        })
    }

    /// The coupling of these limits, or none when neither is given.
    pub fn if_limited(
        n: usize,
        velocity_max: Option<&[f64]>,
        acceleration_max: Option<&[f64]>,
        gains: TemporalCouplingGains,
    ) -> Result<Option<Self>> {
        if velocity_max.is_none() && acceleration_max.is_none() {
            return Ok(None);
        }
        Self::new(n, velocity_max, acceleration_max, gains).map(Some)
    }

    pub fn velocity_max(&self) -> &[f64] {
        &self.velocity_max
    }
    pub fn acceleration_max(&self) -> &[f64] {
        &self.acceleration_max
    }
    /// Whether any acceleration is limited (then the next state's `h` is needed).
    pub fn limits_acceleration(&self) -> bool {
        self.has_acceleration
    }

    /// The smallest `tau >= tau_min` at which a state at rest (`z = 0`, derivative `h`) has its
    /// accelerations `h / tau^2` within the limits: the time scale to start a movement with.
    pub fn tau_at_rest(&self, tau_min: f64, h: &[f64]) -> f64 {
        let mut tau2 = 0.0f64;
        for (&h, &a) in h.iter().zip(&self.acceleration_max) {
            if a.is_finite() {
                tau2 = tau2.max(h.abs() / a);
            }
        }
        tau_min.max(tau2.sqrt())
    }

    /// The time scale of the next control period, `tau_{k+1} = tau + taud dt`.
    ///
    /// `z`, `h` are the scaled velocity and `tau dz/dt` at sample k (whose acceleration is
    /// `(h - taud z) / (tau tau_{k+1})`, the change of its velocity `z / tau` to the next one's),
    /// `z_next`, `h_next` those at sample k+1 (`h_next` is read only when accelerations are
    /// limited). `target` is the scale the clock should run at (the nominal tau, or phase
    /// stopping's `nominal (1 + ...)`): without acceleration limits a floor, met at once; with
    /// them approached as fast as the accelerations allow, the floor being `nominal`, so that a
    /// measurement that jumps cannot jump the command.
    #[allow(clippy::too_many_arguments)]
    pub fn next_tau(
        &mut self,
        tau: f64,
        nominal: f64,
        target: f64,
        z: &[f64],
        h: &[f64],
        z_next: &[f64],
        h_next: &[f64],
        dt: f64,
    ) -> f64 {
        let tau2 = tau * tau;
        // Lower bounds on tau_{k+1}: the nominal (or phase-stopped) scale and the velocities.
        let mut tau_floor = if self.has_acceleration {
            nominal
        } else {
            target
        };
        for (&z, &v) in z_next.iter().zip(&self.velocity_max) {
            // |z| / inf = 0 leaves an unlimited coordinate out.
            tau_floor = tau_floor.max(z.abs() / v);
        }
        let mut taud = self.gains.nominal * (target - tau);
        let (mut lo, mut hi) = (f64::NEG_INFINITY, f64::INFINITY);
        if self.has_acceleration {
            if target > tau {
                // Phase stopping slows the clock at once where the accelerations allow it.
                taud = (target - tau) / dt;
            }
            let g = &self.gains;
            let mut sigma = 0.0;
            for d in 0..z.len() {
                let a = self.acceleration_max[d];
                if !a.is_finite() {
                    continue;
                }
                let r = h[d] / (tau2 * a);
                // gamma_a = 0 is "off": no potential, not 0 x (r^2 / 0) = NaN at the limit.
                if g.potential > 0.0 {
                    sigma += r * r / (1.0 - r * r).max(g.potential * g.eps);
                }
                // |h - taud z| <= a tau (tau + taud dt), linear in taud on each side:
                // taud (z + c) >= h - a tau^2 and taud (z - c) <= h + a tau^2, c = a tau dt.
                let c = a * tau * dt;
                let (k, v) = (z[d] + c, h[d] - a * tau2);
                if k > 0.0 {
                    lo = lo.max(v / k);
                } else if k < 0.0 {
                    hi = hi.min(v / k);
                }
                let (k, v) = (z[d] - c, h[d] + a * tau2);
                if k > 0.0 {
                    hi = hi.min(v / k);
                } else if k < 0.0 {
                    lo = lo.max(v / k);
                }
            }
            if g.potential > 0.0 {
                taud += tau * g.potential * sigma;
            }
            tau_floor = tau_floor.max(self.feasible_tau(z_next, h_next));
        }
        // The acceleration's upper bound first, then every lower bound (they win).
        taud = taud.min(hi).max(lo).max((tau_floor - tau) / dt);
        // Rounding in `(tau_floor - tau) / dt * dt` must not leave tau_{k+1} a hair below a floor.
        (tau + taud * dt).max(tau_floor)
    }

    /// Whether accelerations `ydd` exceed their limits by more than rounding (1e-12 relative).
    pub fn exceeded(&self, ydd: &[f64]) -> bool {
        ydd.iter()
            .zip(&self.acceleration_max)
            .any(|(y, a)| y.abs() > a * (1.0 + 1e-12))
    }

    /// The smallest `tau` at which the acceleration bounds of a state `(z, h)` have a common
    /// solution `taud` (module docs): `max_{i,j} (p_i - p_j) / (q_i + q_j)` over pairs of moving
    /// coordinates with `p = h / z`, `q = a / |z|`, and `|h| / a` for those at rest.
    fn feasible_tau(&mut self, z: &[f64], h: &[f64]) -> f64 {
        let mut tau2 = 0.0f64;
        // Coordinates that take part in the pairs: moving and limited (q = 0 leaves one out;
        // as the second of a pair, p = +inf does, its gap -inf never winning).
        for d in 0..z.len() {
            let a = self.acceleration_max[d];
            if !a.is_finite() {
                (self.p[d], self.q[d]) = (f64::INFINITY, 0.0);
            } else if z[d] == 0.0 {
                tau2 = tau2.max(h[d].abs() / a);
                (self.p[d], self.q[d]) = (f64::INFINITY, 0.0);
            } else {
                self.p[d] = h[d] / z[d];
                self.q[d] = a / z[d].abs();
            }
        }
        let (p, q) = (&self.p[..z.len()], &self.q[..z.len()]);
        for (&p_i, &q_i) in p.iter().zip(q) {
            if q_i == 0.0 {
                continue;
            }
            // Every j, without branches to mispredict: j = i has gap 0, which never wins.
            for (&p_j, &q_j) in p.iter().zip(q) {
                let (gap, room) = (p_i - p_j, q_i + q_j);
                // gap / room > tau2, without a division for the pairs that lose.
                if gap > tau2 * room {
                    tau2 = gap / room;
                }
            }
        }
        tau2.sqrt()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn coupling(v: &[f64], a: Option<&[f64]>) -> TemporalCoupling {
        TemporalCoupling::new(v.len(), Some(v), a, TemporalCouplingGains::default()).unwrap()
    }

    #[test]
    fn the_next_velocity_is_within_its_limit() {
        let mut tc = coupling(&[1.0, 2.0], None);
        let z_next = [3.0, -10.0];
        let tau = tc.next_tau(
            1.0, 1.0, 1.0, &[0.0; 2], &[0.0; 2], &z_next, &[0.0; 2], 1e-3,
        );
        assert!((tau - 5.0).abs() < 1e-12);
        assert!(z_next[1].abs() / tau <= 2.0 * (1.0 + 1e-15));
    }

    #[test]
    fn the_acceleration_bounds_are_met_when_feasible() {
        let a = [2.0, 3.0];
        let mut tc = coupling(&[f64::INFINITY; 2], Some(&a));
        let (z, h) = ([0.5, -0.2], [4.0, 1.0]);
        let tau = 1.2;
        let next = tc.next_tau(tau, 1.0, 1.0, &z, &h, &z, &h, 1e-3);
        let taud = (next - tau) / 1e-3;
        for d in 0..2 {
            let acc = (h[d] - taud * z[d]) / (tau * next);
            assert!(acc.abs() <= a[d] * (1.0 + 1e-12), "{d}: {acc}");
        }
    }

    #[test]
    fn feasibility_is_the_smallest_tau_with_a_common_taud() {
        let a = [1.0, 1.0, 2.0];
        let mut tc = coupling(&[f64::INFINITY; 3], Some(&a));
        let (z, h) = ([0.3, -0.7, 0.1], [2.0, 3.0, -1.5]);
        let tau = tc.feasible_tau(&z, &h);
        let interval = |tau: f64| {
            let (mut lo, mut hi) = (f64::NEG_INFINITY, f64::INFINITY);
            for d in 0..3 {
                lo = lo.max(h[d] / z[d] - a[d] * tau * tau / z[d].abs());
                hi = hi.min(h[d] / z[d] + a[d] * tau * tau / z[d].abs());
            }
            hi - lo
        };
        assert!(interval(tau) >= -1e-9);
        assert!(interval(tau * 0.999) < 0.0);
    }

    /// `feasible_tau` as its docs say it, pair by pair with the left-out coordinates skipped.
    fn feasible_tau_by_pairs(a: &[f64], z: &[f64], h: &[f64]) -> f64 {
        let n = z.len();
        let taking_part = |d: usize| a[d].is_finite() && z[d] != 0.0;
        let mut tau2 = (0..n)
            .filter(|&d| a[d].is_finite() && z[d] == 0.0)
            .fold(0.0f64, |t, d| t.max(h[d].abs() / a[d]));
        for i in (0..n).filter(|&i| taking_part(i)) {
            for j in (0..n).filter(|&j| j != i && taking_part(j)) {
                let (p_i, p_j) = (h[i] / z[i], h[j] / z[j]);
                let (gap, room) = (p_i - p_j, a[i] / z[i].abs() + a[j] / z[j].abs());
                if gap > tau2 * room {
                    tau2 = gap / room;
                }
            }
        }
        tau2.sqrt()
    }

    proptest::proptest! {
        #[test]
        fn feasibility_gives_the_pairwise_bound_bits(
            rows in proptest::collection::vec(
                (0u8..4, -3.0f64..3.0, -50.0f64..50.0, 0.1f64..30.0), 1..9,
            ),
        ) {
            // Some coordinates at rest (z = 0), some unlimited (a = inf).
            let z: Vec<f64> = rows.iter().map(|r| if r.0 == 0 { 0.0 } else { r.1 }).collect();
            let h: Vec<f64> = rows.iter().map(|r| r.2).collect();
            let a: Vec<f64> = rows.iter().map(|r| if r.0 == 1 { f64::INFINITY } else { r.3 }).collect();
            let mut tc = coupling(&vec![f64::INFINITY; z.len()], Some(&a));
            let want = feasible_tau_by_pairs(&a, &z, &h);
            proptest::prop_assert_eq!(tc.feasible_tau(&z, &h).to_bits(), want.to_bits());
            // Again, with the scratch of the last call in place.
            proptest::prop_assert_eq!(tc.feasible_tau(&z, &h).to_bits(), want.to_bits());
        }
    }

    #[test]
    fn bad_limits_are_refused() {
        let g = TemporalCouplingGains::default();
        assert!(TemporalCoupling::new(2, Some(&[1.0]), None, g).is_err());
        assert!(TemporalCoupling::new(1, Some(&[0.0]), None, g).is_err());
        assert!(TemporalCoupling::new(1, None, Some(&[f64::NAN]), g).is_err());
        let bad = TemporalCouplingGains { nominal: -1.0, ..g };
        assert!(TemporalCoupling::new(1, Some(&[1.0]), None, bad).is_err());
    }
}
