//! `dmprs._core.Generalizer`: the generalizers of `dmp_core::generalize` over demonstrations
//! passed as numpy arrays. `dmprs.Generalizer` (Python) builds it from a `dmprs.Database`.

use dmp_core::{Demonstration, DmpConfig, Generalizer, Kernel, LwrGpOptions, LwrOptions, Method};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;

use crate::dmp::{PyDmp, time_major};
use crate::errors::{IntoPyResult, invalid_input};

type DemoArrays<'py> = (
    PyReadonlyArray1<'py, f64>,
    PyReadonlyArray2<'py, f64>,
    Option<PyReadonlyArray2<'py, f64>>,
    Option<PyReadonlyArray2<'py, f64>>,
);

fn query<'a>(q: &'a PyReadonlyArray1<'_, f64>) -> PyResult<&'a [f64]> {
    q.as_slice()
        .map_err(|_| invalid_input("q must be a contiguous array"))
}

#[pyclass(name = "Generalizer", module = "dmprs._core", frozen)]
pub struct PyGeneralizer {
    inner: Generalizer,
}

#[pymethods]
impl PyGeneralizer {
    /// `queries` `(M, n)`; `demos` a list of `(t, y, yd, ydd)` with `y` `(T, D)`.
    #[new]
    #[pyo3(signature = (queries, demos, method, *, n_basis, alpha_z, beta_z, alpha_x, width_factor,
                        kernel, bandwidth, ridge, interpolate, gp_noise, gp_optimize, gp_restarts))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        queries: PyReadonlyArray2<'_, f64>,
        demos: Vec<DemoArrays<'_>>,
        method: &str,
        n_basis: usize,
        alpha_z: f64,
        beta_z: f64,
        alpha_x: f64,
        width_factor: f64,
        kernel: &str,
        bandwidth: f64,
        ridge: f64,
        interpolate: bool,
        gp_noise: f64,
        gp_optimize: Option<bool>,
        gp_restarts: usize,
    ) -> PyResult<Self> {
        let kernel = match kernel {
            "tricube" => Kernel::Tricube,
            "gaussian" => Kernel::Gaussian,
            other => {
                return Err(invalid_input(format!(
                    "kernel = {other:?} is invalid: use 'tricube' or 'gaussian'"
                )));
            }
        };
        let method = match method {
            "linear" => Method::Linear,
            "lwr-gp" => Method::LwrGp(LwrGpOptions {
                lwr: LwrOptions {
                    kernel,
                    bandwidth,
                    ridge,
                    interpolate,
                },
                gp_noise,
                gp_optimize,
                gp_restarts,
            }),
            other => {
                return Err(invalid_input(format!(
                    "method = {other:?} is invalid: use 'linear' or 'lwr-gp'"
                )));
            }
        };
        let qv = time_major("queries", &queries)?;
        let qs: Vec<Vec<f64>> = qv
            .column_iter()
            .map(|c| c.iter().copied().collect())
            .collect();
        let mut views = Vec::with_capacity(demos.len());
        for (t, y, yd, ydd) in &demos {
            let t = t
                .as_slice()
                .map_err(|_| invalid_input("t must be a contiguous array"))?;
            views.push(Demonstration {
                t,
                y: time_major("y", y)?,
                yd: yd.as_ref().map(|a| time_major("yd", a)).transpose()?,
                ydd: ydd.as_ref().map(|a| time_major("ydd", a)).transpose()?,
            });
        }
        let config = DmpConfig {
            n_basis,
            alpha_z,
            beta_z,
            alpha_x,
            width_factor,
        };
        let inner = py
            .detach(|| Generalizer::new(&qs, &views, config, method))
            .py_err()?;
        Ok(Self { inner })
    }

    fn predict(&self, q: PyReadonlyArray1<'_, f64>) -> PyResult<PyDmp> {
        Ok(PyDmp {
            inner: self.inner.predict(query(&q)?).py_err()?,
        })
    }

    fn parameters<'py>(
        &self,
        py: Python<'py>,
        q: PyReadonlyArray1<'_, f64>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        Ok(self
            .inner
            .parameters(query(&q)?)
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
        let jac = self.inner.jacobian(query(&q)?, rel_step).py_err()?;
        let (p, n) = jac.shape();
        let row_major: Vec<f64> = (0..p)
            .flat_map(|i| (0..n).map(move |j| (i, j)))
            .map(|ij| jac[ij])
            .collect();
        row_major.into_pyarray(py).reshape([p, n])
    }

    #[getter]
    fn demo_dmps(&self) -> Vec<PyDmp> {
        self.inner
            .demo_dmps()
            .iter()
            .map(|d| PyDmp { inner: d.clone() })
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
    fn n_dof(&self) -> usize {
        self.inner.n_dof()
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
