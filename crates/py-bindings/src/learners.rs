//! `dmprs._core.ErrorLearning`, `GoldenSection`, `IllinoisRootFinder`, `PolicyGradient`, `PoWER`
//! and `PI2`: one thin class per ask/tell learner of the `learners` crate, with typed getters for
//! its state. `dmprs.learners` (Python) documents them and converts array-likes.
//!
//! Every constructor takes the learner's options as keyword arguments; an option left out (None)
//! keeps the value of the core's `Default` config, so each default exists once, in the core,
//! which also validates every value.

use learners::{
    AskTell, DEFAULT_FD_DELTA, ErrorLearning, ErrorLearningConfig, GoldenConfig, GoldenMode,
    GoldenSection, IllinoisRootFinder, Jacobian, Pi2, Pi2Config, PolicyGradient,
    PolicyGradientConfig, Power, PowerConfig, RootFinderConfig, SquareMatrix, Trial, scalar_entry,
};
use nalgebra::DMatrix;
use numpy::{
    IntoPyArray, PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2,
    PyUntypedArrayMethods,
};
use pyo3::prelude::*;
use pyo3::types::PyString;

use crate::errors::{IntoPyResult, invalid_input};

fn slice<'a>(name: &str, a: &'a PyReadonlyArray1<'_, f64>) -> PyResult<&'a [f64]> {
    a.as_slice()
        .map_err(|_| invalid_input(format!("{name} must be a contiguous array")))
}

fn opt_vec(name: &str, a: &Option<PyReadonlyArray1<'_, f64>>) -> PyResult<Option<Vec<f64>>> {
    a.as_ref()
        .map(|a| slice(name, a).map(<[f64]>::to_vec))
        .transpose()
}

/// A required limit of a bracketing learner, as its one entry.
fn limit(
    name: &'static str,
    a: &Option<PyReadonlyArray1<'_, f64>>,
    learner: &str,
) -> PyResult<f64> {
    match a {
        Some(a) => scalar_entry(name, slice(name, a)?).py_err(),
        None => Err(invalid_input(format!(
            "{name} is required: {learner} searches the interval [low, high]"
        ))),
    }
}

/// A float (times I), a diagonal (1-D array) or a full (2-D, C-ordered) array.
fn square(name: &str, value: &Bound<'_, PyAny>) -> PyResult<SquareMatrix> {
    if let Ok(g) = value.extract::<f64>() {
        return Ok(SquareMatrix::Scalar(g));
    }
    if let Ok(d) = value.extract::<PyReadonlyArray1<'_, f64>>() {
        return Ok(SquareMatrix::Diagonal(slice(name, &d)?.to_vec()));
    }
    if let Ok(m) = value.extract::<PyReadonlyArray2<'_, f64>>() {
        let (r, c) = (m.shape()[0], m.shape()[1]);
        let s = m
            .as_slice()
            .map_err(|_| invalid_input(format!("{name} must be a contiguous array")))?;
        return Ok(SquareMatrix::Full(DMatrix::from_row_slice(r, c, s)));
    }
    Err(invalid_input(format!(
        "{name} must be a float or a 1-D or 2-D float64 array"
    )))
}

fn jacobian(value: &Bound<'_, PyAny>, delta: Option<f64>) -> PyResult<Jacobian> {
    let Ok(name) = value.cast::<PyString>() else {
        return Ok(Jacobian::Fixed(square("jacobian", value)?));
    };
    Ok(match name.to_str()? {
        "identity" => Jacobian::Identity,
        "secant" => Jacobian::Secant,
        "finite-difference" => Jacobian::FiniteDifference {
            delta: delta.unwrap_or(DEFAULT_FD_DELTA),
        },
        other => {
            return Err(invalid_input(format!(
                "jacobian = {other:?} is invalid: use \"identity\", \"secant\", \"finite-difference\" or an (n, n) array"
            )));
        }
    })
}

type PyTrial<'py> = (Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<f64>>, f64);

fn py_trial<'py>(py: Python<'py>, t: &Trial) -> PyTrial<'py> {
    (
        t.q.clone().into_pyarray(py),
        t.feedback.clone().into_pyarray(py),
        t.score,
    )
}

fn vector<'py>(py: Python<'py>, v: &[f64]) -> Bound<'py, PyArray1<f64>> {
    v.to_vec().into_pyarray(py)
}

/// One pyclass around one core learner: its constructor and typed getters (`$extra`) and the
/// ask/tell methods every learner shares.
macro_rules! ask_tell_class {
    ($py_name:literal, $class:ident, $core:ty, { $($extra:tt)* }) => {
        #[pyclass(name = $py_name, module = "dmprs._core")]
        pub struct $class {
            inner: $core,
        }

        #[pymethods]
        impl $class {
            $($extra)*

            fn ask<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
                Ok(self.inner.ask().py_err()?.into_pyarray(py))
            }

            fn tell(
                &mut self,
                q: PyReadonlyArray1<'_, f64>,
                feedback: PyReadonlyArray1<'_, f64>,
            ) -> PyResult<()> {
                let (q, f) = (slice("q", &q)?, slice("feedback", &feedback)?);
                self.inner.tell(q, f).py_err()
            }

            #[getter]
            fn dim(&self) -> usize {
                self.inner.dim()
            }

            #[getter]
            fn status(&self) -> &'static str {
                self.inner.status().name()
            }

            /// The status with its detail (which limit was hit).
            #[getter]
            fn status_detail(&self) -> String {
                self.inner.status().to_string()
            }

            #[getter]
            fn converged(&self) -> bool {
                self.inner.converged()
            }

            #[getter]
            fn n_told(&self) -> usize {
                self.inner.n_told()
            }

            /// (q, feedback, score) of the best trial, or None before the first tell.
            #[getter]
            fn best<'py>(&self, py: Python<'py>) -> Option<PyTrial<'py>> {
                self.inner.best().map(|t| py_trial(py, t))
            }

            /// [(q, feedback, score), ...] in the order of the trials.
            #[getter]
            fn history<'py>(&self, py: Python<'py>) -> Vec<PyTrial<'py>> {
                self.inner.history().iter().map(|t| py_trial(py, t)).collect()
            }
        }
    };
}

ask_tell_class!("ErrorLearning", PyErrorLearning, ErrorLearning, {
    #[new]
    #[pyo3(signature = (q0, *, low=None, high=None, gain=None, weighted=None, scale=None,
        jacobian=None, delta=None, tol=None, max_trials=None, pin_limit=None, broyden=None,
        trust_radius=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        q0: PyReadonlyArray1<'_, f64>,
        low: Option<PyReadonlyArray1<'_, f64>>,
        high: Option<PyReadonlyArray1<'_, f64>>,
        gain: Option<&Bound<'_, PyAny>>,
        weighted: Option<bool>,
        scale: Option<f64>,
        jacobian: Option<&Bound<'_, PyAny>>,
        delta: Option<f64>,
        tol: Option<f64>,
        max_trials: Option<usize>,
        pin_limit: Option<usize>,
        broyden: Option<bool>,
        trust_radius: Option<f64>,
    ) -> PyResult<Self> {
        let d = ErrorLearningConfig::default();
        let cfg = ErrorLearningConfig {
            gain: gain
                .map(|g| square("gain", g))
                .transpose()?
                .unwrap_or(d.gain),
            weighted: weighted.unwrap_or(d.weighted),
            scale: scale.unwrap_or(d.scale),
            jacobian: jacobian
                .map(|j| self::jacobian(j, delta))
                .transpose()?
                .unwrap_or(d.jacobian),
            low: opt_vec("low", &low)?,
            high: opt_vec("high", &high)?,
            tol: tol.unwrap_or(d.tol),
            max_trials: max_trials.unwrap_or(d.max_trials),
            pin_limit: pin_limit.unwrap_or(d.pin_limit),
            broyden: broyden.unwrap_or(d.broyden),
            trust_radius: trust_radius.or(d.trust_radius),
        };
        Ok(Self {
            inner: ErrorLearning::new(slice("q0", &q0)?, cfg).py_err()?,
        })
    }

    /// The current estimate J of dq_a/dq, (n, n).
    #[getter]
    fn jacobian<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let j = self.inner.jacobian();
        let rows: Vec<f64> = j.transpose().as_slice().to_vec(); // row-major for numpy
        rows.into_pyarray(py).reshape([j.nrows(), j.ncols()])
    }
});

ask_tell_class!("GoldenSection", PyGoldenSection, GoldenSection, {
    #[new]
    #[pyo3(signature = (q0, *, low=None, high=None, mode=None, tol=None, q_tol=None,
        max_trials=None, max_expansions=None, noise=None, max_repeats=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        q0: PyReadonlyArray1<'_, f64>,
        low: Option<PyReadonlyArray1<'_, f64>>,
        high: Option<PyReadonlyArray1<'_, f64>>,
        mode: Option<&str>,
        tol: Option<f64>,
        q_tol: Option<f64>,
        max_trials: Option<usize>,
        max_expansions: Option<usize>,
        noise: Option<f64>,
        max_repeats: Option<usize>,
    ) -> PyResult<Self> {
        let d = GoldenConfig::default();
        let mode = match mode {
            None => d.mode,
            Some("paper") => GoldenMode::Paper,
            Some("robust") => GoldenMode::Robust,
            Some(other) => {
                return Err(invalid_input(format!(
                    "mode = {other:?} is invalid: use \"paper\" or \"robust\""
                )));
            }
        };
        let cfg = GoldenConfig {
            mode,
            tol: tol.unwrap_or(d.tol),
            q_tol: q_tol.or(d.q_tol),
            max_trials: max_trials.unwrap_or(d.max_trials),
            max_expansions: max_expansions.unwrap_or(d.max_expansions),
            noise: noise.or(d.noise),
            max_repeats: max_repeats.unwrap_or(d.max_repeats),
        };
        let q0 = scalar_entry("q0", slice("q0", &q0)?).py_err()?;
        let (low, high) = (
            limit("low", &low, "golden section")?,
            limit("high", &high, "golden section")?,
        );
        Ok(Self {
            inner: GoldenSection::new(q0, low, high, cfg).py_err()?,
        })
    }

    /// The current search limits (q_l, q_h).
    #[getter]
    fn bracket(&self) -> (f64, f64) {
        self.inner.bracket()
    }

    /// How many limits the noise guard re-opened.
    #[getter]
    fn reopened(&self) -> usize {
        self.inner.reopened()
    }
});

ask_tell_class!(
    "IllinoisRootFinder",
    PyIllinoisRootFinder,
    IllinoisRootFinder,
    {
        #[new]
        #[pyo3(signature = (q0, *, low=None, high=None, tol=None, q_tol=None, max_trials=None,
                            max_expansions=None))]
        fn new(
            q0: PyReadonlyArray1<'_, f64>,
            low: Option<PyReadonlyArray1<'_, f64>>,
            high: Option<PyReadonlyArray1<'_, f64>>,
            tol: Option<f64>,
            q_tol: Option<f64>,
            max_trials: Option<usize>,
            max_expansions: Option<usize>,
        ) -> PyResult<Self> {
            let d = RootFinderConfig::default();
            let cfg = RootFinderConfig {
                tol: tol.unwrap_or(d.tol),
                q_tol: q_tol.or(d.q_tol),
                max_trials: max_trials.unwrap_or(d.max_trials),
                max_expansions: max_expansions.unwrap_or(d.max_expansions),
            };
            let q0 = scalar_entry("q0", slice("q0", &q0)?).py_err()?;
            let (low, high) = (
                limit("low", &low, "the root finder")?,
                limit("high", &high, "the root finder")?,
            );
            Ok(Self {
                inner: IllinoisRootFinder::new(q0, low, high, cfg).py_err()?,
            })
        }

        /// The current bracket (a, b).
        #[getter]
        fn bracket(&self) -> (f64, f64) {
            self.inner.bracket()
        }

        /// The expansions of (low, high) so far.
        #[getter]
        fn expansions(&self) -> (usize, usize) {
            self.inner.expansions()
        }
    }
);

ask_tell_class!("PolicyGradient", PyPolicyGradient, PolicyGradient, {
    #[new]
    #[pyo3(signature = (q0, *, low=None, high=None, alpha0=None, decay=None, delta=None,
        scale=None, evaluate_center=None, tol=None, max_trials=None, pin_limit=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        q0: PyReadonlyArray1<'_, f64>,
        low: Option<PyReadonlyArray1<'_, f64>>,
        high: Option<PyReadonlyArray1<'_, f64>>,
        alpha0: Option<f64>,
        decay: Option<f64>,
        delta: Option<f64>,
        scale: Option<f64>,
        evaluate_center: Option<bool>,
        tol: Option<f64>,
        max_trials: Option<usize>,
        pin_limit: Option<usize>,
    ) -> PyResult<Self> {
        let d = PolicyGradientConfig::default();
        let cfg = PolicyGradientConfig {
            alpha0: alpha0.or(d.alpha0),
            decay: decay.unwrap_or(d.decay),
            delta: delta.or(d.delta),
            scale: scale.unwrap_or(d.scale),
            evaluate_center: evaluate_center.unwrap_or(d.evaluate_center),
            low: opt_vec("low", &low)?,
            high: opt_vec("high", &high)?,
            tol: tol.unwrap_or(d.tol),
            max_trials: max_trials.unwrap_or(d.max_trials),
            pin_limit: pin_limit.unwrap_or(d.pin_limit),
        };
        Ok(Self {
            inner: PolicyGradient::new(slice("q0", &q0)?, cfg).py_err()?,
        })
    }

    /// The current iterate q_m.
    #[getter]
    fn center<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        vector(py, self.inner.center())
    }
});

ask_tell_class!("PoWER", PyPower, Power, {
    #[new]
    #[pyo3(signature = (theta0, sigma, *, seed=None, n_best=None, adapt_variance=None,
        variance_window=None, target_return=None, max_trials=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        theta0: PyReadonlyArray1<'_, f64>,
        sigma: PyReadonlyArray1<'_, f64>,
        seed: Option<u64>,
        n_best: Option<usize>,
        adapt_variance: Option<bool>,
        variance_window: Option<usize>,
        target_return: Option<f64>,
        max_trials: Option<usize>,
    ) -> PyResult<Self> {
        let d = PowerConfig::default();
        let cfg = PowerConfig {
            n_best: n_best.unwrap_or(d.n_best),
            adapt_variance: adapt_variance.unwrap_or(d.adapt_variance),
            variance_window: variance_window.unwrap_or(d.variance_window),
            target_return: target_return.or(d.target_return),
            max_trials: max_trials.unwrap_or(d.max_trials),
            seed: seed.unwrap_or(d.seed),
        };
        let (theta0, sigma) = (slice("theta0", &theta0)?, slice("sigma", &sigma)?);
        Ok(Self {
            inner: Power::new(theta0, sigma, cfg).py_err()?,
        })
    }

    /// The current mean weight vector.
    #[getter]
    fn mean<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        vector(py, self.inner.mean())
    }

    /// The current exploration variance per weight.
    #[getter]
    fn variance<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        vector(py, self.inner.variance())
    }
});

ask_tell_class!("PI2", PyPi2, Pi2, {
    #[new]
    #[pyo3(signature = (theta0, sigma, *, seed=None, n_rollouts=None, n_reuse=None, h=None,
        n_updates=None, n_dof=None, n_steps=None, alpha_x=None, width_factor=None,
        projection=None, cost_tol=None, max_trials=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        theta0: PyReadonlyArray1<'_, f64>,
        sigma: PyReadonlyArray1<'_, f64>,
        seed: Option<u64>,
        n_rollouts: Option<usize>,
        n_reuse: Option<usize>,
        h: Option<f64>,
        n_updates: Option<usize>,
        n_dof: Option<usize>,
        n_steps: Option<usize>,
        alpha_x: Option<f64>,
        width_factor: Option<f64>,
        projection: Option<bool>,
        cost_tol: Option<f64>,
        max_trials: Option<usize>,
    ) -> PyResult<Self> {
        let d = Pi2Config::default();
        let cfg = Pi2Config {
            n_rollouts: n_rollouts.unwrap_or(d.n_rollouts),
            n_reuse: n_reuse.unwrap_or(d.n_reuse),
            h: h.unwrap_or(d.h),
            n_updates: n_updates.unwrap_or(d.n_updates),
            n_dof: n_dof.unwrap_or(d.n_dof),
            n_steps: n_steps.unwrap_or(d.n_steps),
            alpha_x: alpha_x.unwrap_or(d.alpha_x),
            width_factor: width_factor.unwrap_or(d.width_factor),
            projection: projection.unwrap_or(d.projection),
            cost_tol: cost_tol.or(d.cost_tol),
            max_trials: max_trials.unwrap_or(d.max_trials),
            seed: seed.unwrap_or(d.seed),
        };
        let (theta0, sigma) = (slice("theta0", &theta0)?, slice("sigma", &sigma)?);
        Ok(Self {
            inner: Pi2::new(theta0, sigma, cfg).py_err()?,
        })
    }

    /// The current weight vector.
    #[getter]
    fn theta<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        vector(py, self.inner.theta())
    }

    /// Updates completed.
    #[getter]
    fn n_updates_done(&self) -> usize {
        self.inner.n_updates_done()
    }

    /// Whether the last asked query is an evaluation rollout (noiseless, of the current theta).
    #[getter]
    fn asked_evaluation(&self) -> bool {
        self.inner.asked_evaluation()
    }
});
