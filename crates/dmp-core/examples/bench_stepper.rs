//! Time of one `step()` of the online steppers in Rust (benches/README.md, "Online steppers"):
//! a 7-DOF joint DMP with 25 and 50 kernels and a Cartesian DMP with 50, open loop, and the
//! joint one with a measured state (a robot that tracks perfectly) and with velocity and
//! acceleration limits; a 7-DOF periodic DMP with 50 kernels, open loop; and one sample of the
//! rollouts of the same joint, Cartesian and periodic DMPs.
//!
//! `cargo run --release -p dmp-core --example bench_stepper`: the median over 2000 rounds of
//! 500 steps (about 20 us each, mostly shorter than a scheduler's time slice, so that the median
//! round ran undisturbed on a loaded machine); the movement restarts every 10 rounds, so the
//! phase sweeps the basis and the movement comes to rest.

use std::hint::black_box;
use std::time::Instant;

use dmp_core::{
    CartesianDmp, CartesianStepper, CartesianStepperOptions, Dmp, DmpConfig, PeriodicConfig,
    PeriodicDmp, PeriodicStepper, PeriodicStepperOptions, RolloutOptions, Stepper, StepperOptions,
};
use nalgebra::{DMatrix, DVector};

const ROUNDS: usize = 2000;
const STEPS: usize = 500;
const ROUNDS_PER_MOVEMENT: usize = 10;

fn weights(n_basis: usize, n: usize) -> DMatrix<f64> {
    DMatrix::from_fn(n_basis, n, |k, d| {
        150.0 * ((k * 7 + d * 3) as f64 * 0.37).sin()
    })
}

fn config(n_basis: usize) -> DmpConfig {
    DmpConfig {
        n_basis,
        ..DmpConfig::default()
    }
}

/// Median ns per call of `step` over `ROUNDS` rounds of `STEPS` calls; `round(i)` restarts the
/// movement when `i` is a multiple of `ROUNDS_PER_MOVEMENT`.
fn median_ns(mut round: impl FnMut(bool) -> f64) -> f64 {
    let mut times: Vec<f64> = (0..ROUNDS)
        .map(|i| round(i % ROUNDS_PER_MOVEMENT == 0))
        .collect();
    times.sort_by(f64::total_cmp);
    times[ROUNDS / 2]
}

fn joint(n_basis: usize, opts: &StepperOptions, measured: bool) -> f64 {
    let dmp = joint_dmp(n_basis);
    let mut s = Stepper::new(&dmp, opts).unwrap();
    // A robot that tracks perfectly: the measured position is the last command.
    let mut y = vec![0.0; 7];
    median_ns(|restart| {
        if restart {
            s.reset(None).unwrap();
            y.fill(0.0);
        }
        let t = Instant::now();
        for _ in 0..STEPS {
            let m = measured.then_some(y.as_slice());
            let (command, _, _) = s.step(black_box(m)).unwrap();
            if measured {
                y.copy_from_slice(command);
            }
            black_box(&y);
        }
        t.elapsed().as_secs_f64() * 1e9 / STEPS as f64
    })
}

fn joint_dmp(n_basis: usize) -> Dmp {
    Dmp::new(
        config(n_basis),
        weights(n_basis, 7),
        DVector::from_element(7, 1.0),
        DVector::from_element(7, 0.0),
        1.0,
    )
    .unwrap()
}

fn cartesian_dmp(n_basis: usize) -> CartesianDmp {
    let goal = [
        0.4,
        0.1,
        0.05,
        0.8775825618903728,
        0.0,
        0.479425538604203,
        0.0,
    ];
    let start = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0];
    CartesianDmp::new(config(n_basis), weights(n_basis, 6), &goal, &start, 1.0).unwrap()
}

fn cartesian(n_basis: usize) -> f64 {
    let dmp = cartesian_dmp(n_basis);
    let mut s = CartesianStepper::new(&dmp, &CartesianStepperOptions::new(1e-3)).unwrap();
    median_ns(|restart| {
        if restart {
            s.reset(None).unwrap();
        }
        let t = Instant::now();
        for _ in 0..STEPS {
            black_box(s.step(None).unwrap());
        }
        t.elapsed().as_secs_f64() * 1e9 / STEPS as f64
    })
}

fn periodic_dmp(n_basis: usize) -> PeriodicDmp {
    let config = PeriodicConfig {
        n_basis,
        ..PeriodicConfig::default()
    };
    let ones = DVector::from_element(7, 1.0);
    PeriodicDmp::new(
        config,
        weights(n_basis, 7),
        ones.clone() * 0.5,
        ones,
        DVector::from_element(7, 0.0),
        1.0,
    )
    .unwrap()
}

fn periodic(n_basis: usize) -> f64 {
    let dmp = periodic_dmp(n_basis);
    let opts = PeriodicStepperOptions {
        ramp: 0.0,
        ..PeriodicStepperOptions::new(1e-3)
    };
    let mut s = PeriodicStepper::new(&dmp, &opts).unwrap();
    median_ns(|_| {
        let t = Instant::now();
        for _ in 0..STEPS {
            black_box(s.step(None).unwrap());
        }
        t.elapsed().as_secs_f64() * 1e9 / STEPS as f64
    })
}

/// ns per sample of `rollout` (returning its number of samples), the least of 200 calls (the
/// machine's load only ever adds time).
fn per_sample(mut rollout: impl FnMut() -> usize) -> f64 {
    let times: Vec<f64> = (0..200)
        .map(|_| {
            let t = Instant::now();
            let samples = black_box(rollout());
            t.elapsed().as_secs_f64() * 1e9 / samples as f64
        })
        .collect();
    times.iter().copied().fold(f64::INFINITY, f64::min)
}

fn main() {
    let open = StepperOptions::new(1e-3);
    let limited = StepperOptions {
        velocity_max: Some(vec![1.0; 7]),
        acceleration_max: Some(vec![20.0; 7]),
        ..StepperOptions::new(1e-3)
    };
    println!("| stepper | ns per step (median of {ROUNDS} rounds of {STEPS}) |");
    println!("|---|---:|");
    for n in [25, 50] {
        println!(
            "| joint, 7 DOF, N = {n}, open loop | {:.1} |",
            joint(n, &open, false)
        );
    }
    println!(
        "| joint, 7 DOF, N = 50, measured (phase stopping) | {:.1} |",
        joint(50, &open, true)
    );
    println!(
        "| joint, 7 DOF, N = 50, velocity + acceleration limits | {:.1} |",
        joint(50, &limited, false)
    );
    println!("| Cartesian, N = 50, open loop | {:.1} |", cartesian(50));
    println!(
        "| periodic, 7 DOF, N = 50, open loop | {:.1} |",
        periodic(50)
    );
    // The rollouts beside their steppers over the same movement: the 1001 samples of 1 s from
    // the start, the phase sweeping the basis (the rounds above are mostly past it).
    let opts = RolloutOptions::new(1e-3);
    let joint = joint_dmp(50);
    let plain = StepperOptions {
        alpha_e: vec![],
        goal_filter: None,
        ..StepperOptions::new(1e-3)
    };
    println!(
        "| joint stepper, 7 DOF, N = 50, the 1001 steps of 1 s | {:.1} |",
        per_sample(|| {
            let mut s = Stepper::new(&joint, &plain).unwrap();
            for _ in 0..1001 {
                black_box(s.step(None).unwrap());
            }
            1001
        })
    );
    println!(
        "| joint rollout, 7 DOF, N = 50, 1 s, per sample | {:.1} |",
        per_sample(|| joint.rollout(&opts).unwrap().t.len())
    );
    let pose = cartesian_dmp(50);
    let plain = CartesianStepperOptions {
        base: plain,
        ..CartesianStepperOptions::new(1e-3)
    };
    println!(
        "| Cartesian stepper, N = 50, the 1001 steps of 1 s | {:.1} |",
        per_sample(|| {
            let mut s = CartesianStepper::new(&pose, &plain).unwrap();
            for _ in 0..1001 {
                black_box(s.step(None).unwrap());
            }
            1001
        })
    );
    println!(
        "| Cartesian rollout, N = 50, 1 s, per sample | {:.1} |",
        per_sample(|| pose.rollout(&opts).unwrap().t.len())
    );
    let rhythm = periodic_dmp(50);
    println!(
        "| periodic rollout, 7 DOF, N = 50, one period, per sample | {:.1} |",
        per_sample(|| rhythm.rollout(1e-3, None, 0.0).unwrap().t.len())
    );
}
