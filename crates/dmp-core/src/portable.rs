//! Numerics whose bits do not depend on the machine, for every computation that feeds a chaotic
//! simulator or a learner's branch from Python: elementwise maths and the damped least-squares
//! step of the arm's inverse kinematics.
//!
//! numpy picks its elementwise kernels by the CPU at run time (on AVX-512, its own `exp`, `log`,
//! `sin`, `cos`, `power` and `arctan2`, whose last bits differ from the C library's), and its
//! matrix products and solves go through the BLAS kernel chosen for the CPU. Granular flow
//! amplifies one differing bit into a different pour. The functions here are libm's (a pure-Rust
//! port of musl's, compiled once, with no run-time dispatch) and plain loops in a fixed order.

use crate::linalg::{cholesky_in_place, solve_lower_in_place, solve_upper_t_in_place};

/// An elementwise function of one argument, by its numpy name.
pub fn unary(name: &str) -> Option<fn(f64) -> f64> {
    Some(match name {
        "sin" => libm::sin,
        "cos" => libm::cos,
        "tan" => libm::tan,
        "arcsin" => libm::asin,
        "arccos" => libm::acos,
        "arctan" => libm::atan,
        "exp" => libm::exp,
        "log" => libm::log,
        "tanh" => libm::tanh,
        _ => return None,
    })
}

/// An elementwise function of two arguments, by its numpy name.
pub fn binary(name: &str) -> Option<fn(f64, f64) -> f64> {
    Some(match name {
        "arctan2" => libm::atan2,
        "hypot" => libm::hypot,
        "power" => libm::pow,
        _ => return None,
    })
}

/// The Euclidean norm `sqrt(sum_i v_i^2)`, summed in index order.
pub fn norm(v: &[f64]) -> f64 {
    v.iter().fold(0.0, |s, x| s + x * x).sqrt()
}

/// One damped-least-squares step of differential inverse kinematics (Wampler 1986; Nakamura and
/// Hanafusa 1986) with a null-space motion `z`:
///
/// `dq = J^+ e + (I - J^+ J) z = z + J^+ (e - J z)`,  `J^+ = J^T (J J^T + lambda^2 I)^-1`,
///
/// for the `m x n` Jacobian `jac` (row-major), the task error `e` (`m`) and `z` (`n`, zeros for
/// none). `J J^T + lambda^2 I` is factored by Cholesky; every sum runs in index order. Returns
/// `None` when `lambda = 0` leaves that matrix singular.
pub fn dls_step(jac: &[f64], m: usize, e: &[f64], z: &[f64], lambda: f64) -> Option<Vec<f64>> {
    let n = z.len();
    assert!(jac.len() == m * n && e.len() == m, "dls_step: shapes");
    let row = |i: usize| &jac[i * n..(i + 1) * n];
    let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).fold(0.0, |s, (x, y)| s + x * y);
    // A = J J^T + lambda^2 I (symmetric: column-major is row-major).
    let mut a = vec![0.0; m * m];
    for i in 0..m {
        for j in 0..m {
            a[j * m + i] = dot(row(i), row(j)) + if i == j { lambda * lambda } else { 0.0 };
        }
    }
    if !cholesky_in_place(&mut a, m) {
        return None;
    }
    let mut y: Vec<f64> = (0..m).map(|i| e[i] - dot(row(i), z)).collect();
    solve_lower_in_place(&a, m, &mut y);
    solve_upper_t_in_place(&a, m, &mut y);
    Some(
        (0..n)
            .map(|k| z[k] + (0..m).fold(0.0, |s, i| s + jac[i * n + k] * y[i]))
            .collect(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{DMatrix, DVector};

    #[test]
    fn the_step_is_the_damped_pseudo_inverse_with_its_null_space() {
        let (m, n) = (6, 7);
        // Pseudo-random entries in [-1, 1) (a linear congruential sequence): full rank.
        let jac: Vec<f64> = (0..m * n)
            .map(|k| ((k * k * 7919 + 104_729 * k + 13) % 2003) as f64 / 1001.5 - 1.0)
            .collect();
        let e: Vec<f64> = (0..m).map(|i| 0.1 * i as f64 - 0.2).collect();
        let z: Vec<f64> = (0..n).map(|k| 0.03 * (k as f64 - 3.0)).collect();
        let lambda = 0.02;
        let j = DMatrix::from_row_slice(m, n, &jac);
        let pinv = j.transpose()
            * (&j * j.transpose() + DMatrix::identity(m, m) * lambda * lambda)
                .try_inverse()
                .unwrap();
        let (ev, zv) = (
            DVector::from_column_slice(&e),
            DVector::from_column_slice(&z),
        );
        let expect = &pinv * &ev + &zv - &pinv * (&j * &zv);
        let dq = dls_step(&jac, m, &e, &z, lambda).unwrap();
        for k in 0..n {
            assert!(
                (dq[k] - expect[k]).abs() < 1e-12,
                "{k}: {} vs {}",
                dq[k],
                expect[k]
            );
        }
        // Undamped, on a full-rank Jacobian, the step solves J dq = e exactly.
        let dq = dls_step(&jac, m, &e, &vec![0.0; n], 0.0).unwrap();
        let r = &j * DVector::from_column_slice(&dq) - &ev;
        assert!(r.amax() < 1e-12);
        // A rank-deficient Jacobian without damping is refused, not divided by zero.
        assert!(dls_step(&vec![0.0; m * n], m, &e, &z, 0.0).is_none());
    }

    #[test]
    fn the_functions_are_libm_and_agree_with_std() {
        for k in 0..1000 {
            let x = -7.0 + 0.0141 * k as f64;
            for (name, f) in [
                ("sin", f64::sin as fn(f64) -> f64),
                ("cos", f64::cos),
                ("exp", f64::exp),
            ] {
                let (a, b) = (unary(name).unwrap()(x), f(x));
                assert!(
                    (a - b).abs() <= 2.0 * f64::EPSILON * b.abs().max(1e-300),
                    "{name}({x})"
                );
            }
            let y = 0.3 + 0.01 * k as f64;
            assert!((binary("arctan2").unwrap()(x, y) - x.atan2(y)).abs() < 1e-15);
        }
        assert!(unary("nope").is_none() && binary("nope").is_none());
        assert_eq!(norm(&[3.0, 4.0]), 5.0);
    }
}
