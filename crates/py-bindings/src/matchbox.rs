//! `dmprs._core.MatchboxConfig`, `matchbox_simulate`, `matchbox_simulate_batch`, `matchbox_check`:
//! the Rapier matchbox simulation of the `matchbox` crate, numpy in and out, GIL released.

use matchbox::{Episode, FingerPath, MatchboxConfig, simulate, simulate_batch};
use numpy::{IntoPyArray, PyReadonlyArray1};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::errors::{IntoPyResult, invalid_input};

#[pyclass(name = "MatchboxConfig", module = "dmprs._core", frozen)]
#[derive(Clone)]
pub struct PyMatchboxConfig {
    pub inner: MatchboxConfig,
}

#[pymethods]
impl PyMatchboxConfig {
    #[new]
    #[pyo3(signature = (*, box_size=None, box_mass=None, overhang=None, friction=None,
        restitution=None, finger_radius=None, dt=None, solver_iterations=None, settle_time=None,
        delta_t=None, upright_tolerance=None, upright_hold=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        box_size: Option<[f64; 3]>,
        box_mass: Option<f64>,
        overhang: Option<f64>,
        friction: Option<f64>,
        restitution: Option<f64>,
        finger_radius: Option<f64>,
        dt: Option<f64>,
        solver_iterations: Option<usize>,
        settle_time: Option<f64>,
        delta_t: Option<f64>,
        upright_tolerance: Option<f64>,
        upright_hold: Option<f64>,
    ) -> PyResult<Self> {
        let d = MatchboxConfig::default();
        let inner = MatchboxConfig {
            box_size: box_size.unwrap_or(d.box_size),
            box_mass: box_mass.unwrap_or(d.box_mass),
            overhang: overhang.unwrap_or(d.overhang),
            friction: friction.unwrap_or(d.friction),
            restitution: restitution.unwrap_or(d.restitution),
            finger_radius: finger_radius.unwrap_or(d.finger_radius),
            dt: dt.unwrap_or(d.dt),
            solver_iterations: solver_iterations.unwrap_or(d.solver_iterations),
            settle_time: settle_time.unwrap_or(d.settle_time),
            delta_t: delta_t.unwrap_or(d.delta_t),
            upright_tolerance: upright_tolerance.unwrap_or(d.upright_tolerance),
            upright_hold: upright_hold.unwrap_or(d.upright_hold),
            ..d
        };
        inner.validate().py_err()?;
        Ok(Self { inner })
    }

    /// All parameters as a dict (for logs and repr).
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let c = &self.inner;
        let d = PyDict::new(py);
        d.set_item("box_size", c.box_size.to_vec())?;
        d.set_item("box_mass", c.box_mass)?;
        d.set_item("overhang", c.overhang)?;
        d.set_item("friction", c.friction)?;
        d.set_item("restitution", c.restitution)?;
        d.set_item("finger_radius", c.finger_radius)?;
        d.set_item("dt", c.dt)?;
        d.set_item("solver_iterations", c.solver_iterations)?;
        d.set_item("settle_time", c.settle_time)?;
        d.set_item("delta_t", c.delta_t)?;
        d.set_item("upright_tolerance", c.upright_tolerance)?;
        d.set_item("upright_hold", c.upright_hold)?;
        d.set_item("workspace_x", c.workspace_x.to_vec())?;
        d.set_item("workspace_z", c.workspace_z.to_vec())?;
        Ok(d)
    }

    /// ((x, z) start, (x, z) goal) of the default strike, m.
    fn default_strike(&self) -> ([f64; 2], [f64; 2]) {
        self.inner.default_strike()
    }
}

fn slices<'a>(
    t: &'a PyReadonlyArray1<'_, f64>,
    x: &'a PyReadonlyArray1<'_, f64>,
    z: &'a PyReadonlyArray1<'_, f64>,
) -> PyResult<FingerPath<'a>> {
    let get = |name: &str, a: &'a PyReadonlyArray1<'_, f64>| {
        a.as_slice()
            .map_err(|_| invalid_input(format!("{name} must be a contiguous array")))
    };
    Ok(FingerPath {
        t: get("t", t)?,
        x: get("x", x)?,
        z: get("z", z)?,
    })
}

fn episode_dict(py: Python<'_>, ep: Episode) -> PyResult<Bound<'_, PyDict>> {
    let m = ep.measures;
    let d = PyDict::new(py);
    d.set_item("t", ep.t.into_pyarray(py))?;
    d.set_item("phi", ep.phi.into_pyarray(py))?;
    d.set_item("box_z", ep.box_z.into_pyarray(py))?;
    d.set_item("phi_max", m.phi_max)?;
    d.set_item("t0", m.t0)?;
    d.set_item("phi_after", m.phi_after)?;
    d.set_item("outcome_angle", m.outcome_angle)?;
    d.set_item("eps18", m.eps18)?;
    d.set_item("regime", m.regime.as_str())?;
    Ok(d)
}

/// Every reason the fingertip path (t, x, z) is unusable; empty if none.
#[pyfunction]
pub fn matchbox_check(
    t: PyReadonlyArray1<'_, f64>,
    x: PyReadonlyArray1<'_, f64>,
    z: PyReadonlyArray1<'_, f64>,
    config: &PyMatchboxConfig,
) -> PyResult<Vec<String>> {
    Ok(slices(&t, &x, &z)?.problems(&config.inner))
}

/// Simulates one strike; returns the episode's arrays and measures.
#[pyfunction]
pub fn matchbox_simulate<'py>(
    py: Python<'py>,
    t: PyReadonlyArray1<'py, f64>,
    x: PyReadonlyArray1<'py, f64>,
    z: PyReadonlyArray1<'py, f64>,
    config: &PyMatchboxConfig,
) -> PyResult<Bound<'py, PyDict>> {
    let path = slices(&t, &x, &z)?;
    let cfg = config.inner;
    let ep = py.detach(|| simulate(&path, &cfg)).py_err()?;
    episode_dict(py, ep)
}

/// Simulates many strikes on all cores. Every path is checked first; a bad one raises naming its
/// index, before anything runs.
#[pyfunction]
pub fn matchbox_simulate_batch<'py>(
    py: Python<'py>,
    paths: Vec<(
        PyReadonlyArray1<'py, f64>,
        PyReadonlyArray1<'py, f64>,
        PyReadonlyArray1<'py, f64>,
    )>,
    config: &PyMatchboxConfig,
) -> PyResult<Vec<Bound<'py, PyDict>>> {
    let cfg = config.inner;
    let views: Vec<FingerPath> = paths
        .iter()
        .map(|(t, x, z)| slices(t, x, z))
        .collect::<PyResult<_>>()?;
    for (i, p) in views.iter().enumerate() {
        let problems = p.problems(&cfg);
        if !problems.is_empty() {
            return Err(invalid_input(format!(
                "paths[{i}]: {}",
                problems.join("; ")
            )));
        }
    }
    let episodes = py.detach(|| simulate_batch(&views, &cfg));
    episodes
        .into_iter()
        .map(|e| episode_dict(py, e.py_err()?))
        .collect()
}
