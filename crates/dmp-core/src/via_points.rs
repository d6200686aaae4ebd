//! Via-points: the least change of a DMP's weights that makes its rollout pass given positions
//! at given times (docs/method.md §2.6).
//!
//! A rollout is linear in the weights: eqs. 1-3 are linear in `(g, y0, w)` and explicit Euler
//! keeps them so, so the sample `k` of DOF `d` is `y_k,d(w) = y_k,d(w_0) + sum_i J_ki dw_i,d`,
//! where `J_ki` is the sample `k` of the rollout with weight `e_i` alone, goal and start 0 (the
//! same for every DOF: they share the basis, the phase and tau). The via-points
//! `(t_v, p_v)` are met by the weights change of least norm per DOF,
//!
//! ```text
//! dw_d = J^T (J J^T)^-1 r_d,     r_v,d = p_v,d - y_{k_v},d(w_0),    k_v = round(t_v / dt),
//! ```
//!
//! exactly (to rounding) for rollouts at that `dt`, and to the integrator's order at another.
//! A via-point already on the rollout leaves the weights as they are.

use nalgebra::{DMatrix, DMatrixView, DVector};

use crate::dmp::Dmp;
use crate::error::{Error, Result, check_scalar, fmt_g};
use crate::linalg::{cholesky_in_place, solve_lower_in_place, solve_upper_t_in_place};
use crate::rollout::RolloutOptions;

/// The DMP whose rollout at step `dt` passes `positions[:, v]` (`D x V`) at the samples nearest
/// the times `times[v]`, with the weights changed as little as possible (module docs).
pub fn through_via_points(
    dmp: &Dmp,
    times: &[f64],
    positions: &DMatrixView<'_, f64>,
    dt: f64,
) -> Result<Dmp> {
    check_scalar("dt", dt, true)?;
    let (n_dof, n_via) = (dmp.n_dof(), times.len());
    if n_via == 0 || positions.shape() != (n_dof, n_via) {
        return Err(Error::Shape {
            name: "positions",
            expected: format!(
                "({n_via}, {n_dof}): one row per time, one column per DOF, at least one"
            ),
            got: format!("({}, {})", positions.ncols(), positions.nrows()),
        });
    }
    if let Some((i, &p)) = positions.iter().enumerate().find(|(_, p)| !p.is_finite()) {
        return Err(Error::NonFinite {
            name: "positions",
            location: format!("[{}, {}]", i / n_dof, i % n_dof),
            value: p,
        });
    }
    let mut samples = Vec::with_capacity(n_via);
    for (v, &t) in times.iter().enumerate() {
        check_scalar("times", t, true)?;
        let k = (t / dt).round();
        if !(1.0..=1e8).contains(&k) {
            return Err(Error::InvalidParameter {
                name: "times",
                value: format!("{} at [{v}]", fmt_g(t)),
                requirement: "must be at least one step after the start (the weights cannot move \
                              the start) and within 1e8 steps",
            });
        }
        if samples.contains(&(k as usize)) {
            return Err(Error::InvalidParameter {
                name: "times",
                value: format!("{} at [{v}]", fmt_g(t)),
                requirement: "must fall on different samples of the rollout at dt",
            });
        }
        samples.push(k as usize);
    }
    let last = *samples.iter().max().expect("at least one via-point");
    let opts = RolloutOptions {
        duration: Some(last as f64 * dt),
        ..RolloutOptions::new(dt)
    };
    let at = |y: &[f64], width: usize, k: usize, d: usize| y[k * width + d];
    let base = dmp.rollout(&opts)?;
    // J (V x N, row-major): the impulse response of each weight at the via samples
    let n = dmp.n_basis();
    // With a final velocity the forcing term is read at another phase (docs/method.md §2.8):
    // the impulse responses are then those of a moving DMP, less its spring's own motion.
    let unit = |w: DMatrix<f64>| -> Result<Dmp> {
        let d = Dmp::new(
            *dmp.config(),
            w,
            DVector::zeros(1),
            DVector::zeros(1),
            dmp.tau(),
        )?;
        match dmp.final_velocity() {
            Some(_) => d.with_final_velocity(DVector::from_element(1, 1.0)),
            None => Ok(d),
        }
    };
    let spring = match dmp.final_velocity() {
        Some(_) => Some(unit(DMatrix::zeros(n, 1))?.rollout(&opts)?),
        None => None,
    };
    let mut jac = vec![0.0; n_via * n];
    for i in 0..n {
        let mut w = DMatrix::zeros(n, 1);
        w[i] = 1.0;
        let tr = unit(w)?.rollout(&opts)?;
        for (v, &k) in samples.iter().enumerate() {
            let own = spring.as_ref().map_or(0.0, |s| at(&s.y, 1, k, 0));
            jac[v * n + i] = at(&tr.y, 1, k, 0) - own;
        }
    }
    // G = J J^T (V x V, column-major, symmetric), factored once for every DOF
    let mut gram = vec![0.0; n_via * n_via];
    for a in 0..n_via {
        for b in 0..n_via {
            gram[b * n_via + a] =
                crate::linalg::dot(&jac[a * n..(a + 1) * n], &jac[b * n..(b + 1) * n]);
        }
    }
    let scale = (0..n_via).map(|v| gram[v * n_via + v]).fold(0.0, f64::max);
    if !cholesky_in_place(&mut gram, n_via)
        || (0..n_via).any(|v| gram[v * n_via + v] <= 1e-7 * scale.sqrt())
    {
        return Err(Error::InvalidParameter {
            name: "times",
            value: times
                .iter()
                .map(|t| fmt_g(*t))
                .collect::<Vec<_>>()
                .join(", "),
            requirement: "must be far enough apart, and early enough that the forcing term still \
                          acts, for the weights to move each via-point on its own",
        });
    }
    let mut weights = dmp.weights().clone();
    let mut r = vec![0.0; n_via];
    for d in 0..n_dof {
        for (v, &k) in samples.iter().enumerate() {
            r[v] = positions[(d, v)] - at(&base.y, n_dof, k, d);
        }
        solve_lower_in_place(&gram, n_via, &mut r);
        solve_upper_t_in_place(&gram, n_via, &mut r);
        for i in 0..n {
            let dw: f64 = (0..n_via).map(|v| jac[v * n + i] * r[v]).sum();
            weights[(i, d)] += dw;
        }
    }
    dmp.with_weights(weights)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dmp::DmpConfig;

    fn dmp() -> Dmp {
        let cfg = DmpConfig {
            n_basis: 20,
            ..DmpConfig::default()
        };
        let w = DMatrix::from_fn(20, 2, |i, d| (i as f64 * 0.7 + d as f64).sin() * 50.0);
        Dmp::new(
            cfg,
            w,
            DVector::from_vec(vec![1.0, -0.5]),
            DVector::from_vec(vec![0.0, 0.3]),
            1.2,
        )
        .unwrap()
    }

    #[test]
    fn the_via_points_are_met_and_a_point_on_the_rollout_changes_nothing() {
        let d = dmp();
        let dt = 1e-3;
        let p = DMatrix::from_row_slice(2, 2, &[0.4, 0.9, 0.2, -0.4]);
        let moved = through_via_points(&d, &[0.3, 0.7], &p.as_view(), dt).unwrap();
        let tr = moved.rollout(&RolloutOptions::new(dt)).unwrap();
        for (v, k) in [300usize, 700].into_iter().enumerate() {
            for dof in 0..2 {
                assert!((tr.y[k * 2 + dof] - p[(dof, v)]).abs() < 1e-9);
            }
        }
        let own = d.rollout(&RolloutOptions::new(dt)).unwrap();
        let on = DMatrix::from_column_slice(2, 1, &own.y[500 * 2..500 * 2 + 2]);
        let same = through_via_points(&d, &[0.5], &on.as_view(), dt).unwrap();
        assert_eq!(same.weights(), d.weights());
    }

    #[test]
    fn impossible_via_points_are_refused_by_name() {
        let d = dmp();
        let p = DMatrix::from_element(2, 2, 0.5);
        for times in [[0.0, 0.5], [0.5, 0.5002]] {
            let err = through_via_points(&d, &times, &p.as_view(), 1e-3).unwrap_err();
            assert!(err.to_string().contains("times"), "{err}");
        }
    }
}
