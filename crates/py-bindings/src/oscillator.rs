//! `dmprs._core.AdaptiveOscillator`: numpy in, numpy out. `dmprs.oscillator` (Python) wraps it
//! and documents it.

use dmp_core::{AdaptiveOscillator, OscillatorGains};
use numpy::{PyArray1, PyArray2, PyReadonlyArray1};
use pyo3::prelude::*;

use crate::dmp::contiguous;
use crate::errors::IntoPyResult;
use crate::primitive::vector_array;

type Vector<'py> = Bound<'py, PyArray1<f64>>;
type Matrix<'py> = Bound<'py, PyArray2<f64>>;

#[pyclass(name = "AdaptiveOscillator", module = "dmprs._core")]
pub struct PyAdaptiveOscillator {
    inner: AdaptiveOscillator,
}

#[pymethods]
impl PyAdaptiveOscillator {
    #[new]
    #[pyo3(signature = (frequency, n_dof, harmonics, drive, frequency_range, gains))]
    fn new(
        frequency: f64,
        n_dof: usize,
        harmonics: usize,
        drive: usize,
        frequency_range: (f64, f64),
        gains: (f64, f64, f64),
    ) -> PyResult<Self> {
        let gains = OscillatorGains {
            phase: gains.0,
            frequency: gains.1,
            fourier: gains.2,
        };
        Ok(Self {
            inner: AdaptiveOscillator::new(
                frequency,
                n_dof,
                harmonics,
                drive,
                frequency_range,
                gains,
            )
            .py_err()?,
        })
    }

    fn update(&mut self, dt: f64, y: PyReadonlyArray1<'_, f64>) -> PyResult<()> {
        self.inner.update(dt, contiguous("y", &y)?).py_err()
    }

    /// `(y, yd, ydd)`, each `(D,)`
    fn estimate<'py>(&mut self, py: Python<'py>) -> (Vector<'py>, Vector<'py>, Vector<'py>) {
        let (y, yd, ydd) = self.inner.estimate();
        (
            vector_array(py, y),
            vector_array(py, yd),
            vector_array(py, ydd),
        )
    }

    /// `(D, M + 1)` each: `a_0..a_M` and `b_0..b_M`
    fn coefficients<'py>(&self, py: Python<'py>) -> PyResult<(Matrix<'py>, Matrix<'py>)> {
        let n = self.inner.n_dof();
        let rows = |f: &dyn Fn(usize) -> Vec<f64>| (0..n).map(f).collect::<Vec<_>>();
        let a = rows(&|d| self.inner.cosine_coefficients(d).to_vec());
        let b = rows(&|d| self.inner.sine_coefficients(d).to_vec());
        Ok((PyArray2::from_vec2(py, &a)?, PyArray2::from_vec2(py, &b)?))
    }

    #[getter]
    fn phase(&self) -> f64 {
        self.inner.phase()
    }
    #[getter]
    fn omega(&self) -> f64 {
        self.inner.omega()
    }
    #[getter]
    fn samples(&self) -> u64 {
        self.inner.samples()
    }
    #[getter]
    fn n_dof(&self) -> usize {
        self.inner.n_dof()
    }

    fn copy(&self) -> Self {
        Self {
            inner: self.inner.clone(),
        }
    }
}
