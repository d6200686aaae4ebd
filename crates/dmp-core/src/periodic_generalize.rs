//! Generalization of periodic demonstrations (Ude, Gams, Asfour and Morimoto 2010, the paper's
//! reference 11; docs/method.md §12.7): from M rhythms, each with a task query `q_k`, to a
//! [`PeriodicDmp`] for any query, its parameters
//!
//! ```text
//! theta = [w (N x D), tau, g (D), r (D), y0 (D)]
//! ```
//!
//! the amplitude-normalized shape weights, the frequency `1 / tau`, the baseline, the amplitude
//! and the start. Each demonstration is fitted by [`PeriodicDmp::fit`] (its own period, baseline
//! and amplitude), and the map from the query to theta is the joint generalizer's
//! ([`crate::generalize`]): affine in `q` (`"linear"`), or the weights by locally weighted
//! regression on the demos' normal equations (which are in the phase, so demos of different
//! frequencies share them) and every scalar by a Gaussian process (`"lwr-gp"`).
//!
//! A query whose tau leaves `(0.2 min tau_k, 5 max tau_k)`, or whose amplitude of some DOF is not
//! positive (every demo's is), is refused with [`Error::Extrapolation`].

use nalgebra::{DMatrix, DVector};

use crate::design_matrix::PreparedDemo;
use crate::dmp::Demonstration;
use crate::error::{Error, Result};
use crate::generalize::{Method, ParameterMap, check_queries, tau_range};
use crate::periodic::{PeriodicConfig, PeriodicDmp};

/// A generalizer over M periodic demonstrations.
#[derive(Debug, Clone)]
pub struct PeriodicGeneralizer {
    config: PeriodicConfig,
    n_dof: usize,
    demo_dmps: Vec<PeriodicDmp>,
    tau_valid: (f64, f64),
    map: ParameterMap,
}

/// A periodic DMP's scalar parameters `[tau, g (D), r (D), y0 (D)]`.
fn scalars(dmp: &PeriodicDmp) -> Vec<f64> {
    let mut v = vec![dmp.tau()];
    v.extend(dmp.goal().iter());
    v.extend(dmp.amplitude().iter());
    v.extend(dmp.y0().iter());
    v
}

fn scalar_names(n_dof: usize) -> Vec<String> {
    let mut names = vec!["tau".to_string()];
    for part in ["goal", "amplitude", "start"] {
        names.extend((0..n_dof).map(|i| format!("{part}[{i}]")));
    }
    names
}

impl PeriodicGeneralizer {
    /// Fits one periodic DMP per demonstration (`periods[k]` its period, or its duration when
    /// `None`) and precomputes what `method` needs for fast queries.
    pub fn new(
        queries: &[Vec<f64>],
        demos: &[Demonstration<'_>],
        periods: &[Option<f64>],
        config: PeriodicConfig,
        method: Method,
    ) -> Result<Self> {
        config.validate()?;
        let m = demos.len();
        check_queries(queries, m, method.name())?;
        if periods.len() != m {
            return Err(Error::Shape {
                name: "periods",
                expected: format!("one per demonstration ({m})"),
                got: periods.len().to_string(),
            });
        }
        let mut normal = Vec::with_capacity(m);
        let mut demo_dmps: Vec<PeriodicDmp> = Vec::with_capacity(m);
        for (k, (demo, &period)) in demos.iter().zip(periods).enumerate() {
            let in_demo = |e: Error| Error::InDemo {
                index: k,
                source: Box::new(e),
            };
            let prepared = PreparedDemo::new(demo).map_err(in_demo)?;
            if let Some(first) = demo_dmps.first()
                && prepared.n_dof() != first.n_dof()
            {
                return Err(Error::DofMismatch {
                    index: k,
                    got: prepared.n_dof(),
                    expected: first.n_dof(),
                });
            }
            // Exactly what PeriodicDmp::fit computes: the demo's own rhythm, bit for bit.
            let (dmp, ne) = PeriodicDmp::fit_with_normal_equations(&prepared, period, config)
                .map_err(in_demo)?;
            demo_dmps.push(dmp);
            normal.push(ne);
        }
        let n_dof = demo_dmps[0].n_dof();
        let tau_valid = tau_range(demo_dmps.iter().map(|d| d.tau()));
        let weights: Vec<&DMatrix<f64>> = demo_dmps.iter().map(|d| d.weights()).collect();
        let values: Vec<Vec<f64>> = demo_dmps.iter().map(scalars).collect();
        let map = ParameterMap::new(
            queries,
            normal,
            &weights,
            &values,
            &scalar_names(n_dof),
            &method,
        )?;
        Ok(Self {
            config,
            n_dof,
            demo_dmps,
            tau_valid,
            map,
        })
    }

    pub fn method(&self) -> &'static str {
        self.map.method()
    }
    pub fn n_query(&self) -> usize {
        self.map.n_query()
    }
    pub fn n_dof(&self) -> usize {
        self.n_dof
    }
    pub fn n_demos(&self) -> usize {
        self.demo_dmps.len()
    }
    pub fn config(&self) -> &PeriodicConfig {
        &self.config
    }
    /// The periodic DMP fitted to each demonstration.
    pub fn demo_dmps(&self) -> &[PeriodicDmp] {
        &self.demo_dmps
    }
    pub fn queries(&self) -> &[Vec<f64>] {
        self.map.queries()
    }
    /// Length of the flattened parameter vector: `D N + 1 + 3 D`.
    pub fn n_parameters(&self) -> usize {
        self.n_dof * self.config.n_basis + 1 + 3 * self.n_dof
    }
    /// The interval tau(q) must lie strictly inside.
    pub fn tau_bounds(&self) -> (f64, f64) {
        self.tau_valid
    }

    /// The periodic DMP for query `q`. Fails with [`Error::Extrapolation`] if its tau would leave
    /// `(0.2 min tau_k, 5 max tau_k)` or an amplitude would not be positive.
    pub fn predict(&self, q: &[f64]) -> Result<PeriodicDmp> {
        self.map.check_query(q)?;
        let (w, s) = self.map.at(q)?;
        let n = self.n_dof;
        self.map.check_tau(q, s[0], self.tau_valid)?;
        let part = |k: usize| DVector::from_column_slice(&s[1 + k * n..1 + (k + 1) * n]);
        let amplitude = part(1);
        if let Some((d, &r)) = amplitude
            .iter()
            .enumerate()
            .find(|(_, r)| r.is_nan() || **r <= 0.0)
        {
            return Err(Error::Extrapolation {
                query: format!("{q:?}"),
                reason: format!(
                    "the '{}' generalization gives amplitude[{d}] = {r}, not positive (every \
                     demonstration's is); the query is too far from the demonstrations",
                    self.map.method()
                ),
            });
        }
        PeriodicDmp::new(self.config, w, part(0), amplitude, part(2), s[0])
    }

    /// Flattened parameters `[w (D x N, DOF-major), tau, g (D), r (D), y0 (D)]` at `q`, without
    /// the checks of tau and the amplitude.
    pub fn parameters(&self, q: &[f64]) -> Result<DVector<f64>> {
        self.map.flat_at(q)
    }

    /// Central-difference Jacobian of [`Self::parameters`] with respect to `q`
    /// (`n_parameters x n`), as the joint generalizer's.
    pub fn jacobian(&self, q: &[f64], rel_step: f64) -> Result<DMatrix<f64>> {
        self.map.jacobian(q, rel_step)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::generalize::LwrGpOptions;
    use std::f64::consts::PI;

    /// Two periods of a 2-DOF rhythm whose frequency, baseline and amplitude depend on q.
    fn demo(q: f64) -> (Vec<f64>, DMatrix<f64>) {
        let period = 1.0 + 0.5 * q;
        let n = 400;
        let t: Vec<f64> = (0..n).map(|j| 2.0 * period * j as f64 / n as f64).collect();
        let y = DMatrix::from_fn(2, n, |d, j| {
            let phi = 2.0 * PI * t[j] / period;
            if d == 0 {
                0.3 * q + (1.0 + q) * phi.sin()
            } else {
                -0.2 + 0.5 * (phi + 0.3).cos() + 0.1 * q * (2.0 * phi).sin()
            }
        });
        (t, y)
    }

    fn build(qs: &[f64], method: Method) -> Result<PeriodicGeneralizer> {
        let data: Vec<_> = qs.iter().map(|&q| demo(q)).collect();
        let demos: Vec<Demonstration> = data
            .iter()
            .map(|(t, y)| Demonstration {
                t,
                y: y.as_view(),
                yd: None,
                ydd: None,
            })
            .collect();
        let queries: Vec<Vec<f64>> = qs.iter().map(|&q| vec![q]).collect();
        let periods: Vec<Option<f64>> = qs.iter().map(|&q| Some(1.0 + 0.5 * q)).collect();
        PeriodicGeneralizer::new(
            &queries,
            &demos,
            &periods,
            PeriodicConfig::default(),
            method,
        )
    }

    #[test]
    fn both_methods_return_each_demo_at_its_query() {
        let lin = build(&[0.0, 1.0], Method::Linear).unwrap();
        for k in 0..2 {
            assert_eq!(lin.predict(&[k as f64]).unwrap(), lin.demo_dmps()[k]);
        }
        let ude = build(
            &[0.0, 0.5, 1.0, 1.5],
            Method::LwrGp(LwrGpOptions::default()),
        )
        .unwrap();
        for (k, q) in [0.0, 0.5, 1.0, 1.5].into_iter().enumerate() {
            let want = &ude.demo_dmps()[k];
            let got = ude.predict(&[q]).unwrap();
            assert!((got.weights() - want.weights()).amax() < 1e-6 * want.weights().amax());
            assert!((got.tau() - want.tau()).abs() < 1e-5 * want.tau());
            assert!((got.amplitude() - want.amplitude()).amax() < 1e-5);
        }
    }

    #[test]
    fn linear_interpolates_period_baseline_and_amplitude() {
        let g = build(&[0.0, 1.0], Method::Linear).unwrap();
        let mid = g.predict(&[0.5]).unwrap();
        let (a, b) = (&g.demo_dmps()[0], &g.demo_dmps()[1]);
        assert!((mid.tau() - 0.5 * (a.tau() + b.tau())).abs() < 1e-15);
        assert!((mid.amplitude() - (a.amplitude() + b.amplitude()) * 0.5).amax() < 1e-15);
        assert!((mid.goal() - (a.goal() + b.goal()) * 0.5).amax() < 1e-15);
    }

    #[test]
    fn a_vanishing_amplitude_and_a_wrong_period_count_are_refused() {
        let g = build(&[0.0, 1.0], Method::Linear).unwrap();
        // amplitude[0] = 1 + q is zero at q = -1
        let err = g.predict(&[-1.5]).unwrap_err().to_string();
        assert!(err.contains("amplitude[0]"), "{err}");
        let (t, y) = demo(0.0);
        let d = Demonstration {
            t: &t,
            y: y.as_view(),
            yd: None,
            ydd: None,
        };
        let err = PeriodicGeneralizer::new(
            &[vec![0.0], vec![1.0]],
            &[d, d],
            &[None],
            PeriodicConfig::default(),
            Method::Linear,
        )
        .unwrap_err()
        .to_string();
        assert!(err.contains("periods"), "{err}");
    }
}
