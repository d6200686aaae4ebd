//! `dmprs._core.Generalizer`: the generalizers of `dmp_core::generalize` over demonstrations
//! passed as numpy arrays. `dmprs.Generalizer` (Python) builds it from a `dmprs.Database`.

use dmp_core::{Generalizer, GpMean, Kernel, LocalModel, LwrGpOptions, LwrOptions, Method};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;

use crate::dmp::{PyDmp, contiguous, demonstration, time_major};
use crate::errors::{IntoPyResult, invalid_input};
use crate::primitive::Constants;

pub(crate) type DemoArrays<'py> = (
    PyReadonlyArray1<'py, f64>,
    PyReadonlyArray2<'py, f64>,
    Option<PyReadonlyArray2<'py, f64>>,
    Option<PyReadonlyArray2<'py, f64>>,
);

pub(crate) fn query<'a>(q: &'a PyReadonlyArray1<'_, f64>) -> PyResult<&'a [f64]> {
    contiguous("q", q)
}

/// The generalizer's options as Python passes them: a dict with these keys
/// (`dmprs.generalize.Generalizer` builds it, validated), for joint and Cartesian demos alike.
#[derive(FromPyObject)]
#[pyo3(from_item_all)]
pub(crate) struct GeneralizerOptions {
    kernel: String,
    bandwidth: f64,
    ridge: f64,
    interpolate: bool,
    gp_noise: f64,
    gp_optimize: Option<bool>,
    gp_restarts: usize,
    gp_neighbours: Option<usize>,
    gp_sparse: bool,
    trend: String,
}

/// The generalization method `method` with `options`.
pub(crate) fn parse_method(method: &str, options: &GeneralizerOptions) -> PyResult<Method> {
    // "affine": first-order LWR for the weights and an affine prior mean for the GPs.
    let (local_model, gp_mean) = match options.trend.as_str() {
        "constant" => (LocalModel::Constant, GpMean::Constant),
        "affine" => (LocalModel::Linear, GpMean::Affine),
        other => {
            return Err(invalid_input(format!(
                "trend = {other:?} is invalid: use 'constant' or 'affine'"
            )));
        }
    };
    let kernel = match options.kernel.as_str() {
        "tricube" => Kernel::Tricube,
        "gaussian" => Kernel::Gaussian,
        other => {
            return Err(invalid_input(format!(
                "kernel = {other:?} is invalid: use 'tricube' or 'gaussian'"
            )));
        }
    };
    Ok(match method {
        "linear" => Method::Linear,
        "lwr-gp" => Method::LwrGp(LwrGpOptions {
            lwr: LwrOptions {
                kernel,
                bandwidth: options.bandwidth,
                ridge: options.ridge,
                interpolate: options.interpolate,
                local_model,
            },
            gp_noise: options.gp_noise,
            gp_optimize: options.gp_optimize,
            gp_restarts: options.gp_restarts,
            gp_mean,
            gp_neighbours: options.gp_neighbours,
            gp_sparse: options.gp_sparse,
        }),
        other => {
            return Err(invalid_input(format!(
                "method = {other:?} is invalid: use 'linear' or 'lwr-gp'"
            )));
        }
    })
}

/// `(M, n)` queries as one `Vec` per demonstration.
pub(crate) fn parse_queries(queries: &PyReadonlyArray2<'_, f64>) -> PyResult<Vec<Vec<f64>>> {
    let qv = time_major("queries", queries)?;
    Ok(qv
        .column_iter()
        .map(|c| c.iter().copied().collect())
        .collect())
}

/// A `p x n` matrix as a C-ordered `(p, n)` array.
pub(crate) fn row_major<'py>(
    py: Python<'py>,
    m: &nalgebra::DMatrix<f64>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let (p, n) = m.shape();
    let data: Vec<f64> = (0..p)
        .flat_map(|i| (0..n).map(move |j| (i, j)))
        .map(|ij| m[ij])
        .collect();
    data.into_pyarray(py).reshape([p, n])
}

/// The methods both generalizer classes share, over their `inner` core generalizer; `$dmp` is
/// the Python class of the DMPs they predict.
macro_rules! generalizer_methods {
    ($class:ty, $dmp:ident) => {
        #[pymethods]
        impl $class {
            fn predict(&self, q: PyReadonlyArray1<'_, f64>) -> PyResult<$dmp> {
                Ok($dmp {
                    inner: self
                        .inner
                        .predict($crate::generalize::query(&q)?)
                        .py_err()?,
                })
            }

            fn parameters<'py>(
                &self,
                py: Python<'py>,
                q: PyReadonlyArray1<'_, f64>,
            ) -> PyResult<Bound<'py, PyArray1<f64>>> {
                Ok(self
                    .inner
                    .parameters($crate::generalize::query(&q)?)
                    .py_err()?
                    .as_slice()
                    .to_vec()
                    .into_pyarray(py))
            }

            /// `(n_parameters, n)`.
            fn jacobian<'py>(
                &self,
                py: Python<'py>,
                q: PyReadonlyArray1<'_, f64>,
                rel_step: f64,
            ) -> PyResult<Bound<'py, PyArray2<f64>>> {
                let jac = self
                    .inner
                    .jacobian($crate::generalize::query(&q)?, rel_step)
                    .py_err()?;
                $crate::generalize::row_major(py, &jac)
            }

            #[getter]
            fn demo_dmps(&self) -> Vec<$dmp> {
                self.inner
                    .demo_dmps()
                    .iter()
                    .map(|d| $dmp { inner: d.clone() })
                    .collect()
            }
            #[getter]
            fn method(&self) -> &'static str {
                self.inner.method()
            }
            #[getter]
            fn n_query(&self) -> usize {
                self.inner.n_query()
            }
            #[getter]
            fn n_demos(&self) -> usize {
                self.inner.n_demos()
            }
            #[getter]
            fn n_basis(&self) -> usize {
                self.inner.config().n_basis
            }
            #[getter]
            fn n_parameters(&self) -> usize {
                self.inner.n_parameters()
            }
            #[getter]
            fn tau_bounds(&self) -> (f64, f64) {
                self.inner.tau_bounds()
            }
        }
    };
}
pub(crate) use generalizer_methods;

#[pyclass(name = "Generalizer", module = "dmprs._core", frozen)]
pub struct PyGeneralizer {
    inner: Generalizer,
}

#[pymethods]
impl PyGeneralizer {
    /// `queries` `(M, n)`; `demos` a list of `(t, y, yd, ydd)` with `y` `(T, D)`;
    /// `final_velocity`: each demo's last velocity is its DMP's final velocity, generalized.
    #[new]
    #[pyo3(signature = (queries, demos, method, n_basis, constants, options, final_velocity=false))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        queries: PyReadonlyArray2<'_, f64>,
        demos: Vec<DemoArrays<'_>>,
        method: &str,
        n_basis: usize,
        constants: Constants,
        options: GeneralizerOptions,
        final_velocity: bool,
    ) -> PyResult<Self> {
        let method = parse_method(method, &options)?;
        let qs = parse_queries(&queries)?;
        let mut views = Vec::with_capacity(demos.len());
        for (t, y, yd, ydd) in &demos {
            views.push(demonstration(t, y, yd.as_ref(), ydd.as_ref())?);
        }
        let config = constants.config(n_basis);
        let build = if final_velocity {
            Generalizer::with_final_velocity
        } else {
            Generalizer::new
        };
        let inner = py.detach(|| build(&qs, &views, config, method)).py_err()?;
        Ok(Self { inner })
    }

    #[getter]
    fn n_dof(&self) -> usize {
        self.inner.n_dof()
    }
}

generalizer_methods!(PyGeneralizer, PyDmp);
