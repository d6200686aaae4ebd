//! The periodic DMP's rollout: its stepper run open loop (docs/method.md §12.6), so the rollout
//! and an uncoupled stepper are one integrator, not two that agree.

use rayon::prelude::*;

use crate::error::Result;
use crate::periodic::PeriodicDmp;
use crate::periodic_stepper::{PeriodicStepper, PeriodicStepperOptions};
use crate::rollout::{Trajectory, check_trajectory};

impl PeriodicDmp {
    /// Integrates eqs. P1-P3 from the start at rest at phase `phi0` and returns positions,
    /// velocities `z / tau` and accelerations `dz/dt / tau` at `t_j = j dt` up to `duration`
    /// (default one period). Too coarse a `dt` is integrated in stable sub-steps, as for the
    /// discrete DMP.
    pub fn rollout(&self, dt: f64, duration: Option<f64>, phi0: f64) -> Result<Trajectory> {
        let n_dof = self.n_dof();
        let (len, _) = self.plan(dt, duration, phi0, n_dof, "periodic DMP rollout")?;
        // At full amplitude from the start about g (no ramp), no measurement, no limits: each
        // step is the integrator's plain period, sub-stepped where `dt` needs it.
        let mut stepper = PeriodicStepper::new(
            self,
            &PeriodicStepperOptions {
                phase: phi0,
                ramp: 0.0,
                alpha_e: vec![],
                ..PeriodicStepperOptions::new(dt)
            },
        )?;
        // every sample written in place into arrays allocated once
        let mut out = Trajectory {
            t: (0..len).map(|j| j as f64 * dt).collect(),
            y: vec![0.0; len * n_dof],
            yd: vec![0.0; len * n_dof],
            ydd: vec![0.0; len * n_dof],
            n_dof,
        };
        let rows = out
            .y
            .chunks_exact_mut(n_dof)
            .zip(out.yd.chunks_exact_mut(n_dof))
            .zip(out.ydd.chunks_exact_mut(n_dof));
        for ((y, yd), ydd) in rows {
            let (sy, syd, sydd) = stepper.step_open_loop()?;
            y.copy_from_slice(sy);
            yd.copy_from_slice(syd);
            ydd.copy_from_slice(sydd);
        }
        check_trajectory(&out, "periodic DMP rollout")?;
        Ok(out)
    }
}

/// Rolls out many periodic DMPs in parallel (rayon); the same bits as one by one.
pub fn rollout_batch_periodic(
    dmps: &[PeriodicDmp],
    dt: f64,
    duration: Option<f64>,
    phi0: f64,
) -> Result<Vec<Trajectory>> {
    dmps.par_iter()
        .map(|d| d.rollout(dt, duration, phi0))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::periodic::PeriodicConfig;
    use nalgebra::{DMatrix, DVector};

    fn dmp(n_basis: usize, n_dof: usize, tau: f64, seed: f64) -> PeriodicDmp {
        let weights = DMatrix::from_fn(n_basis, n_dof, |i, d| {
            (seed + 0.7 * i as f64 + 1.3 * d as f64).sin() * 40.0
        });
        PeriodicDmp::new(
            PeriodicConfig {
                n_basis,
                ..PeriodicConfig::default()
            },
            weights,
            DVector::from_fn(n_dof, |d, _| 0.1 * d as f64),
            DVector::from_fn(n_dof, |d, _| 1.0 + 0.2 * d as f64),
            DVector::from_fn(n_dof, |d, _| -0.3 + 0.1 * d as f64),
            tau,
        )
        .unwrap()
    }

    /// Eqs. P1-P3 integrated stage by stage with the DMP's own acceleration and step: the
    /// reference the stepper's fused period must reproduce.
    fn staged(d: &PeriodicDmp, dt: f64, duration: f64, phi0: f64) -> Trajectory {
        let n = d.n_dof();
        let (len, substeps) = d.plan(dt, Some(duration), phi0, n, "test").unwrap();
        let (tau, h) = (d.tau(), dt / substeps as f64);
        let (inv_tau, inv_tau2) = (1.0 / tau, 1.0 / (tau * tau));
        let (goal, amplitude) = (d.goal().as_slice(), d.amplitude().as_slice());
        let (mut state, mut ws, mut dz) = (d.initial_state(phi0), d.workspace(), vec![0.0; n]);
        let mut out = Trajectory {
            t: vec![],
            y: vec![],
            yd: vec![],
            ydd: vec![],
            n_dof: n,
        };
        for j in 0..len {
            d.acceleration(&state, goal, amplitude, &mut ws, &mut dz);
            out.t.push(j as f64 * dt);
            out.y.extend_from_slice(&state.y);
            out.yd.extend(state.z.iter().map(|z| z * inv_tau));
            out.ydd.extend(dz.iter().map(|dz| dz * inv_tau2));
            for sub in 0..substeps {
                if sub > 0 {
                    d.acceleration(&state, goal, amplitude, &mut ws, &mut dz);
                }
                PeriodicDmp::advance(&mut state, &dz, tau, h);
            }
        }
        out
    }

    #[test]
    fn the_rollout_is_the_staged_integration_bit_for_bit() {
        // 7 and 5 DOF (the last vector overlapping the one before), 4 DOF (one whole vector),
        // 3 and 1 DOF (one by one); one Euler step a sample and sub-steps (a coarse dt and a fast
        // rhythm)
        for (n_basis, n_dof, tau, dt) in [
            (50, 7, 1.0, 1e-3),
            (20, 5, 0.7, 1e-3),
            (30, 4, 0.5, 2e-3),
            (25, 3, 0.2, 1e-3),
            (12, 1, 0.05, 2e-2),
        ] {
            let d = dmp(n_basis, n_dof, tau, n_dof as f64);
            for phi0 in [0.0, 2.5] {
                let tr = d.rollout(dt, Some(3.0), phi0).unwrap();
                let reference = staged(&d, dt, 3.0, phi0);
                let bits = |tr: &Trajectory| {
                    [&tr.t, &tr.y, &tr.yd, &tr.ydd]
                        .map(|v| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>())
                };
                assert_eq!(
                    bits(&tr),
                    bits(&reference),
                    "{n_dof} DOF, dt {dt}, phase {phi0}"
                );
            }
        }
    }

    #[test]
    fn batch_is_the_same_bits() {
        let dmps: Vec<PeriodicDmp> = (0..5)
            .map(|k| dmp(8, 3, 0.1 + 0.05 * k as f64, k as f64))
            .collect();
        let batch = rollout_batch_periodic(&dmps, 1e-3, Some(0.5), 0.3).unwrap();
        for (d, tr) in dmps.iter().zip(batch) {
            assert_eq!(d.rollout(1e-3, Some(0.5), 0.3).unwrap(), tr);
        }
    }
}
