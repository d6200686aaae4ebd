//! Times one log-marginal-likelihood evaluation with gradient, and one ML-II fit, for the GP.
use dmp_core::gp::{GaussianProcess, GpOptions, log_marginal_likelihood};
use nalgebra::DMatrix;
fn main() {
    for m in [100usize, 200, 500] {
        let x = DMatrix::from_fn(2, m, |d, j| {
            ((j * 7919 + d * 104729) % 1000) as f64 / 166.0 - 3.0
        });
        let y: Vec<f64> = (0..m)
            .map(|j| {
                (x[(0, j)]).sin() + 0.3 * x[(1, j)] + 0.05 * ((j * 31 % 17) as f64 / 17.0 - 0.5)
            })
            .collect();
        let xv: Vec<f64> = x.iter().copied().collect();
        let mean = y.iter().sum::<f64>() / m as f64;
        let r: Vec<f64> = y.iter().map(|v| v - mean).collect();
        let theta = [0.5, 0.5, 0.0, -4.0];
        let reps = if m <= 200 { 200 } else { 10 };
        let t = std::time::Instant::now();
        for _ in 0..reps {
            std::hint::black_box(log_marginal_likelihood(&xv, 2, &r, &theta));
        }
        let per = t.elapsed().as_secs_f64() / reps as f64;
        let t = std::time::Instant::now();
        for _ in 0..reps {
            std::hint::black_box(dmp_core::gp::log_marginal_likelihood_value(
                &xv, 2, &r, &theta,
            ));
        }
        println!(
            "  value only {:.1} us",
            t.elapsed().as_secs_f64() / reps as f64 * 1e6
        );
        let mut a = vec![0.0; m * m];
        for b in 0..m {
            for i in 0..m {
                let s: f64 = (0..2)
                    .map(|d| (xv[i * 2 + d] - xv[b * 2 + d]).powi(2))
                    .sum();
                a[b * m + i] = (-0.5 * s / 2.7).exp() + if i == b { 0.02 } else { 0.0 };
            }
        }
        let t = std::time::Instant::now();
        for _ in 0..reps {
            let mut l = a.clone();
            std::hint::black_box(dmp_core::linalg::cholesky_in_place(&mut l, m));
        }
        let chol = t.elapsed().as_secs_f64() / reps as f64;
        let mut l = a.clone();
        dmp_core::linalg::cholesky_in_place(&mut l, m);
        let mut kinv = vec![0.0; m * m];
        let t = std::time::Instant::now();
        for _ in 0..reps {
            dmp_core::linalg::spd_inverse_lower(&l, m, &mut kinv);
            std::hint::black_box(&kinv);
        }
        let inv = t.elapsed().as_secs_f64() / reps as f64;
        println!(
            "  chol {:.0} us, K^-1 (lower) {:.0} us",
            chol * 1e6,
            inv * 1e6
        );
        // The fastest of 5 fits: the least disturbed by other load (run with RAYON_NUM_THREADS=1
        // for the single-threaded time).
        let mut fit = f64::INFINITY;
        let mut gp = None;
        for _ in 0..5 {
            let t = std::time::Instant::now();
            gp = Some(GaussianProcess::fit(&x.as_view(), &y, None, &GpOptions::default()).unwrap());
            fit = fit.min(t.elapsed().as_secs_f64());
        }
        let gp = gp.unwrap();
        println!(
            "m={m}: eval {:.1} us, fit {:.1} ms (~{:.0} evals), lml {:.3}",
            per * 1e6,
            fit * 1e3,
            fit / per,
            gp.log_marginal_likelihood()
        );
    }
}
