use dmp_core::*;
use nalgebra::DMatrix;
fn main() {
    let n = 1000;
    let dofs = 7;
    let t: Vec<f64> = (0..n).map(|j| j as f64 / (n - 1) as f64).collect();
    let y = DMatrix::from_fn(dofs, n, |d, j| {
        let s = t[j];
        (10.0 * s.powi(3) - 15.0 * s.powi(4) + 6.0 * s.powi(5)) * (d as f64 + 1.0)
            + 0.1 * (3.0 * s).sin()
    });
    let cfg = DmpConfig {
        n_basis: 50,
        ..DmpConfig::default()
    };
    let demo = Demonstration {
        t: &t,
        y: y.as_view(),
        yd: None,
        ydd: None,
    };
    let mode = std::env::args().nth(1).unwrap_or_default();
    let start = std::time::Instant::now();
    let reps = 2000;
    let dmp = Dmp::fit(&demo, cfg).unwrap();
    if mode == "fit" {
        for _ in 0..reps {
            std::hint::black_box(Dmp::fit(&demo, cfg).unwrap());
        }
    } else if mode == "batch" {
        let many: Vec<Dmp> = (0..1000).map(|_| dmp.clone()).collect();
        let s = std::time::Instant::now();
        for _ in 0..5 {
            std::hint::black_box(rollout_batch(&many, &RolloutOptions::new(1e-3)).unwrap());
        }
        println!(
            "batch: {:.1} ns per step-dof",
            s.elapsed().as_secs_f64() / 5.0 * 1e9 / 7e6
        );
    } else {
        for _ in 0..reps {
            std::hint::black_box(dmp.rollout(&RolloutOptions::new(1e-3)).unwrap());
        }
    }
    let el = start.elapsed().as_secs_f64() / reps as f64;
    println!(
        "{mode}: {:.1} us per call, {:.1} ns per step-dof",
        el * 1e6,
        el * 1e9 / 7000.0
    );
}
