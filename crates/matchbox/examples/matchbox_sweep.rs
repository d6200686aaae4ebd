//! Sweeps the strike duration of the scripted demonstrator and prints the regimes:
//! `cargo run --release -p matchbox --example matchbox_sweep [T_min T_max steps]`.
use matchbox::{FingerPath, MatchboxConfig, min_jerk_strike, simulate};

fn main() {
    let args: Vec<f64> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let (lo, hi, n) = match args[..] {
        [a, b, c] => (a, b, c as usize),
        _ => (0.03, 0.15, 25),
    };
    // Optional overrides for calibration: MB_FRICTION, MB_RESTITUTION, MB_DT, MB_ITERS, MB_OVERHANG.
    let env = |k: &str| std::env::var(k).ok().and_then(|v| v.parse::<f64>().ok());
    let mut cfg = MatchboxConfig::default();
    if let Some(v) = env("MB_FRICTION") {
        cfg.friction = v;
    }
    if let Some(v) = env("MB_RESTITUTION") {
        cfg.restitution = v;
    }
    if let Some(v) = env("MB_DT") {
        cfg.dt = v;
    }
    if let Some(v) = env("MB_ITERS") {
        cfg.solver_iterations = v as usize;
    }
    if let Some(v) = env("MB_OVERHANG") {
        cfg.overhang = v;
    }
    let (from, to) = cfg.default_strike();
    let mut counts = std::collections::BTreeMap::new();
    println!(
        "T (s)   peak speed (m/s)  regime         phi_max (deg)  outcome angle (deg)  cpu (ms)"
    );
    for k in 0..n {
        let dur = hi - (hi - lo) * k as f64 / (n - 1).max(1) as f64;
        let (t, x, z) = min_jerk_strike(from, to, dur, 1e-3);
        let start = std::time::Instant::now();
        let ep = simulate(
            &FingerPath {
                t: &t,
                x: &x,
                z: &z,
            },
            &cfg,
        )
        .unwrap();
        let ms = start.elapsed().as_secs_f64() * 1e3;
        let m = ep.measures;
        *counts.entry(m.regime.as_str()).or_insert(0) += 1;
        if std::env::var("MB_TRACE").is_ok() {
            let line: Vec<String> = (0..ep.t.len())
                .step_by(10)
                .take(60)
                .map(|j| format!("{:.0}", ep.phi[j].to_degrees()))
                .collect();
            println!("  phi every 10 ms: {}", line.join(" "));
        }
        println!(
            "{dur:.4}  {:.3}             {:<14} {:>8.1}       {:>8.1}          {ms:.1}",
            1.875 * (to[1] - from[1]) / dur,
            m.regime.as_str(),
            m.phi_max.to_degrees(),
            m.outcome_angle.to_degrees()
        );
    }
    println!("{counts:?}");
}
