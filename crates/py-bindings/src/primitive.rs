//! What `Dmp` and `CartesianDmp` share in Python: the constants as one argument, and one set of
//! parameter getters generated for both classes.

use dmp_core::{Basis, CartesianDmp, Dmp, DmpConfig};
use nalgebra::DMatrix;
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArrayMethods};
use pyo3::prelude::*;

/// The DMP's constants as Python passes them: a dict with these keys (`dmprs.dmp._constants`
/// builds it, validated), for DMPs, their fits and the generalizers alike.
#[derive(FromPyObject, Clone, Copy)]
#[pyo3(from_item_all)]
pub(crate) struct Constants {
    alpha_z: f64,
    beta_z: f64,
    alpha_x: f64,
    width_factor: f64,
}

impl Constants {
    /// The core's configuration with `n_basis` kernels.
    pub(crate) fn config(self, n_basis: usize) -> DmpConfig {
        DmpConfig {
            n_basis,
            alpha_z: self.alpha_z,
            beta_z: self.beta_z,
            alpha_x: self.alpha_x,
            width_factor: self.width_factor,
        }
    }
}

/// The parameters every primitive of the core has, as the getters read them.
pub(crate) trait Parameters {
    fn config(&self) -> &DmpConfig;
    fn basis(&self) -> &Basis;
    /// `N x D` (column d: DOF d, or coordinate d of a pose: x, y, z, then the orientation's 3).
    fn weights(&self) -> &DMatrix<f64>;
    fn tau(&self) -> f64;
    fn n_dof(&self) -> usize;
    fn goal(&self) -> Vec<f64>;
    fn start(&self) -> Vec<f64>;
}

impl Parameters for Dmp {
    fn config(&self) -> &DmpConfig {
        Dmp::config(self)
    }
    fn basis(&self) -> &Basis {
        Dmp::basis(self)
    }
    fn weights(&self) -> &DMatrix<f64> {
        Dmp::weights(self)
    }
    fn tau(&self) -> f64 {
        Dmp::tau(self)
    }
    fn n_dof(&self) -> usize {
        Dmp::n_dof(self)
    }
    fn goal(&self) -> Vec<f64> {
        Dmp::goal(self).as_slice().to_vec()
    }
    fn start(&self) -> Vec<f64> {
        self.y0().as_slice().to_vec()
    }
}

impl Parameters for CartesianDmp {
    fn config(&self) -> &DmpConfig {
        CartesianDmp::config(self)
    }
    fn basis(&self) -> &Basis {
        CartesianDmp::basis(self)
    }
    fn weights(&self) -> &DMatrix<f64> {
        CartesianDmp::weights(self)
    }
    fn tau(&self) -> f64 {
        CartesianDmp::tau(self)
    }
    fn n_dof(&self) -> usize {
        // three translations and three rotations, as a CartesianTrajectory counts them
        CartesianDmp::weights(self).ncols()
    }
    fn goal(&self) -> Vec<f64> {
        CartesianDmp::goal(self).to_vec()
    }
    fn start(&self) -> Vec<f64> {
        CartesianDmp::start(self).to_vec()
    }
}

/// The weights as the `(D, N)` array Python sees (the core's `N x D` column-major matrix is that
/// array's C order).
pub(crate) fn weights_array<'py>(
    py: Python<'py>,
    w: &DMatrix<f64>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    w.as_slice()
        .to_vec()
        .into_pyarray(py)
        .reshape([w.ncols(), w.nrows()])
}

pub(crate) fn vector_array<'py>(py: Python<'py>, v: Vec<f64>) -> Bound<'py, PyArray1<f64>> {
    v.into_pyarray(py)
}

/// The parameter getters of a primitive class whose `inner` implements [`Parameters`].
macro_rules! parameter_getters {
    ($class:ty) => {
        #[pyo3::pymethods]
        impl $class {
            /// `(D, N)`
            #[getter]
            fn weights<'py>(
                &self,
                py: pyo3::Python<'py>,
            ) -> pyo3::PyResult<pyo3::Bound<'py, numpy::PyArray2<f64>>> {
                $crate::primitive::weights_array(
                    py,
                    $crate::primitive::Parameters::weights(&self.inner),
                )
            }
            #[getter]
            fn goal<'py>(&self, py: pyo3::Python<'py>) -> pyo3::Bound<'py, numpy::PyArray1<f64>> {
                $crate::primitive::vector_array(
                    py,
                    $crate::primitive::Parameters::goal(&self.inner),
                )
            }
            #[getter]
            fn start<'py>(&self, py: pyo3::Python<'py>) -> pyo3::Bound<'py, numpy::PyArray1<f64>> {
                $crate::primitive::vector_array(
                    py,
                    $crate::primitive::Parameters::start(&self.inner),
                )
            }
            #[getter]
            fn tau(&self) -> f64 {
                $crate::primitive::Parameters::tau(&self.inner)
            }
            #[getter]
            fn n_dof(&self) -> usize {
                $crate::primitive::Parameters::n_dof(&self.inner)
            }
            #[getter]
            fn n_basis(&self) -> usize {
                $crate::primitive::Parameters::config(&self.inner).n_basis
            }
            #[getter]
            fn alpha_z(&self) -> f64 {
                $crate::primitive::Parameters::config(&self.inner).alpha_z
            }
            #[getter]
            fn beta_z(&self) -> f64 {
                $crate::primitive::Parameters::config(&self.inner).beta_z
            }
            #[getter]
            fn alpha_x(&self) -> f64 {
                $crate::primitive::Parameters::config(&self.inner).alpha_x
            }
            #[getter]
            fn width_factor(&self) -> f64 {
                $crate::primitive::Parameters::config(&self.inner).width_factor
            }
            #[getter]
            fn centers<'py>(
                &self,
                py: pyo3::Python<'py>,
            ) -> pyo3::Bound<'py, numpy::PyArray1<f64>> {
                let basis = $crate::primitive::Parameters::basis(&self.inner);
                $crate::primitive::vector_array(py, basis.centers().to_vec())
            }
            #[getter]
            fn widths<'py>(&self, py: pyo3::Python<'py>) -> pyo3::Bound<'py, numpy::PyArray1<f64>> {
                let basis = $crate::primitive::Parameters::basis(&self.inner);
                $crate::primitive::vector_array(py, basis.widths().to_vec())
            }
        }
    };
}
pub(crate) use parameter_getters;
