//! `dmprs._core.portable_*` and `dls_step`: the machine-independent numerics of
//! `dmp_core::portable`, numpy in, numpy out. `dmprs.portable` (Python) wraps and documents them.

use numpy::{
    IntoPyArray, PyArray1, PyArrayDyn, PyReadonlyArray1, PyReadonlyArray2, PyReadonlyArrayDyn,
    PyUntypedArrayMethods,
};
use pyo3::prelude::*;

use crate::dmp::contiguous;
use crate::errors::{PyErrorClass, invalid_input};

/// `name(x)` elementwise, for a numpy function name that `dmp_core::portable::unary` knows.
#[pyfunction]
pub fn portable_unary<'py>(
    py: Python<'py>,
    name: &str,
    x: PyReadonlyArrayDyn<'py, f64>,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    let f = dmp_core::portable::unary(name)
        .ok_or_else(|| invalid_input(format!("no portable function {name:?}")))?;
    Ok(x.as_array().mapv(f).into_pyarray(py))
}

/// `name(x, y)` elementwise, for arrays of one shape (the caller broadcasts).
#[pyfunction]
pub fn portable_binary<'py>(
    py: Python<'py>,
    name: &str,
    x: PyReadonlyArrayDyn<'py, f64>,
    y: PyReadonlyArrayDyn<'py, f64>,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    let f = dmp_core::portable::binary(name)
        .ok_or_else(|| invalid_input(format!("no portable function {name:?}")))?;
    let (x, y) = (x.as_array(), y.as_array());
    if x.shape() != y.shape() {
        return Err(invalid_input(format!(
            "{name}: the arguments' shapes {:?} and {:?} differ",
            x.shape(),
            y.shape()
        )));
    }
    let mut out = x.to_owned();
    out.zip_mut_with(&y, |a, &b| *a = f(*a, b));
    Ok(out.into_pyarray(py))
}

/// The Euclidean norm of a vector, summed in index order.
#[pyfunction]
pub fn portable_norm(x: PyReadonlyArray1<'_, f64>) -> PyResult<f64> {
    Ok(dmp_core::portable::norm(contiguous("x", &x)?))
}

/// One damped-least-squares step `z + J^+ (e - J z)` (`dmp_core::portable::dls_step`).
#[pyfunction]
pub fn dls_step<'py>(
    py: Python<'py>,
    jac: PyReadonlyArray2<'py, f64>,
    e: PyReadonlyArray1<'py, f64>,
    z: PyReadonlyArray1<'py, f64>,
    damping: f64,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let (m, n) = (jac.shape()[0], jac.shape()[1]);
    let (e, z) = (contiguous("e", &e)?, contiguous("z", &z)?);
    if e.len() != m || z.len() != n {
        return Err(invalid_input(format!(
            "dls_step: jac is {m} x {n}, so e needs {m} values (has {}) and z {n} (has {})",
            e.len(),
            z.len()
        )));
    }
    dmp_core::portable::dls_step(contiguous("jac", &jac)?, m, e, z, damping)
        .map(|dq| dq.into_pyarray(py))
        .ok_or_else(|| {
            PyErrorClass::Numerical.err("dls_step: J J^T + damping^2 I is not positive definite")
        })
}
