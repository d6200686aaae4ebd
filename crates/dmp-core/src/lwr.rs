//! Locally weighted regression of the DMP shape weights across demonstrations (docs/method.md §3.2,
//! after Ude et al. 2010): at a query `q`, one weighted least-squares problem over the stacked
//! data of all demonstrations, with one kernel weight per demonstration,
//!
//! ```text
//! w(q) = ( sum_k kappa_k A_k^T A_k + lambda I )^{-1} ( sum_k kappa_k A_k^T F_k )
//! ```
//!
//! `A_k`, `F_k` are the design matrix and targets of demo k (docs/method.md §2.3), each on its own
//! `tau_k` and `g_k` through the common phase, so `A_k^T A_k` and `A_k^T F_k` are computed once
//! (see [`crate::design_matrix::normal_equations`]) and a query costs one `N x N` solve.
//!
//! Kernel weights: `kappa_k = K(d_k)` with `d_k = |D (q - q_k)| / b`, `D = diag(1 / range)` of
//! the demo queries, the tricube `K(d) = (1 - |d|^3)^3` (`|d| < 1`, else 0) or the Gaussian
//! `exp(-d^2)`, and the bandwidth rule `b = bandwidth x` the distance to the farthest of the
//! `n + 1` nearest demos (so that at least `n + 1` demos get a positive weight).
//!
//! Interpolation (our addition, on by default): a plain kernel gives a locally constant blend, so
//! `w(q_k)` would mix demo k with its neighbours and the generalizer would not reproduce its own
//! demonstrations (required by docs/method.md §10). Multiplying each weight by `(d_min / d_k)^2`, a
//! Shepard-type factor that grows without bound as `q -> q_k` (Atkeson, Moore & Schaal 1997,
//! "Locally weighted learning", on kernels that make LWR interpolate), makes `w(q_k)` the fit of
//! demo k alone (up to the ridge) while leaving `w` continuous and a convex blend elsewhere.
//!
//! Local model (our addition): the above is locally *constant* in q, so beyond the demos the
//! weights tend to those of the nearest ones and the generalization cannot extrapolate.
//! `LocalModel::Linear` is first-order LWR (Atkeson, Moore & Schaal 1997): at q the weights are
//! the intercept `W` of a model `W + sum_d B_d (q_k - q)_d` fitted to every demo's data with the
//! same kernel weights,
//!
//! ```text
//! min over W, B_1..B_n of  sum_k kappa_k | A_k (W + sum_d B_d delta_kd) - F_k |^2,   delta_k = D (q_k - q)
//! ```
//!
//! one `(n + 1) N` square solve per query. It reproduces the demos as the constant model does
//! (at a demo's query only that demo has weight, and delta = 0 there), is affine in q where the
//! demos are, and extrapolates affinely from the nearest demos.

use nalgebra::DMatrix;

use crate::design_matrix::{NormalEquations, solve_ridge};
use crate::error::{Error, Result, check_scalar};

/// The kernel on the scaled query distance.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kernel {
    /// `(1 - |d|^3)^3` for `|d| < 1`, else 0 (compact).
    Tricube,
    /// `exp(-d^2)`.
    Gaussian,
}

impl Kernel {
    pub fn eval(self, d: f64) -> f64 {
        match self {
            Kernel::Tricube => {
                let a = d.abs();
                if a < 1.0 {
                    let u = 1.0 - a * a * a;
                    u * u * u
                } else {
                    0.0
                }
            }
            Kernel::Gaussian => (-d * d).exp(),
        }
    }
}

/// The model fitted around each query (module doc).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LocalModel {
    /// A kernel-weighted blend of the demos (Ude et al. 2010): cannot extrapolate.
    Constant,
    /// First-order LWR: extrapolates affinely from the nearest demos.
    Linear,
}

/// Meta-parameters of the regression.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LwrOptions {
    pub kernel: Kernel,
    /// `b = bandwidth x` distance to the farthest of the `n + 1` nearest demos; must be > 1.
    pub bandwidth: f64,
    /// `lambda = ridge x trace(sum kappa A^T A) / N`. Default 1e-10, the relative ridge of
    /// [`crate::Dmp::fit`], so that at a demo's query the regression is that demo's own fit bit for
    /// bit. (docs/method.md §3.2 suggests about 1e-6 for fear of a singular normal matrix; that cannot
    /// happen here, because every demo covers the whole phase interval and so activates every
    /// kernel.)
    pub ridge: f64,
    /// Multiply the kernel weights by `(d_min / d_k)^2` so that demos are reproduced.
    pub interpolate: bool,
    pub local_model: LocalModel,
}

impl Default for LwrOptions {
    fn default() -> Self {
        Self {
            kernel: Kernel::Tricube,
            bandwidth: 1.5,
            ridge: crate::dmp::FIT_RIDGE,
            interpolate: true,
            local_model: LocalModel::Constant,
        }
    }
}

impl LwrOptions {
    pub fn validate(&self) -> Result<()> {
        check_scalar("bandwidth", self.bandwidth, true)?;
        if self.bandwidth <= 1.0 {
            return Err(Error::InvalidParameter {
                name: "bandwidth",
                value: self.bandwidth.to_string(),
                requirement: "must be > 1 so that the n + 1 nearest demonstrations get a positive weight",
            });
        }
        check_scalar("ridge", self.ridge, true)
    }
}

/// The precomputed regression over M demonstrations.
#[derive(Debug, Clone)]
pub struct Lwr {
    n_dim: usize,
    /// Demo queries, demo-major (`queries[k * n_dim + d]`), already multiplied by `D`.
    scaled_queries: Vec<f64>,
    /// `D = 1 / range` per query dimension (1 where the demos do not vary).
    inv_range: Vec<f64>,
    normal: Vec<NormalEquations>,
    options: LwrOptions,
}

impl Lwr {
    /// `queries[k]` is the query of demo k (all of length `n_dim`, finite, distinct: checked by
    /// the caller); `normal[k]` its normal equations, all of the same size.
    pub fn new(
        queries: &[Vec<f64>],
        normal: Vec<NormalEquations>,
        options: LwrOptions,
    ) -> Result<Self> {
        options.validate()?;
        if queries.is_empty() || queries.len() != normal.len() {
            return Err(Error::Shape {
                name: "normal equations",
                expected: format!("{} (one per demo query), at least 1", queries.len()),
                got: normal.len().to_string(),
            });
        }
        let n_dim = queries[0].len();
        let inv_range: Vec<f64> = (0..n_dim)
            .map(|d| {
                let (lo, hi) = queries
                    .iter()
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), q| {
                        (a.min(q[d]), b.max(q[d]))
                    });
                if hi > lo { 1.0 / (hi - lo) } else { 1.0 }
            })
            .collect();
        let scaled_queries = queries
            .iter()
            .flat_map(|q| q.iter().zip(&inv_range).map(|(v, s)| v * s))
            .collect();
        Ok(Self {
            n_dim,
            scaled_queries,
            inv_range,
            normal,
            options,
        })
    }

    pub fn n_demos(&self) -> usize {
        self.normal.len()
    }

    /// The distance from `q` to each demo's query, each dimension scaled by the demos' range.
    fn distances(&self, q: &[f64]) -> Vec<f64> {
        let n = self.n_dim;
        let qs: Vec<f64> = q.iter().zip(&self.inv_range).map(|(v, s)| v * s).collect();
        (0..self.n_demos())
            .map(|k| {
                let qk = &self.scaled_queries[k * n..(k + 1) * n];
                qk.iter()
                    .zip(&qs)
                    .map(|(a, b)| (a - b) * (a - b))
                    .sum::<f64>()
                    .sqrt()
            })
            .collect()
    }

    /// The indices of the `k` demos nearest to `q` in the distance of [`Self::demo_weights`]
    /// (of equally distant ones, the lower index), in ascending order; every demo if `k >= M`.
    pub fn nearest(&self, q: &[f64], k: usize) -> Vec<usize> {
        if k == 0 {
            return Vec::new();
        }
        let dist = self.distances(q);
        let mut idx: Vec<usize> = (0..dist.len()).collect();
        if k < idx.len() {
            idx.select_nth_unstable_by(k - 1, |&a, &b| dist[a].total_cmp(&dist[b]).then(a.cmp(&b)));
            idx.truncate(k);
            idx.sort_unstable();
        }
        idx
    }

    /// The normalized weight of each demo at `q` (they sum to 1).
    pub fn demo_weights(&self, q: &[f64]) -> Vec<f64> {
        let n = self.n_dim;
        let m = self.n_demos();
        let dist = self.distances(q);
        let mut sorted = dist.clone();
        sorted.sort_by(f64::total_cmp);
        let d_min = sorted[0];
        let mut kappa: Vec<f64> = if d_min == 0.0 {
            // At a demo's query (exactly): the limit of the interpolating weights, or of any
            // kernel as the bandwidth shrinks to the nearest demo.
            dist.iter()
                .map(|&d| if d == 0.0 { 1.0 } else { 0.0 })
                .collect()
        } else {
            let b = self.options.bandwidth * sorted[(n + 1).min(m) - 1];
            dist.iter()
                .map(|&d| {
                    let k = self.options.kernel.eval(d / b);
                    if self.options.interpolate {
                        k * (d_min / d) * (d_min / d)
                    } else {
                        k
                    }
                })
                .collect()
        };
        let total: f64 = kappa.iter().sum();
        kappa.iter_mut().for_each(|v| *v /= total);
        kappa
    }

    /// The shape weights `N x D` at `q` (length `n_dim`, checked by the caller).
    pub fn weights_at(&self, q: &[f64]) -> Result<DMatrix<f64>> {
        let kappa = self.demo_weights(q);
        if self.options.local_model == LocalModel::Linear {
            return self.local_linear(q, &kappa);
        }
        let first = &self.normal[0];
        let mut ata = DMatrix::zeros(first.ata.nrows(), first.ata.ncols());
        let mut atf = DMatrix::zeros(first.atf.nrows(), first.atf.ncols());
        let axpy = |acc: &mut DMatrix<f64>, a: f64, x: &DMatrix<f64>| {
            for (o, v) in acc.as_mut_slice().iter_mut().zip(x.as_slice()) {
                *o += a * v;
            }
        };
        for (k, ne) in self.normal.iter().enumerate() {
            if kappa[k] > 0.0 {
                axpy(&mut ata, kappa[k], &ne.ata);
                axpy(&mut atf, kappa[k], &ne.atf);
            }
        }
        solve_ridge(ata, &atf, self.options.ridge, "locally weighted regression")
    }

    /// `LocalModel::Linear`: the block normal equations of the unknowns `[W; B_1; ..; B_n]`,
    /// `sum_k kappa_k (x_k x_k^T) (x) A_k^T A_k` with `x_k = [1, delta_k]`; returns `W`.
    fn local_linear(&self, q: &[f64], kappa: &[f64]) -> Result<DMatrix<f64>> {
        let (n, p) = (self.n_dim, self.n_dim + 1);
        let first = &self.normal[0];
        let (nb, nd) = (first.ata.nrows(), first.atf.ncols());
        let mut ata = DMatrix::zeros(p * nb, p * nb);
        let mut atf = DMatrix::zeros(p * nb, nd);
        let mut x = vec![1.0; p];
        for (k, ne) in self.normal.iter().enumerate() {
            if kappa[k] <= 0.0 {
                continue;
            }
            let qk = &self.scaled_queries[k * n..(k + 1) * n];
            for d in 0..n {
                x[1 + d] = qk[d] - q[d] * self.inv_range[d];
            }
            for i in 0..p {
                for j in 0..p {
                    let c = kappa[k] * x[i] * x[j];
                    if c != 0.0 {
                        let mut block = ata.view_mut((i * nb, j * nb), (nb, nb));
                        block.zip_apply(&ne.ata, |o, v| *o += c * v);
                    }
                }
                let c = kappa[k] * x[i];
                if c != 0.0 {
                    let mut block = atf.view_mut((i * nb, 0), (nb, nd));
                    block.zip_apply(&ne.atf, |o, v| *o += c * v);
                }
            }
        }
        // The ridge relative to trace / N of the intercept's block as in the constant model
        // (at a demo's query the other blocks are zero), so that model's demo fits carry over.
        let w = solve_ridge(
            ata,
            &atf,
            self.options.ridge * p as f64,
            "locally weighted linear regression",
        )?;
        Ok(w.rows(0, nb).into_owned())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spd(n: usize, seed: f64) -> DMatrix<f64> {
        let b = DMatrix::from_fn(n, n, |i, j| ((i * 5 + j * 3) as f64 * seed).sin());
        &b * b.transpose() + DMatrix::identity(n, n)
    }

    #[test]
    fn nearest_is_the_head_of_the_stable_sort_by_distance() {
        // a 5 x 5 grid: many demos at the same distance from its centre and from a node
        let queries: Vec<Vec<f64>> = (0..25)
            .map(|k| vec![(k % 5) as f64, 2.0 * (k / 5) as f64])
            .collect();
        let ne = NormalEquations {
            ata: spd(3, 0.3),
            atf: DMatrix::zeros(3, 1),
        };
        let lwr = Lwr::new(&queries, vec![ne; 25], LwrOptions::default()).unwrap();
        for q in [[2.0, 4.0], [0.0, 0.0], [1.5, 3.0], [9.0, -1.0]] {
            let dist = lwr.distances(&q);
            let mut sorted: Vec<usize> = (0..25).collect();
            sorted.sort_by(|&a, &b| dist[a].total_cmp(&dist[b]));
            for k in [0, 1, 4, 5, 9, 24, 25, 40] {
                let mut want = sorted[..k.min(25)].to_vec();
                want.sort_unstable();
                assert_eq!(lwr.nearest(&q, k), want, "q={q:?} k={k}");
            }
        }
    }

    #[test]
    fn identical_demos_give_their_own_weights() {
        let ata = spd(6, 0.7);
        let w = DMatrix::from_fn(6, 2, |i, j| i as f64 - 2.0 * j as f64);
        let atf = &ata * &w;
        let ne = NormalEquations { ata, atf };
        let lwr = Lwr::new(
            &[vec![0.0], vec![1.0], vec![3.0]],
            vec![ne.clone(), ne.clone(), ne],
            LwrOptions::default(),
        )
        .unwrap();
        for q in [-1.0, 0.3, 2.0, 7.0] {
            let got = lwr.weights_at(&[q]).unwrap();
            assert!((got - &w).abs().max() < 1e-6, "q={q}");
        }
    }

    #[test]
    fn equal_design_matrices_give_a_convex_blend() {
        let ata = spd(5, 0.3);
        let ws: Vec<DMatrix<f64>> = (0..3)
            .map(|k| DMatrix::from_fn(5, 1, |i, _| (i + 3 * k) as f64))
            .collect();
        let normal: Vec<NormalEquations> = ws
            .iter()
            .map(|w| NormalEquations {
                ata: ata.clone(),
                atf: &ata * w,
            })
            .collect();
        for options in [
            LwrOptions {
                ridge: 1e-14,
                ..LwrOptions::default()
            },
            LwrOptions {
                kernel: Kernel::Gaussian,
                ridge: 1e-14,
                interpolate: false,
                ..LwrOptions::default()
            },
        ] {
            let lwr = Lwr::new(
                &[vec![0.0, 0.0], vec![1.0, 0.0], vec![0.0, 1.0]],
                normal.clone(),
                options,
            )
            .unwrap();
            let q = [0.3, 0.2];
            let kappa = lwr.demo_weights(&q);
            assert!(kappa.iter().all(|&k| (0.0..=1.0).contains(&k)));
            assert!((kappa.iter().sum::<f64>() - 1.0).abs() < 1e-14);
            let blend = ws
                .iter()
                .zip(&kappa)
                .fold(DMatrix::zeros(5, 1), |acc, (w, k)| acc + w * *k);
            assert!((lwr.weights_at(&q).unwrap() - blend).abs().max() < 1e-9);
        }
    }

    #[test]
    fn a_demo_query_selects_that_demo_and_nearby_queries_approach_it() {
        let ws: Vec<DMatrix<f64>> = (0..3)
            .map(|k| DMatrix::from_element(4, 1, k as f64))
            .collect();
        let normal = ws
            .iter()
            .enumerate()
            .map(|(k, w)| {
                let ata = spd(4, 0.2 + k as f64);
                NormalEquations { atf: &ata * w, ata }
            })
            .collect();
        let lwr = Lwr::new(
            &[vec![0.0], vec![1.0], vec![2.0]],
            normal,
            LwrOptions::default(),
        )
        .unwrap();
        assert_eq!(lwr.demo_weights(&[1.0]), vec![0.0, 1.0, 0.0]);
        let near = lwr.demo_weights(&[1.0 + 1e-6]);
        assert!(near[1] > 1.0 - 1e-9);
        let w = lwr.weights_at(&[1.0]).unwrap();
        assert!((w - &ws[1]).abs().max() < 1e-6);
    }

    #[test]
    fn tricube_is_compact_and_the_bandwidth_keeps_n_plus_1_demos() {
        assert_eq!(Kernel::Tricube.eval(1.0), 0.0);
        assert_eq!(Kernel::Tricube.eval(0.0), 1.0);
        let normal: Vec<NormalEquations> = (0..5)
            .map(|_| NormalEquations {
                ata: DMatrix::identity(2, 2),
                atf: DMatrix::zeros(2, 1),
            })
            .collect();
        let queries: Vec<Vec<f64>> = (0..5).map(|k| vec![(k * k) as f64]).collect();
        let lwr = Lwr::new(
            &queries,
            normal,
            LwrOptions {
                interpolate: false,
                ..LwrOptions::default()
            },
        )
        .unwrap();
        // Distances from 5: 5, 4, 1, 4, 11; the two nearest end at 4, so b = 6 and only 16 is out.
        let kappa = lwr.demo_weights(&[5.0]);
        assert_eq!(
            kappa.iter().map(|&k| k > 0.0).collect::<Vec<_>>(),
            vec![true, true, true, true, false]
        );
        let kappa = lwr.demo_weights(&[0.5]); // 0.5, 0.5 nearest: b = 0.75; 4 is at 3.5
        assert_eq!(kappa.iter().filter(|&&k| k > 0.0).count(), 2);
        assert!(
            LwrOptions {
                bandwidth: 1.0,
                ..LwrOptions::default()
            }
            .validate()
            .is_err()
        );
    }
}
