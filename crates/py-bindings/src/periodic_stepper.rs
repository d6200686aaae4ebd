//! `dmprs._core.PeriodicStepper`: a periodic DMP stepped online. `dmprs.periodic_stepper`
//! (Python) validates its options and documents it.

use dmp_core::temporal_coupling::TemporalCouplingGains;
use dmp_core::{PeriodicStepper, PeriodicStepperOptions};
use numpy::PyReadonlyArray1;
use pyo3::prelude::*;
use pyo3::types::PyTuple;

use crate::dmp::contiguous;
use crate::errors::{IntoPyResult, invalid_input};
use crate::periodic::PyPeriodicDmp;
use crate::stepper::{Outputs, read_vector};

/// The options as Python passes them (already validated there).
#[derive(FromPyObject)]
#[pyo3(from_item_all)]
struct Options {
    phase: f64,
    ramp: f64,
    change_filter: f64,
    alpha_e: Vec<f64>,
    velocity_max: Option<Vec<f64>>,
    acceleration_max: Option<Vec<f64>>,
    gamma_nominal: f64,
    gamma_a: f64,
    eps: f64,
}

#[pyclass(name = "PeriodicStepper", module = "dmprs._core", subclass)]
pub struct PyPeriodicStepper {
    inner: PeriodicStepper,
    out: Outputs,
    measured: Vec<f64>,
}

#[pymethods]
impl PyPeriodicStepper {
    /// From a periodic DMP, a control period and the options; or, given another stepper alone,
    /// an independent copy of it in its state (what `copy.copy` calls, with the caller's class).
    #[new]
    #[pyo3(signature = (source, dt=None, options=None))]
    fn new(
        py: Python<'_>,
        source: &Bound<'_, PyAny>,
        dt: Option<f64>,
        options: Option<Options>,
    ) -> PyResult<Self> {
        let inner = if let Ok(other) = source.cast::<Self>() {
            other.borrow().inner.clone()
        } else {
            let dmp = source.cast::<PyPeriodicDmp>()?.borrow();
            let (Some(dt), Some(options)) = (dt, options) else {
                return Err(invalid_input("a periodic stepper needs dt and its options"));
            };
            let opts = PeriodicStepperOptions {
                dt,
                phase: options.phase,
                ramp: options.ramp,
                change_filter: options.change_filter,
                alpha_e: options.alpha_e,
                velocity_max: options.velocity_max,
                acceleration_max: options.acceleration_max,
                temporal_coupling: TemporalCouplingGains {
                    nominal: options.gamma_nominal,
                    potential: options.gamma_a,
                    eps: options.eps,
                },
            };
            PeriodicStepper::new(&dmp.inner, &opts).py_err()?
        };
        let n = inner.n_dof();
        Ok(Self {
            inner,
            out: Outputs::new(py, [n; 3])?,
            measured: Vec::with_capacity(n),
        })
    }

    #[pyo3(signature = (measured=None))]
    fn step(
        &mut self,
        py: Python<'_>,
        measured: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Py<PyTuple>> {
        if let Some(m) = measured {
            read_vector("measured", m, &mut self.measured)?;
        }
        let (y, yd, ydd) = self
            .inner
            .step(measured.map(|_| self.measured.as_slice()))
            .py_err()?;
        for (i, v) in [y, yd, ydd].into_iter().enumerate() {
            self.out.write(py, i, v)?;
        }
        Ok(self.out.tuple(py))
    }

    #[pyo3(signature = (rest=None))]
    fn stop(&mut self, rest: Option<PyReadonlyArray1<'_, f64>>) -> PyResult<()> {
        let rest = rest.as_ref().map(|r| contiguous("rest", r)).transpose()?;
        self.inner.stop(rest).py_err()
    }
    fn set_goal(&mut self, goal: PyReadonlyArray1<'_, f64>) -> PyResult<()> {
        self.inner.set_goal(contiguous("goal", &goal)?).py_err()
    }
    fn set_amplitude(&mut self, amplitude: PyReadonlyArray1<'_, f64>) -> PyResult<()> {
        self.inner
            .set_amplitude(contiguous("amplitude", &amplitude)?)
            .py_err()
    }
    fn set_tau(&mut self, tau: f64) -> PyResult<()> {
        self.inner.set_tau(tau).py_err()
    }
    fn done(&self) -> bool {
        self.inner.done()
    }
    fn over_limit(&self) -> bool {
        self.inner.over_limit()
    }
    #[getter]
    fn phase(&self) -> f64 {
        self.inner.phase()
    }
    #[getter]
    fn tau(&self) -> f64 {
        self.inner.tau()
    }
    #[getter]
    fn nominal_tau(&self) -> f64 {
        self.inner.nominal_tau()
    }
    #[getter]
    fn envelope(&self) -> f64 {
        self.inner.envelope()
    }
    #[getter]
    fn goal(&self) -> Vec<f64> {
        self.inner.goal().to_vec()
    }
    #[getter]
    fn amplitude(&self) -> Vec<f64> {
        self.inner.amplitude().to_vec()
    }
    #[getter]
    fn steps(&self) -> u64 {
        self.inner.steps()
    }
    #[getter]
    fn dt(&self) -> f64 {
        self.inner.dt()
    }
    #[getter]
    fn n_dof(&self) -> usize {
        self.inner.n_dof()
    }
}
