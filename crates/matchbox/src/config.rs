//! Constants of the matchbox flip-up scene (docs/method.md §8.3) and the module's error type.
//!
//! Geometry, in SI units, z up, the table top at z = 0 and its edge at x = 0 (the table is x < 0):
//! the box (36 mm along x, 53 mm along y, 16 mm tall) lies flat with its 53 mm edge parallel to
//! the table edge, overhanging it by `overhang`. A spherical fingertip under the overhang strikes
//! upward; the box pivots about its bottom edge on the table (x = overhang - 36 mm, z = 0) and,
//! with the right speed, comes to rest standing on its 53 x 16 mm face, 36 mm tall.

use thiserror::Error;

/// Errors of the matchbox simulation. Every variant is bad input: the simulation itself cannot
/// fail once its input is valid.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum Error {
    #[error("{0}")]
    InvalidConfig(String),
    #[error("fingertip trajectory rejected: {0}")]
    InvalidTrajectory(String),
}

pub type Result<T> = std::result::Result<T, Error>;

/// Physical and numerical parameters. The defaults are assumptions, not measurements (the paper
/// gives none): a 15 g cardboard box on a smooth table (friction 0.3, restitution 0.3).
///
/// Calibration note: with friction 0.45 and restitution 0.05 (the plan in docs/method.md §8.3) this
/// Rapier scene stands the box up only for strike durations within about +-1.5 % of 0.099 s, and
/// not contiguously; with 0.3 / 0.3 the upright window is contiguous and spans strike durations
/// 0.097-0.113 s (peak fingertip speed 0.70-0.81 m/s, +-7 %), like the +-6 % the pymunk
/// prototype of docs/method.md §8.3 found. `cargo run --release -p matchbox --example matchbox_sweep`
/// prints the sweep.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MatchboxConfig {
    /// Box extent along x (the tipping direction), y (along the table edge) and z (height), m.
    pub box_size: [f64; 3],
    /// Box mass, kg (uniform density).
    pub box_mass: f64,
    /// How far the box sticks out over the table edge, m.
    pub overhang: f64,
    /// Coulomb friction coefficient of every contact.
    pub friction: f64,
    /// Restitution of every contact.
    pub restitution: f64,
    /// Fingertip sphere radius, m.
    pub finger_radius: f64,
    /// Physics step, s.
    pub dt: f64,
    /// Solver iterations per step.
    pub solver_iterations: usize,
    /// How long to simulate after the fingertip trajectory ends, s.
    pub settle_time: f64,
    /// Time after first reaching upright at which a flip-over is measured (eq. 18's Delta t), s.
    pub delta_t: f64,
    /// Upright means |phi - pi/2| <= upright_tolerance for the last `upright_hold` seconds.
    pub upright_tolerance: f64,
    pub upright_hold: f64,
    /// Fingertip workspace: x and z ranges its centre may visit, m.
    pub workspace_x: [f64; 2],
    pub workspace_z: [f64; 2],
}

impl Default for MatchboxConfig {
    fn default() -> Self {
        Self {
            box_size: [0.036, 0.053, 0.016],
            box_mass: 0.015,
            overhang: 0.014,
            friction: 0.3,
            restitution: 0.3,
            finger_radius: 0.006,
            dt: 1.0 / 1000.0,
            solver_iterations: 8,
            settle_time: 2.0,
            delta_t: 0.05,
            upright_tolerance: 0.1,
            upright_hold: 0.5,
            workspace_x: [-0.05, 0.10],
            workspace_z: [-0.10, 0.05],
        }
    }
}

/// Thickness of the simulated table slab, m.
pub const TABLE_THICKNESS: f64 = 0.04;
/// Height of the floor that catches a box knocked off the table, m.
pub const FLOOR_Z: f64 = -0.30;

impl MatchboxConfig {
    pub fn validate(&self) -> Result<()> {
        let positive = [
            ("box_size[0]", self.box_size[0]),
            ("box_size[1]", self.box_size[1]),
            ("box_size[2]", self.box_size[2]),
            ("box_mass", self.box_mass),
            ("finger_radius", self.finger_radius),
            ("dt", self.dt),
            ("settle_time", self.settle_time),
            ("delta_t", self.delta_t),
            ("upright_tolerance", self.upright_tolerance),
            ("upright_hold", self.upright_hold),
        ];
        for (name, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return Err(Error::InvalidConfig(format!(
                    "{name} = {v} must be finite and > 0"
                )));
            }
        }
        for (name, v) in [
            ("friction", self.friction),
            ("restitution", self.restitution),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(Error::InvalidConfig(format!(
                    "{name} = {v} must be finite and >= 0"
                )));
            }
        }
        if !(self.overhang > 0.0 && self.overhang < self.box_size[0] / 2.0) {
            return Err(Error::InvalidConfig(format!(
                "overhang = {} must be in (0, {}): the box must rest on the table",
                self.overhang,
                self.box_size[0] / 2.0
            )));
        }
        if self.dt > 0.005 {
            return Err(Error::InvalidConfig(format!(
                "dt = {} is too coarse for a strike (max 0.005 s)",
                self.dt
            )));
        }
        if self.solver_iterations == 0 {
            return Err(Error::InvalidConfig(
                "solver_iterations must be at least 1".into(),
            ));
        }
        Ok(())
    }

    /// x of the pivot edge (the box's bottom edge that stays on the table).
    pub fn pivot_x(&self) -> f64 {
        self.overhang - self.box_size[0]
    }

    /// Where a strike starts and ends by default: 40 mm below the table top to 2 mm above it, at
    /// `finger_radius` inside the box's outer edge (docs/method.md §8.3).
    pub fn default_strike(&self) -> ([f64; 2], [f64; 2]) {
        let x = self.overhang - self.finger_radius;
        ([x, -0.040], [x, 0.002])
    }
}
