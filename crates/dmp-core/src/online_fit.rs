//! The periodic DMP's weights learned online, one sample at a time, by recursive least squares
//! with a forgetting factor (docs/method.md §12.3; Gams, Ijspeert, Schaal and Lenarčič 2009 learn
//! the same weights this way, while an oscillator supplies the phase and the frequency).
//!
//! Every DOF's regressor is the same row of normalized activations `a = psi(phi) / sum psi`, so
//! one inverse-covariance `P` serves them all:
//!
//! ```text
//! k = P a / (lambda + a^T P a)
//! w_d += k (F_d / r_d - a^T w_d)        F_d = tau^2 ydd - alpha_z (beta_z (g - y) - tau yd)
//! P = (P - k a^T P) / lambda
//! ```
//!
//! With `lambda = 1` and `P_0 = I / delta` the weights after the last sample are exactly the
//! ridge solution `(A^T A + delta I)^-1 A^T F / r` of the batch fit's least squares; `lambda < 1`
//! forgets old periods with time constant `1 / (1 - lambda)` samples, so the weights follow a
//! demonstration that changes.

use nalgebra::DMatrix;

use crate::dmp::check_n_dof;
use crate::error::{Error, Result, check_scalar, fmt_g};
use crate::periodic::{Activations, PeriodicBasis, PeriodicConfig, check_per_dof};

/// Learns the weights of a periodic DMP from a stream of samples.
#[derive(Debug, Clone)]
pub struct OnlineFit {
    config: PeriodicConfig,
    basis: PeriodicBasis,
    /// `N x N`, symmetric.
    p: DMatrix<f64>,
    /// `N x D`.
    weights: DMatrix<f64>,
    forgetting: f64,
    samples: u64,
    activations: Activations,
    row: Vec<f64>,
    pa: Vec<f64>,
}

impl OnlineFit {
    /// Starts from zero weights and `P_0 = I / delta`: a small `delta` trusts the first samples
    /// fully, a large one holds the weights near zero until evidence accumulates.
    pub fn new(config: PeriodicConfig, n_dof: usize, forgetting: f64, delta: f64) -> Result<Self> {
        config.validate()?;
        check_scalar("delta", delta, true)?;
        check_scalar("forgetting", forgetting, true)?;
        if !(0.5..=1.0).contains(&forgetting) {
            return Err(Error::InvalidParameter {
                name: "forgetting",
                value: fmt_g(forgetting),
                requirement: "must be in [0.5, 1]: 1 forgets nothing, 0.995-0.999 forgets old \
                              periods over 200-1000 samples, and below 0.5 the covariance grows \
                              faster than one sample can correct",
            });
        }
        check_n_dof(n_dof)?;
        let n = config.n_basis;
        let basis = PeriodicBasis::new(n, config.width_factor)?;
        Ok(Self {
            config,
            activations: Activations {
                start: 0,
                values: Vec::with_capacity(n),
            },
            basis,
            p: DMatrix::from_diagonal_element(n, n, 1.0 / delta),
            weights: DMatrix::zeros(n, n_dof),
            forgetting,
            samples: 0,
            row: vec![0.0; n],
            pa: vec![0.0; n],
        })
    }

    pub fn config(&self) -> &PeriodicConfig {
        &self.config
    }
    /// `N x D`, column d = the weights of DOF d.
    pub fn weights(&self) -> &DMatrix<f64> {
        &self.weights
    }
    pub fn samples(&self) -> u64 {
        self.samples
    }
    pub fn n_dof(&self) -> usize {
        self.weights.ncols()
    }

    /// Takes one sample `(y, yd, ydd)` at phase `phi` of a rhythm with time constant `tau`,
    /// baseline `goal` and amplitude `amplitude` (all per DOF). A sample that would leave a
    /// non-finite weight or covariance is refused and leaves the fit unchanged.
    #[allow(clippy::too_many_arguments)]
    pub fn update(
        &mut self,
        phi: f64,
        tau: f64,
        y: &[f64],
        yd: &[f64],
        ydd: &[f64],
        goal: &[f64],
        amplitude: &[f64],
    ) -> Result<()> {
        check_scalar("phase", phi, false)?;
        check_scalar("tau", tau, true)?;
        let n_dof = self.n_dof();
        for (name, v) in [
            ("y", y),
            ("yd", yd),
            ("ydd", ydd),
            ("goal", goal),
            ("amplitude", amplitude),
        ] {
            check_per_dof(name, v, n_dof)?;
        }
        if let Some((i, &r)) = amplitude.iter().enumerate().find(|(_, r)| **r == 0.0) {
            return Err(Error::InvalidParameter {
                name: "amplitude",
                value: format!("{} at [{i}]", fmt_g(r)),
                requirement: "must be non-zero: the weights are the forcing per unit amplitude",
            });
        }
        let n = self.config.n_basis;
        let (az, bz) = (self.config.alpha_z, self.config.beta_z);
        self.basis
            .normalized_activations(phi.rem_euclid(std::f64::consts::TAU), &mut self.activations);
        self.row.iter_mut().for_each(|v| *v = 0.0);
        let start = self.activations.start;
        for (m, &v) in self.activations.values.iter().enumerate() {
            self.row[(start + m) % n] = v;
        }
        // P a, in a fixed order (P is symmetric: row i of P times a)
        let p = self.p.as_slice();
        for i in 0..n {
            self.pa[i] = self
                .activations
                .values
                .iter()
                .enumerate()
                .map(|(m, v)| p[((start + m) % n) * n + i] * v)
                .sum();
        }
        let apa: f64 = self.row.iter().zip(&self.pa).map(|(a, b)| a * b).sum();
        let denom = self.forgetting + apa;
        let mut new_w = self.weights.clone();
        for d in 0..n_dof {
            let target =
                (tau * tau * ydd[d] - az * (bz * (goal[d] - y[d]) - tau * yd[d])) / amplitude[d];
            let col = &mut new_w.as_mut_slice()[d * n..(d + 1) * n];
            let e = target - self.activations.dot(col);
            for (w, pa) in col.iter_mut().zip(&self.pa) {
                *w += pa / denom * e;
            }
        }
        let mut new_p = self.p.clone();
        let inv_lambda = 1.0 / self.forgetting;
        for j in 0..n {
            let col = &mut new_p.as_mut_slice()[j * n..(j + 1) * n];
            let pj = self.pa[j] / denom;
            for (i, c) in col.iter_mut().enumerate() {
                *c = (*c - self.pa[i] * pj) * inv_lambda;
            }
        }
        if new_w.iter().chain(new_p.iter()).any(|v| !v.is_finite()) {
            return Err(Error::Numerical {
                context: "periodic online fit",
                detail: "the sample would make the weights or the covariance non-finite; it was \
                         not taken (the target is too large for f64)"
                    .into(),
            });
        }
        self.weights = new_w;
        self.p = new_p;
        self.samples += 1;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DVector;

    #[test]
    fn without_forgetting_it_is_the_ridge_least_squares() {
        let cfg = PeriodicConfig {
            n_basis: 15,
            ..PeriodicConfig::default()
        };
        let delta = 1e-3;
        let mut fit = OnlineFit::new(cfg, 1, 1.0, delta).unwrap();
        let basis = PeriodicBasis::new(15, 2.0).unwrap();
        let mut ata = DMatrix::<f64>::from_diagonal_element(15, 15, delta);
        let mut atf = DVector::<f64>::zeros(15);
        let mut act = Activations {
            start: 0,
            values: vec![],
        };
        let tau = 0.2;
        for j in 0..700 {
            let phi = j as f64 * 0.013;
            let (y, yd, ydd) = (phi.sin() + 0.3 * (3.0 * phi).cos(), phi.cos(), -phi.sin());
            fit.update(phi, tau, &[y], &[yd], &[ydd], &[0.1], &[2.0])
                .unwrap();
            basis.normalized_activations(phi.rem_euclid(std::f64::consts::TAU), &mut act);
            let mut a = DVector::<f64>::zeros(15);
            for (m, v) in act.values.iter().enumerate() {
                a[(act.start + m) % 15] = *v;
            }
            let f = (tau * tau * ydd - 48.0 * (12.0 * (0.1 - y) - tau * yd)) / 2.0;
            ata += &a * a.transpose();
            atf += &a * f;
        }
        let exact = ata.lu().solve(&atf).unwrap();
        for i in 0..15 {
            let (w, e) = (fit.weights()[(i, 0)], exact[i]);
            assert!((w - e).abs() < 1e-8 * e.abs().max(1.0), "{i}: {w} {e}");
        }
    }

    #[test]
    fn bad_samples_leave_it_unchanged() {
        let mut fit = OnlineFit::new(PeriodicConfig::default(), 2, 0.995, 1.0).unwrap();
        fit.update(
            0.1,
            1.0,
            &[1.0, 2.0],
            &[0.0; 2],
            &[0.0; 2],
            &[0.0; 2],
            &[1.0; 2],
        )
        .unwrap();
        let before = fit.weights().clone();
        assert!(
            fit.update(
                0.2,
                1.0,
                &[f64::NAN, 0.0],
                &[0.0; 2],
                &[0.0; 2],
                &[0.0; 2],
                &[1.0; 2]
            )
            .is_err()
        );
        assert!(
            fit.update(
                0.2,
                1.0,
                &[1e300, 0.0],
                &[0.0; 2],
                &[1e300; 2],
                &[0.0; 2],
                &[1e-300; 2]
            )
            .is_err()
        );
        assert!(
            fit.update(0.2, 1.0, &[1.0], &[0.0; 2], &[0.0; 2], &[0.0; 2], &[1.0; 2])
                .is_err()
        );
        assert_eq!(fit.weights(), &before);
        assert_eq!(fit.samples(), 1);
        assert!(OnlineFit::new(PeriodicConfig::default(), 1, 0.2, 1.0).is_err());
    }
}
