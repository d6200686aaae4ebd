//! A small box-constrained quasi-Newton minimizer (projected L-BFGS) for the GP hyperparameters
//! (ML-II, Rasmussen & Williams ch. 5), and the deterministic low-discrepancy starting points of
//! its restarts.
//!
//! The method: L-BFGS two-loop recursion on the free variables (those not held at a bound by a
//! gradient pushing outwards), a projected backtracking Armijo line search along
//! `clamp(x + a d)`, and a fall-back to projected steepest descent whenever the quasi-Newton
//! direction is not a descent direction. It is sequential and uses no randomness, so the same
//! inputs always give bit-identical results.

/// Where and how to stop.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MinimizeOptions {
    pub max_iter: usize,
    /// Stop when the largest projected-gradient component is at most this.
    pub gtol: f64,
    /// Stop when an iteration lowers f by at most `ftol * max(|f|, 1)`.
    pub ftol: f64,
    /// Number of (s, y) pairs kept.
    pub memory: usize,
}

impl Default for MinimizeOptions {
    /// The stopping rules of SciPy's L-BFGS-B defaults (`pgtol = 1e-5`, `factr = 1e7`, i.e.
    /// `ftol = 1e7 x eps = 2.2e-9`), which scikit-learn's GP uses; memory as its `m = 10`.
    fn default() -> Self {
        Self {
            max_iter: 200,
            gtol: 1e-5,
            ftol: 1e7 * f64::EPSILON,
            memory: 10,
        }
    }
}

/// The result of one minimization.
#[derive(Debug, Clone, PartialEq)]
pub struct Minimum {
    pub x: Vec<f64>,
    pub f: f64,
    pub iterations: usize,
    pub evaluations: usize,
}

fn project(x: &mut [f64], lo: &[f64], hi: &[f64]) {
    for i in 0..x.len() {
        x[i] = x[i].clamp(lo[i], hi[i]);
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// The gradient with the components that would push `x` out of the box (or that belong to a
/// fixed variable, `lo == hi`) set to zero.
fn projected_gradient(x: &[f64], g: &[f64], lo: &[f64], hi: &[f64]) -> Vec<f64> {
    (0..x.len())
        .map(|i| {
            let at_lo = x[i] <= lo[i] && g[i] > 0.0;
            let at_hi = x[i] >= hi[i] && g[i] < 0.0;
            if at_lo || at_hi || lo[i] >= hi[i] {
                0.0
            } else {
                g[i]
            }
        })
        .collect()
}

/// A function to minimize. The value and the gradient are asked for separately because the line
/// search rejects some trial points, and for the GP's likelihood the gradient costs twice the
/// value (it needs the whole `K^{-1}`): it is asked for only at accepted points.
pub trait Objective {
    /// `f(x)`, or `None` where it cannot be evaluated (treated as +infinity: the line search
    /// backs off).
    fn value(&mut self, x: &[f64]) -> Option<f64>;
    /// The gradient at the point of the last `value` call, which returned a finite value.
    fn gradient(&mut self) -> Vec<f64>;
}

/// An [`Objective`] from a closure that returns the value and the gradient together.
pub struct WithGradient<F> {
    f: F,
    last: Vec<f64>,
}

impl<F: FnMut(&[f64]) -> Option<(f64, Vec<f64>)>> WithGradient<F> {
    pub fn new(f: F) -> Self {
        Self {
            f,
            last: Vec::new(),
        }
    }
}

impl<F: FnMut(&[f64]) -> Option<(f64, Vec<f64>)>> Objective for WithGradient<F> {
    fn value(&mut self, x: &[f64]) -> Option<f64> {
        let (v, g) = (self.f)(x)?;
        self.last = g;
        Some(v)
    }
    fn gradient(&mut self) -> Vec<f64> {
        std::mem::take(&mut self.last)
    }
}

/// Minimizes `f` over the box `[lo, hi]` from `x0` (clamped into the box). Returns `None` only
/// if `f` cannot be evaluated at the start.
pub fn minimize_box(
    f: &mut impl Objective,
    x0: &[f64],
    lo: &[f64],
    hi: &[f64],
    opts: &MinimizeOptions,
) -> Option<Minimum> {
    let n = x0.len();
    debug_assert!(lo.len() == n && hi.len() == n);
    let mut x = x0.to_vec();
    project(&mut x, lo, hi);
    let mut fx = f.value(&x)?;
    if !fx.is_finite() {
        return None;
    }
    let mut gx = f.gradient();
    let mut evaluations = 1;
    let mut s_hist: Vec<Vec<f64>> = Vec::new();
    let mut y_hist: Vec<Vec<f64>> = Vec::new();
    let mut iterations = 0;
    while iterations < opts.max_iter {
        iterations += 1;
        let pg = projected_gradient(&x, &gx, lo, hi);
        let pg_max = pg.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        if pg_max <= opts.gtol {
            break;
        }
        // Two-loop recursion on the free variables only.
        let free: Vec<bool> = pg.iter().map(|v| *v != 0.0).collect();
        let mask = |v: &[f64]| -> Vec<f64> {
            v.iter()
                .zip(&free)
                .map(|(a, &fr)| if fr { *a } else { 0.0 })
                .collect()
        };
        let mut d = {
            let mut q = pg.clone();
            let k = s_hist.len();
            let mut alpha = vec![0.0; k];
            let mut rho = vec![0.0; k];
            for i in (0..k).rev() {
                let (s, y) = (mask(&s_hist[i]), mask(&y_hist[i]));
                let sy = dot(&s, &y);
                rho[i] = if sy > 0.0 { 1.0 / sy } else { 0.0 };
                alpha[i] = rho[i] * dot(&s, &q);
                for j in 0..n {
                    q[j] -= alpha[i] * y[j];
                }
            }
            if k > 0 {
                let (s, y) = (mask(&s_hist[k - 1]), mask(&y_hist[k - 1]));
                let yy = dot(&y, &y);
                if yy > 0.0 {
                    let gamma = dot(&s, &y) / yy;
                    if gamma > 0.0 {
                        q.iter_mut().for_each(|v| *v *= gamma);
                    }
                }
            }
            for i in 0..k {
                let (s, y) = (mask(&s_hist[i]), mask(&y_hist[i]));
                let beta = rho[i] * dot(&y, &q);
                for j in 0..n {
                    q[j] += s[j] * (alpha[i] - beta);
                }
            }
            mask(&q).iter().map(|v| -v).collect::<Vec<f64>>()
        };
        let slope = dot(&d, &pg);
        if slope.is_nan() || slope >= 0.0 || d.iter().any(|v| !v.is_finite()) {
            d = pg.iter().map(|v| -v).collect();
            s_hist.clear();
            y_hist.clear();
        }
        // Without curvature information, a first step of length at most 1 in the infinity norm.
        let mut step = if s_hist.is_empty() {
            let dmax = d.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            (1.0 / dmax).min(1.0)
        } else {
            1.0
        };
        let mut accepted = None;
        for _ in 0..40 {
            let mut xn: Vec<f64> = (0..n).map(|i| x[i] + step * d[i]).collect();
            project(&mut xn, lo, hi);
            let decrease: f64 = (0..n).map(|i| gx[i] * (xn[i] - x[i])).sum();
            evaluations += 1;
            if let Some(fnew) = f.value(&xn)
                && fnew.is_finite()
                && fnew <= fx + 1e-4 * decrease
            {
                accepted = Some((xn, fnew, f.gradient()));
                break;
            }
            step *= 0.5;
        }
        let Some((xn, fnew, gnew)) = accepted else {
            if s_hist.is_empty() {
                break; // even projected steepest descent makes no progress
            }
            s_hist.clear();
            y_hist.clear();
            continue;
        };
        let s: Vec<f64> = (0..n).map(|i| xn[i] - x[i]).collect();
        let y: Vec<f64> = (0..n).map(|i| gnew[i] - gx[i]).collect();
        let sy = dot(&s, &y);
        if sy > 1e-12 * dot(&s, &s).sqrt() * dot(&y, &y).sqrt() && sy > 0.0 {
            if s_hist.len() == opts.memory {
                s_hist.remove(0);
                y_hist.remove(0);
            }
            s_hist.push(s);
            y_hist.push(y);
        }
        let converged = fx - fnew <= opts.ftol * fx.abs().max(fnew.abs()).max(1.0);
        x = xn;
        fx = fnew;
        gx = gnew;
        if converged {
            break;
        }
    }
    Some(Minimum {
        x,
        f: fx,
        iterations,
        evaluations,
    })
}

/// The first primes, for the Halton sequence.
fn primes(count: usize) -> Vec<u64> {
    let mut out = Vec::with_capacity(count);
    let mut c = 2u64;
    while out.len() < count {
        if out.iter().all(|p| !c.is_multiple_of(*p)) {
            out.push(c);
        }
        c += 1;
    }
    out
}

/// Point `index` (from 1) of the `dim`-dimensional Halton sequence in `(0, 1)^dim`: a fixed,
/// evenly spread set of restart points that needs no random number generator.
pub fn halton(index: u64, dim: usize) -> Vec<f64> {
    primes(dim)
        .into_iter()
        .map(|base| {
            let (mut f, mut r, mut i) = (1.0, 0.0, index);
            while i > 0 {
                f /= base as f64;
                r += f * (i % base) as f64;
                i /= base;
            }
            r
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rosenbrock(x: &[f64]) -> Option<(f64, Vec<f64>)> {
        let (a, b) = (x[0], x[1]);
        let f = (1.0 - a).powi(2) + 100.0 * (b - a * a).powi(2);
        let g = vec![
            -2.0 * (1.0 - a) - 400.0 * a * (b - a * a),
            200.0 * (b - a * a),
        ];
        Some((f, g))
    }

    #[test]
    fn finds_the_rosenbrock_minimum() {
        let m = minimize_box(
            &mut WithGradient::new(rosenbrock),
            &[-1.2, 1.0],
            &[-5.0, -5.0],
            &[5.0, 5.0],
            &MinimizeOptions::default(),
        )
        .unwrap();
        assert!(
            (m.x[0] - 1.0).abs() < 1e-4 && (m.x[1] - 1.0).abs() < 1e-4,
            "{m:?}"
        );
    }

    #[test]
    fn stops_at_an_active_bound() {
        // min (x-3)^2 + (y+1)^2 on [0,2] x [0,2] is at (2, 0).
        let f = |x: &[f64]| {
            Some((
                (x[0] - 3.0).powi(2) + (x[1] + 1.0).powi(2),
                vec![2.0 * (x[0] - 3.0), 2.0 * (x[1] + 1.0)],
            ))
        };
        let m = minimize_box(
            &mut WithGradient::new(f),
            &[0.5, 1.5],
            &[0.0, 0.0],
            &[2.0, 2.0],
            &MinimizeOptions::default(),
        )
        .unwrap();
        assert_eq!(m.x, vec![2.0, 0.0]);
    }

    #[test]
    fn a_fixed_variable_stays_fixed() {
        let f = |x: &[f64]| {
            Some((
                x[0].powi(2) + (x[1] - 1.0).powi(2),
                vec![2.0 * x[0], 2.0 * (x[1] - 1.0)],
            ))
        };
        let m = minimize_box(
            &mut WithGradient::new(f),
            &[3.0, 4.0],
            &[-9.0, 4.0],
            &[9.0, 4.0],
            &MinimizeOptions::default(),
        )
        .unwrap();
        assert!(m.x[0].abs() < 1e-6);
        assert_eq!(m.x[1], 4.0);
    }

    #[test]
    fn backs_off_where_f_is_undefined() {
        // f undefined for x < 0.5; minimum of (x-1)^2 from x = 3 must still be found.
        let f = |x: &[f64]| {
            if x[0] < 0.5 {
                None
            } else {
                Some(((x[0] - 1.0).powi(2), vec![2.0 * (x[0] - 1.0)]))
            }
        };
        let m = minimize_box(
            &mut WithGradient::new(f),
            &[3.0],
            &[-10.0],
            &[10.0],
            &MinimizeOptions::default(),
        )
        .unwrap();
        assert!((m.x[0] - 1.0).abs() < 1e-6);
    }

    #[test]
    fn halton_points_are_the_radical_inverses() {
        assert_eq!(halton(1, 2), vec![0.5, 1.0 / 3.0]);
        assert_eq!(halton(2, 2), vec![0.25, 2.0 / 3.0]);
        let h = halton(3, 3);
        for (a, b) in h.iter().zip([0.75, 1.0 / 9.0, 3.0 / 5.0]) {
            assert!((a - b).abs() < 1e-15);
        }
    }
}
