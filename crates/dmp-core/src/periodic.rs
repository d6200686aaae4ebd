//! The periodic (rhythmic) Dynamic Movement Primitive of Ijspeert, Nakanishi, Hoffmann, Pastor and
//! Schaal (2013, §2.2), with the amplitude and frequency parameters that Ude, Gams, Asfour and
//! Morimoto (2010) generalize (docs/method.md §12):
//!
//! ```text
//! tau dz/dt   = alpha_z (beta_z (g - y) - z) + f(phi)                       (P1)
//! tau dy/dt   = z                                                           (P2)
//! tau dphi/dt = 1,   phi taken mod 2 pi: the period is 2 pi tau             (P3)
//! f(phi)      = r sum_i psi_i(phi) w_i / sum_i psi_i(phi)                   (P4)
//! psi_i(phi)  = exp(h (cos(phi - c_i) - 1)),   c_i = 2 pi i / N
//! ```
//!
//! `g` is the baseline (the anchor the rhythm oscillates about), `r` the amplitude, `1 / tau` the
//! angular frequency. Every DOF has its own weights, baseline and amplitude; the phase and tau are
//! shared. The elementwise functions are the `libm` crate's, so the phase and the kernels give the
//! same bits on every machine.
//!
//! One integrator ([`PeriodicDmp::acceleration`] then [`PeriodicDmp::advance`]) serves the rollout
//! and every caller that steps the system itself.

use std::f64::consts::TAU as TWO_PI;

use nalgebra::{DMatrix, DMatrixView, DVector};

use crate::design_matrix::{
    DESIGN_CUTOFF, NormalEquations, PreparedDemo, accumulate_row, solve_ridge,
};
use crate::dmp::{Demonstration, FIT_RIDGE, MAX_BASIS};
use crate::error::{Error, Result, check_scalar, fmt_g};
use crate::euler::{MAX_SUBSTEPS, spring_stable_step};
use crate::periodic_forcing::{ForcingScratch, PeriodicForcing};
use crate::rollout::{check_values, check_work, n_steps};

/// Relative activations below `exp(-ACTIVATION_CUTOFF)` are exactly zero, as for the discrete
/// basis ([`crate::basis`]): they cannot change the normalized sum beyond rounding.
pub(crate) const ACTIVATION_CUTOFF: f64 = 37.0;

/// The meta-parameters of a periodic DMP.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PeriodicConfig {
    pub n_basis: usize,
    pub alpha_z: f64,
    pub beta_z: f64,
    /// Each kernel falls to `exp(-width_factor)` at its neighbours' centres:
    /// `h = width_factor / (1 - cos(2 pi / N))`, the von Mises counterpart of the discrete
    /// basis's `h_k = width_factor / (c_{k+1} - c_k)^2`. 2 gives `h` about `2.5 N` at N = 25, the
    /// width of Gams et al. (2009).
    pub width_factor: f64,
}

impl Default for PeriodicConfig {
    /// The discrete DMP's spring (alpha_z = 48, beta_z = alpha_z / 4) and width factor; 25 kernels.
    fn default() -> Self {
        Self {
            n_basis: 25,
            alpha_z: 48.0,
            beta_z: 12.0,
            width_factor: 2.0,
        }
    }
}

impl PeriodicConfig {
    pub fn validate(&self) -> Result<()> {
        check_scalar("alpha_z", self.alpha_z, true)?;
        check_scalar("beta_z", self.beta_z, true)?;
        check_scalar("width_factor", self.width_factor, true)?;
        if !(3..=MAX_BASIS).contains(&self.n_basis) {
            return Err(Error::InvalidParameter {
                name: "n_basis",
                value: self.n_basis.to_string(),
                requirement: "must be from 3 to 1000: fewer kernels cannot shape a rhythm, and \
                              the fit solves an n_basis x n_basis system",
            });
        }
        Ok(())
    }
}

/// Von Mises kernels evenly spaced on the circle (eq. P4).
#[derive(Debug, Clone, PartialEq)]
pub struct PeriodicBasis {
    centers: Vec<f64>,
    /// `cos c_i` and `sin c_i`: `cos(phi - c_i) = cos phi cos c_i + sin phi sin c_i` costs two
    /// products per kernel instead of a cosine.
    cos_c: Vec<f64>,
    sin_c: Vec<f64>,
    h: f64,
    /// `N / (2 pi)`, one over the centres' spacing.
    inv_spacing: f64,
    /// `2^(j / 64)`, j = 0..63, for [`PeriodicBasis::exp`].
    exp2_64ths: [f64; 64],
}

/// The kernels active at one phase: normalized activations `values[m]` of kernel
/// `(start + m) mod N`. The active set is contiguous on the circle and may wrap past `N - 1`.
#[derive(Debug, Clone)]
pub struct Activations {
    pub start: usize,
    pub values: Vec<f64>,
}

impl Activations {
    pub(crate) fn with_capacity(n: usize) -> Self {
        Self {
            start: 0,
            values: Vec::with_capacity(n),
        }
    }

    /// `sum_m values[m] w[(start + m) mod N]` for one DOF's weights `w` (length N).
    #[inline]
    pub fn dot(&self, w: &[f64]) -> f64 {
        let n = w.len();
        let first = (n - self.start).min(self.values.len());
        let (a, b) = self.values.split_at(first);
        let head: f64 = a.iter().zip(&w[self.start..]).map(|(p, w)| p * w).sum();
        head + b.iter().zip(w).map(|(p, w)| p * w).sum::<f64>()
    }
}

impl PeriodicBasis {
    pub fn new(n_basis: usize, width_factor: f64) -> Result<Self> {
        check_scalar("width_factor", width_factor, true)?;
        let spacing = TWO_PI / n_basis as f64;
        // c_i = i (2 pi / N), the centres of pydmps' rhythmic DMP (numpy's linspace without its
        // end point computes them the same way).
        let centers: Vec<f64> = (0..n_basis).map(|i| i as f64 * spacing).collect();
        let h = width_factor / (1.0 - libm::cos(spacing));
        Ok(Self {
            cos_c: centers.iter().map(|&c| libm::cos(c)).collect(),
            sin_c: centers.iter().map(|&c| libm::sin(c)).collect(),
            centers,
            h,
            inv_spacing: 1.0 / spacing,
            exp2_64ths: std::array::from_fn(|j| libm::exp2(j as f64 / 64.0)),
        })
    }

    pub fn len(&self) -> usize {
        self.centers.len()
    }

    pub fn is_empty(&self) -> bool {
        self.centers.is_empty()
    }

    pub fn centers(&self) -> &[f64] {
        &self.centers
    }

    /// The concentration `h` shared by every kernel.
    pub fn h(&self) -> f64 {
        self.h
    }

    /// `exp(x)` for `-ACTIVATION_CUTOFF <= x <= 0`, to within a few units in the last place:
    /// `x = (k / 64) ln 2 + r` with `|r| <= ln 2 / 128`, `exp(x) = 2^(k div 64) 2^((k mod 64) / 64)
    /// e^r`, e^r by its Taylor polynomial to r^5 (the next term is below 4e-17). The kernels'
    /// exponentials are most of a step's work; this is about three times quicker than libm's
    /// general `exp`, and like it is plain arithmetic in a fixed order: the same bits everywhere.
    #[inline(always)]
    pub(crate) fn exp(&self, x: f64) -> f64 {
        const SIXTY_FOUR_OVER_LN2: f64 = 92.332_482_616_893_66;
        // ln 2 / 64 split, its high part with 32 significant bits: k * LN2_64_HI is exact for |k| < 2^21
        const LN2_64_HI: f64 = 0.010_830_424_693_267_56;
        const LN2_64_LO: f64 = 2.981_585_826_985_293_3e-12;
        // adding and subtracting 1.5 * 2^52 rounds to the nearest integer, ties to even
        const ROUND: f64 = 6_755_399_441_055_744.0;
        // (a neighbour's exponent may exceed the nearest kernel's by a rounding error)
        debug_assert!((-ACTIVATION_CUTOFF - 1.0..=1.0).contains(&x));
        let shifted = x * SIXTY_FOUR_OVER_LN2 + ROUND;
        let kf = shifted - ROUND;
        // k = kf as an integer, read from the bits of `shifted` (whose last bit is worth 1, and
        // ROUND's last six bits are 0), so that the lanes of a vector need no conversion
        let k = shifted.to_bits().wrapping_sub(ROUND.to_bits()) as i64;
        let r = (x - kf * LN2_64_HI) - kf * LN2_64_LO;
        let p =
            1.0 + r * (1.0 + r * (0.5 + r * (1.0 / 6.0 + r * (1.0 / 24.0 + r * (1.0 / 120.0)))));
        let scale = f64::from_bits(((1023 + (k >> 6)) as u64) << 52);
        self.exp2_64ths[(k & 63) as usize] * p * scale
    }

    /// [`PeriodicBasis::exp`] of four lanes, for callers compiled for AVX2: the same
    /// operations lane by lane (multiplies and adds, never fused), so the same bits.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    pub(crate) fn exp4(&self, x: std::arch::x86_64::__m256d) -> std::arch::x86_64::__m256d {
        use std::arch::x86_64::*;
        const SIXTY_FOUR_OVER_LN2: f64 = 92.332_482_616_893_66;
        const LN2_64_HI: f64 = 0.010_830_424_693_267_56;
        const LN2_64_LO: f64 = 2.981_585_826_985_293_3e-12;
        const ROUND: f64 = 6_755_399_441_055_744.0;
        let c = |v: f64| _mm256_set1_pd(v);
        let shifted = _mm256_add_pd(_mm256_mul_pd(x, c(SIXTY_FOUR_OVER_LN2)), c(ROUND));
        let kf = _mm256_sub_pd(shifted, c(ROUND));
        let k = _mm256_sub_epi64(
            _mm256_castpd_si256(shifted),
            _mm256_set1_epi64x(ROUND.to_bits() as i64),
        );
        let r = _mm256_sub_pd(
            _mm256_sub_pd(x, _mm256_mul_pd(kf, c(LN2_64_HI))),
            _mm256_mul_pd(kf, c(LN2_64_LO)),
        );
        let horner = |a: f64, inner| _mm256_add_pd(c(a), _mm256_mul_pd(r, inner));
        let p = horner(
            1.0,
            horner(
                1.0,
                horner(0.5, horner(1.0 / 6.0, horner(1.0 / 24.0, c(1.0 / 120.0)))),
            ),
        );
        // 2^(k div 64): `k` is small, so its low 32 bits shift arithmetically as the whole
        // would, and only the low 12 bits of `1023 + (k >> 6)` reach the exponent field.
        let e = _mm256_add_epi32(_mm256_srai_epi32::<6>(k), _mm256_set1_epi64x(1023));
        let scale = _mm256_castsi256_pd(_mm256_slli_epi64::<52>(e));
        let idx = _mm256_and_si256(k, _mm256_set1_epi64x(63));
        // SAFETY: every index is below 64, within the table.
        let t = unsafe { _mm256_i64gather_pd::<8>(self.exp2_64ths.as_ptr(), idx) };
        _mm256_mul_pd(_mm256_mul_pd(t, p), scale)
    }

    #[inline(always)]
    pub(crate) fn arg(&self, i: usize, cos_phi: f64, sin_phi: f64) -> f64 {
        self.h * (cos_phi * self.cos_c[i] + sin_phi * self.sin_c[i] - 1.0)
    }

    /// `cos c_i` and `sin c_i` of every centre.
    pub(crate) fn trig(&self) -> (&[f64], &[f64]) {
        (&self.cos_c, &self.sin_c)
    }

    /// The index of the centre nearest to `phi`.
    #[inline(always)]
    pub(crate) fn nearest(&self, phi: f64) -> usize {
        let n = self.len();
        // phi in [0, 2 pi) (the integrator keeps it there), so the nearest centre's index is a
        // truncation, without a division
        let wrapped = if (0.0..TWO_PI).contains(&phi) {
            phi
        } else {
            phi.rem_euclid(TWO_PI)
        };
        let nearest = (wrapped * self.inv_spacing + 0.5) as usize;
        if nearest >= n { nearest - n } else { nearest }
    }

    /// The normalized activations `psi_i(phi) / sum_j psi_j(phi)` at `phi` into `out`.
    ///
    /// `h (cos(phi - c) - 1)` falls monotonically from the centre nearest to `phi` to the
    /// opposite point of the circle, so the active set is found by walking outwards from that
    /// centre until the activation relative to it drops below the cut-off (about ten kernels,
    /// not N). Activations are taken relative to the largest, which never underflows.
    pub fn normalized_activations(&self, phi: f64, out: &mut Activations) {
        let n = self.len();
        let (sin_phi, cos_phi) = libm::sincos(phi);
        let nearest = self.nearest(phi);
        let top = self.arg(nearest, cos_phi, sin_phi);
        let floor = top - ACTIVATION_CUTOFF;
        // Walk down, then up, at most half the circle each way (the two walks never overlap),
        // keeping each exponent: the indices wrap by a comparison, not a division.
        let values = &mut out.values;
        values.clear();
        let mut i = nearest;
        while values.len() < (n - 1) / 2 {
            i = if i == 0 { n - 1 } else { i - 1 };
            let a = self.arg(i, cos_phi, sin_phi);
            if a <= floor {
                break;
            }
            values.push(a);
        }
        let below = values.len();
        values.reverse();
        values.push(top);
        let mut i = nearest;
        while values.len() - below - 1 < n / 2 {
            i = if i + 1 == n { 0 } else { i + 1 };
            let a = self.arg(i, cos_phi, sin_phi);
            if a <= floor {
                break;
            }
            values.push(a);
        }
        out.start = if nearest >= below {
            nearest - below
        } else {
            nearest + n - below
        };
        let mut sum = 0.0;
        for v in values.iter_mut() {
            *v = self.exp(*v - top);
            sum += *v;
        }
        let inv_sum = 1.0 / sum;
        for v in values.iter_mut() {
            *v *= inv_sum;
        }
    }
}

/// Positions, velocities `z / tau` and phase of a running periodic DMP.
#[derive(Debug, Clone, PartialEq)]
pub struct PeriodicState {
    /// In `[0, 2 pi)`.
    pub phi: f64,
    pub y: Vec<f64>,
    pub z: Vec<f64>,
}

/// A multi-DOF periodic DMP.
#[derive(Debug, Clone, PartialEq)]
pub struct PeriodicDmp {
    config: PeriodicConfig,
    /// `N x D`: column d holds the weights of DOF d, in units of y per unit amplitude.
    weights: DMatrix<f64>,
    /// The forcing term's shape, evaluated a phase at a time.
    forcing: PeriodicForcing,
    goal: DVector<f64>,
    amplitude: DVector<f64>,
    y0: DVector<f64>,
    tau: f64,
}

/// Scratch space for [`PeriodicDmp::acceleration`], reused from step to step.
#[derive(Debug, Clone)]
pub struct Workspace {
    scratch: ForcingScratch,
    /// `sum_i psi_i w_i / sum_i psi_i` per DOF, padded to whole vectors.
    shape: Vec<f64>,
}

impl PeriodicDmp {
    /// Builds a periodic DMP from its parameters, validating every one.
    pub fn new(
        config: PeriodicConfig,
        weights: DMatrix<f64>,
        goal: DVector<f64>,
        amplitude: DVector<f64>,
        y0: DVector<f64>,
        tau: f64,
    ) -> Result<Self> {
        config.validate()?;
        let basis = PeriodicBasis::new(config.n_basis, config.width_factor)?;
        if weights.nrows() != config.n_basis || weights.ncols() == 0 {
            return Err(Error::Shape {
                name: "weights",
                expected: format!("(n_dof >= 1, {}) (n_dof, n_basis)", config.n_basis),
                got: format!("({}, {})", weights.ncols(), weights.nrows()),
            });
        }
        let n_dof = weights.ncols();
        for (name, v) in [("goal", &goal), ("amplitude", &amplitude), ("start", &y0)] {
            check_per_dof(name, v.as_slice(), n_dof)?;
        }
        check_scalar("tau", tau, true)?;
        if let Some((i, &w)) = weights.iter().enumerate().find(|(_, w)| !w.is_finite()) {
            return Err(Error::NonFinite {
                name: "weights",
                location: format!("[{}, {}]", i / config.n_basis, i % config.n_basis),
                value: w,
            });
        }
        Ok(Self {
            config,
            forcing: PeriodicForcing::new(basis, &weights),
            weights,
            goal,
            amplitude,
            y0,
            tau,
        })
    }

    /// Fits a periodic DMP to a demonstration of one or more whole periods by batch least squares
    /// (docs/method.md §12.2): `tau = period / (2 pi)`, `phi_j = (t_j - t_1) / tau`, the baseline
    /// `g = (min y + max y) / 2` and the amplitude `r = (max y - min y) / 2` per DOF (1 for a DOF
    /// that does not move), `F_j = tau^2 ydd_j - alpha_z (beta_z (g - y_j) - tau yd_j)`, and
    /// `w = argmin |A w - F / r|` with `A_ji = psi_i(phi_j) / sum_k psi_k(phi_j)`.
    ///
    /// `period` defaults to the demonstration's duration (exactly one period).
    pub fn fit(
        demo: &Demonstration<'_>,
        period: Option<f64>,
        config: PeriodicConfig,
    ) -> Result<Self> {
        let prepared = PreparedDemo::new(demo)?;
        let (goal, amplitude) = baseline_and_amplitude(&prepared.y);
        Self::fit_about(&prepared, period, config, goal, amplitude)
    }

    /// The least squares of [`PeriodicDmp::fit`] about a given baseline and amplitude (the
    /// periodic Cartesian DMP's orientation has its own).
    pub(crate) fn fit_about(
        prepared: &PreparedDemo<'_>,
        period: Option<f64>,
        config: PeriodicConfig,
        goal: DVector<f64>,
        amplitude: DVector<f64>,
    ) -> Result<Self> {
        let (ne, tau) = Self::normal_equations_about(prepared, period, &config, &goal, &amplitude)?;
        let weights = solve_ridge(ne.ata, &ne.atf, FIT_RIDGE, "periodic DMP fit")?;
        Self::new(config, weights, goal, amplitude, prepared.y0.clone(), tau)
    }

    /// [`PeriodicDmp::fit`] and the normal equations `A^T A`, `A^T F / r` it solved, which the
    /// generalizer's LWR weighs across demonstrations.
    pub(crate) fn fit_with_normal_equations(
        prepared: &PreparedDemo<'_>,
        period: Option<f64>,
        config: PeriodicConfig,
    ) -> Result<(Self, NormalEquations)> {
        let (goal, amplitude) = baseline_and_amplitude(&prepared.y);
        let (ne, tau) = Self::normal_equations_about(prepared, period, &config, &goal, &amplitude)?;
        let weights = solve_ridge(ne.ata.clone(), &ne.atf, FIT_RIDGE, "periodic DMP fit")?;
        let dmp = Self::new(config, weights, goal, amplitude, prepared.y0.clone(), tau)?;
        Ok((dmp, ne))
    }

    /// The normal equations of the fit about `goal` and `amplitude`, and tau.
    fn normal_equations_about(
        prepared: &PreparedDemo<'_>,
        period: Option<f64>,
        config: &PeriodicConfig,
        goal: &DVector<f64>,
        amplitude: &DVector<f64>,
    ) -> Result<(NormalEquations, f64)> {
        config.validate()?;
        let period = period.unwrap_or(prepared.tau);
        check_scalar("period", period, true)?;
        if period > prepared.tau * (1.0 + 1e-9) {
            return Err(Error::InvalidParameter {
                name: "period",
                value: fmt_g(period),
                requirement: "must be at most the demonstration's duration: a periodic DMP is \
                              fitted to one or more whole periods",
            });
        }
        let basis = PeriodicBasis::new(config.n_basis, config.width_factor)?;
        let tau = period / TWO_PI;
        let n_dof = prepared.n_dof();
        let n = basis.len();
        let mut ata = DMatrix::<f64>::zeros(n, n);
        let mut atf = DMatrix::<f64>::zeros(n, n_dof);
        let mut act = Activations::with_capacity(n);
        let mut row = vec![0.0; n];
        let mut force = vec![0.0; n_dof];
        let t0 = prepared.t[0];
        for (j, &tj) in prepared.t.iter().enumerate() {
            basis.normalized_activations(((tj - t0) / tau).rem_euclid(TWO_PI), &mut act);
            row.iter_mut().for_each(|v| *v = 0.0);
            for (m, &v) in act.values.iter().enumerate() {
                // the lab code's cut-off, as in the discrete fit
                row[(act.start + m) % n] = if v < DESIGN_CUTOFF { 0.0 } else { v };
            }
            let end = act.start + act.values.len();
            // a span that wraps past N - 1 is added as a whole row
            let nz = if end <= n { act.start..end } else { 0..n };
            for d in 0..n_dof {
                force[d] = (tau * tau * prepared.ydd[(d, j)]
                    - config.alpha_z
                        * (config.beta_z * (goal[d] - prepared.y[(d, j)])
                            - tau * prepared.yd[(d, j)]))
                    / amplitude[d];
            }
            accumulate_row(&mut ata, &mut atf, &row, nz, &force);
        }
        Ok((NormalEquations { ata, atf }, tau))
    }

    pub fn config(&self) -> &PeriodicConfig {
        &self.config
    }
    pub fn basis(&self) -> &PeriodicBasis {
        self.forcing.basis()
    }
    /// `N x D`, column d = the weights of DOF d.
    pub fn weights(&self) -> &DMatrix<f64> {
        &self.weights
    }
    pub fn goal(&self) -> &DVector<f64> {
        &self.goal
    }
    pub fn amplitude(&self) -> &DVector<f64> {
        &self.amplitude
    }
    pub fn y0(&self) -> &DVector<f64> {
        &self.y0
    }
    pub fn tau(&self) -> f64 {
        self.tau
    }
    /// `2 pi tau` (s).
    pub fn period(&self) -> f64 {
        TWO_PI * self.tau
    }
    pub fn n_dof(&self) -> usize {
        self.goal.len()
    }

    fn rebuilt(
        &self,
        goal: DVector<f64>,
        amplitude: DVector<f64>,
        y0: DVector<f64>,
        tau: f64,
    ) -> Result<Self> {
        Self::new(self.config, self.weights.clone(), goal, amplitude, y0, tau)
    }
    /// The same rhythm about another baseline.
    pub fn with_goal(&self, goal: DVector<f64>) -> Result<Self> {
        self.rebuilt(goal, self.amplitude.clone(), self.y0.clone(), self.tau)
    }
    /// The same rhythm scaled about its baseline.
    pub fn with_amplitude(&self, amplitude: DVector<f64>) -> Result<Self> {
        self.rebuilt(self.goal.clone(), amplitude, self.y0.clone(), self.tau)
    }
    /// The same rhythm started from another position.
    pub fn with_start(&self, y0: DVector<f64>) -> Result<Self> {
        self.rebuilt(self.goal.clone(), self.amplitude.clone(), y0, self.tau)
    }
    /// The same rhythm at another frequency: only the period changes.
    pub fn with_tau(&self, tau: f64) -> Result<Self> {
        self.rebuilt(
            self.goal.clone(),
            self.amplitude.clone(),
            self.y0.clone(),
            tau,
        )
    }

    pub fn workspace(&self) -> Workspace {
        Workspace {
            scratch: self.forcing.scratch(),
            shape: vec![0.0; self.forcing.stride()],
        }
    }

    /// The state at rest at the start, at phase `phi`.
    pub fn initial_state(&self, phi: f64) -> PeriodicState {
        PeriodicState {
            phi: phi.rem_euclid(TWO_PI),
            y: self.y0.as_slice().to_vec(),
            z: vec![0.0; self.n_dof()],
        }
    }

    /// `tau dz/dt` of eq. P1 at `state` into `dz`, with the baseline `goal`, the amplitude
    /// `amplitude` (a caller changing them while it runs passes its own) and the DMP's weights.
    pub fn acceleration(
        &self,
        state: &PeriodicState,
        goal: &[f64],
        amplitude: &[f64],
        ws: &mut Workspace,
        dz: &mut [f64],
    ) {
        let cfg = &self.config;
        let shape = self.shape(state.phi, ws);
        for d in 0..dz.len() {
            dz[d] = cfg.alpha_z * (cfg.beta_z * (goal[d] - state.y[d]) - state.z[d])
                + amplitude[d] * shape[d];
        }
    }

    /// The forcing term's shape `sum_i psi_i w_i / sum_i psi_i` at phase `phi` (eq. P4 without
    /// the amplitude), per coordinate, in `ws`.
    #[inline]
    pub(crate) fn shape<'w>(&self, phi: f64, ws: &'w mut Workspace) -> &'w [f64] {
        self.forcing.eval(phi, &mut ws.scratch, &mut ws.shape);
        &ws.shape
    }

    /// One semi-implicit (symplectic) Euler step of length `h` (s) at time constant `tau`, with
    /// `dz = tau dz/dt` evaluated at `state`: `z` first, then `y` with the new `z` (eqs. P1-P2),
    /// then the phase (P3). Symplectic Euler keeps an undamped oscillation's amplitude where
    /// explicit Euler lets it grow, and it is pydmps' scheme, so the two agree exactly.
    pub fn advance(state: &mut PeriodicState, dz: &[f64], tau: f64, h: f64) {
        let k = h / tau;
        for ((y, z), dz) in state.y.iter_mut().zip(state.z.iter_mut()).zip(dz) {
            *z += dz * k;
            *y += *z * k;
        }
        state.phi += k;
        if state.phi >= TWO_PI {
            state.phi -= TWO_PI;
        }
    }

    /// Validates a rollout's arguments and returns its samples and the sub-steps per sample;
    /// `width` values are returned per sample.
    pub(crate) fn plan(
        &self,
        dt: f64,
        duration: Option<f64>,
        phi0: f64,
        width: usize,
        context: &'static str,
    ) -> Result<(usize, usize)> {
        check_scalar("dt", dt, true)?;
        check_scalar("phase", phi0, false)?;
        let duration = duration.unwrap_or(self.period());
        check_scalar("duration", duration, true)?;
        let steps = n_steps(duration, dt);
        check_values(steps, width, dt)?;
        let substeps = self.substeps(dt)?;
        check_work((steps + 1.0) * substeps as f64, self.n_dof(), context)?;
        Ok((steps as usize + 1, substeps))
    }

    /// Sub-steps per sample that keep the spring stable (1 when `dt` already is).
    fn substeps(&self, dt: f64) -> Result<usize> {
        self.substeps_at(dt, self.tau)
    }

    /// Sub-steps per sample of `dt` that keep the spring stable at time constant `tau`.
    pub(crate) fn substeps_at(&self, dt: f64, tau: f64) -> Result<usize> {
        let limit = spring_stable_step(self.config.alpha_z, self.config.beta_z) * tau;
        if dt <= limit {
            return Ok(1);
        }
        let k = (dt / limit).ceil();
        if k.is_nan() || k > MAX_SUBSTEPS as f64 {
            return Err(Error::Numerical {
                context: "periodic DMP rollout",
                detail: format!(
                    "dt = {} is too coarse for tau = {}, alpha_z = {} and beta_z = {}: it needs {} \
                     sub-steps per sample, at most {MAX_SUBSTEPS} are taken; use a smaller dt or \
                     a larger tau",
                    fmt_g(dt),
                    fmt_g(tau),
                    fmt_g(self.config.alpha_z),
                    fmt_g(self.config.beta_z),
                    fmt_g(k)
                ),
            });
        }
        Ok(k as usize)
    }
}

/// One finite value per DOF, or an error naming `name`.
pub(crate) fn check_per_dof(name: &'static str, v: &[f64], n_dof: usize) -> Result<()> {
    if v.len() != n_dof {
        return Err(Error::Shape {
            name,
            expected: format!("({n_dof},), one entry per DOF"),
            got: format!("({},)", v.len()),
        });
    }
    if let Some((i, &x)) = v.iter().enumerate().find(|(_, x)| !x.is_finite()) {
        return Err(Error::NonFinite {
            name,
            location: format!("[{i}]"),
            value: x,
        });
    }
    Ok(())
}

/// `(min + max) / 2` and `(max - min) / 2` of every DOF of a demonstration (1 where it is 0).
pub(crate) fn baseline_and_amplitude(y: &DMatrixView<'_, f64>) -> (DVector<f64>, DVector<f64>) {
    let n_dof = y.nrows();
    let mut goal = DVector::zeros(n_dof);
    let mut amplitude = DVector::zeros(n_dof);
    for d in 0..n_dof {
        let row = y.row(d);
        let (lo, hi) = (row.min(), row.max());
        goal[d] = 0.5 * (lo + hi);
        let r = 0.5 * (hi - lo);
        amplitude[d] = if r > 0.0 { r } else { 1.0 };
    }
    (goal, amplitude)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DMatrixView;

    fn dmp(weights: DMatrix<f64>, tau: f64, y0: f64) -> PeriodicDmp {
        let n_dof = weights.ncols();
        let cfg = PeriodicConfig {
            n_basis: weights.nrows(),
            ..PeriodicConfig::default()
        };
        PeriodicDmp::new(
            cfg,
            weights,
            DVector::from_element(n_dof, 0.5),
            DVector::from_element(n_dof, 1.0),
            DVector::from_element(n_dof, y0),
            tau,
        )
        .unwrap()
    }

    #[test]
    fn the_kernels_exp_is_within_two_ulp_of_libms_over_its_range() {
        let b = PeriodicBasis::new(30, 2.0).unwrap();
        let mut worst = 0.0_f64;
        for j in 0..=200_000 {
            let x = -ACTIVATION_CUTOFF * j as f64 / 200_000.0;
            let (ours, exact) = (b.exp(x), libm::exp(x));
            worst = worst.max((ours - exact).abs() / (exact * f64::EPSILON));
        }
        assert!(worst <= 2.0, "{worst} ulp");
        assert_eq!(b.exp(0.0), 1.0);
    }

    #[test]
    fn activations_match_every_kernel_evaluated() {
        let b = PeriodicBasis::new(30, 2.0).unwrap();
        let mut act = Activations::with_capacity(30);
        for k in 0..1000 {
            let phi = k as f64 * 0.0071;
            b.normalized_activations(phi, &mut act);
            let all: Vec<f64> = b
                .centers()
                .iter()
                .map(|c| (b.h() * ((phi - c).cos() - 1.0)).exp())
                .collect();
            let sum: f64 = all.iter().sum();
            let mut dense = vec![0.0; 30];
            for (m, v) in act.values.iter().enumerate() {
                dense[(act.start + m) % 30] = *v;
            }
            for i in 0..30 {
                assert!(
                    (dense[i] - all[i] / sum).abs() < 1e-14,
                    "phi {phi} kernel {i}"
                );
            }
        }
    }

    #[test]
    fn without_forcing_it_is_the_critically_damped_spring() {
        // f = 0: y = g + (A + B t) exp(-alpha_z t / (2 tau)); Euler's error halves with dt.
        let d = dmp(DMatrix::zeros(10, 1), 0.3, 1.5);
        let err = |dt: f64| {
            let tr = d.rollout(dt, Some(0.3), 0.0).unwrap();
            let (a, b) = (1.0, 48.0 * 1.0 / (2.0 * 0.3));
            tr.t.iter()
                .zip(&tr.y)
                .map(|(t, y)| (y - (0.5 + (a + b * t) * (-48.0 * t / 0.6).exp())).abs())
                .fold(0.0, f64::max)
        };
        let (e1, e2) = (err(1e-4), err(5e-5));
        assert!(e1 < 5e-3 && (e1 / e2 - 2.0).abs() < 0.1, "{e1} {e2}");
    }

    #[test]
    fn a_sine_is_reproduced_from_its_exact_forcing() {
        // y = g + A sin(phi): the forcing target is A ((alpha_z beta_z - 1) sin + alpha_z cos);
        // a fit to one period of it must reproduce the sine once the start transient has gone.
        let (tau, amp) = (0.25, 0.3);
        let t: Vec<f64> = (0..=2000)
            .map(|j| j as f64 * TWO_PI * tau / 2000.0)
            .collect();
        let y: Vec<f64> = t.iter().map(|t| 0.5 + amp * (t / tau).sin()).collect();
        let yd: Vec<f64> = t.iter().map(|t| amp / tau * (t / tau).cos()).collect();
        let ydd: Vec<f64> = t
            .iter()
            .map(|t| -amp / (tau * tau) * (t / tau).sin())
            .collect();
        let view = |v: &Vec<f64>| DMatrixView::from_slice(v.as_slice(), 1, v.len()).into_owned();
        let (y, yd, ydd) = (view(&y), view(&yd), view(&ydd));
        let demo = Demonstration {
            t: &t,
            y: y.as_view(),
            yd: Some(yd.as_view()),
            ydd: Some(ydd.as_view()),
        };
        let cfg = PeriodicConfig {
            n_basis: 50,
            ..PeriodicConfig::default()
        };
        let d = PeriodicDmp::fit(&demo, None, cfg).unwrap();
        assert!((d.goal()[0] - 0.5).abs() < 1e-12 && (d.amplitude()[0] - amp).abs() < 1e-12);
        // the fitted forcing equals the exact target at every sample
        let mut ws = d.workspace();
        for j in (0..2000).step_by(37) {
            let phi = t[j] / tau;
            let state = PeriodicState {
                phi,
                y: vec![y[j]],
                z: vec![tau * yd[j]],
            };
            let mut dz = [0.0];
            d.acceleration(&state, &[0.5], &[amp], &mut ws, &mut dz);
            assert!(
                (dz[0] - tau * tau * ydd[j]).abs() < 5e-3 * amp * 48.0 * 12.0,
                "{j} {} {}",
                dz[0],
                tau * tau * ydd[j]
            );
        }
        let tr = d.with_start(DVector::from_element(1, 0.5)).unwrap();
        let tr = tr.rollout(1e-4, Some(4.0 * d.period()), 0.0).unwrap();
        for (t, yv) in
            tr.t.iter()
                .zip(&tr.y)
                .filter(|(t, _)| **t > 2.0 * d.period())
        {
            assert!((yv - (0.5 + amp * (t / tau).sin())).abs() < 3e-3, "t {t}");
        }
    }

    #[test]
    fn amplitude_scales_and_tau_only_changes_the_period() {
        let w = DMatrix::from_fn(12, 2, |i, d| ((i * 7 + d * 3) % 5) as f64 - 2.0);
        let d = dmp(w, 0.2, 0.5);
        let base = d.rollout(1e-3, Some(1.0), 0.0).unwrap();
        let scaled = d.with_amplitude(DVector::from_element(2, 3.0)).unwrap();
        let scaled = scaled.rollout(1e-3, Some(1.0), 0.0).unwrap();
        for (a, b) in base.y.iter().zip(&scaled.y) {
            assert!(((b - 0.5) - 3.0 * (a - 0.5)).abs() < 1e-12);
        }
        // twice tau at twice dt: the same samples
        let slow = d
            .with_tau(0.4)
            .unwrap()
            .rollout(2e-3, Some(2.0), 0.0)
            .unwrap();
        for (a, b) in base.y.iter().zip(&slow.y) {
            assert!((a - b).abs() < 1e-12);
        }
    }

    #[test]
    fn bad_parameters_are_named() {
        let e = PeriodicDmp::new(
            PeriodicConfig::default(),
            DMatrix::zeros(25, 1),
            DVector::from_element(1, f64::NAN),
            DVector::from_element(1, 1.0),
            DVector::zeros(1),
            1.0,
        )
        .unwrap_err();
        assert!(e.to_string().contains("goal"), "{e}");
        let d = dmp(DMatrix::zeros(5, 1), 1.0, 0.0);
        assert!(
            d.rollout(0.0, None, 0.0)
                .unwrap_err()
                .to_string()
                .contains("dt")
        );
        assert!(
            d.rollout(100.0, Some(200.0), 0.0)
                .unwrap_err()
                .to_string()
                .contains("coarse")
        );
    }
}
