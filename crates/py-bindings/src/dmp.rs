//! `dmprs._core.Dmp` and `rollout_batch`: numpy in, numpy out. `dmprs.DMP` (Python) wraps these
//! and documents them; the arrays reaching here are already float64 and of the right rank.

use dmp_core::{
    Demonstration, Dmp, FinalVelocity, RolloutOptions, Trajectory, rollout_batch,
    through_via_points,
};
use nalgebra::{DMatrix, DMatrixView, DVector};
use numpy::{
    IntoPyArray, PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2,
    PyUntypedArrayMethods,
};
use pyo3::prelude::*;

use crate::errors::{IntoPyResult, invalid_input};
use crate::primitive::{Constants, parameter_getters};

/// The data of a numpy array that must be contiguous (every array the Python layer passes is:
/// it goes through `as_float_array`, so this only fails when the bindings are called directly).
pub(crate) fn contiguous<'a, D: numpy::ndarray::Dimension>(
    name: &str,
    a: &'a numpy::PyReadonlyArray<'_, f64, D>,
) -> PyResult<&'a [f64]> {
    a.as_slice()
        .map_err(|_| invalid_input(format!("{name} must be a C-contiguous array")))
}

/// A C-ordered `(T, D)` array viewed as the `D x T` matrix the core expects (no copy).
pub(crate) fn time_major<'a>(
    name: &str,
    a: &'a PyReadonlyArray2<'_, f64>,
) -> PyResult<DMatrixView<'a, f64>> {
    let (t, d) = (a.shape()[0], a.shape()[1]);
    Ok(DMatrixView::from_slice(contiguous(name, a)?, d, t))
}

pub(crate) fn vector(name: &str, a: &PyReadonlyArray1<'_, f64>) -> PyResult<DVector<f64>> {
    Ok(DVector::from_column_slice(contiguous(name, a)?))
}

/// A sample-times array and its `(T, D)` positions and optional derivatives as a core
/// demonstration (no copies).
pub(crate) fn demonstration<'a>(
    t: &'a PyReadonlyArray1<'_, f64>,
    y: &'a PyReadonlyArray2<'_, f64>,
    yd: Option<&'a PyReadonlyArray2<'_, f64>>,
    ydd: Option<&'a PyReadonlyArray2<'_, f64>>,
) -> PyResult<Demonstration<'a>> {
    Ok(Demonstration {
        t: contiguous("t", t)?,
        y: time_major("y", y)?,
        yd: yd.map(|a| time_major("yd", a)).transpose()?,
        ydd: ydd.map(|a| time_major("ydd", a)).transpose()?,
    })
}

pub(crate) type TrajectoryArrays<'py> = (
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray2<f64>>,
);

pub(crate) fn trajectory_arrays(py: Python<'_>, tr: Trajectory) -> PyResult<TrajectoryArrays<'_>> {
    let shape = [tr.t.len(), tr.n_dof];
    Ok((
        tr.t.into_pyarray(py),
        tr.y.into_pyarray(py).reshape(shape)?,
        tr.yd.into_pyarray(py).reshape(shape)?,
        tr.ydd.into_pyarray(py).reshape(shape)?,
    ))
}

#[pyclass(name = "Dmp", module = "dmprs._core", frozen)]
pub struct PyDmp {
    pub inner: Dmp,
}

#[pymethods]
impl PyDmp {
    #[new]
    #[pyo3(signature = (weights, goal, start, tau, constants))]
    fn new(
        weights: PyReadonlyArray2<'_, f64>,
        goal: PyReadonlyArray1<'_, f64>,
        start: PyReadonlyArray1<'_, f64>,
        tau: f64,
        constants: Constants,
    ) -> PyResult<Self> {
        // weights arrive (D, N) C-ordered, which is the N x D column-major matrix of the core.
        let w = time_major("weights", &weights)?;
        let config = constants.config(weights.shape()[1]);
        let inner = Dmp::new(
            config,
            DMatrix::from(w),
            vector("goal", &goal)?,
            vector("start", &start)?,
            tau,
        );
        Ok(Self {
            inner: inner.py_err()?,
        })
    }

    /// `final_velocity`: the velocity `(D,)` the fitted DMP reaches its goal with; when `None`,
    /// the demonstration's last velocity if `final_velocity_from_demo`, else zero.
    #[staticmethod]
    #[pyo3(signature = (t, y, yd, ydd, n_basis, constants, final_velocity=None, final_velocity_from_demo=false))]
    #[allow(clippy::too_many_arguments)]
    fn fit(
        t: PyReadonlyArray1<'_, f64>,
        y: PyReadonlyArray2<'_, f64>,
        yd: Option<PyReadonlyArray2<'_, f64>>,
        ydd: Option<PyReadonlyArray2<'_, f64>>,
        n_basis: usize,
        constants: Constants,
        final_velocity: Option<PyReadonlyArray1<'_, f64>>,
        final_velocity_from_demo: bool,
    ) -> PyResult<Self> {
        let demo = demonstration(&t, &y, yd.as_ref(), ydd.as_ref())?;
        let config = constants.config(n_basis);
        let given = final_velocity
            .map(|v| vector("final_velocity", &v))
            .transpose()?;
        let inner = match (given, final_velocity_from_demo) {
            (Some(v), _) => Dmp::fit_with_final_velocity(&demo, config, FinalVelocity::Given(v)),
            (None, true) => Dmp::fit_with_final_velocity(&demo, config, FinalVelocity::FromDemo),
            (None, false) => Dmp::fit(&demo, config),
        };
        Ok(Self {
            inner: inner.py_err()?,
        })
    }

    fn with_final_velocity(&self, final_velocity: PyReadonlyArray1<'_, f64>) -> PyResult<Self> {
        let v = vector("final_velocity", &final_velocity)?;
        Ok(Self {
            inner: self.inner.with_final_velocity(v).py_err()?,
        })
    }

    /// `(D,)`, or `None` when it is zero.
    #[getter]
    fn final_velocity<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<f64>>> {
        self.inner
            .final_velocity()
            .map(|v| v.as_slice().to_vec().into_pyarray(py))
    }

    #[pyo3(signature = (dt, duration=None, until_rest=false, rest_tol=1e-4))]
    fn rollout<'py>(
        &self,
        py: Python<'py>,
        dt: f64,
        duration: Option<f64>,
        until_rest: bool,
        rest_tol: f64,
    ) -> PyResult<TrajectoryArrays<'py>> {
        let opts = RolloutOptions {
            dt,
            duration,
            until_rest,
            rest_tol,
        };
        let tr = py.detach(|| self.inner.rollout(&opts)).py_err()?;
        trajectory_arrays(py, tr)
    }

    fn with_goal(&self, goal: PyReadonlyArray1<'_, f64>) -> PyResult<Self> {
        Ok(Self {
            inner: self.inner.with_goal(vector("goal", &goal)?).py_err()?,
        })
    }

    /// `positions` `(V, D)` at `times` `(V,)`, for rollouts at `dt`.
    fn with_via_points(
        &self,
        times: PyReadonlyArray1<'_, f64>,
        positions: PyReadonlyArray2<'_, f64>,
        dt: f64,
    ) -> PyResult<Self> {
        let times = contiguous("times", &times)?;
        let positions = time_major("positions", &positions)?;
        Ok(Self {
            inner: through_via_points(&self.inner, times, &positions, dt).py_err()?,
        })
    }

    fn with_start(&self, start: PyReadonlyArray1<'_, f64>) -> PyResult<Self> {
        Ok(Self {
            inner: self.inner.with_start(vector("start", &start)?).py_err()?,
        })
    }

    fn with_tau(&self, tau: f64) -> PyResult<Self> {
        Ok(Self {
            inner: self.inner.with_tau(tau).py_err()?,
        })
    }
}

parameter_getters!(PyDmp);

/// Rolls out many DMPs on all cores with the GIL released.
#[pyfunction(name = "rollout_batch")]
#[pyo3(signature = (dmps, dt, duration=None, until_rest=false, rest_tol=1e-4))]
pub fn py_rollout_batch<'py>(
    py: Python<'py>,
    dmps: Vec<PyRef<'py, PyDmp>>,
    dt: f64,
    duration: Option<f64>,
    until_rest: bool,
    rest_tol: f64,
) -> PyResult<Vec<TrajectoryArrays<'py>>> {
    let owned: Vec<Dmp> = dmps.iter().map(|d| d.inner.clone()).collect();
    let opts = RolloutOptions {
        dt,
        duration,
        until_rest,
        rest_tol,
    };
    let trajectories = py.detach(|| rollout_batch(&owned, &opts)).py_err()?;
    trajectories
        .into_iter()
        .map(|tr| trajectory_arrays(py, tr))
        .collect()
}
