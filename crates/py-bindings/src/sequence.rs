//! `dmprs._core.SequenceStepper` and `sequence_rollout`: joint DMPs joined end to start
//! (`dmp_core::sequence`), and `CartesianSequenceStepper` and `cartesian_sequence_rollout`:
//! Cartesian DMPs likewise (`dmp_core::cartesian_sequence`). `dmprs.sequence` (Python) builds
//! them, validates the options and documents them; the steppers have the surface of
//! `dmprs._core.Stepper` and `CartesianStepper` (the same methods, from `crate::stepper`'s
//! `stepper_methods!`) and the movement that runs, `active`.

use dmp_core::{CartesianDmp, CartesianSequenceStepper, Dmp, RolloutOptions, SequenceStepper};
use numpy::{PyArray1, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::PyTuple;

use crate::cartesian::{CartesianArrays, PyCartesianDmp};
use crate::dmp::{PyDmp, TrajectoryArrays, trajectory_arrays};
use crate::errors::{IntoPyResult, invalid_input};
use crate::stepper::{
    Outputs, SharedOptions, cartesian_options, obstacle_rows, read_vector, stepper_methods,
};

/// The core DMPs of a list of `dmprs._core.Dmp`.
fn core_dmps(dmps: &[PyRef<'_, PyDmp>]) -> Vec<Dmp> {
    dmps.iter().map(|d| d.inner.clone()).collect()
}

#[pyclass(name = "SequenceStepper", module = "dmprs._core", subclass)]
pub struct PySequenceStepper {
    inner: SequenceStepper,
    out: Outputs,
    measured: Vec<f64>,
    coupling: Vec<f64>,
}

#[pymethods]
impl PySequenceStepper {
    /// `SequenceStepper(dmps, dt, options)`; `SequenceStepper.__new__(cls, stepper)` is a copy
    /// of `stepper` as a `cls` (as `Stepper`'s).
    #[new]
    #[pyo3(signature = (dmps, dt=None, options=None))]
    fn new(
        py: Python<'_>,
        dmps: &Bound<'_, PyAny>,
        dt: Option<f64>,
        options: Option<SharedOptions>,
    ) -> PyResult<Self> {
        let (dt, options) = match (dt, options) {
            (Some(dt), Some(options)) => (dt, options),
            (None, None) if dmps.is_instance_of::<Self>() => {
                let this = dmps.cast::<Self>()?.borrow();
                return Self::of(py, this.inner.clone());
            }
            _ => {
                return Err(invalid_input(
                    "SequenceStepper takes a list of DMPs, dt and the options",
                ));
            }
        };
        let dmps: Vec<PyRef<'_, PyDmp>> = dmps.extract()?;
        Self::of(
            py,
            SequenceStepper::new(&core_dmps(&dmps), &options.at(dt)).py_err()?,
        )
    }

    /// The movement that runs (0-based).
    #[getter]
    fn active(&self) -> usize {
        self.inner.active()
    }
    #[getter]
    fn n_dof(&self) -> usize {
        self.inner.n_dof()
    }
}

impl PySequenceStepper {
    /// A Python stepper over `inner`, its output arrays holding its last command.
    fn of(py: Python<'_>, inner: SequenceStepper) -> PyResult<Self> {
        let n = inner.n_dof();
        let s = Self {
            inner,
            out: Outputs::new(py, [n; 3])?,
            measured: Vec::with_capacity(n),
            coupling: Vec::with_capacity(n),
        };
        s.publish(py)?;
        Ok(s)
    }

    fn publish(&self, py: Python<'_>) -> PyResult<()> {
        let (y, yd, ydd) = self.inner.output();
        self.out.write(py, 0, y)?;
        self.out.write(py, 1, yd)?;
        self.out.write(py, 2, ydd)
    }
}

stepper_methods!(
    PySequenceStepper,
    "One control period: `(y, yd, ydd)` of this period (read-only arrays that the next call \
     overwrites), handing over to the next movement first when the one that runs has run its \
     tau; then the state advances by dt."
);

/// `rollout(dmps)` with the GIL released, at the Python call's `(dt, duration, until_rest,
/// rest_tol)`.
fn released<D: Sync, T: Send>(
    py: Python<'_>,
    dmps: &[D],
    (dt, duration, until_rest, rest_tol): (f64, Option<f64>, bool, f64),
    rollout: fn(&[D], &RolloutOptions) -> dmp_core::Result<T>,
) -> PyResult<T> {
    let opts = RolloutOptions {
        dt,
        duration,
        until_rest,
        rest_tol,
    };
    py.detach(|| rollout(dmps, &opts)).py_err()
}

/// The sequence of `dmps` rolled out open loop with the GIL released (one DMP: its rollout).
#[pyfunction(name = "sequence_rollout")]
#[pyo3(signature = (dmps, dt, duration=None, until_rest=false, rest_tol=1e-4))]
pub fn py_sequence_rollout<'py>(
    py: Python<'py>,
    dmps: Vec<PyRef<'py, PyDmp>>,
    dt: f64,
    duration: Option<f64>,
    until_rest: bool,
    rest_tol: f64,
) -> PyResult<TrajectoryArrays<'py>> {
    let options = (dt, duration, until_rest, rest_tol);
    let tr = released(py, &core_dmps(&dmps), options, dmp_core::sequence::rollout)?;
    trajectory_arrays(py, tr)
}

#[pyclass(name = "CartesianSequenceStepper", module = "dmprs._core", subclass)]
pub struct PyCartesianSequenceStepper {
    inner: CartesianSequenceStepper,
    out: Outputs,
    measured: Vec<f64>,
    coupling: Vec<f64>,
}

#[pymethods]
impl PyCartesianSequenceStepper {
    /// `CartesianSequenceStepper(dmps, dt, options, obstacles, obstacle_gain, obstacle_beta)`;
    /// `CartesianSequenceStepper.__new__(cls, stepper)` is a copy of `stepper` as a `cls`.
    #[new]
    #[pyo3(signature = (dmps, dt=None, options=None, obstacles=None, obstacle_gain=None, obstacle_beta=None))]
    fn new(
        py: Python<'_>,
        dmps: &Bound<'_, PyAny>,
        dt: Option<f64>,
        options: Option<SharedOptions>,
        obstacles: Option<PyReadonlyArray2<'_, f64>>,
        obstacle_gain: Option<f64>,
        obstacle_beta: Option<f64>,
    ) -> PyResult<Self> {
        let (dt, options, gain, beta) = match (dt, options, obstacle_gain, obstacle_beta) {
            (Some(dt), Some(options), Some(gain), Some(beta)) => (dt, options, gain, beta),
            (None, None, None, None) if obstacles.is_none() && dmps.is_instance_of::<Self>() => {
                let this = dmps.cast::<Self>()?.borrow();
                return Self::of(py, this.inner.clone());
            }
            _ => {
                return Err(invalid_input(
                    "CartesianSequenceStepper takes a list of CartesianDMPs, dt, the options, \
                     obstacles and the obstacle gains",
                ));
            }
        };
        let dmps: Vec<PyRef<'_, PyCartesianDmp>> = dmps.extract()?;
        let opts = cartesian_options(dt, options, obstacles, gain, beta)?;
        Self::of(
            py,
            CartesianSequenceStepper::new(&core_cartesian(&dmps), &opts).py_err()?,
        )
    }

    /// The movement that runs (0-based).
    #[getter]
    fn active(&self) -> usize {
        self.inner.active()
    }
    #[getter]
    fn obstacles<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, numpy::PyArray2<f64>>> {
        obstacle_rows(py, self.inner.obstacles())
    }
}

impl PyCartesianSequenceStepper {
    /// A Python stepper over `inner`, its output arrays holding its last command.
    fn of(py: Python<'_>, inner: CartesianSequenceStepper) -> PyResult<Self> {
        let s = Self {
            inner,
            out: Outputs::new(py, [7, 6, 6])?,
            measured: Vec::with_capacity(7),
            coupling: Vec::with_capacity(6),
        };
        s.publish(py)?;
        Ok(s)
    }

    fn publish(&self, py: Python<'_>) -> PyResult<()> {
        let (pose, v, a) = self.inner.output();
        self.out.write(py, 0, pose)?;
        self.out.write(py, 1, v)?;
        self.out.write(py, 2, a)
    }
}

stepper_methods!(
    PyCartesianSequenceStepper,
    "One control period: `(pose, velocity, acceleration)` of this period as \
     `CartesianStepper.step` gives them (read-only arrays that the next call overwrites), \
     handing over to the next movement first when the one that runs has run its tau; then the \
     state advances by dt."
);

/// The core DMPs of a list of `dmprs._core.CartesianDmp`.
fn core_cartesian(dmps: &[PyRef<'_, PyCartesianDmp>]) -> Vec<CartesianDmp> {
    dmps.iter().map(|d| d.inner.clone()).collect()
}

/// The sequence of Cartesian `dmps` rolled out open loop with the GIL released (one DMP: its
/// rollout).
#[pyfunction(name = "cartesian_sequence_rollout")]
#[pyo3(signature = (dmps, dt, duration=None, until_rest=false, rest_tol=1e-4))]
pub fn py_cartesian_sequence_rollout<'py>(
    py: Python<'py>,
    dmps: Vec<PyRef<'py, PyCartesianDmp>>,
    dt: f64,
    duration: Option<f64>,
    until_rest: bool,
    rest_tol: f64,
) -> PyResult<CartesianArrays<'py>> {
    let options = (dt, duration, until_rest, rest_tol);
    let tr = released(
        py,
        &core_cartesian(&dmps),
        options,
        dmp_core::cartesian_sequence::rollout,
    )?;
    crate::cartesian::trajectory_arrays(py, tr)
}
