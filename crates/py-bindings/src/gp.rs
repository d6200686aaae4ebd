//! `dmprs._core.GaussianProcess`: numpy in, numpy out. `dmprs.GaussianProcess` (Python) wraps
//! and documents it; arrays arriving here are float64 and of the right rank.

use dmp_core::gp::{GaussianProcess, GpOptions, resolve_bounds, resolve_hyperparameters};
use std::sync::atomic::{AtomicBool, Ordering};

use numpy::{IntoPyArray, PyArray1, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;

use crate::dmp::{contiguous, time_major};
use crate::errors::{IntoPyResult, PyErrorClass, invalid_input};

fn pairs(name: &str, a: &PyReadonlyArray2<'_, f64>) -> PyResult<Vec<(f64, f64)>> {
    if a.shape()[1] != 2 {
        return Err(invalid_input(format!(
            "{name} must have shape (n, 2); got {:?}",
            a.shape()
        )));
    }
    Ok(contiguous(name, a)?
        .chunks(2)
        .map(|c| (c[0], c[1]))
        .collect())
}

/// Restarts x iterations x m^3 beyond which a fit may run long enough to want Ctrl-C (about a
/// second of Cholesky factorizations).
const LONG_FIT_FLOPS: f64 = 1e9;

/// Runs `work` on a scoped thread with the GIL released while this thread checks for signals
/// every 50 ms; on Ctrl-C (or any signal handler raising) it sets the flag `work` polls, waits for
/// it to stop and returns the handler's exception (KeyboardInterrupt).
fn interruptible<T: Send>(
    py: Python<'_>,
    work: impl FnOnce(&AtomicBool) -> T + Send,
) -> PyResult<T> {
    let cancel = AtomicBool::new(false);
    std::thread::scope(|scope| {
        let (done, mut finished) = std::sync::mpsc::channel();
        let cancel = &cancel;
        // A panic of the worker (a bug) is caught there and becomes an error, never a panic in Python.
        scope.spawn(move || {
            done.send(std::panic::catch_unwind(std::panic::AssertUnwindSafe(
                || work(cancel),
            )))
        });
        let mut pending: Option<PyErr> = None;
        loop {
            // Returns as soon as the work is done: no latency added to short fits.
            let (tick, receiver) = py.detach(move || {
                let tick = finished.recv_timeout(std::time::Duration::from_millis(50));
                (tick, finished)
            });
            finished = receiver;
            match tick {
                Ok(Ok(result)) => return pending.map_or(Ok(result), Err),
                Ok(Err(_)) | Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => {
                    return Err(PyErrorClass::Numerical.err(
                        "the Gaussian process fit stopped without a result (an internal error)",
                    ));
                }
                Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {}
            }
            if pending.is_none()
                && let Err(e) = py.check_signals()
            {
                cancel.store(true, Ordering::Relaxed);
                pending = Some(e);
            }
        }
    })
}

type MeanStd<'py> = (Bound<'py, PyArray1<f64>>, Option<Bound<'py, PyArray1<f64>>>);

#[pyclass(name = "GaussianProcess", module = "dmprs._core", frozen)]
pub struct PyGaussianProcess {
    inner: GaussianProcess,
}

#[pymethods]
impl PyGaussianProcess {
    /// `x` is `(m, n)`, `y` `(m,)`. Unset hyperparameters and bounds take the core's defaults.
    #[staticmethod]
    #[pyo3(signature = (x, y, *, length_scale, signal_var, noise_var, optimize, n_restarts,
                        length_scale_bounds, signal_var_bounds, noise_var_bounds, max_iter))]
    #[allow(clippy::too_many_arguments)]
    fn fit(
        py: Python<'_>,
        x: PyReadonlyArray2<'_, f64>,
        y: PyReadonlyArray1<'_, f64>,
        length_scale: Option<PyReadonlyArray1<'_, f64>>,
        signal_var: Option<f64>,
        noise_var: Option<f64>,
        optimize: bool,
        n_restarts: usize,
        length_scale_bounds: Option<PyReadonlyArray2<'_, f64>>,
        signal_var_bounds: Option<(f64, f64)>,
        noise_var_bounds: Option<(f64, f64)>,
        max_iter: usize,
    ) -> PyResult<Self> {
        let xv = time_major("X", &x)?;
        let yv = contiguous("y", &y)?;
        let ls = length_scale
            .as_ref()
            .map(|a| contiguous("length_scale", a).map(<[f64]>::to_vec))
            .transpose()?;
        let ls_bounds = length_scale_bounds
            .as_ref()
            .map(|a| pairs("length_scale_bounds", a))
            .transpose()?;
        let start = resolve_hyperparameters(&xv, yv, ls, signal_var, noise_var).py_err()?;
        let bounds = if optimize {
            Some(
                resolve_bounds(
                    &xv,
                    yv,
                    &start,
                    ls_bounds,
                    signal_var_bounds,
                    noise_var_bounds,
                )
                .py_err()?,
            )
        } else {
            None
        };
        let mut options = GpOptions {
            optimize,
            n_restarts,
            bounds,
            ..GpOptions::default()
        };
        options.minimize.max_iter = max_iter;
        // Only a fit that can take long is worth a watcher thread (its spawn costs ~0.1 ms).
        let m = yv.len() as f64;
        let work = if optimize {
            (n_restarts + 1) as f64 * max_iter as f64 * m * m * m
        } else {
            0.0
        };
        let inner = if work > LONG_FIT_FLOPS {
            interruptible(py, |cancel| {
                GaussianProcess::fit_cancellable(&xv, yv, Some(start), &options, cancel)
            })?
        } else {
            py.detach(|| GaussianProcess::fit(&xv, yv, Some(start), &options))
        }
        .py_err()?;
        Ok(Self { inner })
    }

    /// Mean `(p,)` and, if asked, the latent standard deviation `(p,)` at `x` `(p, n)`.
    #[pyo3(signature = (x, return_std=false))]
    fn predict<'py>(
        &self,
        py: Python<'py>,
        x: PyReadonlyArray2<'_, f64>,
        return_std: bool,
    ) -> PyResult<MeanStd<'py>> {
        let xv = time_major("X", &x)?;
        let (mean, std) = self.inner.predict(&xv, return_std).py_err()?;
        Ok((mean.into_pyarray(py), std.map(|s| s.into_pyarray(py))))
    }

    fn log_marginal_likelihood_at<'py>(
        &self,
        py: Python<'py>,
        theta: PyReadonlyArray1<'_, f64>,
    ) -> PyResult<(f64, Bound<'py, PyArray1<f64>>)> {
        let (lml, grad) = self
            .inner
            .log_marginal_likelihood_at(contiguous("theta", &theta)?)
            .py_err()?;
        Ok((lml, grad.into_pyarray(py)))
    }

    #[getter]
    fn log_marginal_likelihood(&self) -> f64 {
        self.inner.log_marginal_likelihood()
    }
    #[getter]
    fn length_scale<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.inner
            .hyperparameters()
            .length_scales
            .clone()
            .into_pyarray(py)
    }
    #[getter]
    fn signal_var(&self) -> f64 {
        self.inner.hyperparameters().signal_var
    }
    #[getter]
    fn noise_var(&self) -> f64 {
        self.inner.hyperparameters().noise_var
    }
    #[getter]
    fn prior_mean(&self) -> f64 {
        self.inner.prior_mean()
    }
    #[getter]
    fn n_dim(&self) -> usize {
        self.inner.n_dim()
    }
    #[getter]
    fn n_train(&self) -> usize {
        self.inner.n_train()
    }
}
