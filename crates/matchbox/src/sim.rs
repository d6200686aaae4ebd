//! The Rapier 3-D scene and one episode of it.
//!
//! Rapier's math is f32 and glam; this module converts at its edge, so the rest of the crate and
//! the bindings see f64 slices only.

use std::f64::consts::PI;

use rapier3d::prelude::*;

use super::config::{Error, FLOOR_Z, MatchboxConfig, Result, TABLE_THICKNESS};
use super::measure::{Measures, measure, unwrap};

/// The longest episode (trajectory plus settling) one call may simulate, s: a bound on memory and
/// time for a mistyped input (a real strike lasts about 0.1 s).
pub const MAX_SIMULATED_TIME: f64 = 60.0;

/// A fingertip path: centre positions (x, z) in m at increasing times t in s (y is fixed at 0,
/// the middle of the box). After the last sample the fingertip holds still.
#[derive(Debug, Clone, Copy)]
pub struct FingerPath<'a> {
    pub t: &'a [f64],
    pub x: &'a [f64],
    pub z: &'a [f64],
}

/// Everything one episode measured.
#[derive(Debug, Clone, PartialEq)]
pub struct Episode {
    /// Physics time of each sample, s (one per step, from 0).
    pub t: Vec<f64>,
    /// Tilt phi about the pivot axis, unwrapped and clipped to [0, pi], rad.
    pub phi: Vec<f64>,
    /// Height of the box's centre, m.
    pub box_z: Vec<f64>,
    pub measures: Measures,
}

impl FingerPath<'_> {
    fn at(&self, time: f64) -> (f64, f64) {
        let t = self.t;
        let j = t.partition_point(|&s| s <= time);
        if j == 0 {
            return (self.x[0], self.z[0]);
        }
        if j >= t.len() {
            return (self.x[t.len() - 1], self.z[t.len() - 1]);
        }
        let w = (time - t[j - 1]) / (t[j] - t[j - 1]);
        (
            self.x[j - 1] + w * (self.x[j] - self.x[j - 1]),
            self.z[j - 1] + w * (self.z[j] - self.z[j - 1]),
        )
    }

    /// Every reason the path is unusable, or empty. Checked at the physics step, between samples
    /// too, because the fingertip moves along the interpolated path.
    pub fn problems(&self, cfg: &MatchboxConfig) -> Vec<String> {
        let (t, x, z) = (self.t, self.x, self.z);
        let mut out = Vec::new();
        if t.len() != x.len() || t.len() != z.len() {
            out.push(format!(
                "t, x and z have {}, {} and {} samples",
                t.len(),
                x.len(),
                z.len()
            ));
            return out;
        }
        if t.len() < 2 {
            out.push(format!("{} sample(s): at least 2 are needed", t.len()));
            return out;
        }
        for (name, v) in [("t", t), ("x", x), ("z", z)] {
            if let Some(j) = v.iter().position(|a| !a.is_finite()) {
                out.push(format!("{name}[{j}] is {}", v[j]));
            }
        }
        if !out.is_empty() {
            return out;
        }
        if let Some(j) = (1..t.len()).find(|&j| t[j] <= t[j - 1]) {
            out.push(format!(
                "t must be strictly increasing: t[{j}] = {} after {}",
                t[j],
                t[j - 1]
            ));
            return out;
        }
        let duration = t[t.len() - 1] - t[0];
        if duration + cfg.settle_time > MAX_SIMULATED_TIME {
            out.push(format!(
                "lasts {duration} s; with {} s of settling that exceeds the {MAX_SIMULATED_TIME} s an episode may simulate",
                cfg.settle_time
            ));
            return out;
        }
        let r = cfg.finger_radius;
        let steps = (duration / cfg.dt).ceil() as usize;
        let mut outside = None;
        let mut in_table = None;
        for k in 0..=steps.max(1) {
            let time = (t[0] + k as f64 * cfg.dt).min(t[t.len() - 1]);
            let (px, pz) = self.at(time);
            let in_workspace = (cfg.workspace_x[0]..=cfg.workspace_x[1]).contains(&px)
                && (cfg.workspace_z[0]..=cfg.workspace_z[1]).contains(&pz);
            if outside.is_none() && !in_workspace {
                outside = Some((time, px, pz));
            }
            // Distance from the centre to the table slab {x <= 0, -TABLE_THICKNESS <= z <= 0}.
            let dx = px.max(0.0);
            let dz = (-TABLE_THICKNESS - pz).max(pz).max(0.0);
            let dist = (dx * dx + dz * dz).sqrt();
            if in_table.is_none() && dist < r - 1e-9 {
                in_table = Some((time, px, pz));
            }
        }
        if let Some((time, px, pz)) = outside {
            out.push(format!(
                "the fingertip leaves the workspace x in [{}, {}] m, z in [{}, {}] m: ({px:.4}, {pz:.4}) m at t = {time:.4} s",
                cfg.workspace_x[0], cfg.workspace_x[1], cfg.workspace_z[0], cfg.workspace_z[1]
            ));
        }
        if let Some((time, px, pz)) = in_table {
            out.push(format!(
                "the fingertip (radius {r} m) passes through the table at ({px:.4}, {pz:.4}) m, t = {time:.4} s"
            ));
        }
        out
    }
}

fn v(x: f64, y: f64, z: f64) -> Vector {
    Vector::new(x as f32, y as f32, z as f32)
}

/// Simulates one strike and measures it. Deterministic: Rapier's enhanced determinism, a fixed
/// step, and the same insertion order every time.
pub fn simulate(path: &FingerPath<'_>, cfg: &MatchboxConfig) -> Result<Episode> {
    cfg.validate()?;
    let problems = path.problems(cfg);
    if !problems.is_empty() {
        return Err(Error::InvalidTrajectory(problems.join("; ")));
    }
    let [bx, by, bz] = cfg.box_size;
    let mut bodies = RigidBodySet::new();
    let mut colliders = ColliderSet::new();
    let surface = |b: ColliderBuilder| {
        b.friction(cfg.friction as f32)
            .restitution(cfg.restitution as f32)
    };

    let table =
        bodies.insert(RigidBodyBuilder::fixed().translation(v(-0.25, 0.0, -TABLE_THICKNESS / 2.0)));
    colliders.insert_with_parent(
        surface(ColliderBuilder::cuboid(
            0.25,
            0.25,
            (TABLE_THICKNESS / 2.0) as f32,
        )),
        table,
        &mut bodies,
    );
    let floor = bodies.insert(RigidBodyBuilder::fixed().translation(v(0.0, 0.0, FLOOR_Z - 0.01)));
    colliders.insert_with_parent(
        surface(ColliderBuilder::cuboid(1.0, 1.0, 0.01)),
        floor,
        &mut bodies,
    );

    let box_x0 = cfg.overhang - bx / 2.0;
    let matchbox = bodies.insert(
        RigidBodyBuilder::dynamic()
            .translation(v(box_x0, 0.0, bz / 2.0))
            .ccd_enabled(true),
    );
    colliders.insert_with_parent(
        surface(ColliderBuilder::cuboid(
            (bx / 2.0) as f32,
            (by / 2.0) as f32,
            (bz / 2.0) as f32,
        ))
        .mass(cfg.box_mass as f32),
        matchbox,
        &mut bodies,
    );
    let (fx, fz) = path.at(path.t[0]);
    let finger =
        bodies.insert(RigidBodyBuilder::kinematic_position_based().translation(v(fx, 0.0, fz)));
    colliders.insert_with_parent(
        surface(ColliderBuilder::ball(cfg.finger_radius as f32)),
        finger,
        &mut bodies,
    );

    let params = IntegrationParameters {
        dt: cfg.dt as f32,
        num_solver_iterations: cfg.solver_iterations,
        // Centimetre-sized objects: scale Rapier's tolerances to the scene.
        length_unit: 0.01,
        ..IntegrationParameters::default()
    };
    let mut pipeline = PhysicsPipeline::new();
    let mut islands = IslandManager::new();
    let mut broad_phase = DefaultBroadPhase::new();
    let mut narrow_phase = NarrowPhase::new();
    let mut impulse_joints = ImpulseJointSet::new();
    let mut multibody_joints = MultibodyJointSet::new();
    let mut soft_bodies = SoftBodySet::new();
    let mut ccd = CCDSolver::new();
    let gravity = Vector::new(0.0, 0.0, -9.81);

    let start = path.t[0];
    let end = path.t[path.t.len() - 1] - start + cfg.settle_time;
    let n_steps = (end / cfg.dt).ceil() as usize;
    let mut t = Vec::with_capacity(n_steps + 1);
    let mut raw = Vec::with_capacity(n_steps + 1);
    let mut box_z = Vec::with_capacity(n_steps + 1);
    let record = |bodies: &RigidBodySet, raw: &mut Vec<f64>, box_z: &mut Vec<f64>| {
        let b = &bodies[matchbox];
        // The box's local x axis projected on the x-z plane: 0 lying flat, pi/2 upright.
        let axis = *b.rotation() * Vector::X;
        raw.push((axis.z as f64).atan2(axis.x as f64));
        box_z.push(b.translation().z as f64);
    };
    t.push(0.0);
    record(&bodies, &mut raw, &mut box_z);
    for k in 1..=n_steps {
        let time = k as f64 * cfg.dt;
        let (fx, fz) = path.at(start + time);
        bodies[finger].set_next_kinematic_translation(v(fx, 0.0, fz));
        pipeline.step(
            gravity,
            &params,
            &mut islands,
            &mut broad_phase,
            &mut narrow_phase,
            &mut bodies,
            &mut colliders,
            &mut impulse_joints,
            &mut multibody_joints,
            &mut soft_bodies,
            &mut ccd,
            &(),
            &(),
        );
        t.push(time);
        record(&bodies, &mut raw, &mut box_z);
    }
    let phi: Vec<f64> = unwrap(&raw).into_iter().map(|p| p.clamp(0.0, PI)).collect();
    let off_table = box_z.last().is_some_and(|&z| z < -0.01);
    let measures = measure(&t, &phi, off_table, cfg);
    Ok(Episode {
        t,
        phi,
        box_z,
        measures,
    })
}
