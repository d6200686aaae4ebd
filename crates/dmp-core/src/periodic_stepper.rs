//! A periodic DMP executed online, one control period at a time (docs/method.md §12.6): the
//! rollout's integrator (`PeriodicDmp::acceleration` and `advance`) with what a robot needs
//! around it.
//!
//! - **Start and stop at rest.** The forcing term is multiplied by an envelope `m` in `[0, 1]`
//!   that rises over `ramp` periods of the phase after the start and falls over as many after
//!   [`PeriodicStepper::stop`], by the smoothstep `3 s^2 - 2 s^3` of its progress `s`, while the
//!   baseline moves from the start to `g` (and to the rest position on stopping) through the
//!   change filter. With `m = 0` the spring is critically damped: one period after the ramp
//!   ends the residue is `exp(-alpha_z pi)` of the motion, and the stepper is done.
//! - **Filtered changes.** A new baseline, amplitude or frequency is approached by the filter
//!   `tau dv/dt = alpha_c (v* - v)` (for the frequency `1/tau`), so a change never jumps the
//!   command.
//! - **Phase stopping.** Given the measured position, the time scale is the nominal times
//!   `1 + sum_d alpha_e,d e_d^2` (Ijspeert et al. 2013), so the rhythm waits for a held robot.
//! - **Limits by temporal coupling.** Velocity and acceleration limits slow the clock
//!   (`crate::temporal_coupling`, Dahlin and Karayiannidis 2021) instead of clipping.
//!
//! Each step returns sample k and chooses the time scale of period k+1 first, so that the
//! returned acceleration is the change of the returned velocity to the next command's,
//! `yd_{k+1} = yd_k + dt ydd_k`, and the position follows the semi-implicit scheme,
//! `y_{k+1} = y_k + dt yd_{k+1}`. With no option in play (no ramp, no change, no measurement,
//! no limits) a step is the rollout's step, bit for bit.

use std::f64::consts::TAU as TWO_PI;

use crate::error::{Error, Result, check_scalar, fmt_g};
use crate::periodic::{PeriodicDmp, PeriodicState, Workspace, check_per_dof};
use crate::stepper::{DEFAULT_ALPHA_E, check_state, phase_stop_factor, phase_stopping_gains};
use crate::temporal_coupling::{TemporalCoupling, TemporalCouplingGains};

/// The change filter's default `alpha_c`: a change settles to 1 % in about 4.6 rad of phase,
/// three quarters of a period.
pub const DEFAULT_CHANGE_FILTER: f64 = 1.0;

/// How a periodic stepper runs.
#[derive(Debug, Clone, PartialEq)]
pub struct PeriodicStepperOptions {
    /// The control period (s).
    pub dt: f64,
    /// The phase to start at (rad).
    pub phase: f64,
    /// Periods over which the rhythm fades in after the start and out after `stop`; 0: it
    /// starts at full amplitude (the rollout) and stops by the spring alone.
    pub ramp: f64,
    /// `alpha_c` of the change filter.
    pub change_filter: f64,
    /// Phase-stopping gains, one or one per coordinate; all 0: off.
    pub alpha_e: Vec<f64>,
    pub velocity_max: Option<Vec<f64>>,
    pub acceleration_max: Option<Vec<f64>>,
    pub temporal_coupling: TemporalCouplingGains,
}

impl PeriodicStepperOptions {
    pub fn new(dt: f64) -> Self {
        Self {
            dt,
            phase: 0.0,
            ramp: 1.0,
            change_filter: DEFAULT_CHANGE_FILTER,
            alpha_e: vec![DEFAULT_ALPHA_E],
            velocity_max: None,
            acceleration_max: None,
            temporal_coupling: TemporalCouplingGains::default(),
        }
    }
}

/// Where the envelope is going.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Envelope {
    Rising,
    Running,
    Falling,
    /// Stopped: the time (s) the spring has had since the envelope reached 0.
    Settling(f64),
}

/// What a step saves before it changes anything, to put back if it fails.
#[derive(Debug, Clone)]
struct Saved {
    state: PeriodicState,
    goal: Filtered,
    amplitude: Filtered,
    frequency: Filtered,
}

/// A periodic DMP stepped online.
#[derive(Debug, Clone)]
pub struct PeriodicStepper {
    dmp: PeriodicDmp,
    opts: PeriodicStepperOptions,
    alpha_e: Vec<f64>,
    coupling: Option<TemporalCoupling>,
    state: PeriodicState,
    ws: Workspace,
    /// The envelope's progress `s` in `[0, 1]` and its direction.
    progress: f64,
    envelope: Envelope,
    goal: Filtered,
    amplitude: Filtered,
    /// The nominal frequency `1/tau`.
    frequency: Filtered,
    /// The time scale of the coming period.
    tau: f64,
    /// Euler sub-steps per control period (the rollout's rule at the smallest nominal tau set).
    substeps: usize,
    over_limit: bool,
    steps: u64,
    dz: Vec<f64>,
    dz_next: Vec<f64>,
    z_k: Vec<f64>,
    scratch: PeriodicState,
    saved: Saved,
    effective: Vec<f64>,
    out_y: Vec<f64>,
    out_yd: Vec<f64>,
    out_ydd: Vec<f64>,
}

/// f64 lanes of an AVX2 vector.
const LANES: usize = 4;

/// The constants of one plain period (`PeriodicStepper::plain_period`).
struct PlainPass {
    alpha_z: f64,
    beta_z: f64,
    /// The envelope's factor.
    m: f64,
    inv_tau: f64,
    /// `dt / tau` as the rollout's step takes it.
    k: f64,
    dt: f64,
    /// `1 / tau_next - 1 / tau`.
    change: f64,
    inv_tau2: f64,
}

/// What one plain period reads and writes per coordinate, `n` values each.
struct PlainRows<'a> {
    goal: &'a [f64],
    amplitude: &'a [f64],
    shape: &'a [f64],
    y: &'a mut [f64],
    z: &'a mut [f64],
    dz: &'a mut [f64],
    out_y: &'a mut [f64],
    out_yd: &'a mut [f64],
    out_ydd: &'a mut [f64],
}

impl PlainRows<'_> {
    /// The period's pass over the coordinates (eqs. P1-P2, then the position step at the next
    /// period's scale); returns whether the new state and the command are finite.
    #[inline(always)]
    fn pass(self, c: &PlainPass) -> bool {
        let mut finite = true;
        for d in 0..self.y.len() {
            let (y0, z0) = (self.y[d], self.z[d]);
            let h = c.alpha_z * (c.beta_z * (self.goal[d] - y0) - z0)
                + c.m * self.amplitude[d] * self.shape[d];
            self.dz[d] = h;
            self.out_y[d] = y0;
            self.out_yd[d] = z0 * c.inv_tau;
            let z1 = z0 + h * c.k;
            let y1 = y0 + z1 * c.k;
            self.z[d] = z1;
            self.y[d] = y1 + z1 * c.dt * c.change;
            self.out_ydd[d] = h * c.inv_tau2 + z1 * c.change / c.dt;
            finite &= self.y[d].is_finite() & z1.is_finite() & self.out_ydd[d].is_finite();
        }
        finite
    }

    /// [`PlainRows::pass`] four coordinates at a time in AVX2 registers, the same operations
    /// lane by lane (never fused). With `n` not a multiple of four the last vector is the last
    /// four coordinates, overlapping the one before: it is computed first, from the values
    /// before any store, so an overlapped coordinate is computed twice from the same values
    /// with the same bits, and no store is masked (AMD cores microcode masked stores). Fewer
    /// than four coordinates take the scalar pass.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn pass_avx2(mut self, c: &PlainPass) -> bool {
        use std::arch::x86_64::*;
        let n = self.y.len();
        if n < LANES {
            return self.pass(c);
        }
        let mut finite = _mm256_castsi256_pd(_mm256_set1_epi64x(-1));
        // SAFETY (every call below): each vector's four coordinates `at..at + 4` are within
        // every slice, all `n` long.
        let tail = (!n.is_multiple_of(LANES)).then(|| {
            let at = n - LANES;
            (at, unsafe { self.lanes_avx2(c, at, &mut finite) })
        });
        for at in (0..n - n % LANES).step_by(LANES) {
            let row = unsafe { self.lanes_avx2(c, at, &mut finite) };
            unsafe { self.store_avx2(at, row) };
        }
        if let Some((at, row)) = tail {
            unsafe { self.store_avx2(at, row) };
        }
        _mm256_movemask_pd(finite) == 0b1111
    }

    /// The pass on coordinates `at..at + 4`: `[dz, y, yd, z, y, ydd]` to store (the command's
    /// and the new state's), their finiteness folded into `finite`.
    ///
    /// # Safety
    /// `at + 4 <= n`, and the CPU has AVX2 and FMA.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn lanes_avx2(
        &self,
        c: &PlainPass,
        at: usize,
        finite: &mut std::arch::x86_64::__m256d,
    ) -> [std::arch::x86_64::__m256d; 6] {
        use std::arch::x86_64::*;
        let v = |x: f64| _mm256_set1_pd(x);
        // SAFETY: `at + 4 <= n` (the caller's).
        let load = |s: &[f64]| unsafe { _mm256_loadu_pd(s.as_ptr().add(at)) };
        let (y0, z0) = (load(self.y), load(self.z));
        let spring = _mm256_sub_pd(
            _mm256_mul_pd(v(c.beta_z), _mm256_sub_pd(load(self.goal), y0)),
            z0,
        );
        let forcing = _mm256_mul_pd(
            _mm256_mul_pd(v(c.m), load(self.amplitude)),
            load(self.shape),
        );
        let h = _mm256_add_pd(_mm256_mul_pd(v(c.alpha_z), spring), forcing);
        let z1 = _mm256_add_pd(z0, _mm256_mul_pd(h, v(c.k)));
        let y1 = _mm256_add_pd(y0, _mm256_mul_pd(z1, v(c.k)));
        let y2 = _mm256_add_pd(y1, _mm256_mul_pd(_mm256_mul_pd(z1, v(c.dt)), v(c.change)));
        let ydd = _mm256_add_pd(
            _mm256_mul_pd(h, v(c.inv_tau2)),
            _mm256_div_pd(_mm256_mul_pd(z1, v(c.change)), v(c.dt)),
        );
        let (sign, inf) = (v(-0.0), v(f64::INFINITY));
        let is_finite = |x| _mm256_cmp_pd::<_CMP_LT_OQ>(_mm256_andnot_pd(sign, x), inf);
        *finite = _mm256_and_pd(*finite, _mm256_and_pd(is_finite(y2), is_finite(z1)));
        *finite = _mm256_and_pd(*finite, is_finite(ydd));
        [h, y0, _mm256_mul_pd(z0, v(c.inv_tau)), z1, y2, ydd]
    }

    /// Stores a vector of [`PlainRows::lanes_avx2`] at coordinates `at..at + 4`.
    ///
    /// # Safety
    /// `at + 4 <= n`, and the CPU has AVX2 and FMA.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn store_avx2(&mut self, at: usize, row: [std::arch::x86_64::__m256d; 6]) {
        use std::arch::x86_64::*;
        let [dz, y0, yd, z1, y2, ydd] = row;
        for (s, x) in [
            (&mut *self.dz, dz),
            (&mut *self.out_y, y0),
            (&mut *self.out_yd, yd),
            (&mut *self.z, z1),
            (&mut *self.y, y2),
            (&mut *self.out_ydd, ydd),
        ] {
            // SAFETY: `at + 4 <= n` (the caller's), the length of every slice.
            unsafe { _mm256_storeu_pd(s.as_mut_ptr().add(at), x) };
        }
    }
}

fn smoothstep(s: f64) -> f64 {
    s * s * (3.0 - 2.0 * s)
}

impl PeriodicStepper {
    pub fn new(dmp: &PeriodicDmp, opts: &PeriodicStepperOptions) -> Result<Self> {
        check_scalar("dt", opts.dt, true)?;
        check_scalar("phase", opts.phase, false)?;
        check_scalar("ramp", opts.ramp, false)?;
        if opts.ramp < 0.0 {
            return Err(Error::InvalidParameter {
                name: "ramp",
                value: fmt_g(opts.ramp),
                requirement: "must be >= 0 (periods; 0: no fade in or out)",
            });
        }
        check_scalar("change_filter", opts.change_filter, true)?;
        let n = dmp.n_dof();
        let alpha_e = phase_stopping_gains(&opts.alpha_e, n)?;
        let coupling = TemporalCoupling::if_limited(
            n,
            opts.velocity_max.as_deref(),
            opts.acceleration_max.as_deref(),
            opts.temporal_coupling,
        )?;
        let tau = dmp.tau();
        check_time_scale(dmp, opts, tau, "dt")?;
        let y0 = dmp.y0().as_slice().to_vec();
        let ramped = opts.ramp > 0.0;
        let mut stepper = Self {
            alpha_e,
            coupling,
            state: dmp.initial_state(opts.phase),
            ws: dmp.workspace(),
            progress: if ramped { 0.0 } else { 1.0 },
            envelope: if ramped {
                Envelope::Rising
            } else {
                Envelope::Running
            },
            // faded in, the baseline moves from the start (the rollout's runs about g at once)
            goal: Filtered::new(
                if ramped { &y0 } else { dmp.goal().as_slice() },
                dmp.goal().as_slice(),
            ),
            amplitude: Filtered::at(dmp.amplitude().as_slice()),
            frequency: Filtered::at(&[1.0 / tau]),
            tau,
            substeps: dmp.substeps_at(opts.dt, tau)?,
            over_limit: false,
            steps: 0,
            dz: vec![0.0; n],
            dz_next: vec![0.0; n],
            z_k: vec![0.0; n],
            scratch: dmp.initial_state(opts.phase),
            saved: Saved {
                state: dmp.initial_state(opts.phase),
                goal: Filtered::at(&vec![0.0; n]),
                amplitude: Filtered::at(&vec![0.0; n]),
                frequency: Filtered::at(&[0.0]),
            },
            effective: vec![0.0; n],
            out_y: y0.clone(),
            out_yd: vec![0.0; n],
            out_ydd: vec![0.0; n],
            dmp: dmp.clone(),
            opts: opts.clone(),
        };
        if stepper.coupling.is_some() {
            // start slow enough that the first command's accelerations are within the limits
            stepper.effective_amplitude();
            stepper.dmp.acceleration(
                &stepper.state,
                &stepper.goal.value,
                &stepper.effective,
                &mut stepper.ws,
                &mut stepper.dz,
            );
            let tc = stepper.coupling.as_ref().expect("checked");
            stepper.tau = tc.tau_at_rest(tau, &stepper.dz);
        }
        Ok(stepper)
    }

    /// The envelope times the amplitude, into `effective`.
    fn effective_amplitude(&mut self) {
        let m = smoothstep(self.progress);
        for (e, a) in self.effective.iter_mut().zip(&self.amplitude.value) {
            *e = m * a;
        }
    }

    /// One control period: returns the command `(y, yd, ydd)` of sample k and advances to k+1.
    /// `measured` (the robot's position, one per coordinate) slows the clock by phase stopping.
    /// A measurement that is not finite or too far off is refused with the state unchanged;
    /// a state that would become non-finite is an error and nothing is returned.
    pub fn step(&mut self, measured: Option<&[f64]>) -> Result<(&[f64], &[f64], &[f64])> {
        let n = self.dmp.n_dof();
        let stop = match measured {
            Some(m) => {
                check_per_dof("measured", m, n)?;
                phase_stop_factor(
                    &self.alpha_e,
                    m.iter().zip(&self.state.y).map(|(a, b)| a - b),
                )?
            }
            None => 1.0,
        };
        // what a failed step must leave as it was, saved into buffers of the same sizes (no
        // allocation); `tau`, `steps` and `over_limit` are only written once the state is finite
        let saved = &mut self.saved;
        saved.state.phi = self.state.phi;
        saved.state.y.copy_from_slice(&self.state.y);
        saved.state.z.copy_from_slice(&self.state.z);
        // (a filter at rest stays as it is)
        let moving = [&self.goal, &self.amplitude, &self.frequency].map(|f| !f.at_rest);
        for ((saved, filter), moving) in [
            (&mut saved.goal, &self.goal),
            (&mut saved.amplitude, &self.amplitude),
            (&mut saved.frequency, &self.frequency),
        ]
        .into_iter()
        .zip(moving)
        {
            if moving {
                saved.copy_from(filter);
            }
        }
        let (progress, envelope) = (self.progress, self.envelope);
        match self.advance(stop) {
            Ok(()) => Ok((&self.out_y, &self.out_yd, &self.out_ydd)),
            Err(e) => {
                let saved = &mut self.saved;
                std::mem::swap(&mut self.state, &mut saved.state);
                for ((filter, saved), moving) in [
                    (&mut self.goal, &mut saved.goal),
                    (&mut self.amplitude, &mut saved.amplitude),
                    (&mut self.frequency, &mut saved.frequency),
                ]
                .into_iter()
                .zip(moving)
                {
                    if moving {
                        std::mem::swap(filter, saved);
                    }
                }
                (self.progress, self.envelope) = (progress, envelope);
                Err(e)
            }
        }
    }

    /// [`PeriodicStepper::step`] without a measurement and without keeping what a failed step
    /// would put back: the rollout's step, whose error ends the rollout.
    pub(crate) fn step_open_loop(&mut self) -> Result<(&[f64], &[f64], &[f64])> {
        self.advance(1.0)?;
        Ok((&self.out_y, &self.out_yd, &self.out_ydd))
    }

    /// That the new state, the command's acceleration and the next period's scale `next` are
    /// finite.
    fn check_finite(&self, next: f64) -> Result<()> {
        check_state(
            "periodic stepper",
            self.state.phi,
            &[
                &self.state.y,
                &self.state.z,
                &self.out_ydd,
                std::slice::from_ref(&next),
            ],
            self.steps,
        )
    }

    fn advance(&mut self, stop: f64) -> Result<()> {
        if self.coupling.is_none() && self.substeps == 1 {
            return self.plain_period(stop);
        }
        self.staged_period(stop)
    }

    /// The period of [`PeriodicStepper::staged_period`] without limits or sub-steps, the common
    /// case: the same operations on every coordinate, in one pass over the coordinates instead
    /// of one per stage. The frequency filter, which the pass does not read, moves first, so
    /// that the next period's scale is known in the pass; the baseline and amplitude filters
    /// and the envelope move after it, as there.
    fn plain_period(&mut self, stop: f64) -> Result<()> {
        let (dt, tau) = (self.opts.dt, self.tau);
        let cfg = *self.dmp.config();
        let m = smoothstep(self.progress);
        let shape = self.dmp.shape(self.state.phi, &mut self.ws);
        let inv_tau = 1.0 / tau;
        // (`PeriodicDmp::advance`'s step of `h = dt / substeps`, with one sub-step)
        let k = dt / 1.0 / tau;
        let dphase = dt / tau;
        let alpha = self.opts.change_filter;
        self.frequency.advance(alpha, dphase);
        let next = stop * (1.0 / self.frequency.value[0]);
        let change = 1.0 / next - inv_tau;
        let inv_tau2 = 1.0 / (tau * tau);
        let pass = PlainPass {
            alpha_z: cfg.alpha_z,
            beta_z: cfg.beta_z,
            m,
            inv_tau,
            k,
            dt,
            change,
            inv_tau2,
        };
        let n = self.dz.len();
        let rows = PlainRows {
            goal: &self.goal.value[..n],
            amplitude: &self.amplitude.value[..n],
            shape: &shape[..n],
            y: &mut self.state.y[..n],
            z: &mut self.state.z[..n],
            dz: &mut self.dz[..n],
            out_y: &mut self.out_y[..n],
            out_yd: &mut self.out_yd[..n],
            out_ydd: &mut self.out_ydd[..n],
        };
        #[cfg(target_arch = "x86_64")]
        let finite = if crate::linalg::has_avx2_fma() {
            // SAFETY: the CPU supports the enabled features (checked just above).
            unsafe { rows.pass_avx2(&pass) }
        } else {
            rows.pass(&pass)
        };
        #[cfg(not(target_arch = "x86_64"))]
        let finite = rows.pass(&pass);
        let finite = finite && next.is_finite();
        self.state.phi += k;
        if self.state.phi >= TWO_PI {
            self.state.phi -= TWO_PI;
        }
        if !finite {
            self.check_finite(next)?;
        }
        self.move_envelope(dphase);
        self.goal.advance(alpha, dphase);
        self.amplitude.advance(alpha, dphase);
        self.over_limit = false;
        self.tau = next;
        if let Envelope::Settling(t) = &mut self.envelope {
            *t += dt;
        }
        self.steps += 1;
        Ok(())
    }

    /// One period with every stage in its own pass: the effective amplitude, the rollout's
    /// acceleration and sub-steps, the filters, the next period's scale (from the temporal
    /// coupling where there are limits), the position step at that scale.
    fn staged_period(&mut self, stop: f64) -> Result<()> {
        let dt = self.opts.dt;
        let tau = self.tau;
        self.effective_amplitude();
        self.dmp.acceleration(
            &self.state,
            &self.goal.value,
            &self.effective,
            &mut self.ws,
            &mut self.dz,
        );
        let inv_tau = 1.0 / tau;
        for ((oy, oyd), (y, z)) in self
            .out_y
            .iter_mut()
            .zip(self.out_yd.iter_mut())
            .zip(self.state.y.iter().zip(&self.state.z))
        {
            *oy = *y;
            *oyd = z * inv_tau;
        }
        self.z_k.copy_from_slice(&self.state.z);
        let h = dt / self.substeps as f64;
        PeriodicDmp::advance(&mut self.state, &self.dz, tau, h);
        for _ in 1..self.substeps {
            // (the rollout's sub-steps: the envelope and the filters hold within a period)
            self.dmp.acceleration(
                &self.state,
                &self.goal.value,
                &self.effective,
                &mut self.ws,
                &mut self.dz_next,
            );
            PeriodicDmp::advance(&mut self.state, &self.dz_next, tau, h);
        }
        // the phase advanced by dt / tau: the envelope and the filters move with it
        let dphase = dt / tau;
        self.move_envelope(dphase);
        let alpha = self.opts.change_filter;
        self.goal.advance(alpha, dphase);
        self.amplitude.advance(alpha, dphase);
        self.frequency.advance(alpha, dphase);
        let nominal = 1.0 / self.frequency.value[0];
        let target = stop * nominal;
        let next = match self.coupling.as_mut() {
            None => target,
            Some(tc) => {
                if tc.limits_acceleration() {
                    self.scratch.clone_from(&self.state);
                    let m = smoothstep(self.progress);
                    for (e, a) in self.effective.iter_mut().zip(&self.amplitude.value) {
                        *e = m * a;
                    }
                    // (the next position at this period's scale: the coupling's bound for the
                    // next sample is approximate by that one position step)
                    self.dmp.acceleration(
                        &self.scratch,
                        &self.goal.value,
                        &self.effective,
                        &mut self.ws,
                        &mut self.dz_next,
                    );
                }
                tc.next_tau(
                    tau,
                    nominal,
                    target,
                    &self.z_k,
                    &self.dz,
                    &self.state.z,
                    &self.dz_next,
                    dt,
                )
            }
        };
        // the semi-implicit position step at the next period's scale: y_{k+1} = y_k + dt yd_{k+1}
        // (adds exactly 0 while the scale does not change)
        let change = 1.0 / next - inv_tau;
        let inv_tau2 = 1.0 / (tau * tau);
        for (((y, z), dz), ydd) in self
            .state
            .y
            .iter_mut()
            .zip(&self.state.z)
            .zip(&self.dz)
            .zip(self.out_ydd.iter_mut())
        {
            *y += z * dt * change;
            *ydd = dz * inv_tau2 + z * change / dt;
        }
        self.check_finite(next)?;
        self.over_limit = match &self.coupling {
            Some(tc) if tc.limits_acceleration() => self
                .out_ydd
                .iter()
                .zip(tc.acceleration_max())
                .any(|(a, m)| a.abs() > m * (1.0 + 1e-12)),
            _ => false,
        };
        self.tau = next;
        if let Envelope::Settling(t) = &mut self.envelope {
            *t += dt;
        }
        self.steps += 1;
        Ok(())
    }

    fn move_envelope(&mut self, dphase: f64) {
        let ramp = self.opts.ramp;
        let ds = if ramp > 0.0 {
            dphase / (TWO_PI * ramp)
        } else {
            1.0
        };
        match self.envelope {
            Envelope::Rising => {
                self.progress = (self.progress + ds).min(1.0);
                if self.progress == 1.0 {
                    self.envelope = Envelope::Running;
                }
            }
            Envelope::Falling => {
                self.progress = (self.progress - ds).max(0.0);
                if self.progress == 0.0 {
                    self.envelope = Envelope::Settling(0.0);
                }
            }
            Envelope::Running | Envelope::Settling(_) => {}
        }
    }

    /// Fades the rhythm out over `ramp` periods (at once with `ramp = 0`) and brings it to rest
    /// at `rest` (by default the baseline) through the change filter.
    pub fn stop(&mut self, rest: Option<&[f64]>) -> Result<()> {
        if let Some(r) = rest {
            check_per_dof("rest", r, self.dmp.n_dof())?;
            self.goal.set_target(r);
        }
        if self.opts.ramp == 0.0 {
            self.progress = 0.0;
            self.envelope = Envelope::Settling(0.0);
        } else if !matches!(self.envelope, Envelope::Settling(_)) {
            self.envelope = Envelope::Falling;
        }
        Ok(())
    }

    /// A new baseline, approached through the change filter.
    pub fn set_goal(&mut self, goal: &[f64]) -> Result<()> {
        check_per_dof("goal", goal, self.dmp.n_dof())?;
        self.goal.set_target(goal);
        Ok(())
    }

    /// A new amplitude per coordinate, approached through the change filter.
    pub fn set_amplitude(&mut self, amplitude: &[f64]) -> Result<()> {
        check_per_dof("amplitude", amplitude, self.dmp.n_dof())?;
        self.amplitude.set_target(amplitude);
        Ok(())
    }

    /// A new nominal time constant (the period over 2 pi), its frequency approached through the
    /// change filter; refused if the spring would be unstable at it or the filter at `dt`.
    pub fn set_tau(&mut self, tau: f64) -> Result<()> {
        check_scalar("tau", tau, true)?;
        check_time_scale(&self.dmp, &self.opts, tau, "tau")?;
        self.substeps = self.substeps.max(self.dmp.substeps_at(self.opts.dt, tau)?);
        self.frequency.set_target(&[1.0 / tau]);
        Ok(())
    }

    /// Whether the rhythm has stopped: faded out and one period of the spring since, at rest at
    /// its rest position to `exp(-alpha_z pi)` of the motion.
    pub fn done(&self) -> bool {
        match self.envelope {
            Envelope::Settling(t) => t >= TWO_PI / self.frequency.target[0] && self.goal.settled(),
            _ => false,
        }
    }
    /// Whether the last command's acceleration exceeds `acceleration_max` (the coupling's
    /// feasibility condition failed); false without acceleration limits.
    pub fn over_limit(&self) -> bool {
        self.over_limit
    }
    /// The phase of the coming sample (rad).
    pub fn phase(&self) -> f64 {
        self.state.phi
    }
    /// The time scale of the coming period.
    pub fn tau(&self) -> f64 {
        self.tau
    }
    /// The nominal time scale the frequency filter is at.
    pub fn nominal_tau(&self) -> f64 {
        1.0 / self.frequency.value[0]
    }
    /// The envelope `m` in `[0, 1]` of the coming sample.
    pub fn envelope(&self) -> f64 {
        smoothstep(self.progress)
    }
    pub fn goal(&self) -> &[f64] {
        &self.goal.value
    }
    pub fn amplitude(&self) -> &[f64] {
        &self.amplitude.value
    }
    pub fn steps(&self) -> u64 {
        self.steps
    }
    pub fn dt(&self) -> f64 {
        self.opts.dt
    }
    pub fn n_dof(&self) -> usize {
        self.dmp.n_dof()
    }
    pub fn dmp(&self) -> &PeriodicDmp {
        &self.dmp
    }
}

/// Values moved to their targets by a critically damped second-order filter in the phase,
/// `v'' = alpha^2 (v* - v) - 2 alpha v'` (`'` per radian): a change starts and ends with zero
/// rate, so it never jumps the command's velocity.
#[derive(Debug, Clone, PartialEq)]
struct Filtered {
    value: Vec<f64>,
    rate: Vec<f64>,
    target: Vec<f64>,
    /// Every value at its target at rest: a step changes nothing (the common case, kept so that
    /// a step neither advances nor saves it).
    at_rest: bool,
}

impl Filtered {
    fn new(value: &[f64], target: &[f64]) -> Self {
        Self {
            value: value.to_vec(),
            rate: vec![0.0; value.len()],
            target: target.to_vec(),
            at_rest: value == target,
        }
    }
    fn at(value: &[f64]) -> Self {
        Self::new(value, value)
    }
    fn copy_from(&mut self, other: &Self) {
        self.value.copy_from_slice(&other.value);
        self.rate.copy_from_slice(&other.rate);
        self.target.copy_from_slice(&other.target);
        self.at_rest = other.at_rest;
    }
    fn set_target(&mut self, target: &[f64]) {
        self.target.copy_from_slice(target);
        self.at_rest = self.settled();
    }
    fn settled_at(&self, d: usize) -> bool {
        self.value[d] == self.target[d] && self.rate[d] == 0.0
    }
    fn settled(&self) -> bool {
        (0..self.value.len()).all(|d| self.settled_at(d))
    }
    /// One semi-implicit Euler step over `dphase` radians; values within 1e-12 (relative to
    /// max(1, |target|)) of their targets, at a rate as small, are set to them.
    fn advance(&mut self, alpha: f64, dphase: f64) {
        if self.at_rest {
            return;
        }
        for d in 0..self.value.len() {
            if self.settled_at(d) {
                continue;
            }
            let (v, r, t) = (&mut self.value[d], &mut self.rate[d], self.target[d]);
            *r += (alpha * alpha * (t - *v) - 2.0 * alpha * *r) * dphase;
            *v += *r * dphase;
            let tol = 1e-12 * t.abs().max(1.0);
            if (*v - t).abs() <= tol && r.abs() <= tol {
                *v = t;
                *r = 0.0;
            }
        }
        self.at_rest = self.settled();
    }
}

/// The change filter takes one step per control period: `dt` must keep it stable at the time
/// scale `tau` (the nominal; phase stopping and the coupling only lengthen it). The spring is
/// kept stable by sub-steps, as in the rollout.
fn check_time_scale(
    dmp: &PeriodicDmp,
    opts: &PeriodicStepperOptions,
    tau: f64,
    name: &'static str,
) -> Result<()> {
    let refused = |requirement| Error::InvalidParameter {
        name,
        value: if name == "dt" {
            fmt_g(opts.dt)
        } else {
            fmt_g(tau)
        },
        requirement,
    };
    // the rollout's rule, refused here as the option that broke it (the joint stepper's words)
    if dmp.substeps_at(opts.dt, tau).is_err() {
        return Err(refused(if name == "dt" {
            "is too coarse for this DMP: explicit Euler would need more than 1000 sub-steps per \
             period; use a smaller dt or a larger tau"
        } else {
            "is too short for dt: explicit Euler would need more than 1000 sub-steps per period; \
             use a larger tau or a smaller dt"
        }));
    }
    if opts.dt * opts.change_filter > tau {
        return Err(refused(
            "must keep the change filter stable: dt * change_filter <= tau",
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use nalgebra::{DMatrix, DVector};

    use super::*;
    use crate::periodic::PeriodicConfig;

    fn rhythm() -> PeriodicDmp {
        let cfg = PeriodicConfig {
            n_basis: 20,
            alpha_z: 48.0,
            beta_z: 12.0,
            width_factor: 2.0,
        };
        let w = DMatrix::from_fn(20, 2, |i, d| ((i * 7 + d * 3) % 11) as f64 - 5.0);
        PeriodicDmp::new(
            cfg,
            w,
            DVector::from_vec(vec![0.5, -0.2]),
            DVector::from_vec(vec![0.1, 0.3]),
            DVector::from_vec(vec![0.4, 0.0]),
            0.2,
        )
        .unwrap()
    }

    /// The one-pass period must give the staged period's bits, through a ramp, changes of the
    /// baseline, amplitude and frequency, phase stopping and a stop.
    #[test]
    fn the_one_pass_period_gives_the_staged_periods_bits() {
        let dmp = rhythm();
        let opts = PeriodicStepperOptions {
            ramp: 0.5,
            ..PeriodicStepperOptions::new(1e-3)
        };
        let mut plain = PeriodicStepper::new(&dmp, &opts).unwrap();
        let mut staged = plain.clone();
        let bits = |v: &[f64]| v.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        for k in 0..8000 {
            for s in [&mut plain, &mut staged] {
                match k {
                    700 => s.set_goal(&[0.2, 0.1]).unwrap(),
                    1500 => s.set_amplitude(&[0.3, 0.2]).unwrap(),
                    2200 => s.set_tau(0.25).unwrap(),
                    4500 => s.stop(None).unwrap(),
                    _ => {}
                }
            }
            let lag = if (3000..3300).contains(&k) { 0.01 } else { 0.0 };
            let stop = 1.0 + 1e4 * lag * lag;
            plain.plain_period(stop).unwrap();
            staged.staged_period(stop).unwrap();
            assert_eq!(bits(&plain.out_y), bits(&staged.out_y), "step {k}");
            assert_eq!(bits(&plain.out_yd), bits(&staged.out_yd), "step {k}");
            assert_eq!(bits(&plain.out_ydd), bits(&staged.out_ydd), "step {k}");
            assert_eq!(plain.tau.to_bits(), staged.tau.to_bits(), "step {k}");
            assert_eq!(plain.done(), staged.done(), "step {k}");
        }
        assert!(plain.done());
    }

    #[test]
    fn without_options_a_step_is_the_rollouts_step_bit_for_bit() {
        let dmp = rhythm();
        // 1 ms: one Euler step a period; 10 ms: the rollout's sub-steps
        for dt in [1e-3, 1e-2] {
            let mut opts = PeriodicStepperOptions::new(dt);
            opts.ramp = 0.0;
            opts.phase = 0.7;
            let tr = dmp.rollout(dt, Some(3.0), 0.7).unwrap();
            let mut st = PeriodicStepper::new(&dmp, &opts).unwrap();
            for k in 0..tr.t.len() {
                let (y, yd, ydd) = st.step(None).unwrap();
                assert_eq!(y, &tr.y[2 * k..2 * k + 2]);
                assert_eq!(yd, &tr.yd[2 * k..2 * k + 2]);
                assert_eq!(ydd, &tr.ydd[2 * k..2 * k + 2]);
            }
        }
    }

    #[test]
    fn commands_stay_consistent_through_changes_stopping_and_a_held_robot() {
        let dmp = rhythm();
        let dt = 1e-3;
        let mut st = PeriodicStepper::new(&dmp, &PeriodicStepperOptions::new(dt)).unwrap();
        let mut last: Option<(Vec<f64>, Vec<f64>, Vec<f64>)> = None;
        for k in 0..9000 {
            match k {
                1500 => st.set_tau(0.12).unwrap(),
                2000 => st.set_goal(&[0.0, 0.3]).unwrap(),
                2500 => st.set_amplitude(&[0.2, 0.1]).unwrap(),
                4000 => st.stop(Some(&[0.1, 0.1])).unwrap(),
                _ => {}
            }
            // held between 3000 and 3300
            let held = (3000..3300).contains(&k);
            let measured = last.as_ref().map(|(y, _, _)| y.clone());
            let m = if held { measured.as_deref() } else { None };
            let (y, yd, ydd) = st.step(m).unwrap();
            if let Some((py, pyd, pydd)) = &last {
                for d in 0..2 {
                    assert!((yd[d] - (pyd[d] + dt * pydd[d])).abs() < 1e-9 * (1.0 + yd[d].abs()));
                    assert!((y[d] - (py[d] + dt * yd[d])).abs() < 1e-12);
                }
            }
            last = Some((y.to_vec(), yd.to_vec(), ydd.to_vec()));
        }
        assert!(st.done());
        let (y, yd, _) = last.unwrap();
        for d in 0..2 {
            assert!(
                (y[d] - 0.1).abs() < 1e-9 && yd[d].abs() < 1e-9,
                "{y:?} {yd:?}"
            );
        }
    }
}
