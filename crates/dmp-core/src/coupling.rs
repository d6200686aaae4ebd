//! Coupling terms of the online DMP (docs/method.md §2.5.5): accelerations added to the right side
//! of eq. 1, `tau dz/dt = alpha_z (beta_z (g - y) - z) + f(x) + C`, as Ijspeert et al. (Neural
//! Computation 2013, §3) add their coupling terms. Each depends only on the position and the
//! scaled velocity `z = tau yd`, never on `tau`, so a stepper that slows its clock (phase
//! stopping, temporal coupling) still traces one path.
//!
//! * [`PositionLimits`]: a repulsion from `position_min` / `position_max` inside a band of width
//!   `rho` next to each limit,
//!   `C = +- kappa alpha_z beta_z rho (rho / d - 1)^2` (`d` the distance to the limit), the
//!   negative gradient of `U(d) = kappa alpha_z beta_z rho^2 (rho / d + 2 ln(d / rho) - d / rho)`,
//!   which is 0 with zero slope at the band's edge and grows without bound at the limit.
//! * [`SphereObstacle`]: the dynamic potential field of Park, Hoffmann, Pastor and Schaal,
//!   "Movement reproduction and obstacle avoidance with dynamic movement primitives and potential
//!   fields" (Humanoids 2008), with the distance measured to the sphere's surface.

use crate::error::{Error, Result, fmt_g};

/// Where the repulsion's band ends inside a limit: below `DISTANCE_FLOOR * rho` the repulsion is
/// continued by its tangent, so that a state that numerically reached or crossed a limit is
/// pushed back by a finite force instead of an infinite one.
const DISTANCE_FLOOR: f64 = 0.02;

/// The default band as a fraction of the range `max - min`.
pub const DEFAULT_MARGIN_FRACTION: f64 = 0.05;

/// Repulsion from per-coordinate position limits (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct PositionLimits {
    min: Vec<f64>,
    max: Vec<f64>,
    margin: Vec<f64>,
    /// `kappa alpha_z beta_z`.
    stiffness: f64,
}

impl PositionLimits {
    /// `min`, `max` per coordinate (`-inf` / `+inf` for none); `margin` the band `rho` per
    /// coordinate, or `None` for [`DEFAULT_MARGIN_FRACTION`] of the range (then every limited
    /// coordinate needs both limits); `gain` is `kappa`, `spring` is `alpha_z beta_z`.
    pub fn new(
        min: &[f64],
        max: &[f64],
        margin: Option<&[f64]>,
        gain: f64,
        spring: f64,
    ) -> Result<Self> {
        let n = min.len();
        let shape = |name: &'static str, len: usize| Error::Shape {
            name,
            expected: format!("({n},), like position_min"),
            got: format!("({len},)"),
        };
        if max.len() != n {
            return Err(shape("position_max", max.len()));
        }
        if let Some(m) = margin
            && m.len() != n
        {
            return Err(shape("limit_margin", m.len()));
        }
        crate::error::check_scalar("limit_gain", gain, true)?;
        let mut bands = Vec::with_capacity(n);
        for d in 0..n {
            let (lo, hi) = (min[d], max[d]);
            if lo.is_nan() || hi.is_nan() || lo == f64::INFINITY || hi == f64::NEG_INFINITY {
                return Err(Error::InvalidParameter {
                    name: "position_min/position_max",
                    value: format!("[{}, {}] at [{d}]", fmt_g(lo), fmt_g(hi)),
                    requirement: "each limit must be a number (-inf / inf for none)",
                });
            }
            if lo >= hi {
                return Err(Error::InvalidParameter {
                    name: "position_min/position_max",
                    value: format!("[{}, {}] at [{d}]", fmt_g(lo), fmt_g(hi)),
                    requirement: "position_min must be below position_max",
                });
            }
            let limited = lo.is_finite() || hi.is_finite();
            let rho = match margin {
                Some(m) => m[d],
                None if !limited => 0.0,
                None if lo.is_finite() && hi.is_finite() => DEFAULT_MARGIN_FRACTION * (hi - lo),
                None => {
                    return Err(Error::InvalidParameter {
                        name: "limit_margin",
                        value: format!("None for coordinate {d}"),
                        requirement: "must be given for a coordinate limited on one side only \
                                      (the default is 5 % of the range)",
                    });
                }
            };
            if limited && !(rho.is_finite() && rho > 0.0) {
                return Err(Error::InvalidParameter {
                    name: "limit_margin",
                    value: format!("{} at [{d}]", fmt_g(rho)),
                    requirement: "must be finite and > 0",
                });
            }
            if lo.is_finite() && hi.is_finite() && 2.0 * rho > hi - lo {
                return Err(Error::InvalidParameter {
                    name: "limit_margin",
                    value: format!("{} at [{d}]", fmt_g(rho)),
                    requirement: "the two bands must not overlap: at most half of max - min",
                });
            }
            bands.push(rho);
        }
        Ok(Self {
            min: min.to_vec(),
            max: max.to_vec(),
            margin: bands,
            stiffness: gain * spring,
        })
    }

    pub fn min(&self) -> &[f64] {
        &self.min
    }
    pub fn max(&self) -> &[f64] {
        &self.max
    }
    pub fn margin(&self) -> &[f64] {
        &self.margin
    }

    /// Whether `y` is strictly inside every limit.
    pub fn contains(&self, y: &[f64]) -> Option<usize> {
        (0..self.min.len()).find(|&d| !(y[d] > self.min[d] && y[d] < self.max[d]))
    }

    /// The repulsion on coordinate `d` at position `y` and its derivative `dC/dy` (<= 0), or
    /// `None` outside both bands.
    #[inline]
    pub fn repulsion(&self, d: usize, y: f64) -> Option<(f64, f64)> {
        let rho = self.margin[d];
        let below = y - self.min[d];
        let above = self.max[d] - y;
        // sign: +1 pushes up (from the lower limit), -1 down.
        let (dist, sign) = if below < rho {
            (below, 1.0)
        } else if above < rho {
            (above, -1.0)
        } else {
            return None;
        };
        let floor = DISTANCE_FLOOR * rho;
        let k = self.stiffness * rho;
        // C(dist) = k (rho/dist - 1)^2 and dC/d(dist) = -2 k rho (rho/dist - 1) / dist^2;
        // d(dist)/dy = sign, so dC/dy = sign * sign * dC/d(dist) <= 0 on both sides.
        let at = dist.max(floor);
        let r = rho / at - 1.0;
        let slope = -2.0 * k * rho * r / (at * at);
        let value = k * r * r + slope * (dist - at);
        Some((sign * value, slope))
    }
}

/// A sphere (radius 0: a point) in the position space of a Cartesian DMP.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SphereObstacle {
    pub center: [f64; 3],
    pub radius: f64,
}

/// The gains of the dynamic potential `U = lambda (-cos theta)^beta |z| / p` (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ObstacleGains {
    /// `lambda`, in (units of position)^2.
    pub lambda: f64,
    /// `beta >= 1`: how sharply the field narrows to headings straight at the obstacle.
    pub beta: f64,
}

impl Default for ObstacleGains {
    /// `lambda = 0.1 m^2`, `beta = 2` (docs/method.md §2.5.5: chosen on a 0.4 m reach past spheres
    /// of 2-5 cm on its path).
    fn default() -> Self {
        Self {
            lambda: 0.1,
            beta: 2.0,
        }
    }
}

/// Clearances below this (in units of position) are taken as this: the field stays finite for a
/// state that touched the surface.
const CLEARANCE_FLOOR: f64 = 1e-6;

/// The bound on the obstacles' push, relative to the DMP's damping: `|C| <= OBSTACLE_PUSH_MAX
/// alpha_z |z|` in total, so the acceleration it adds is at most `OBSTACLE_PUSH_MAX alpha_z
/// |yd| / tau`. Park et al.'s field grows as `1 / p^2` towards the surface and without bound in
/// `lambda`: near a sphere, or with a large gain, it would command accelerations and velocities
/// no robot takes. 16 is twice the largest push of the reaches past spheres that the default
/// gains were chosen on (docs/method.md §2.5.5), which the bound leaves as they were.
pub const OBSTACLE_PUSH_MAX: f64 = 16.0;
/// The most by which the obstacles' field may lengthen `z`, relative to `alpha_z`: half the
/// DMP's damping, so that it can never speed a movement up without bound.
pub const OBSTACLE_SPEED_UP_MAX: f64 = 0.5;

/// A heading whose part across the direction to a sphere's centre is below this fraction of the
/// speed is steered as if it were this fraction: straight at the centre the steering term
/// vanishes (a saddle of the field), and the movement would stop in front of the sphere instead
/// of going round. Below the smallest crossing part of the reaches the gains were chosen on, so
/// that those are unchanged.
const HEAD_ON: f64 = 1e-4;
/// A crossing part below this fraction of the speed is rounding, its direction noise: the side
/// to pass on is then `SphereObstacle::side`'s, fixed.
const HEAD_ON_NOISE: f64 = 1e-9;

impl SphereObstacle {
    pub fn validate(&self, index: usize) -> Result<()> {
        if self.center.iter().any(|c| !c.is_finite()) {
            return Err(Error::NonFinite {
                name: "obstacles",
                location: format!("[{index}]"),
                value: self
                    .center
                    .iter()
                    .copied()
                    .find(|c| !c.is_finite())
                    .unwrap_or(0.0),
            });
        }
        if !(self.radius.is_finite() && self.radius >= 0.0) {
            return Err(Error::InvalidParameter {
                name: "obstacles",
                value: format!("radius {} at [{index}]", fmt_g(self.radius)),
                requirement: "radii must be finite and >= 0",
            });
        }
        Ok(())
    }

    /// The distance from `p` to the surface (negative inside).
    pub fn clearance(&self, p: &[f64; 3]) -> f64 {
        let r = [0, 1, 2].map(|i| p[i] - self.center[i]);
        (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt() - self.radius
    }

    /// Whether `p` is inside the sphere or on its surface (where the field is not defined).
    pub fn holds(&self, p: &[f64; 3]) -> bool {
        // NaN (a position not a number) counts as inside.
        self.clearance(p).partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater)
    }

    /// The side on which a movement headed straight at the centre passes the sphere, from `n`,
    /// the unit vector from the centre to the position: the world axis least aligned with `n`
    /// (x before y before z on ties), made perpendicular to `n`. Fixed, so that the same
    /// movement always goes round the same way.
    fn side(n: &[f64; 3]) -> [f64; 3] {
        let mut axis = 0;
        for i in 1..3 {
            if n[i].abs() < n[axis].abs() {
                axis = i;
            }
        }
        let mut e = [0, 1, 2].map(|i| -n[axis] * n[i]);
        e[axis] += 1.0;
        let norm = (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt();
        e.map(|c| c / norm)
    }

    /// Adds `-grad_p U` of Park et al.'s dynamic potential to `out`, at most `bound` long and
    /// lengthening `z` at most by `speed_up z` (its part along `z` within `speed_up |z|`), and
    /// returns the field's rate `lambda (beta + 1) |cos theta|^(beta - 1) / p^2` (a bound on how
    /// fast it changes with `z`, per unit of the scaled time: the stepper keeps its step below
    /// the inverse), at most `(beta + 1) bound / |z|`, the rate of the bounded field.
    ///
    /// With `r = p - c`, `d = |r|`, `n = r / d`, clearance `p = d - radius` and
    /// `cos theta = z . n / |z|`, the field is active only while approaching (`cos theta < 0`):
    ///
    /// ```text
    /// -grad U = lambda (-cos theta)^(beta-1) [ beta z_perp / (d p) + (-cos theta) |z| n / p^2 ]
    /// ```
    ///
    /// where `z_perp = z - (z . n) n`: the first term turns the velocity away from the obstacle,
    /// the second pushes straight away from it, both growing as the clearance shrinks. A
    /// `z_perp` shorter than `HEAD_ON |z|` (1e-4) is taken at that length (in its own direction, or
    /// the fixed side's if it is rounding), so that a heading straight at the centre
    /// is turned.
    #[inline]
    pub fn add_repulsion(
        &self,
        gains: &ObstacleGains,
        pos: &[f64; 3],
        z: &[f64; 3],
        bound: f64,
        speed_up: f64,
        out: &mut [f64; 3],
    ) -> f64 {
        let r = [0, 1, 2].map(|i| pos[i] - self.center[i]);
        let d = (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt();
        let speed = (z[0] * z[0] + z[1] * z[1] + z[2] * z[2]).sqrt();
        if d == 0.0 || speed == 0.0 {
            return 0.0;
        }
        let n = r.map(|c| c / d);
        let along = z[0] * n[0] + z[1] * n[1] + z[2] * n[2];
        let cos = along / speed;
        if cos >= 0.0 {
            return 0.0;
        }
        let p = (d - self.radius).max(CLEARANCE_FLOOR);
        let m = -cos;
        let scale = gains.lambda * m.powf(gains.beta - 1.0);
        let turn = gains.beta / (d * p);
        let push = m * speed / (p * p);
        let mut across = [0, 1, 2].map(|i| z[i] - along * n[i]);
        let length = (across[0] * across[0] + across[1] * across[1] + across[2] * across[2]).sqrt();
        let floor = HEAD_ON * speed;
        if length < floor {
            let dir = if length > HEAD_ON_NOISE * speed {
                across.map(|c| c / length)
            } else {
                Self::side(&n)
            };
            across = dir.map(|c| c * floor);
        }
        let mut field = [0, 1, 2].map(|i| turn * across[i] + push * n[i]);
        // The steering term lengthens `z` (by `turn |z_perp|^2`) where the braking one is weaker,
        // grazing a sphere: with a large gain or near the surface that speeds the movement up
        // exponentially. Its part along `z` is kept within `speed_up` |z|, so that the field
        // never undoes the DMP's damping (`speed_up < alpha_z`).
        let gain = (field[0] * z[0] + field[1] * z[1] + field[2] * z[2]) / speed;
        if gain > speed_up * speed / scale {
            let k = (gain - speed_up * speed / scale) / speed;
            field = [0, 1, 2].map(|i| field[i] - k * z[i]);
        }
        let size = (field[0] * field[0] + field[1] * field[1] + field[2] * field[2]).sqrt();
        // `scale * size` may overflow for a huge gain: compared, never multiplied out then.
        if size <= bound / scale {
            for i in 0..3 {
                out[i] += scale * field[i];
            }
        } else {
            for i in 0..3 {
                out[i] += field[i] * (bound / size);
            }
        }
        let rate = scale * (gains.beta + 1.0) / (p * p);
        rate.min((gains.beta + 1.0) * bound / speed)
    }
}

impl ObstacleGains {
    pub fn validate(&self) -> Result<()> {
        crate::error::check_scalar("obstacle_gain", self.lambda, true)?;
        crate::error::check_scalar("obstacle_beta", self.beta, true)?;
        if self.beta < 1.0 {
            return Err(Error::InvalidParameter {
                name: "obstacle_beta",
                value: fmt_g(self.beta),
                requirement: "must be >= 1 (the field's steering term has (-cos theta)^(beta-1))",
            });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_repulsion_is_the_gradient_of_its_potential() {
        let lim = PositionLimits::new(&[-1.0], &[2.0], Some(&[0.2]), 1.5, 576.0).unwrap();
        let (k, rho) = (1.5 * 576.0, 0.2);
        let u = |d: f64| k * rho * rho * (rho / d + 2.0 * (d / rho).ln() - d / rho);
        for &y in &[-0.95, -0.9, -0.85, 1.81, 1.9, 1.97] {
            let (c, slope) = lim.repulsion(0, y).unwrap();
            let e = 1e-6;
            // U as a function of y: distance to the nearer limit.
            let uy = |y: f64| if y < 0.5 { u(y + 1.0) } else { u(2.0 - y) };
            let grad = (uy(y + e) - uy(y - e)) / (2.0 * e);
            assert!(
                (c + grad).abs() < 1e-5 * c.abs().max(1.0),
                "y={y}: {c} vs {}",
                -grad
            );
            let dc = (lim.repulsion(0, y + e).unwrap().0 - lim.repulsion(0, y - e).unwrap().0)
                / (2.0 * e);
            assert!((slope - dc).abs() < 1e-5 * dc.abs().max(1.0));
            assert!(slope < 0.0);
        }
        assert!(lim.repulsion(0, 0.5).is_none());
        // Zero at the band's edge, pushing inwards inside it, finite past the limit.
        assert!(lim.repulsion(0, -0.8 - 1e-12).unwrap().0.abs() < 1e-6);
        assert!(lim.repulsion(0, -0.9).unwrap().0 > 0.0);
        assert!(lim.repulsion(0, 1.9).unwrap().0 < 0.0);
        assert!(lim.repulsion(0, 2.1).unwrap().0.is_finite());
        assert!(lim.repulsion(0, 2.1).unwrap().0 < lim.repulsion(0, 1.999).unwrap().0);
    }

    #[test]
    fn limits_are_validated() {
        assert!(PositionLimits::new(&[0.0], &[1.0, 2.0], None, 1.0, 1.0).is_err());
        assert!(PositionLimits::new(&[1.0], &[0.0], None, 1.0, 1.0).is_err());
        assert!(PositionLimits::new(&[0.0], &[f64::INFINITY], None, 1.0, 1.0).is_err());
        assert!(PositionLimits::new(&[0.0], &[f64::INFINITY], Some(&[0.1]), 1.0, 1.0).is_ok());
        assert!(PositionLimits::new(&[0.0], &[1.0], Some(&[0.6]), 1.0, 1.0).is_err());
        let free = PositionLimits::new(&[f64::NEG_INFINITY], &[f64::INFINITY], None, 1.0, 1.0);
        assert!(free.unwrap().repulsion(0, 1e300).is_none());
    }

    #[test]
    fn the_obstacle_field_is_the_negative_gradient_of_the_dynamic_potential() {
        let ob = SphereObstacle {
            center: [0.1, -0.2, 0.3],
            radius: 0.05,
        };
        let g = ObstacleGains {
            lambda: 0.3,
            beta: 2.5,
        };
        let z: [f64; 3] = [0.4, 0.7, -0.9];
        let pos = [-0.2, -0.5, 0.65];
        let u = |p: [f64; 3]| {
            let r = [0, 1, 2].map(|i| p[i] - ob.center[i]);
            let d = (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt();
            let sp = (z[0] * z[0] + z[1] * z[1] + z[2] * z[2]).sqrt();
            let cos = (z[0] * r[0] + z[1] * r[1] + z[2] * r[2]) / (d * sp);
            if cos >= 0.0 {
                0.0
            } else {
                g.lambda * (-cos).powf(g.beta) * sp / (d - ob.radius)
            }
        };
        let mut out = [0.0; 3];
        let rate = ob.add_repulsion(&g, &pos, &z, f64::INFINITY, f64::INFINITY, &mut out);
        assert!(rate > 0.0);
        for i in 0..3 {
            let e = 1e-7;
            let (mut a, mut b) = (pos, pos);
            a[i] += e;
            b[i] -= e;
            let grad = (u(a) - u(b)) / (2.0 * e);
            assert!(
                (out[i] + grad).abs() < 1e-6 * grad.abs().max(1.0),
                "{i}: {} vs {}",
                out[i],
                -grad
            );
        }
        // Moving away: no force.
        let mut none = [0.0; 3];
        assert_eq!(
            ob.add_repulsion(
                &g,
                &pos,
                &z.map(|c| -c),
                f64::INFINITY,
                f64::INFINITY,
                &mut none
            ),
            0.0
        );
        assert_eq!(none, [0.0; 3]);
    }
}
