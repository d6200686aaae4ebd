//! `dmprs._core.Learner`: one thin wrapper around every ask/tell learner of the `learners` crate.
//! `dmprs.learners` (Python) validates and converts the arguments, documents the learners and
//! builds them through the static constructors below.

use learners::{
    AskTell, ErrorLearning, ErrorLearningConfig, GoldenConfig, GoldenMode, GoldenSection,
    IllinoisRootFinder, Jacobian, Pi2, Pi2Config, PolicyGradient, PolicyGradientConfig, Power,
    PowerConfig, RootFinderConfig, Status,
};
use nalgebra::DMatrix;
use numpy::{
    IntoPyArray, PyArray1, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2,
    PyUntypedArrayMethods,
};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::errors::{IntoPyResult, invalid_input};

enum Inner {
    ErrorLearning(ErrorLearning),
    Golden(GoldenSection),
    Root(IllinoisRootFinder),
    PolicyGradient(PolicyGradient),
    Power(Power),
    Pi2(Pi2),
}

impl Inner {
    fn get(&self) -> &dyn AskTell {
        match self {
            Inner::ErrorLearning(l) => l,
            Inner::Golden(l) => l,
            Inner::Root(l) => l,
            Inner::PolicyGradient(l) => l,
            Inner::Power(l) => l,
            Inner::Pi2(l) => l,
        }
    }
    fn get_mut(&mut self) -> &mut dyn AskTell {
        match self {
            Inner::ErrorLearning(l) => l,
            Inner::Golden(l) => l,
            Inner::Root(l) => l,
            Inner::PolicyGradient(l) => l,
            Inner::Power(l) => l,
            Inner::Pi2(l) => l,
        }
    }
}

#[pyclass(name = "Learner", module = "dmprs._core")]
pub struct PyLearner {
    inner: Inner,
}

fn slice<'a>(name: &str, a: &'a PyReadonlyArray1<'_, f64>) -> PyResult<&'a [f64]> {
    a.as_slice()
        .map_err(|_| invalid_input(format!("{name} must be a contiguous array")))
}

fn opt_vec(name: &str, a: &Option<PyReadonlyArray1<'_, f64>>) -> PyResult<Option<Vec<f64>>> {
    a.as_ref()
        .map(|a| slice(name, a).map(<[f64]>::to_vec))
        .transpose()
}

/// A C-ordered (r, c) array as an nalgebra matrix.
fn matrix(name: &str, a: &PyReadonlyArray2<'_, f64>) -> PyResult<DMatrix<f64>> {
    let (r, c) = (a.shape()[0], a.shape()[1]);
    let s = a
        .as_slice()
        .map_err(|_| invalid_input(format!("{name} must be a contiguous array")))?;
    Ok(DMatrix::from_row_slice(r, c, s))
}

fn status_name(s: Status) -> &'static str {
    s.name()
}

#[pymethods]
impl PyLearner {
    #[staticmethod]
    #[pyo3(signature = (q0, gain, weighted, scale, jacobian, jacobian_matrix, delta, low, high, tol, max_trials, pin_limit))]
    #[allow(clippy::too_many_arguments)]
    fn error_learning(
        q0: PyReadonlyArray1<'_, f64>,
        gain: PyReadonlyArray2<'_, f64>,
        weighted: bool,
        scale: f64,
        jacobian: &str,
        jacobian_matrix: Option<PyReadonlyArray2<'_, f64>>,
        delta: f64,
        low: Option<PyReadonlyArray1<'_, f64>>,
        high: Option<PyReadonlyArray1<'_, f64>>,
        tol: f64,
        max_trials: usize,
        pin_limit: usize,
    ) -> PyResult<Self> {
        let jacobian = match (jacobian, jacobian_matrix) {
            ("identity", _) => Jacobian::Identity,
            ("secant", _) => Jacobian::Secant,
            ("finite-difference", _) => Jacobian::FiniteDifference { delta },
            ("matrix", Some(m)) => Jacobian::Fixed(matrix("jacobian", &m)?),
            (other, _) => {
                return Err(invalid_input(format!(
                    "jacobian = {other:?} is invalid: use \"identity\", \"secant\", \"finite-difference\" or an (n, n) array"
                )));
            }
        };
        let cfg = ErrorLearningConfig {
            gain: matrix("gain", &gain)?,
            weighted,
            scale,
            jacobian,
            low: opt_vec("low", &low)?,
            high: opt_vec("high", &high)?,
            tol,
            max_trials,
            pin_limit,
        };
        Ok(Self {
            inner: Inner::ErrorLearning(ErrorLearning::new(slice("q0", &q0)?, cfg).py_err()?),
        })
    }

    #[staticmethod]
    #[pyo3(signature = (q0, low, high, mode, tol, q_tol, max_trials, max_expansions))]
    #[allow(clippy::too_many_arguments)]
    fn golden(
        q0: f64,
        low: f64,
        high: f64,
        mode: &str,
        tol: f64,
        q_tol: f64,
        max_trials: usize,
        max_expansions: usize,
    ) -> PyResult<Self> {
        let mode = match mode {
            "paper" => GoldenMode::Paper,
            "robust" => GoldenMode::Robust,
            other => {
                return Err(invalid_input(format!(
                    "mode = {other:?} is invalid: use \"paper\" or \"robust\""
                )));
            }
        };
        let cfg = GoldenConfig {
            mode,
            tol,
            q_tol,
            max_trials,
            max_expansions,
        };
        Ok(Self {
            inner: Inner::Golden(GoldenSection::new(q0, low, high, cfg).py_err()?),
        })
    }

    #[staticmethod]
    fn root_finder(
        q0: f64,
        low: f64,
        high: f64,
        tol: f64,
        q_tol: f64,
        max_trials: usize,
    ) -> PyResult<Self> {
        let cfg = RootFinderConfig {
            tol,
            q_tol,
            max_trials,
        };
        Ok(Self {
            inner: Inner::Root(IllinoisRootFinder::new(q0, low, high, cfg).py_err()?),
        })
    }

    #[staticmethod]
    #[pyo3(signature = (q0, alpha0, decay, delta, scale, evaluate_center, low, high, tol, max_trials, pin_limit))]
    #[allow(clippy::too_many_arguments)]
    fn policy_gradient(
        q0: PyReadonlyArray1<'_, f64>,
        alpha0: f64,
        decay: f64,
        delta: f64,
        scale: f64,
        evaluate_center: bool,
        low: Option<PyReadonlyArray1<'_, f64>>,
        high: Option<PyReadonlyArray1<'_, f64>>,
        tol: f64,
        max_trials: usize,
        pin_limit: usize,
    ) -> PyResult<Self> {
        let cfg = PolicyGradientConfig {
            alpha0,
            decay,
            delta,
            scale,
            evaluate_center,
            low: opt_vec("low", &low)?,
            high: opt_vec("high", &high)?,
            tol,
            max_trials,
            pin_limit,
        };
        Ok(Self {
            inner: Inner::PolicyGradient(PolicyGradient::new(slice("q0", &q0)?, cfg).py_err()?),
        })
    }

    #[staticmethod]
    #[pyo3(signature = (theta0, sigma, n_best, adapt_variance, variance_window, target_return, max_trials, seed))]
    #[allow(clippy::too_many_arguments)]
    fn power(
        theta0: PyReadonlyArray1<'_, f64>,
        sigma: PyReadonlyArray1<'_, f64>,
        n_best: usize,
        adapt_variance: bool,
        variance_window: usize,
        target_return: Option<f64>,
        max_trials: usize,
        seed: u64,
    ) -> PyResult<Self> {
        let cfg = PowerConfig {
            sigma: slice("sigma", &sigma)?.to_vec(),
            n_best,
            adapt_variance,
            variance_window,
            target_return,
            max_trials,
            seed,
        };
        Ok(Self {
            inner: Inner::Power(Power::new(slice("theta0", &theta0)?, cfg).py_err()?),
        })
    }

    #[staticmethod]
    #[pyo3(signature = (theta0, sigma, n_rollouts, n_reuse, h, n_updates, n_dof, n_steps, alpha_x, width_factor, projection, cost_tol, max_trials, seed))]
    #[allow(clippy::too_many_arguments)]
    fn pi2(
        theta0: PyReadonlyArray1<'_, f64>,
        sigma: PyReadonlyArray1<'_, f64>,
        n_rollouts: usize,
        n_reuse: usize,
        h: f64,
        n_updates: usize,
        n_dof: usize,
        n_steps: usize,
        alpha_x: f64,
        width_factor: f64,
        projection: bool,
        cost_tol: Option<f64>,
        max_trials: usize,
        seed: u64,
    ) -> PyResult<Self> {
        let cfg = Pi2Config {
            sigma: slice("sigma", &sigma)?.to_vec(),
            n_rollouts,
            n_reuse,
            h,
            n_updates,
            n_dof,
            n_steps,
            alpha_x,
            width_factor,
            projection,
            cost_tol,
            max_trials,
            seed,
        };
        Ok(Self {
            inner: Inner::Pi2(Pi2::new(slice("theta0", &theta0)?, cfg).py_err()?),
        })
    }

    fn ask<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        Ok(self.inner.get_mut().ask().py_err()?.into_pyarray(py))
    }

    fn tell(
        &mut self,
        q: PyReadonlyArray1<'_, f64>,
        feedback: PyReadonlyArray1<'_, f64>,
    ) -> PyResult<()> {
        let (q, f) = (slice("q", &q)?, slice("feedback", &feedback)?);
        self.inner.get_mut().tell(q, f).py_err()
    }

    #[getter]
    fn dim(&self) -> usize {
        self.inner.get().dim()
    }

    #[getter]
    fn status(&self) -> &'static str {
        status_name(self.inner.get().status())
    }

    /// The status with its detail (which limit was hit).
    #[getter]
    fn status_detail(&self) -> String {
        self.inner.get().status().to_string()
    }

    #[getter]
    fn converged(&self) -> bool {
        self.inner.get().converged()
    }

    #[getter]
    fn n_told(&self) -> usize {
        self.inner.get().n_told()
    }

    /// (q, feedback, score) of the best trial, or None before the first tell.
    #[getter]
    #[allow(clippy::type_complexity)]
    fn best<'py>(
        &self,
        py: Python<'py>,
    ) -> Option<(Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<f64>>, f64)> {
        self.inner.get().best().map(|t| {
            (
                t.q.clone().into_pyarray(py),
                t.feedback.clone().into_pyarray(py),
                t.score,
            )
        })
    }

    /// [(q, feedback, score), ...] in the order of the trials.
    #[getter]
    #[allow(clippy::type_complexity)]
    fn history<'py>(
        &self,
        py: Python<'py>,
    ) -> Vec<(Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<f64>>, f64)> {
        self.inner
            .get()
            .history()
            .iter()
            .map(|t| {
                (
                    t.q.clone().into_pyarray(py),
                    t.feedback.clone().into_pyarray(py),
                    t.score,
                )
            })
            .collect()
    }

    /// Learner-specific state: bracket, jacobian, center, mean, variance, theta.
    fn state<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        match &self.inner {
            Inner::ErrorLearning(l) => {
                let j = l.jacobian();
                let rows: Vec<f64> = j.transpose().as_slice().to_vec(); // row-major for numpy
                d.set_item(
                    "jacobian",
                    rows.into_pyarray(py).reshape([j.nrows(), j.ncols()])?,
                )?;
            }
            Inner::Golden(l) => d.set_item("bracket", l.bracket())?,
            Inner::Root(l) => d.set_item("bracket", l.bracket())?,
            Inner::PolicyGradient(l) => {
                d.set_item("center", l.center().to_vec().into_pyarray(py))?
            }
            Inner::Power(l) => {
                d.set_item("mean", l.mean().to_vec().into_pyarray(py))?;
                d.set_item("variance", l.variance().to_vec().into_pyarray(py))?;
            }
            Inner::Pi2(l) => {
                d.set_item("theta", l.theta().to_vec().into_pyarray(py))?;
                d.set_item("n_updates_done", l.n_updates_done())?;
            }
        }
        Ok(d)
    }
}
