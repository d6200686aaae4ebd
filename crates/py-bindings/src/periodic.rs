//! `dmprs._core.PeriodicDmp`, `PeriodicCartesianDmp`, their batch rollouts and
//! `PeriodicOnlineFit`: numpy in, numpy out. `dmprs.periodic` (Python) wraps these and documents
//! them.

use dmp_core::online_fit::OnlineFit;
use dmp_core::{
    PeriodicCartesianDmp, PeriodicConfig, PeriodicDmp, PeriodicGeneralizer, rollout_batch_periodic,
    rollout_batch_periodic_cartesian,
};
use nalgebra::DMatrix;
use numpy::{
    IntoPyArray, PyArray1, PyArray2, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods,
};
use pyo3::prelude::*;

use crate::cartesian::{
    CartesianArrays, PoseDerivatives, pose, pose_demonstration, trajectory_arrays as pose_arrays,
};
use crate::dmp::{
    TrajectoryArrays, contiguous, demonstration, time_major, trajectory_arrays, vector,
};
use crate::errors::IntoPyResult;
use crate::generalize::{
    DemoArrays, GeneralizerOptions, generalizer_methods, parse_method, parse_queries,
};
use crate::primitive::{vector_array, weights_array};

/// The periodic DMP's constants as Python passes them (`dmprs.periodic` validates them).
#[derive(FromPyObject, Clone, Copy)]
#[pyo3(from_item_all)]
pub(crate) struct PeriodicConstants {
    alpha_z: f64,
    beta_z: f64,
    width_factor: f64,
}

impl PeriodicConstants {
    fn config(self, n_basis: usize) -> PeriodicConfig {
        PeriodicConfig {
            n_basis,
            alpha_z: self.alpha_z,
            beta_z: self.beta_z,
            width_factor: self.width_factor,
        }
    }
}

/// The getters both periodic primitives share, read from their coordinates' periodic DMP (a
/// second `#[pymethods]` block per class).
macro_rules! rhythm_getters {
    ($class:ty) => {
        #[pymethods]
        impl $class {
            /// `(D, N)`
            #[getter]
            fn weights<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
                weights_array(py, self.coordinates().weights())
            }
            #[getter]
            fn amplitude<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
                vector_array(py, self.coordinates().amplitude().as_slice().to_vec())
            }
            #[getter]
            fn tau(&self) -> f64 {
                self.coordinates().tau()
            }
            #[getter]
            fn n_dof(&self) -> usize {
                self.coordinates().n_dof()
            }
            #[getter]
            fn n_basis(&self) -> usize {
                self.coordinates().config().n_basis
            }
            #[getter]
            fn alpha_z(&self) -> f64 {
                self.coordinates().config().alpha_z
            }
            #[getter]
            fn beta_z(&self) -> f64 {
                self.coordinates().config().beta_z
            }
            #[getter]
            fn width_factor(&self) -> f64 {
                self.coordinates().config().width_factor
            }
            #[getter]
            fn centers<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
                vector_array(py, self.coordinates().basis().centers().to_vec())
            }
            /// The kernels' shared concentration h.
            #[getter]
            fn h(&self) -> f64 {
                self.coordinates().basis().h()
            }
        }
    };
}

#[pyclass(name = "PeriodicDmp", module = "dmprs._core", frozen)]
pub struct PyPeriodicDmp {
    pub inner: PeriodicDmp,
}

#[pymethods]
impl PyPeriodicDmp {
    #[new]
    #[pyo3(signature = (weights, goal, amplitude, start, tau, constants))]
    fn new(
        weights: PyReadonlyArray2<'_, f64>,
        goal: PyReadonlyArray1<'_, f64>,
        amplitude: PyReadonlyArray1<'_, f64>,
        start: PyReadonlyArray1<'_, f64>,
        tau: f64,
        constants: PeriodicConstants,
    ) -> PyResult<Self> {
        let w = time_major("weights", &weights)?;
        let inner = PeriodicDmp::new(
            constants.config(weights.shape()[1]),
            DMatrix::from(w),
            vector("goal", &goal)?,
            vector("amplitude", &amplitude)?,
            vector("start", &start)?,
            tau,
        );
        Ok(Self {
            inner: inner.py_err()?,
        })
    }

    #[staticmethod]
    #[pyo3(signature = (t, y, yd, ydd, period, n_basis, constants))]
    fn fit(
        t: PyReadonlyArray1<'_, f64>,
        y: PyReadonlyArray2<'_, f64>,
        yd: Option<PyReadonlyArray2<'_, f64>>,
        ydd: Option<PyReadonlyArray2<'_, f64>>,
        period: Option<f64>,
        n_basis: usize,
        constants: PeriodicConstants,
    ) -> PyResult<Self> {
        let demo = demonstration(&t, &y, yd.as_ref(), ydd.as_ref())?;
        Ok(Self {
            inner: PeriodicDmp::fit(&demo, period, constants.config(n_basis)).py_err()?,
        })
    }

    #[pyo3(signature = (dt, duration, phase))]
    fn rollout<'py>(
        &self,
        py: Python<'py>,
        dt: f64,
        duration: Option<f64>,
        phase: f64,
    ) -> PyResult<TrajectoryArrays<'py>> {
        let tr = py
            .detach(|| self.inner.rollout(dt, duration, phase))
            .py_err()?;
        trajectory_arrays(py, tr)
    }

    fn with_goal(&self, goal: PyReadonlyArray1<'_, f64>) -> PyResult<Self> {
        Ok(Self {
            inner: self.inner.with_goal(vector("goal", &goal)?).py_err()?,
        })
    }
    fn with_amplitude(&self, amplitude: PyReadonlyArray1<'_, f64>) -> PyResult<Self> {
        Ok(Self {
            inner: self
                .inner
                .with_amplitude(vector("amplitude", &amplitude)?)
                .py_err()?,
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

    #[getter]
    fn goal<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        vector_array(py, self.inner.goal().as_slice().to_vec())
    }
    #[getter]
    fn start<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        vector_array(py, self.inner.y0().as_slice().to_vec())
    }
}

impl PyPeriodicDmp {
    fn coordinates(&self) -> &PeriodicDmp {
        &self.inner
    }
}

rhythm_getters!(PyPeriodicDmp);

/// Rolls out many periodic DMPs on all cores with the GIL released.
#[pyfunction(name = "rollout_batch_periodic")]
#[pyo3(signature = (dmps, dt, duration, phase))]
pub fn py_rollout_batch_periodic<'py>(
    py: Python<'py>,
    dmps: Vec<PyRef<'py, PyPeriodicDmp>>,
    dt: f64,
    duration: Option<f64>,
    phase: f64,
) -> PyResult<Vec<TrajectoryArrays<'py>>> {
    let owned: Vec<PeriodicDmp> = dmps.iter().map(|d| d.inner.clone()).collect();
    let trajectories = py
        .detach(|| rollout_batch_periodic(&owned, dt, duration, phase))
        .py_err()?;
    trajectories
        .into_iter()
        .map(|tr| trajectory_arrays(py, tr))
        .collect()
}

#[pyclass(name = "PeriodicOnlineFit", module = "dmprs._core")]
pub struct PyPeriodicOnlineFit {
    inner: OnlineFit,
}

#[pymethods]
impl PyPeriodicOnlineFit {
    #[new]
    #[pyo3(signature = (n_dof, n_basis, constants, forgetting, delta))]
    fn new(
        n_dof: usize,
        n_basis: usize,
        constants: PeriodicConstants,
        forgetting: f64,
        delta: f64,
    ) -> PyResult<Self> {
        Ok(Self {
            inner: OnlineFit::new(constants.config(n_basis), n_dof, forgetting, delta).py_err()?,
        })
    }

    #[allow(clippy::too_many_arguments)]
    fn update(
        &mut self,
        phase: f64,
        tau: f64,
        y: PyReadonlyArray1<'_, f64>,
        yd: PyReadonlyArray1<'_, f64>,
        ydd: PyReadonlyArray1<'_, f64>,
        goal: PyReadonlyArray1<'_, f64>,
        amplitude: PyReadonlyArray1<'_, f64>,
    ) -> PyResult<()> {
        self.inner
            .update(
                phase,
                tau,
                contiguous("y", &y)?,
                contiguous("yd", &yd)?,
                contiguous("ydd", &ydd)?,
                contiguous("goal", &goal)?,
                contiguous("amplitude", &amplitude)?,
            )
            .py_err()
    }

    /// `(D, N)`
    #[getter]
    fn weights<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        weights_array(py, self.inner.weights())
    }
    #[getter]
    fn samples(&self) -> u64 {
        self.inner.samples()
    }
}

#[pyclass(name = "PeriodicCartesianDmp", module = "dmprs._core", frozen)]
pub struct PyPeriodicCartesianDmp {
    pub inner: PeriodicCartesianDmp,
}

#[pymethods]
impl PyPeriodicCartesianDmp {
    #[new]
    #[pyo3(signature = (weights, goal, amplitude, start, tau, constants))]
    fn new(
        weights: PyReadonlyArray2<'_, f64>,
        goal: PyReadonlyArray1<'_, f64>,
        amplitude: PyReadonlyArray1<'_, f64>,
        start: PyReadonlyArray1<'_, f64>,
        tau: f64,
        constants: PeriodicConstants,
    ) -> PyResult<Self> {
        let w = time_major("weights", &weights)?;
        let inner = PeriodicCartesianDmp::new(
            constants.config(weights.shape()[1]),
            DMatrix::from(w),
            &pose("goal", &goal)?,
            vector("amplitude", &amplitude)?,
            &pose("start", &start)?,
            tau,
        );
        Ok(Self {
            inner: inner.py_err()?,
        })
    }

    #[staticmethod]
    #[pyo3(signature = (t, pose, derivatives, normalize, period, n_basis, constants))]
    #[allow(clippy::too_many_arguments)]
    fn fit(
        py: Python<'_>,
        t: PyReadonlyArray1<'_, f64>,
        pose: PyReadonlyArray2<'_, f64>,
        derivatives: PoseDerivatives<'_>,
        normalize: bool,
        period: Option<f64>,
        n_basis: usize,
        constants: PeriodicConstants,
    ) -> PyResult<Self> {
        let demo = pose_demonstration(&t, &pose, &derivatives, normalize)?;
        let inner = py
            .detach(|| PeriodicCartesianDmp::fit(&demo, period, constants.config(n_basis)))
            .py_err()?;
        Ok(Self { inner })
    }

    #[pyo3(signature = (dt, duration, phase))]
    fn rollout<'py>(
        &self,
        py: Python<'py>,
        dt: f64,
        duration: Option<f64>,
        phase: f64,
    ) -> PyResult<CartesianArrays<'py>> {
        let tr = py
            .detach(|| self.inner.rollout(dt, duration, phase))
            .py_err()?;
        pose_arrays(py, tr)
    }

    fn with_goal(&self, goal: PyReadonlyArray1<'_, f64>) -> PyResult<Self> {
        Ok(Self {
            inner: self.inner.with_goal(&pose("goal", &goal)?).py_err()?,
        })
    }
    fn with_amplitude(&self, amplitude: PyReadonlyArray1<'_, f64>) -> PyResult<Self> {
        Ok(Self {
            inner: self
                .inner
                .with_amplitude(vector("amplitude", &amplitude)?)
                .py_err()?,
        })
    }
    fn with_start(&self, start: PyReadonlyArray1<'_, f64>) -> PyResult<Self> {
        Ok(Self {
            inner: self.inner.with_start(&pose("start", &start)?).py_err()?,
        })
    }
    fn with_tau(&self, tau: f64) -> PyResult<Self> {
        Ok(Self {
            inner: self.inner.with_tau(tau).py_err()?,
        })
    }

    /// The baseline pose `(7,)`.
    #[getter]
    fn goal<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        vector_array(py, self.inner.goal().to_vec())
    }
    #[getter]
    fn start<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        vector_array(py, self.inner.start().to_vec())
    }
}

impl PyPeriodicCartesianDmp {
    fn coordinates(&self) -> &PeriodicDmp {
        self.inner.coordinates()
    }
}

rhythm_getters!(PyPeriodicCartesianDmp);

/// Rolls out many periodic Cartesian DMPs on all cores with the GIL released.
#[pyfunction(name = "rollout_batch_periodic_cartesian")]
#[pyo3(signature = (dmps, dt, duration, phase))]
pub fn py_rollout_batch_periodic_cartesian<'py>(
    py: Python<'py>,
    dmps: Vec<PyRef<'py, PyPeriodicCartesianDmp>>,
    dt: f64,
    duration: Option<f64>,
    phase: f64,
) -> PyResult<Vec<CartesianArrays<'py>>> {
    let owned: Vec<PeriodicCartesianDmp> = dmps.iter().map(|d| d.inner.clone()).collect();
    let trajectories = py
        .detach(|| rollout_batch_periodic_cartesian(&owned, dt, duration, phase))
        .py_err()?;
    trajectories
        .into_iter()
        .map(|tr| pose_arrays(py, tr))
        .collect()
}

/// The periodic generalizer over `(t, y, yd, ydd)` demonstrations, each with its period (or
/// `None`: its duration).
#[pyclass(name = "PeriodicGeneralizer", module = "dmprs._core", frozen)]
pub struct PyPeriodicGeneralizer {
    inner: PeriodicGeneralizer,
}

#[pymethods]
impl PyPeriodicGeneralizer {
    /// `queries` `(M, n)`; `demos` a list of `(t, y, yd, ydd)` with `y` `(T, D)`; `periods` one
    /// per demo.
    #[new]
    #[pyo3(signature = (queries, demos, periods, method, n_basis, constants, options))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        queries: PyReadonlyArray2<'_, f64>,
        demos: Vec<DemoArrays<'_>>,
        periods: Vec<Option<f64>>,
        method: &str,
        n_basis: usize,
        constants: PeriodicConstants,
        options: GeneralizerOptions,
    ) -> PyResult<Self> {
        let method = parse_method(method, &options)?;
        let qs = parse_queries(&queries)?;
        let mut views = Vec::with_capacity(demos.len());
        for (t, y, yd, ydd) in &demos {
            views.push(demonstration(t, y, yd.as_ref(), ydd.as_ref())?);
        }
        let config = constants.config(n_basis);
        let inner = py
            .detach(|| PeriodicGeneralizer::new(&qs, &views, &periods, config, method))
            .py_err()?;
        Ok(Self { inner })
    }

    #[getter]
    fn n_dof(&self) -> usize {
        self.inner.n_dof()
    }
}

generalizer_methods!(PyPeriodicGeneralizer, PyPeriodicDmp);
