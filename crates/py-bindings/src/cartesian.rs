//! `dmprs._core.CartesianDmp`, `rollout_batch_cartesian` and `CartesianGeneralizer`: numpy in,
//! numpy out. `dmprs.CartesianDMP` and `dmprs.Generalizer` (Python) wrap these and document them.

use dmp_core::cartesian::POSE_WIDTH;
use dmp_core::{
    CartesianDemonstration, CartesianDmp, CartesianGeneralizer, CartesianTrajectory, FinalVelocity,
    RolloutOptions, rollout_batch_cartesian,
};
use nalgebra::{DMatrix, DMatrixView, DVector};
use numpy::{
    IntoPyArray, PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2,
    PyUntypedArrayMethods,
};
use pyo3::prelude::*;

use crate::dmp::{contiguous, time_major, vector};
use crate::errors::{IntoPyResult, invalid_input};
use crate::generalize::{GeneralizerOptions, generalizer_methods, parse_method, parse_queries};
use crate::primitive::{Constants, parameter_getters};

/// `(t, position, quaternion, velocity, angular_velocity, acceleration, angular_acceleration)`.
pub(crate) type CartesianArrays<'py> = (
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray2<f64>>,
);

/// `a`, read-only: numpy's `PyArray_CLEARFLAGS(a, NPY_ARRAY_WRITEABLE)`, in place of seven
/// `setflags(write=False)` calls from Python on every rollout.
fn read_only<D>(a: Bound<'_, numpy::PyArray<f64, D>>) -> Bound<'_, numpy::PyArray<f64, D>> {
    // SAFETY: `a` is a live array object that this function owns a reference to; clearing a flag
    // bit is what the C macro does.
    unsafe { (*a.as_array_ptr()).fields.flags &= !numpy::npyffi::flags::NPY_ARRAY_WRITEABLE };
    a
}

pub(crate) fn trajectory_arrays(
    py: Python<'_>,
    tr: CartesianTrajectory,
) -> PyResult<CartesianArrays<'_>> {
    let n = tr.t.len();
    let block = |v: Vec<f64>, width: usize| -> PyResult<Bound<'_, PyArray2<f64>>> {
        Ok(read_only(v.into_pyarray(py).reshape([n, width])?))
    };
    Ok((
        read_only(tr.t.into_pyarray(py)),
        block(tr.position, 3)?,
        block(tr.quaternion, 4)?,
        block(tr.velocity, 3)?,
        block(tr.angular_velocity, 3)?,
        block(tr.acceleration, 3)?,
        block(tr.angular_acceleration, 3)?,
    ))
}

pub(crate) fn pose(name: &str, a: &PyReadonlyArray1<'_, f64>) -> PyResult<[f64; POSE_WIDTH]> {
    let slice = contiguous(name, a)?;
    slice.try_into().map_err(|_| {
        invalid_input(format!(
            "{name} has shape ({},), expected (7,): x, y, z, qw, qx, qy, qz",
            slice.len()
        ))
    })
}

/// A pose demonstration's measured derivatives, each optional, as a dict with these keys
/// (`(T, 3)` arrays, world frame).
#[derive(FromPyObject)]
#[pyo3(from_item_all)]
pub(crate) struct PoseDerivatives<'py> {
    velocity: Option<PyReadonlyArray2<'py, f64>>,
    acceleration: Option<PyReadonlyArray2<'py, f64>>,
    angular_velocity: Option<PyReadonlyArray2<'py, f64>>,
    angular_acceleration: Option<PyReadonlyArray2<'py, f64>>,
}

fn optional<'a>(
    name: &str,
    a: &'a Option<PyReadonlyArray2<'_, f64>>,
) -> PyResult<Option<DMatrixView<'a, f64>>> {
    a.as_ref().map(|a| time_major(name, a)).transpose()
}

/// A pose demonstration as the core takes it, from numpy arrays.
pub(crate) fn pose_demonstration<'a>(
    t: &'a PyReadonlyArray1<'_, f64>,
    pose: &'a PyReadonlyArray2<'_, f64>,
    derivatives: &'a PoseDerivatives<'_>,
    normalize: bool,
) -> PyResult<CartesianDemonstration<'a>> {
    Ok(CartesianDemonstration {
        t: contiguous("t", t)?,
        pose: time_major("pose", pose)?,
        velocity: optional("velocity", &derivatives.velocity)?,
        acceleration: optional("acceleration", &derivatives.acceleration)?,
        angular_velocity: optional("angular_velocity", &derivatives.angular_velocity)?,
        angular_acceleration: optional("angular_acceleration", &derivatives.angular_acceleration)?,
        normalize,
    })
}

#[pyclass(name = "CartesianDmp", module = "dmprs._core", frozen)]
pub struct PyCartesianDmp {
    pub inner: CartesianDmp,
}

#[pymethods]
impl PyCartesianDmp {
    #[new]
    #[pyo3(signature = (weights, goal, start, tau, constants))]
    fn new(
        weights: PyReadonlyArray2<'_, f64>,
        goal: PyReadonlyArray1<'_, f64>,
        start: PyReadonlyArray1<'_, f64>,
        tau: f64,
        constants: Constants,
    ) -> PyResult<Self> {
        // (6, N) C-ordered is the N x 6 column-major matrix of the core.
        let config = constants.config(weights.shape()[1]);
        let w = DMatrix::from(time_major("weights", &weights)?);
        let inner = CartesianDmp::new(
            config,
            w,
            &pose("goal", &goal)?,
            &pose("start", &start)?,
            tau,
        );
        Ok(Self {
            inner: inner.py_err()?,
        })
    }

    /// `final_velocity`: `(6,)` `vx, vy, vz, wx, wy, wz` the fitted DMP reaches its goal with;
    /// when `None`, the demonstration's last velocities if `final_velocity_from_demo`, else zero.
    #[staticmethod]
    #[pyo3(signature = (t, pose, derivatives, normalize, n_basis, constants, final_velocity=None, final_velocity_from_demo=false))]
    #[allow(clippy::too_many_arguments)]
    fn fit(
        py: Python<'_>,
        t: PyReadonlyArray1<'_, f64>,
        pose: PyReadonlyArray2<'_, f64>,
        derivatives: PoseDerivatives<'_>,
        normalize: bool,
        n_basis: usize,
        constants: Constants,
        final_velocity: Option<PyReadonlyArray1<'_, f64>>,
        final_velocity_from_demo: bool,
    ) -> PyResult<Self> {
        let demo = pose_demonstration(&t, &pose, &derivatives, normalize)?;
        let config = constants.config(n_basis);
        let given = final_velocity
            .map(|v| vector("final_velocity", &v))
            .transpose()?;
        let inner = py
            .detach(|| match (given, final_velocity_from_demo) {
                (Some(v), _) => {
                    CartesianDmp::fit_with_final_velocity(&demo, config, FinalVelocity::Given(v))
                }
                (None, true) => {
                    CartesianDmp::fit_with_final_velocity(&demo, config, FinalVelocity::FromDemo)
                }
                (None, false) => CartesianDmp::fit(&demo, config),
            })
            .py_err()?;
        Ok(Self { inner })
    }

    /// `final_velocity` `(6,)`: `vx, vy, vz` (m/s), then `wx, wy, wz` (rad/s, world frame).
    fn with_final_velocity(&self, final_velocity: PyReadonlyArray1<'_, f64>) -> PyResult<Self> {
        let v: DVector<f64> = vector("final_velocity", &final_velocity)?;
        if v.len() != 6 {
            return Err(invalid_input(format!(
                "final_velocity has shape ({},), expected (6,): vx, vy, vz, wx, wy, wz",
                v.len()
            )));
        }
        Ok(Self {
            inner: self
                .inner
                .with_final_velocity([v[0], v[1], v[2]], [v[3], v[4], v[5]])
                .py_err()?,
        })
    }

    /// `(6,)`, or `None` when it is zero.
    #[getter]
    fn final_velocity<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<f64>>> {
        self.inner
            .final_velocity()
            .map(|v| v.to_vec().into_pyarray(py))
    }

    #[pyo3(signature = (dt, duration=None, until_rest=false, rest_tol=1e-4))]
    fn rollout<'py>(
        &self,
        py: Python<'py>,
        dt: f64,
        duration: Option<f64>,
        until_rest: bool,
        rest_tol: f64,
    ) -> PyResult<CartesianArrays<'py>> {
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
            inner: self.inner.with_goal(&pose("goal", &goal)?).py_err()?,
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
}

parameter_getters!(PyCartesianDmp);

/// Rolls out many Cartesian DMPs on all cores with the GIL released.
#[pyfunction(name = "rollout_batch_cartesian")]
#[pyo3(signature = (dmps, dt, duration=None, until_rest=false, rest_tol=1e-4))]
pub fn py_rollout_batch_cartesian<'py>(
    py: Python<'py>,
    dmps: Vec<PyRef<'py, PyCartesianDmp>>,
    dt: f64,
    duration: Option<f64>,
    until_rest: bool,
    rest_tol: f64,
) -> PyResult<Vec<CartesianArrays<'py>>> {
    let owned: Vec<CartesianDmp> = dmps.iter().map(|d| d.inner.clone()).collect();
    let opts = RolloutOptions {
        dt,
        duration,
        until_rest,
        rest_tol,
    };
    let trajectories = py
        .detach(|| rollout_batch_cartesian(&owned, &opts))
        .py_err()?;
    trajectories
        .into_iter()
        .map(|tr| trajectory_arrays(py, tr))
        .collect()
}

/// `(t, pose, velocity, acceleration, angular_velocity, angular_acceleration)` of one demo.
type PoseDemoArrays<'py> = (
    PyReadonlyArray1<'py, f64>,
    PyReadonlyArray2<'py, f64>,
    Option<PyReadonlyArray2<'py, f64>>,
    Option<PyReadonlyArray2<'py, f64>>,
    Option<PyReadonlyArray2<'py, f64>>,
    Option<PyReadonlyArray2<'py, f64>>,
);

#[pyclass(name = "CartesianGeneralizer", module = "dmprs._core", frozen)]
pub struct PyCartesianGeneralizer {
    inner: CartesianGeneralizer,
}

#[pymethods]
impl PyCartesianGeneralizer {
    /// `queries` `(M, n)`; `demos` a list of [`PoseDemoArrays`] with `pose` `(T, 7)`;
    /// `final_velocity`: each demo's last linear and angular velocity is its DMP's final
    /// velocity, generalized.
    #[new]
    #[pyo3(signature = (queries, demos, method, n_basis, constants, options, final_velocity=false))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        queries: PyReadonlyArray2<'_, f64>,
        demos: Vec<PoseDemoArrays<'_>>,
        method: &str,
        n_basis: usize,
        constants: Constants,
        options: GeneralizerOptions,
        final_velocity: bool,
    ) -> PyResult<Self> {
        let method = parse_method(method, &options)?;
        let qs = parse_queries(&queries)?;
        let mut views = Vec::with_capacity(demos.len());
        for (t, pose, v, a, w, wd) in &demos {
            let t = contiguous("t", t)?;
            views.push(CartesianDemonstration {
                t,
                pose: time_major("pose", pose)?,
                velocity: optional("velocity", v)?,
                acceleration: optional("acceleration", a)?,
                angular_velocity: optional("angular_velocity", w)?,
                angular_acceleration: optional("angular_acceleration", wd)?,
                normalize: false,
            });
        }
        let config = constants.config(n_basis);
        let build = if final_velocity {
            CartesianGeneralizer::with_final_velocity
        } else {
            CartesianGeneralizer::new
        };
        let inner = py.detach(|| build(&qs, &views, config, method)).py_err()?;
        Ok(Self { inner })
    }

    #[getter]
    fn n_dof(&self) -> usize {
        6
    }
}

generalizer_methods!(PyCartesianGeneralizer, PyCartesianDmp);
