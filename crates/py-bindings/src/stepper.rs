//! `dmprs._core.Stepper` and `CartesianStepper`: the online steppers of `dmp-core` for a control
//! loop. `dmprs.stepper` (Python) subclasses them, validates the options and documents them.
//!
//! `step` is called once per control period, so it must cost little more than the Rust step:
//! it writes into three preallocated read-only numpy arrays and returns one cached tuple of
//! them (no allocation per call), and reads a measured state or a coupling term straight from
//! a float64 numpy array (anything else array-like goes through a slower conversion).

use dmp_core::coupling::{ObstacleGains, SphereObstacle};
use dmp_core::temporal_coupling::TemporalCouplingGains;
use dmp_core::{CartesianStepper, CartesianStepperOptions, Stepper, StepperOptions};
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};

use crate::cartesian::PyCartesianDmp;
use crate::dmp::{PyDmp, contiguous};
use crate::errors::{IntoPyResult, invalid_input};

/// Three read-only float64 arrays that `step` overwrites, and the tuple that holds them.
pub(crate) struct Outputs {
    arrays: [Py<PyArray1<f64>>; 3],
    tuple: Py<PyTuple>,
}

impl Outputs {
    pub(crate) fn new(py: Python<'_>, lengths: [usize; 3]) -> PyResult<Self> {
        let arrays = lengths.map(|n| {
            let a = PyArray1::<f64>::zeros(py, n, false);
            // SAFETY: `a` is a live array this function owns; clearing a flag bit is what
            // numpy's PyArray_CLEARFLAGS does.
            unsafe {
                (*a.as_array_ptr()).fields.flags &= !numpy::npyffi::flags::NPY_ARRAY_WRITEABLE;
            }
            a.unbind()
        });
        let tuple = PyTuple::new(py, arrays.iter().map(|a| a.clone_ref(py)))?.unbind();
        Ok(Self { arrays, tuple })
    }

    /// Copies `values` into output `i`. The arrays' data pointers are read
    /// on every call, so a caller who resized one (`resize(refcheck=False)`) gets an error, not a
    /// write to freed memory.
    pub(crate) fn write(&self, py: Python<'_>, i: usize, values: &[f64]) -> PyResult<()> {
        let a = self.arrays[i].bind(py);
        if a.len() != values.len() || !a.is_contiguous() {
            return Err(invalid_input(
                "a stepper's output array was resized or replaced; create a new stepper",
            ));
        }
        // SAFETY: the array is a contiguous float64 array of `values.len()` elements (checked
        // just above) that this object created and keeps alive; the GIL is held, no Rust
        // reference to its data exists (measured and coupling were copied out before the step),
        // and it is only written here.
        unsafe {
            std::ptr::copy_nonoverlapping(values.as_ptr(), a.data(), values.len());
        }
        Ok(())
    }

    pub(crate) fn tuple(&self, py: Python<'_>) -> Py<PyTuple> {
        self.tuple.clone_ref(py)
    }
}

/// `value` (a 1-D float64 array, or anything `list[float]` accepts) copied into `buf`, which
/// keeps its capacity across calls: the fast path neither allocates nor keeps a borrow of the
/// caller's array while the step writes its outputs.
pub(crate) fn read_vector(
    name: &str,
    value: &Bound<'_, PyAny>,
    buf: &mut Vec<f64>,
) -> PyResult<()> {
    buf.clear();
    if let Ok(a) = value.cast::<PyArray1<f64>>() {
        let a = a.readonly();
        if let Ok(s) = a.as_slice() {
            buf.extend_from_slice(s);
            return Ok(());
        }
        buf.extend(a.as_array().iter().copied());
        return Ok(());
    }
    // Anything else goes through numpy's reading, refused unless it is a 1-D array of real
    // numbers: a complex value would lose its imaginary part, a bool is no position.
    let refused = || {
        invalid_input(format!(
            "{name} must be a 1-D array of real numbers (float or integer); got {}",
            value
                .get_type()
                .name()
                .map(|n| n.to_string())
                .unwrap_or_else(|_| "an object".into())
        ))
    };
    let arr = value
        .py()
        .import("numpy")?
        .call_method1("asarray", (value,))
        .map_err(|_| refused())?;
    let kind: String = arr.getattr("dtype")?.getattr("kind")?.extract()?;
    let ndim: usize = arr.getattr("ndim")?.extract()?;
    if ndim != 1 || !matches!(kind.as_str(), "f" | "i" | "u") {
        return Err(refused());
    }
    let v: Vec<f64> = arr
        .call_method1("astype", ("float64",))?
        .extract()
        .map_err(|_| refused())?;
    buf.extend_from_slice(&v);
    Ok(())
}

/// The options both steppers share, as `dmprs.stepper` passes them: a dict with these keys,
/// validated there.
#[derive(FromPyObject)]
#[pyo3(from_item_all)]
pub(crate) struct SharedOptions {
    substeps: Option<usize>,
    alpha_e: Vec<f64>,
    goal_filter: Option<f64>,
    velocity_max: Option<Vec<f64>>,
    acceleration_max: Option<Vec<f64>>,
    position_min: Option<Vec<f64>>,
    position_max: Option<Vec<f64>>,
    limit_margin: Option<Vec<f64>>,
    limit_gain: f64,
    gamma_nominal: f64,
    gamma_a: f64,
    eps: f64,
    rest_tol: f64,
}

impl SharedOptions {
    /// The core's options at control period `dt`.
    pub(crate) fn at(self, dt: f64) -> StepperOptions {
        StepperOptions {
            dt,
            substeps: self.substeps,
            alpha_e: self.alpha_e,
            goal_filter: self.goal_filter,
            velocity_max: self.velocity_max,
            acceleration_max: self.acceleration_max,
            temporal_coupling: TemporalCouplingGains {
                nominal: self.gamma_nominal,
                potential: self.gamma_a,
                eps: self.eps,
            },
            position_min: self.position_min,
            position_max: self.position_max,
            limit_margin: self.limit_margin,
            limit_gain: self.limit_gain,
            rest_tol: self.rest_tol,
        }
    }
}

#[pyclass(name = "Stepper", module = "dmprs._core", subclass)]
pub struct PyStepper {
    inner: Stepper,
    out: Outputs,
    measured: Vec<f64>,
    coupling: Vec<f64>,
}

/// The defaults of the core's options, for the Python signatures (one home for them).
fn defaults(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    let base = StepperOptions::new(1.0);
    let tc = base.temporal_coupling;
    let obstacle = ObstacleGains::default();
    let d = PyDict::new(py);
    d.set_item("alpha_e", dmp_core::stepper::DEFAULT_ALPHA_E)?;
    d.set_item("goal_filter", dmp_core::stepper::DEFAULT_GOAL_FILTER)?;
    d.set_item("limit_gain", base.limit_gain)?;
    d.set_item("rest_tol", base.rest_tol)?;
    d.set_item("gamma_nominal", tc.nominal)?;
    d.set_item("gamma_a", tc.potential)?;
    d.set_item("eps", tc.eps)?;
    d.set_item("obstacle_gain", obstacle.lambda)?;
    d.set_item("obstacle_beta", obstacle.beta)?;
    Ok(d)
}

#[pymethods]
impl PyStepper {
    #[classattr]
    #[pyo3(name = "DEFAULTS")]
    fn class_defaults(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
        defaults(py)
    }

    /// `Stepper(dmp, dt, options)`; `Stepper.__new__(cls, stepper)` is a copy of `stepper` as a
    /// `cls` (what `copy.copy` and `copy.deepcopy` call, so that a subclass stays one).
    #[new]
    #[pyo3(signature = (dmp, dt=None, options=None))]
    fn new(
        py: Python<'_>,
        dmp: &Bound<'_, PyAny>,
        dt: Option<f64>,
        options: Option<SharedOptions>,
    ) -> PyResult<Self> {
        let (dt, options) = match (dt, options) {
            (Some(dt), Some(options)) => (dt, options),
            (None, None) if dmp.is_instance_of::<Self>() => {
                return dmp.cast::<Self>()?.borrow().duplicate(py);
            }
            _ => return Err(invalid_input("Stepper takes a DMP, dt and the options")),
        };
        let dmp: PyRef<'_, PyDmp> = dmp.extract()?;
        let opts = options.at(dt);
        let inner = Stepper::new(&dmp.inner, &opts).py_err()?;
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

    #[getter]
    fn n_dof(&self) -> usize {
        self.inner.n_dof()
    }
}

impl PyStepper {
    /// An independent stepper in this one's state, with its own output arrays (holding this
    /// one's last command): its steps are this one's, bit for bit.
    fn duplicate(&self, py: Python<'_>) -> PyResult<Self> {
        let n = self.inner.n_dof();
        let s = Self {
            inner: self.inner.clone(),
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

#[pyclass(name = "CartesianStepper", module = "dmprs._core", subclass)]
pub struct PyCartesianStepper {
    inner: CartesianStepper,
    out: Outputs,
    measured: Vec<f64>,
    coupling: Vec<f64>,
}

/// `(M, 4)` rows `x, y, z, radius` as sphere obstacles.
fn spheres(obstacles: Option<PyReadonlyArray2<'_, f64>>) -> PyResult<Vec<SphereObstacle>> {
    let Some(o) = obstacles else {
        return Ok(Vec::new());
    };
    if o.shape()[1] != 4 {
        return Err(invalid_input(format!(
            "obstacles has shape ({}, {}), expected (M, 4): x, y, z, radius per sphere",
            o.shape()[0],
            o.shape()[1]
        )));
    }
    Ok(contiguous("obstacles", &o)?
        .chunks_exact(4)
        .map(|r| SphereObstacle {
            center: [r[0], r[1], r[2]],
            radius: r[3],
        })
        .collect())
}

/// The Cartesian stepper's options at control period `dt`, as `dmprs.stepper` passes them.
pub(crate) fn cartesian_options(
    dt: f64,
    options: SharedOptions,
    obstacles: Option<PyReadonlyArray2<'_, f64>>,
    obstacle_gain: f64,
    obstacle_beta: f64,
) -> PyResult<CartesianStepperOptions> {
    Ok(CartesianStepperOptions {
        base: options.at(dt),
        obstacles: spheres(obstacles)?,
        obstacle_gains: ObstacleGains {
            lambda: obstacle_gain,
            beta: obstacle_beta,
        },
    })
}

/// The obstacles as `CartesianStepper.obstacles` gives them: `(M, 4)` rows `x, y, z, radius`.
pub(crate) fn obstacle_rows<'py>(
    py: Python<'py>,
    obstacles: &[SphereObstacle],
) -> PyResult<Bound<'py, numpy::PyArray2<f64>>> {
    let rows: Vec<f64> = obstacles
        .iter()
        .flat_map(|o| [o.center[0], o.center[1], o.center[2], o.radius])
        .collect();
    let m = rows.len() / 4;
    PyArray1::from_vec(py, rows).reshape([m, 4])
}

#[pymethods]
impl PyCartesianStepper {
    /// As [`PyStepper::new`]: `CartesianStepper.__new__(cls, stepper)` is a copy.
    #[new]
    #[pyo3(signature = (dmp, dt=None, options=None, obstacles=None, obstacle_gain=None, obstacle_beta=None))]
    fn new(
        py: Python<'_>,
        dmp: &Bound<'_, PyAny>,
        dt: Option<f64>,
        options: Option<SharedOptions>,
        obstacles: Option<PyReadonlyArray2<'_, f64>>,
        obstacle_gain: Option<f64>,
        obstacle_beta: Option<f64>,
    ) -> PyResult<Self> {
        let (dt, options, obstacle_gain, obstacle_beta) =
            match (dt, options, obstacle_gain, obstacle_beta) {
                (Some(dt), Some(options), Some(gain), Some(beta)) => (dt, options, gain, beta),
                (None, None, None, None) if obstacles.is_none() && dmp.is_instance_of::<Self>() => {
                    return dmp.cast::<Self>()?.borrow().duplicate(py);
                }
                _ => {
                    return Err(invalid_input(
                        "CartesianStepper takes a CartesianDMP, dt, the options, obstacles and \
                         the obstacle gains",
                    ));
                }
            };
        let dmp: PyRef<'_, PyCartesianDmp> = dmp.extract()?;
        let opts = cartesian_options(dt, options, obstacles, obstacle_gain, obstacle_beta)?;
        let inner = CartesianStepper::new(&dmp.inner, &opts).py_err()?;
        let s = Self {
            inner,
            out: Outputs::new(py, [7, 6, 6])?,
            measured: Vec::with_capacity(7),
            coupling: Vec::with_capacity(6),
        };
        s.publish(py)?;
        Ok(s)
    }

    fn set_obstacles(&mut self, obstacles: Option<PyReadonlyArray2<'_, f64>>) -> PyResult<()> {
        self.inner.set_obstacles(&spheres(obstacles)?).py_err()
    }

    #[getter]
    fn obstacles<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, numpy::PyArray2<f64>>> {
        obstacle_rows(py, self.inner.obstacles())
    }
}

impl PyCartesianStepper {
    /// As [`PyStepper::duplicate`].
    fn duplicate(&self, py: Python<'_>) -> PyResult<Self> {
        let s = Self {
            inner: self.inner.clone(),
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

/// The methods both stepper classes share, over their `inner` core stepper, `out` arrays and
/// `measured`/`coupling` buffers; `$step_doc` documents `step`'s output.
macro_rules! stepper_methods {
    ($class:ty, $step_doc:literal) => {
        #[pymethods]
        impl $class {
            #[doc = $step_doc]
            #[pyo3(signature = (measured=None, coupling=None))]
            fn step(
                &mut self,
                py: Python<'_>,
                measured: Option<&Bound<'_, PyAny>>,
                coupling: Option<&Bound<'_, PyAny>>,
            ) -> PyResult<Py<PyTuple>> {
                if let Some(m) = measured {
                    read_vector("measured", m, &mut self.measured)?;
                }
                if let Some(c) = coupling {
                    read_vector("coupling", c, &mut self.coupling)?;
                }
                self.inner
                    .step_coupled(
                        measured.map(|_| self.measured.as_slice()),
                        coupling.map(|_| self.coupling.as_slice()),
                    )
                    .py_err()?;
                self.publish(py)?;
                Ok(self.out.tuple(py))
            }

            /// An independent copy in this stepper's state (the core stepper is plain data,
            /// so a shallow copy is a deep one): its next steps equal this one's bit for bit.
            fn __copy__<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyAny>> {
                // The base class's constructor with the caller's class: a JointStepper's copy
                // is a JointStepper, without its Python constructor's arguments.
                slf.py()
                    .get_type::<Self>()
                    .getattr("__new__")?
                    .call1((slf.get_type(), slf))
            }

            fn __deepcopy__<'py>(
                slf: &Bound<'py, Self>,
                memo: &Bound<'py, PyAny>,
            ) -> PyResult<Bound<'py, PyAny>> {
                // Nothing inside refers to another Python object: `memo` has nothing to share.
                let _ = memo;
                Self::__copy__(slf)
            }

            #[pyo3(signature = (start=None))]
            fn reset(&mut self, py: Python<'_>, start: Option<&Bound<'_, PyAny>>) -> PyResult<()> {
                match start {
                    Some(s) => {
                        read_vector("start", s, &mut self.measured)?;
                        self.inner.reset(Some(&self.measured)).py_err()?;
                    }
                    None => self.inner.reset(None).py_err()?,
                }
                self.publish(py)
            }

            fn set_goal(&mut self, goal: &Bound<'_, PyAny>) -> PyResult<()> {
                read_vector("goal", goal, &mut self.measured)?;
                self.inner.set_goal(&self.measured).py_err()
            }

            fn set_tau(&mut self, tau: f64) -> PyResult<()> {
                self.inner.set_tau(tau).py_err()
            }

            /// The last command (the start at rest before the first step).
            #[getter]
            fn output(&self, py: Python<'_>) -> Py<PyTuple> {
                self.out.tuple(py)
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
            fn done(&self) -> bool {
                self.inner.done()
            }
            /// Whether the last command's acceleration exceeds `acceleration_max` (where the
            /// temporal coupling's feasibility condition fails; docs/method.md §2.5.4).
            fn over_limit(&self) -> bool {
                self.inner.over_limit()
            }
            /// Whether the last command came to rest away from its goal (an obstacle, a limit
            /// or a coupling holds it): further steps repeat it until the goal, the obstacles
            /// or the coupling change.
            fn blocked(&self) -> bool {
                self.inner.blocked()
            }
            #[getter]
            fn steps(&self) -> u64 {
                self.inner.steps()
            }
            #[getter]
            fn goal<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
                PyArray1::from_slice(py, &self.inner.goal()[..])
            }
            #[getter]
            fn goal_target<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
                PyArray1::from_slice(py, &self.inner.goal_target()[..])
            }
            #[getter]
            fn dt(&self) -> f64 {
                self.inner.dt()
            }
            #[getter]
            fn substeps(&self) -> usize {
                self.inner.substeps()
            }
        }
    };
}

/// For the sequence's stepper, which has the same surface (`crate::sequence`).
pub(crate) use stepper_methods;

stepper_methods!(
    PyStepper,
    "One control period: `(y, yd, ydd)` of this period (read-only arrays that the next call \
     overwrites), then the state advances by dt."
);
stepper_methods!(
    PyCartesianStepper,
    "One control period: `(pose, velocity, acceleration)` of this period, pose \
     `[x, y, z, qw, qx, qy, qz]`, velocity `[v, omega]`, acceleration `[a, omegadot]` (read-only \
     arrays that the next call overwrites), then the state advances by dt."
);
