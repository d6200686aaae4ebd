//! Online execution of a DMP inside a control loop (docs/method.md §2.5): one call of
//! [`Stepper::step`] per control period returns the next command `(y, yd, ydd)`.
//!
//! Without measurements, coupling terms, limits or goal changes the k-th call returns the
//! rollout's sample k (`t = k dt`) bit for bit: the rollout ([`crate::rollout`]) is this stepper
//! run open loop, each sample written into the returned arrays. Explicit Euler in the order
//! `y += z/tau h`, `z += dz h`, `x -= alpha_x x/tau h`, in sub-steps when `dt` is beyond the
//! stability limit ([`crate::euler::stable_step`]).
//!
//! Online, the stepper adds
//! * **phase stopping** (Ijspeert et al. 2002, 2013): a measured state `y~` slows the clock by
//!   `1 + sum_d alpha_e,d (y~_d - y_d)^2`, the same factor for the phase and the transformation
//!   system (`tau_eff = tau (1 + ...)`), so a held robot waits at one phase and resumes from it;
//! * **a goal filter** `tau dg/dt = alpha_g (g_new - g)`, so a new goal moves the attractor
//!   smoothly;
//! * **temporal coupling** ([`crate::temporal_coupling`]) for velocity and acceleration limits;
//! * **coupling terms** ([`crate::coupling`]): repulsion from position limits, and a caller's term
//!   per step.
//!
//! The time scale `tau_eff` is constant over one control period and the state is integrated in
//! the scaled time `ds = dt / tau_eff`, in which the DMP does not depend on `tau`: however the
//! clock is slowed, the path is the DMP's (to the Euler discretization of a finer step). Each
//! step chooses the scale of the next period (from its measurement, `set_tau`, the temporal
//! coupling), so its acceleration `(h - taud z) / (tau tau_next)` is the change of its velocity
//! to the next command's: with one sub-step `yd[k+1] = yd[k] + ydd[k] dt` to rounding.

use crate::coupling::PositionLimits;
use crate::dmp::{Dmp, DmpConfig, phase_clock, phase_to_go};
use crate::error::{Error, Result, check_scalar, fmt_g};
use crate::euler::{MAX_SUBSTEPS, moving_spring, substeps_needed};
use crate::forcing::{Forcing, SumStart, padded};
use crate::temporal_coupling::{TemporalCoupling, TemporalCouplingGains};

/// Default phase-stopping gain, in 1 / (units of y)^2: a tracking error of 0.01 (rad or m)
/// halves the speed of the clock (docs/method.md §2.5.2).
pub const DEFAULT_ALPHA_E: f64 = 1e4;
/// Default goal-filter gain `alpha_g` (= alpha_z / 2 for the default alpha_z = 48): a goal jump
/// raises the commanded acceleration gradually, to a fraction of the unfiltered jump
/// (docs/method.md §2.5.3).
pub const DEFAULT_GOAL_FILTER: f64 = 24.0;
/// A filtered goal within this (relative to max(1, |g|)) of its target is set to it, so that
/// the target is reached exactly rather than approached forever.
const GOAL_SNAP: f64 = 1e-12;

/// How a stepper runs: the control period and everything the online DMP adds to the rollout.
#[derive(Debug, Clone, PartialEq)]
pub struct StepperOptions {
    /// The control period (s): one call of `step` advances the clock by `dt`.
    pub dt: f64,
    /// Euler sub-steps per period; `None`: the fewest stable ones, the rollout's rule (1 for any
    /// `dt` within the stability limit).
    pub substeps: Option<usize>,
    /// Phase-stopping gains in 1 / (units of y)^2: one for every coordinate, or one each; empty
    /// or all 0: off. Only used when `step` is given a measured state.
    pub alpha_e: Vec<f64>,
    /// `alpha_g` of the goal filter; `None`: `set_goal` moves the attractor at once.
    pub goal_filter: Option<f64>,
    /// Velocity limits per coordinate (`+inf`: none), met by temporal coupling.
    pub velocity_max: Option<Vec<f64>>,
    /// Acceleration limits per coordinate (`+inf`: none), met by temporal coupling.
    pub acceleration_max: Option<Vec<f64>>,
    pub temporal_coupling: TemporalCouplingGains,
    /// Position limits per coordinate (`-inf` / `+inf`: none) for the repulsion.
    pub position_min: Option<Vec<f64>>,
    pub position_max: Option<Vec<f64>>,
    /// Width of the repulsion's band per coordinate; `None`: 5 % of the range.
    pub limit_margin: Option<Vec<f64>>,
    /// `kappa` of the repulsion: at half the band from a limit it pushes as the DMP's spring
    /// `alpha_z beta_z` does over `kappa` bands.
    pub limit_gain: f64,
    /// Tolerance of [`Stepper::done`] (units of y): the rollout's `rest_tol`.
    pub rest_tol: f64,
}

impl StepperOptions {
    /// The defaults at control period `dt`: phase stopping with [`DEFAULT_ALPHA_E`], the goal
    /// filter with [`DEFAULT_GOAL_FILTER`], no limits, no coupling.
    pub fn new(dt: f64) -> Self {
        Self {
            dt,
            substeps: None,
            alpha_e: vec![DEFAULT_ALPHA_E],
            goal_filter: Some(DEFAULT_GOAL_FILTER),
            velocity_max: None,
            acceleration_max: None,
            temporal_coupling: TemporalCouplingGains::default(),
            position_min: None,
            position_max: None,
            limit_margin: None,
            limit_gain: 1.0,
            rest_tol: 1e-4,
        }
    }
}

/// Whether a stepper's phase `x` and the slices of its `state` are finite after `steps` steps;
/// the error says how to go on.
#[inline(always)]
pub(crate) fn check_state(
    context: &'static str,
    x: f64,
    state: &[&[f64]],
    steps: u64,
) -> Result<()> {
    // Without short-circuiting, one slice at a time, so that the loops vectorize.
    let bad = state.iter().fold(!x.is_finite(), |bad, v| {
        v.iter().fold(bad, |bad, v| bad | !v.is_finite())
    });
    if !bad {
        return Ok(());
    }
    Err(Error::Numerical {
        context,
        detail: format!(
            "the state became non-finite after {steps} steps (a coupling term or goal too large \
             for f64, or a dt too coarse); reset() to start again"
        ),
    })
}

/// A coordinate vector passed to a stepper, checked: `n` finite values.
pub(crate) fn check_coordinates(name: &'static str, v: &[f64], n: usize) -> Result<()> {
    if v.len() != n {
        return Err(Error::Shape {
            name,
            expected: format!("({n},), one value per coordinate"),
            got: format!("({},)", v.len()),
        });
    }
    match v.iter().position(|v| !v.is_finite()) {
        Some(i) => Err(Error::NonFinite {
            name,
            location: format!("[{i}]"),
            value: v[i],
        }),
        None => Ok(()),
    }
}

/// The per-coordinate phase-stopping gains, `alpha_e` expanded to `n` (all 0 when off).
pub(crate) fn phase_stopping_gains(alpha_e: &[f64], n: usize) -> Result<Vec<f64>> {
    for (i, &a) in alpha_e.iter().enumerate() {
        if !(a.is_finite() && a >= 0.0) {
            return Err(Error::InvalidParameter {
                name: "alpha_e",
                value: format!("{} at [{i}]", fmt_g(a)),
                requirement: "must be finite and >= 0",
            });
        }
    }
    match alpha_e.len() {
        0 => Ok(vec![0.0; n]),
        1 => Ok(vec![alpha_e[0]; n]),
        len if len == n => Ok(alpha_e.to_vec()),
        len => Err(Error::Shape {
            name: "alpha_e",
            expected: format!("a scalar or ({n},), one gain per coordinate"),
            got: format!("({len},)"),
        }),
    }
}

/// That the goal filter's Euler step `g += alpha_g (g_target - g) hs / tau` (`hs = dt /
/// substeps`, docs/method.md §2.5.3) approaches the new goal without overshooting it:
/// `alpha_g hs / tau <= 1` at the nominal tau (temporal coupling only lengthens tau, which
/// shortens the step). Beyond 1 the goal overshoots, beyond 2 it diverges.
fn check_goal_filter(alpha_g: Option<f64>, dt: f64, substeps: usize, tau: f64) -> Result<()> {
    let Some(alpha_g) = alpha_g else {
        return Ok(());
    };
    let step = alpha_g * dt / (substeps as f64 * tau);
    if step > 1.0 {
        return Err(Error::InvalidParameter {
            name: "goal_filter",
            value: format!(
                "{} (with dt = {}, tau = {} and {substeps} sub-step(s), its Euler step is {})",
                fmt_g(alpha_g),
                fmt_g(dt),
                fmt_g(tau),
                fmt_g(step)
            ),
            requirement: "must keep goal_filter x dt / (substeps x tau) <= 1, or the goal \
                          overshoots (beyond 2 it diverges): lower it, or pass more substeps",
        });
    }
    Ok(())
}

/// The fewest Euler sub-steps per period that are stable at time scale `tau` (the rollout's
/// rule), or `requested` if it is at least that many.
pub(crate) fn substeps_for(
    cfg: &DmpConfig,
    tau: f64,
    dt: f64,
    requested: Option<usize>,
) -> Result<usize> {
    let needed = substeps_needed(cfg, tau, dt);
    if needed.is_nan() || needed > MAX_SUBSTEPS as f64 {
        return Err(Error::InvalidParameter {
            name: "dt",
            value: fmt_g(dt),
            requirement: "is too coarse for this DMP: explicit Euler would need more than 1000 \
                          sub-steps per period; use a smaller dt or a larger tau",
        });
    }
    match requested {
        None => Ok(needed as usize),
        Some(k) if k as f64 >= needed && k <= MAX_SUBSTEPS => Ok(k),
        Some(k) => Err(Error::InvalidParameter {
            name: "substeps",
            value: k.to_string(),
            requirement: if k > MAX_SUBSTEPS {
                "must be at most 1000"
            } else {
                "is too few for dt: explicit Euler needs at least the rollout's count \
                 (pass None for it)"
            },
        }),
    }
}

/// One linearly implicit Euler step `(I - a J) (dy, dz) = a (z, h)` of a coordinate inside a
/// position limit's band, over `a = h / tau` of scaled time, with `J = [[0, 1], [-(alpha_z
/// beta_z - stiffness), -alpha_z]]` the Jacobian of its own spring, damper and repulsion
/// (`stiffness = dC/dy < 0`): stable however stiff the repulsion (docs/method.md §2.5.5), where
/// explicit Euler would need thousands of sub-steps next to a limit.
#[inline]
pub(crate) fn implicit_step(cfg: &DmpConfig, stiffness: f64, a: f64, z: f64, h: f64) -> (f64, f64) {
    let k = cfg.alpha_z * cfg.beta_z - stiffness;
    let det = 1.0 + a * cfg.alpha_z + a * a * k;
    (
        a * (z * (1.0 + a * cfg.alpha_z) + a * h) / det,
        a * (h - a * k * z) / det,
    )
}

/// The repulsion from `opts`' position limits over `n` coordinates, if any are given (a missing
/// side is unlimited).
pub(crate) fn position_limits(
    opts: &StepperOptions,
    n: usize,
    cfg: &DmpConfig,
) -> Result<Option<PositionLimits>> {
    if opts.position_min.is_none() && opts.position_max.is_none() {
        return Ok(None);
    }
    let lo = opts
        .position_min
        .clone()
        .unwrap_or_else(|| vec![f64::NEG_INFINITY; n]);
    let hi = opts
        .position_max
        .clone()
        .unwrap_or_else(|| vec![f64::INFINITY; n]);
    if lo.len() != n {
        return Err(Error::Shape {
            name: "position_min",
            expected: format!("({n},), one limit per position coordinate"),
            got: format!("({},)", lo.len()),
        });
    }
    Ok(Some(PositionLimits::new(
        &lo,
        &hi,
        opts.limit_margin.as_deref(),
        opts.limit_gain,
        cfg.alpha_z * cfg.beta_z,
    )?))
}

/// The clock of a stepper: the nominal tau (set by `set_tau`), the time scale of the current
/// period, and the temporal coupling that may raise it.
#[derive(Debug, Clone)]
pub(crate) struct Clock {
    pub dt: f64,
    pub substeps: usize,
    requested_substeps: Option<usize>,
    pub nominal: f64,
    /// The time scale of the next period, chosen by the last step (module docs: a step knows
    /// the scale of the period after its own, so that its acceleration is the change of its
    /// velocity to the next command's).
    pub tau: f64,
    pub coupling: Option<TemporalCoupling>,
    /// `alpha_g`, if the goal is filtered.
    pub goal_filter: Option<f64>,
    pub alpha_e: Vec<f64>,
}

impl Clock {
    /// The closed form `exp(-alpha_x t / tau)` (the fit's phase) of the time read from the
    /// integrator's phase `x` (docs/method.md §2.8): with a final velocity the velocity at tau
    /// is the point, and explicit Euler's phase runs ahead of the closed form by `O(dt)`, which
    /// would play the forcing term early.
    #[inline(always)]
    pub fn closed_form_phase(&self, x: f64, alpha_x: f64) -> f64 {
        let hs = self.dt / self.substeps as f64;
        let to_go = phase_to_go(x, phase_clock(self.tau, alpha_x, hs));
        crate::exp::exp(-alpha_x * (1.0 - to_go))
    }

    pub fn new(cfg: &DmpConfig, tau: f64, n: usize, opts: &StepperOptions) -> Result<Self> {
        check_scalar("dt", opts.dt, true)?;
        check_scalar("rest_tol", opts.rest_tol, true)?;
        if let Some(a) = opts.goal_filter {
            check_scalar("goal_filter", a, true)?;
        }
        let substeps = substeps_for(cfg, tau, opts.dt, opts.substeps)?;
        check_goal_filter(opts.goal_filter, opts.dt, substeps, tau)?;
        let coupling = TemporalCoupling::if_limited(
            n,
            opts.velocity_max.as_deref(),
            opts.acceleration_max.as_deref(),
            opts.temporal_coupling,
        )?;
        Ok(Self {
            dt: opts.dt,
            substeps,
            requested_substeps: opts.substeps,
            nominal: tau,
            tau,
            coupling,
            goal_filter: opts.goal_filter,
            alpha_e: phase_stopping_gains(&opts.alpha_e, n)?,
        })
    }

    /// A new nominal tau; the sub-steps follow it when they are the automatic count.
    pub fn set_nominal(&mut self, cfg: &DmpConfig, tau: f64) -> Result<()> {
        check_scalar("tau", tau, true)?;
        let substeps = substeps_for(cfg, tau, self.dt, self.requested_substeps)?;
        check_goal_filter(self.goal_filter, self.dt, substeps, tau)?;
        self.substeps = substeps;
        self.nominal = tau;
        Ok(())
    }

    /// The phase-stopping factor `1 + sum_d alpha_e,d e_d^2` for the tracking errors `e`; an
    /// error so large that the factor overflows is refused as a measurement the stepper cannot
    /// use (before anything changes, so the stepper stays usable).
    #[inline]
    pub fn stop_factor(&self, errors: impl Iterator<Item = f64>) -> Result<f64> {
        phase_stop_factor(&self.alpha_e, errors)
    }

    /// `taud` of a period at time scale `tau` followed by one at `next`: their forward
    /// difference, exactly 0 while the scale does not change.
    #[inline]
    pub fn rate(&self, tau: f64, next: f64) -> f64 {
        if next == tau {
            0.0
        } else {
            (next - tau) / self.dt
        }
    }
}

/// The error of a movement started in motion under velocity or acceleration limits.
pub(crate) fn moving_start_refused() -> Error {
    Error::InvalidParameter {
        name: "velocity_max/acceleration_max",
        value: "set".into(),
        requirement: "are not taken by a movement started in motion, as the movements of a \
                      sequence after the first are: temporal coupling's time scale at a start \
                      assumes rest",
    }
}

/// Phase stopping's slow-down `1 + sum_d alpha_e,d e_d^2` of the errors `e` between the measured
/// and the commanded positions (Ijspeert et al. 2013), refused, naming `measured`, if it
/// overflows.
pub(crate) fn phase_stop_factor(alpha_e: &[f64], errors: impl Iterator<Item = f64>) -> Result<f64> {
    let mut s = 0.0;
    for (a, e) in alpha_e.iter().zip(errors) {
        s += a * e * e;
    }
    if !s.is_finite() {
        return Err(Error::InvalidParameter {
            name: "measured",
            value: format!(
                "(phase stopping's 1 + sum alpha_e e^2 = {})",
                fmt_g(1.0 + s)
            ),
            requirement: "must be near the last command: this far off, the phase-stopping \
                          factor overflows (the stepper's state is unchanged)",
        });
    }
    Ok(1.0 + s)
}

/// `tau dz/dt` of eq. 1 without coupling terms, `alpha_z (beta_z (g - y) - z) + f`, into `out`.
// The per-coordinate loops of a step are free functions over slices: the slices of distinct
// arguments do not alias, so the loops vectorize instead of reloading each `Vec` per element.
#[inline(always)]
fn spring(cfg: &DmpConfig, out: &mut [f64], g: &[f64], y: &[f64], z: &[f64], f: &[f64]) {
    let n = out.len();
    let (g, y, z, f) = (&g[..n], &y[..n], &z[..n], &f[..n]);
    for d in 0..n {
        out[d] = spring_at(cfg, g[d], y[d], z[d], f[d]);
    }
}

/// One coordinate of [`spring`].
#[inline(always)]
fn spring_at(cfg: &DmpConfig, g: f64, y: f64, z: f64, f: f64) -> f64 {
    cfg.alpha_z * (cfg.beta_z * (g - y) - z) + f
}

/// One explicit Euler sub-step of `hs` seconds of a coordinate (the rollout's).
#[inline(always)]
fn explicit_step(y: &mut f64, z: &mut f64, h: f64, inv_tau: f64, hs: f64) {
    let dz = h * inv_tau;
    *y += *z * inv_tau * hs;
    *z += dz * hs;
}

/// One coordinate of [`acceleration`].
#[inline(always)]
pub(crate) fn acceleration_at(h: f64, z: f64, taud: f64, inv_tau: f64, inv_next: f64) -> f64 {
    if taud == 0.0 {
        h * inv_tau * inv_tau
    } else {
        (h - taud * z) * inv_tau * inv_next
    }
}

/// Whether a coordinate is at rest at `goal` (the rollout's `until_rest`, without the forcing
/// term's bound).
#[inline(always)]
fn rests_at(goal: f64, y: f64, z: f64, tol: f64) -> bool {
    (goal - y).abs() <= tol && z.abs() <= tol
}

/// The command of this period from the state before it is advanced: `y`, `yd = z / tau`, and `z`
/// kept for the acceleration.
#[inline(always)]
fn record(
    out_y: &mut [f64],
    out_yd: &mut [f64],
    z_k: &mut [f64],
    y: &[f64],
    z: &[f64],
    inv_tau: f64,
) {
    let n = out_y.len();
    let (out_yd, z_k, y, z) = (&mut out_yd[..n], &mut z_k[..n], &y[..n], &z[..n]);
    for d in 0..n {
        out_y[d] = y[d];
        out_yd[d] = z[d] * inv_tau;
        z_k[d] = z[d];
    }
}

/// `v`, then zeros up to [`padded`]`(v.len())` values.
fn padded_copy(v: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; padded(v.len())];
    out[..v.len()].copy_from_slice(v);
    out
}

/// One Euler sub-step of `hs` seconds of every coordinate: explicit (the rollout's) outside the
/// limits' bands, linearly implicit ([`implicit_step`]) inside them.
#[inline(always)]
fn euler_substep(
    cfg: &DmpConfig,
    y: &mut [f64],
    z: &mut [f64],
    h: &[f64],
    stiffness: &[f64],
    inv_tau: f64,
    hs: f64,
) {
    let n = y.len();
    let (z, h, stiffness) = (&mut z[..n], &h[..n], &stiffness[..n]);
    let a = hs * inv_tau;
    for d in 0..n {
        if stiffness[d] == 0.0 {
            explicit_step(&mut y[d], &mut z[d], h[d], inv_tau, hs);
        } else {
            let (dy, dz) = implicit_step(cfg, stiffness[d], a, z[d], h[d]);
            y[d] += dy;
            z[d] += dz;
        }
    }
}

/// `ydd = (tau dz/dt - taud z) / (tau tau_next)` of the command, with `h = tau dz/dt` and `z` of
/// the state it was recorded from, `taud = (tau_next - tau) / dt`: with one sub-step exactly
/// the change of the velocity `z / tau` to the next command's, `z_next / tau_next` with
/// `z_next = z + h dt / tau` (module docs); the rollout's `dz / tau` with `dz = h / tau` when
/// the clock is steady (`taud == 0`).
#[inline(always)]
fn acceleration(out: &mut [f64], h: &[f64], z: &[f64], taud: f64, inv_tau: f64, inv_next: f64) {
    let n = out.len();
    let (h, z) = (&h[..n], &z[..n]);
    for d in 0..n {
        out[d] = acceleration_at(h[d], z[d], taud, inv_tau, inv_next);
    }
}

/// Where a period's command goes when it is not the stepper's last command: a sample of a
/// rollout's arrays, its `n` values first. What follows them in each slice (the rows after it,
/// written later) may be written over, so that the command is stored in whole vectors where
/// there is room.
pub(crate) struct Rows<'a> {
    pub y: &'a mut [f64],
    pub yd: &'a mut [f64],
    pub ydd: &'a mut [f64],
}

/// The constants of one plain period.
struct Pass {
    inv_tau: f64,
    inv_next: f64,
    hs: f64,
    taud: f64,
    tol: f64,
    /// The scaled time to go of a final velocity's moving goal (0 without one).
    to_go: f64,
    /// Whether `Stepper::user` is added to `tau dz/dt`.
    coupled: bool,
}

/// Executes a [`Dmp`] one control period at a time (module docs).
#[derive(Debug, Clone)]
pub struct Stepper {
    dmp: Dmp,
    n: usize,
    clock: Clock,
    limits: Option<PositionLimits>,
    rest_tol: f64,
    /// Whether the CPU runs [`Stepper::period_avx2`]: detected once, not at every step.
    avx2: bool,
    /// `max |w|`, for the rest criterion's bound on the forcing term.
    max_w: f64,
    // The state that the next call outputs. `y`, `z`, `g`, `g_target`, `f`, `h` and `out_*` hold
    // `padded(n)` values, zeros after the `n` coordinates, so that the plain period and the
    // forcing term store and load them in whole vectors.
    x: f64,
    y: Vec<f64>,
    z: Vec<f64>,
    /// The (filtered) goal the spring pulls to, and the one it moves to.
    g: Vec<f64>,
    g_target: Vec<f64>,
    goal_moving: bool,
    /// The DMP's final velocity (docs/method.md §2.8) per unit of scaled time, `tau gd` at the
    /// DMP's tau, if it has one: the spring then pulls to the goal moving with it, outside the
    /// plain period. Per scaled time, so that phase stopping and `set_tau` keep the path.
    final_velocity: Option<Vec<f64>>,
    /// `f(x)` of the current phase.
    f: Vec<f64>,
    forcing: Forcing,
    // Scratch, allocated once.
    /// `tau dz/dt` of the state being output; of the sub-steps; of the next state.
    h: Vec<f64>,
    h_sub: Vec<f64>,
    /// `dC/dy` of the position-limit repulsion per coordinate (0 outside its bands).
    stiffness: Vec<f64>,
    z_k: Vec<f64>,
    h_next: Vec<f64>,
    user: Vec<f64>,
    // The last sample returned.
    out_y: Vec<f64>,
    out_yd: Vec<f64>,
    out_ydd: Vec<f64>,
    out_x: f64,
    out_tau: f64,
    at_rest: bool,
    /// Whether the last command's acceleration exceeds a limit (see [`Stepper::over_limit`]).
    over_limit: bool,
    /// Whether the last command rests away from the goal (see [`Stepper::blocked`]).
    blocked: bool,
    steps: u64,
}

impl Stepper {
    pub fn new(dmp: &Dmp, opts: &StepperOptions) -> Result<Self> {
        let n = dmp.n_dof();
        let clock = Clock::new(dmp.config(), dmp.tau(), n, opts)?;
        let cfg = dmp.config();
        let limits = position_limits(opts, n, cfg)?;
        let w = dmp.weights().as_slice();
        let mut s = Self {
            dmp: dmp.clone(),
            n,
            clock,
            limits,
            rest_tol: opts.rest_tol,
            avx2: crate::linalg::has_avx2_fma(),
            max_w: w.iter().fold(0.0f64, |m, w| m.max(w.abs())),
            x: 1.0,
            y: padded_copy(dmp.y0().as_slice()),
            z: vec![0.0; padded(n)],
            g: padded_copy(dmp.goal().as_slice()),
            g_target: padded_copy(dmp.goal().as_slice()),
            goal_moving: false,
            final_velocity: dmp
                .final_velocity()
                .map(|gd| padded_copy((gd * dmp.tau()).as_slice())),
            f: vec![0.0; padded(n)],
            forcing: Forcing::new(dmp.basis(), dmp.weights(), SumStart::NegativeZero),
            h: vec![0.0; padded(n)],
            h_sub: vec![0.0; n],
            stiffness: vec![0.0; n],
            z_k: vec![0.0; n],
            h_next: vec![0.0; n],
            user: vec![0.0; padded(n)],
            out_y: vec![0.0; padded(n)],
            out_yd: vec![0.0; padded(n)],
            out_ydd: vec![0.0; padded(n)],
            out_x: 1.0,
            out_tau: dmp.tau(),
            at_rest: false,
            over_limit: false,
            blocked: false,
            steps: 0,
        };
        s.reset(None)?;
        Ok(s)
    }

    /// Back to the start of a movement from `start` (default: the DMP's y0) at rest, phase 1,
    /// towards the current goal (a goal being filtered is set to its target).
    pub fn reset(&mut self, start: Option<&[f64]>) -> Result<()> {
        let start = start.unwrap_or(self.dmp.y0().as_slice());
        check_coordinates("start", start, self.n)?;
        if let Some(lim) = &self.limits
            && let Some(d) = lim.contains(start)
        {
            return Err(Error::InvalidParameter {
                name: "start",
                value: format!("{} at [{d}]", fmt_g(start[d])),
                requirement: "must be strictly inside position_min and position_max",
            });
        }
        self.y[..self.n].copy_from_slice(start);
        self.z.fill(0.0);
        self.x = 1.0;
        self.g.copy_from_slice(&self.g_target);
        self.goal_moving = false;
        self.forcing.restart();
        self.update_forcing();
        let nominal = self.clock.nominal;
        self.clock.tau = nominal;
        if self.clock.coupling.is_some() {
            self.derivative(false);
            let tc = self.clock.coupling.as_mut().expect("checked");
            self.clock.tau = tc.tau_at_rest(nominal, &self.h[..self.n]);
        }
        self.out_y.copy_from_slice(&self.y);
        self.out_yd.fill(0.0);
        self.out_ydd.fill(0.0);
        self.out_x = 1.0;
        self.out_tau = self.clock.tau;
        self.at_rest = false;
        self.over_limit = false;
        self.blocked = false;
        self.steps = 0;
        Ok(())
    }

    /// [`Stepper::reset`] to the state a preceding movement's stepper `from` hands over (in a
    /// sequence): phase 1 at the position `from` has advanced to, moving with its velocity
    /// (`z = tau v`, so position and velocity run on without a jump), and `from`'s last command
    /// as this one's, against which phase stopping measures the robot. Refused with velocity or
    /// acceleration limits: their time scale at a start assumes rest.
    pub(crate) fn take_over(&mut self, from: &Stepper) -> Result<()> {
        if self.clock.coupling.is_some() {
            return Err(moving_start_refused());
        }
        let n = self.n;
        if from.n != n {
            return Err(Error::Shape {
                name: "dmps",
                expected: format!("({n},) coordinates in every movement"),
                got: format!("({},)", from.n),
            });
        }
        self.reset(Some(&from.y[..n]))?;
        let (tau, inv_from) = (self.clock.tau, 1.0 / from.clock.tau);
        for (z, zf) in self.z[..n].iter_mut().zip(&from.z[..n]) {
            *z = zf * inv_from * tau;
        }
        self.out_y.copy_from_slice(&from.out_y);
        self.out_yd.copy_from_slice(&from.out_yd);
        self.out_ydd.copy_from_slice(&from.out_ydd);
        Ok(())
    }

    /// The phase the next step starts from (the last command's is [`Stepper::phase`]).
    pub(crate) fn next_phase(&self) -> f64 {
        self.x
    }

    /// The tolerance of [`Stepper::done`].
    pub(crate) fn rest_tol(&self) -> f64 {
        self.rest_tol
    }

    /// A new goal: filtered (`tau dg/dt = alpha_g (g_new - g)`) or at once (module docs).
    pub fn set_goal(&mut self, goal: &[f64]) -> Result<()> {
        check_coordinates("goal", goal, self.n)?;
        self.g_target[..self.n].copy_from_slice(goal);
        if self.clock.goal_filter.is_none() {
            self.g[..self.n].copy_from_slice(goal);
        }
        self.goal_moving = self.g != self.g_target;
        Ok(())
    }

    /// A new nominal tau (s), from the next period on.
    pub fn set_tau(&mut self, tau: f64) -> Result<()> {
        self.clock.set_nominal(self.dmp.config(), tau)
    }

    /// One control period: returns the command of this period, `(y, yd, ydd)`, and advances the
    /// state by `dt`. `measured` (the robot's position) turns on phase stopping.
    pub fn step(&mut self, measured: Option<&[f64]>) -> Result<(&[f64], &[f64], &[f64])> {
        self.step_coupled(measured, None)
    }

    /// [`Stepper::step`] with a coupling term `C` added to `tau dz/dt` (eq. 1) for this period.
    pub fn step_coupled(
        &mut self,
        measured: Option<&[f64]>,
        coupling: Option<&[f64]>,
    ) -> Result<(&[f64], &[f64], &[f64])> {
        if !self.period(measured, coupling, None)? {
            self.check_finite()?;
        }
        Ok(self.output())
    }

    /// One period without a measurement or a coupling term, its command written into `rows`
    /// (`n` values each) instead of the stepper's last command: a rollout's sample, by the
    /// stepper's own code. The state is not checked: a rollout checks what it returns.
    pub(crate) fn step_into(&mut self, rows: Rows<'_>) -> Result<()> {
        self.period(None, None, Some(rows)).map(|_| ())
    }

    /// One period, the command into `rows` if given, else into the last command; returns
    /// whether the new state is known to be finite (false: unchecked).
    #[inline(always)]
    fn period(
        &mut self,
        measured: Option<&[f64]>,
        coupling: Option<&[f64]>,
        rows: Option<Rows<'_>>,
    ) -> Result<bool> {
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: the CPU supports the enabled features (detected in `new`).
            return unsafe { self.period_avx2(measured, coupling, rows) };
        }
        self.period_inner::<false>(measured, coupling, rows)
    }

    /// [`Stepper::period_inner`] compiled for AVX2 (the per-coordinate loops run 4 wide); Rust
    /// never fuses a multiply and an add on its own, so both copies give the same bits.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn period_avx2(
        &mut self,
        measured: Option<&[f64]>,
        coupling: Option<&[f64]>,
        rows: Option<Rows<'_>>,
    ) -> Result<bool> {
        self.period_inner::<true>(measured, coupling, rows)
    }

    /// One period; `AVX2`: compiled into [`Stepper::period_avx2`], on a CPU with AVX2 and FMA.
    #[inline(always)]
    fn period_inner<const AVX2: bool>(
        &mut self,
        measured: Option<&[f64]>,
        coupling: Option<&[f64]>,
        rows: Option<Rows<'_>>,
    ) -> Result<bool> {
        let factor = match measured {
            Some(m) => {
                check_coordinates("measured", m, self.n)?;
                let e = m.iter().zip(&self.out_y).map(|(m, y)| m - y);
                self.clock.stop_factor(e)?
            }
            None => 1.0,
        };
        let coupled = coupling.is_some();
        if let Some(c) = coupling {
            check_coordinates("coupling", c, self.n)?;
            self.user[..self.n].copy_from_slice(c);
        }
        let target = if factor == 1.0 {
            self.clock.nominal
        } else {
            self.clock.nominal * factor
        };
        // This period's scale was chosen by the last step; this step chooses the next one's.
        let tau = self.clock.tau;
        let inv_tau = 1.0 / tau;
        if self.limits.is_none()
            && self.clock.coupling.is_none()
            && self.clock.substeps == 1
            && !self.goal_moving
        {
            return Ok(self.plain_period::<AVX2>(tau, inv_tau, target, coupled, rows));
        }
        self.derivative(coupled);
        self.at_rest = self.rest();
        self.blocked = !self.at_rest && self.stalled();
        self.out_x = self.x;
        self.out_tau = tau;
        let n = self.n;
        record(
            &mut self.out_y[..n],
            &mut self.out_yd[..n],
            &mut self.z_k,
            &self.y,
            &self.z,
            inv_tau,
        );
        self.integrate(inv_tau, coupled);
        let next = if self.clock.coupling.is_some() {
            let mut h_next = std::mem::take(&mut self.h_next);
            if self.limits_acceleration() {
                self.derivative_into(&mut h_next, coupled);
            }
            let nominal = self.clock.nominal;
            let tc = self.clock.coupling.as_mut().expect("checked");
            let next = tc.next_tau(
                tau,
                nominal,
                target,
                &self.z_k,
                &self.h[..n],
                &self.z[..n],
                &h_next,
                self.clock.dt,
            );
            self.h_next = h_next;
            next
        } else {
            target
        };
        self.clock.tau = next;
        let taud = self.clock.rate(tau, next);
        acceleration(
            &mut self.out_ydd[..n],
            &self.h,
            &self.z_k,
            taud,
            inv_tau,
            1.0 / next,
        );
        self.over_limit = self.exceeds_limits();
        self.steps += 1;
        if let Some(rows) = rows {
            rows.y[..n].copy_from_slice(&self.out_y[..n]);
            rows.yd[..n].copy_from_slice(&self.out_yd[..n]);
            rows.ydd[..n].copy_from_slice(&self.out_ydd[..n]);
        }
        Ok(false)
    }

    /// The period of [`Stepper::period_inner`] without limits, sub-steps or a moving goal, the
    /// common case (a sequence's join adds a coupling term for the rest of its movement): the
    /// same operations on every coordinate, in one pass over the coordinates instead of one per
    /// stage; `coupled`: `self.user` is added to `tau dz/dt`.
    #[inline(always)]
    fn plain_period<const AVX2: bool>(
        &mut self,
        tau: f64,
        inv_tau: f64,
        next: f64,
        coupled: bool,
        rows: Option<Rows<'_>>,
    ) -> bool {
        let cfg = *self.dmp.config();
        let hs = self.clock.dt;
        let taud = self.clock.rate(tau, next);
        let inv_next = 1.0 / next;
        let tol = self.rest_tol;
        // A final velocity's goal moves with the scaled time to go, read from the phase.
        let to_go = match self.final_velocity {
            Some(_) => phase_to_go(self.x, phase_clock(tau, cfg.alpha_x, hs)),
            None => 0.0,
        };
        let pass = Pass {
            inv_tau,
            inv_next,
            hs,
            taud,
            tol,
            to_go,
            coupled,
        };
        #[cfg(target_arch = "x86_64")]
        let (rests, still, finite) = if AVX2 {
            // SAFETY: with `AVX2` the CPU has AVX2 and FMA (`period_inner`).
            unsafe { self.plain_pass_avx2(&cfg, &pass, rows) }
        } else {
            self.plain_pass(&cfg, &pass, rows)
        };
        #[cfg(not(target_arch = "x86_64"))]
        let (rests, still, finite) = self.plain_pass(&cfg, &pass, rows);
        let spent = self.forcing_spent();
        self.at_rest = rests && spent;
        // (`Stepper::stalled`: without a coupling term the spring always pulls on to the goal)
        self.blocked = coupled && !self.at_rest && spent && still;
        self.out_x = self.x;
        self.out_tau = tau;
        self.x -= cfg.alpha_x * self.x * inv_tau * hs;
        let x = self.forcing_phase();
        #[cfg(target_arch = "x86_64")]
        if AVX2 {
            // SAFETY: as above.
            unsafe { self.forcing.eval_avx2(x, &mut self.f) };
        } else {
            self.forcing.eval(x, &mut self.f);
        }
        #[cfg(not(target_arch = "x86_64"))]
        self.forcing.eval(x, &mut self.f);
        self.clock.tau = next;
        self.over_limit = false;
        self.steps += 1;
        finite && self.x.is_finite()
    }

    /// The plain period's pass over the coordinates: the command from the state (into `rows`,
    /// or the last command), the explicit Euler step; returns whether every coordinate rests,
    /// whether every one is still ([`Stepper::stalled`]'s test of each) and whether the new
    /// state is finite.
    #[inline(always)]
    fn plain_pass(
        &mut self,
        cfg: &DmpConfig,
        pass: &Pass,
        rows: Option<Rows<'_>>,
    ) -> (bool, bool, bool) {
        let n = self.n;
        let (g, g_target, f) = (&self.g[..n], &self.g_target[..n], &self.f[..n]);
        let (user, weak_bound) = (&self.user[..n], cfg.alpha_z * cfg.beta_z * pass.tol);
        let (y, z) = (&mut self.y[..n], &mut self.z[..n]);
        let Rows {
            y: out_y,
            yd: out_yd,
            ydd: out_ydd,
        } = rows.unwrap_or(Rows {
            y: &mut self.out_y[..n],
            yd: &mut self.out_yd[..n],
            ydd: &mut self.out_ydd[..n],
        });
        let (out_yd, out_ydd) = (&mut out_yd[..n], &mut out_ydd[..n]);
        let (mut rests, mut still, mut finite) = (true, true, true);
        let v = self.final_velocity.as_deref();
        for d in 0..n {
            let (y0, z0) = (y[d], z[d]);
            let mut h = match v {
                None => spring_at(cfg, g[d], y0, z0, f[d]),
                Some(v) => moving_spring(cfg, g[d], v[d], pass.to_go, y0, z0) + f[d],
            };
            if pass.coupled {
                h += user[d];
            }
            rests &= rests_at(g_target[d], y0, z0, pass.tol);
            still &= z0.abs() <= pass.tol && h.abs() <= weak_bound;
            out_y[d] = y0;
            out_yd[d] = z0 * pass.inv_tau;
            explicit_step(&mut y[d], &mut z[d], h, pass.inv_tau, pass.hs);
            out_ydd[d] = acceleration_at(h, z0, pass.taud, pass.inv_tau, pass.inv_next);
            finite &= y[d].is_finite() & z[d].is_finite() & out_ydd[d].is_finite();
        }
        (rests, still, finite)
    }

    /// [`Stepper::plain_pass`] four coordinates at a time in AVX2 registers, the same operations
    /// lane by lane, over the padded state (its zeros stay zeros); the command's last vector is
    /// stored masked into `rows`, which hold `n` values.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn plain_pass_avx2(
        &mut self,
        cfg: &DmpConfig,
        pass: &Pass,
        rows: Option<Rows<'_>>,
    ) -> (bool, bool, bool) {
        use std::arch::x86_64::*;
        let c = |v: f64| _mm256_set1_pd(v);
        let (alpha_z, beta_z, inv_tau_v, hs_v, taud_v, tol_v) = (
            c(cfg.alpha_z),
            c(cfg.beta_z),
            c(pass.inv_tau),
            c(pass.hs),
            c(pass.taud),
            c(pass.tol),
        );
        let inv_next_v = c(pass.inv_next);
        let (sign, inf) = (c(-0.0), c(f64::INFINITY));
        let mut rests = _mm256_castsi256_pd(_mm256_set1_epi64x(-1));
        let (mut still, mut finite) = (rests, rests);
        let weak_bound = c(cfg.alpha_z * cfg.beta_z * pass.tol);
        // The arrays' addresses once (stores through them could otherwise change `self`'s).
        let (n, len) = (self.n, self.y.len());
        let padded = |v: &Vec<f64>| {
            assert_eq!(v.len(), len, "the state is padded");
            v.as_ptr()
        };
        let [g, g_target, f, user] = [&self.g, &self.g_target, &self.f, &self.user].map(padded);
        let moving = self.final_velocity.as_ref().map(padded);
        let to_go = c(pass.to_go);
        let [y, z] = [&mut self.y, &mut self.z].map(|v| {
            assert_eq!(v.len(), len, "the state is padded");
            v.as_mut_ptr()
        });
        // The command's room: its stores are whole vectors up to it (a rollout's row may be
        // written past its `n` values, `Rows`), masked past it (AMD cores microcode masked stores).
        let ([out_y, out_yd, out_ydd], room) = match rows {
            Some(r) => {
                let room = r.y.len().min(r.yd.len()).min(r.ydd.len());
                assert!(room >= n, "a row holds n values");
                ([r.y, r.yd, r.ydd].map(|v| v.as_mut_ptr()), room)
            }
            None => (
                [&mut self.out_y, &mut self.out_yd, &mut self.out_ydd].map(|v| v.as_mut_ptr()),
                len,
            ),
        };
        let mut d = 0;
        while d < len {
            // SAFETY: `d + 4 <= len`, the length of every state array (asserted above).
            let load = |v: *const f64| unsafe { _mm256_loadu_pd(v.add(d)) };
            let (y0, z0) = (load(y), load(z));
            let (g, g_target, f) = (load(g), load(g_target), load(f));
            // spring_at, or moving_spring + f
            let h = match moving {
                None => {
                    let spring = _mm256_sub_pd(_mm256_mul_pd(beta_z, _mm256_sub_pd(g, y0)), z0);
                    _mm256_add_pd(_mm256_mul_pd(alpha_z, spring), f)
                }
                Some(v) => {
                    let v = load(v);
                    let gap = _mm256_sub_pd(_mm256_sub_pd(g, _mm256_mul_pd(v, to_go)), y0);
                    let pull = _mm256_sub_pd(_mm256_add_pd(_mm256_mul_pd(beta_z, gap), v), z0);
                    _mm256_add_pd(_mm256_mul_pd(alpha_z, pull), f)
                }
            };
            let h = if pass.coupled {
                _mm256_add_pd(h, load(user))
            } else {
                h
            };
            // rests_at
            let gap = _mm256_andnot_pd(sign, _mm256_sub_pd(g_target, y0));
            let near = _mm256_cmp_pd::<_CMP_LE_OQ>(gap, tol_v);
            let slow = _mm256_cmp_pd::<_CMP_LE_OQ>(_mm256_andnot_pd(sign, z0), tol_v);
            rests = _mm256_and_pd(rests, _mm256_and_pd(near, slow));
            let weak = _mm256_cmp_pd::<_CMP_LE_OQ>(_mm256_andnot_pd(sign, h), weak_bound);
            still = _mm256_and_pd(still, _mm256_and_pd(slow, weak));
            // explicit_step
            let yd = _mm256_mul_pd(z0, inv_tau_v);
            let dz = _mm256_mul_pd(h, inv_tau_v);
            let y1 = _mm256_add_pd(y0, _mm256_mul_pd(yd, hs_v));
            let z1 = _mm256_add_pd(z0, _mm256_mul_pd(dz, hs_v));
            // acceleration_at
            let ydd = if pass.taud == 0.0 {
                _mm256_mul_pd(_mm256_mul_pd(h, inv_tau_v), inv_tau_v)
            } else {
                let rate = _mm256_sub_pd(h, _mm256_mul_pd(taud_v, z0));
                _mm256_mul_pd(_mm256_mul_pd(rate, inv_tau_v), inv_next_v)
            };
            let is_finite = |v| _mm256_cmp_pd::<_CMP_LT_OQ>(_mm256_andnot_pd(sign, v), inf);
            finite = _mm256_and_pd(finite, _mm256_and_pd(is_finite(y1), is_finite(z1)));
            finite = _mm256_and_pd(finite, is_finite(ydd));
            // SAFETY: as for the loads; the command's stores stop at its room, or masked at its
            // `n` values.
            let store = |v: *mut f64, x| unsafe { _mm256_storeu_pd(v.add(d), x) };
            if d + 4 <= room {
                store(out_y, y0);
                store(out_yd, yd);
                store(out_ydd, ydd);
            } else {
                let lanes = _mm256_set_epi64x(d as i64 + 3, d as i64 + 2, d as i64 + 1, d as i64);
                let mask = _mm256_cmpgt_epi64(_mm256_set1_epi64x(n as i64), lanes);
                let store_n = |v: *mut f64, x| unsafe { _mm256_maskstore_pd(v.add(d), mask, x) };
                store_n(out_y, y0);
                store_n(out_yd, yd);
                store_n(out_ydd, ydd);
            }
            store(y, y1);
            store(z, z1);
            d += 4;
        }
        // The zeros after the coordinates compare as 0 <= tol and 0 < inf: true.
        (
            _mm256_movemask_pd(rests) == 0b1111,
            _mm256_movemask_pd(still) == 0b1111,
            _mm256_movemask_pd(finite) == 0b1111,
        )
    }

    /// Integrates one period at time scale `1 / inv_tau` from the current state, whose
    /// derivative is `self.h`, in the rollout's sub-steps and order; leaves `self.f = f(x)` of
    /// the new phase.
    // Index loops over the coordinates, as the rollout writes them (several arrays per index).
    #[allow(clippy::needless_range_loop)]
    #[inline(always)]
    fn integrate(&mut self, inv_tau: f64, coupled: bool) {
        let cfg = *self.dmp.config();
        let hs = self.clock.dt / self.clock.substeps as f64;
        let a = hs * inv_tau;
        let mut h_sub = std::mem::take(&mut self.h_sub);
        for sub in 0..self.clock.substeps {
            if sub > 0 {
                self.update_forcing();
                self.derivative_into(&mut h_sub, coupled);
            }
            let h = if sub == 0 { &self.h } else { &h_sub };
            euler_substep(
                &cfg,
                &mut self.y[..self.n],
                &mut self.z,
                h,
                &self.stiffness,
                inv_tau,
                hs,
            );
            self.x -= cfg.alpha_x * self.x * inv_tau * hs;
            if self.goal_moving {
                self.filter_goal(a);
            }
        }
        self.h_sub = h_sub;
        self.update_forcing();
    }

    /// Whether the last command's acceleration exceeds its limit (by more than rounding).
    fn exceeds_limits(&self) -> bool {
        self.clock
            .coupling
            .as_ref()
            .is_some_and(|tc| tc.exceeded(&self.out_ydd[..self.n]))
    }

    fn limits_acceleration(&self) -> bool {
        self.clock
            .coupling
            .as_ref()
            .is_some_and(|tc| tc.limits_acceleration())
    }

    /// One Euler step of the goal filter over `a = h / tau` of scaled time.
    fn filter_goal(&mut self, a: f64) {
        let alpha_g = self
            .clock
            .goal_filter
            .expect("a goal moves only when filtered");
        let mut settled = true;
        for d in 0..self.n {
            let gap = self.g_target[d] - self.g[d];
            if gap.abs() <= GOAL_SNAP * self.g_target[d].abs().max(1.0) {
                self.g[d] = self.g_target[d];
            } else {
                self.g[d] += alpha_g * gap * a;
                settled = false;
            }
        }
        self.goal_moving = !settled;
    }

    /// `self.f = f(x)` (eq. 4).
    #[inline(always)]
    fn update_forcing(&mut self) {
        let x = self.forcing_phase();
        self.forcing.eval(x, &mut self.f);
    }

    /// The phase the forcing term is read at: the integrator's, or with a final velocity
    /// [`Clock::closed_form_phase`].
    #[inline(always)]
    fn forcing_phase(&self) -> f64 {
        match self.final_velocity {
            None => self.x,
            Some(_) => self
                .clock
                .closed_form_phase(self.x, self.dmp.config().alpha_x),
        }
    }

    /// `tau dz/dt` of the current state (eq. 1 with the coupling terms) into `out`, and the
    /// repulsion's stiffness `dC/dy` per coordinate into `self.stiffness`.
    #[allow(clippy::needless_range_loop)]
    #[inline(always)]
    fn derivative_into(&mut self, out: &mut [f64], coupled: bool) {
        match &self.final_velocity {
            None => spring(self.dmp.config(), out, &self.g, &self.y, &self.z, &self.f),
            Some(gd) => self.moving_spring_into(out, gd),
        }
        if let Some(lim) = &self.limits {
            for d in 0..self.n {
                self.stiffness[d] = match lim.repulsion(d, self.y[d]) {
                    Some((c, slope)) => {
                        out[d] += c;
                        // A slope of exactly 0 would select the explicit update: keep it < 0.
                        slope.min(-f64::MIN_POSITIVE)
                    }
                    None => 0.0,
                };
            }
        }
        if coupled {
            for (o, c) in out.iter_mut().zip(&self.user) {
                *o += c;
            }
        }
    }

    /// [`spring`] towards the goal moving with the final velocity, `v` per unit of scaled
    /// time, as the rollout's (docs/method.md §2.8), at the current phase and time scale.
    #[inline(always)]
    fn moving_spring_into(&self, out: &mut [f64], v: &[f64]) {
        let cfg = self.dmp.config();
        let hs = self.clock.dt / self.clock.substeps as f64;
        let to_go = phase_to_go(self.x, phase_clock(self.clock.tau, cfg.alpha_x, hs));
        for d in 0..self.n {
            out[d] = moving_spring(cfg, self.g[d], v[d], to_go, self.y[d], self.z[d]) + self.f[d];
        }
    }

    /// `self.h` = the derivative of the current state.
    #[inline(always)]
    fn derivative(&mut self, coupled: bool) {
        let mut h = std::mem::take(&mut self.h);
        self.derivative_into(&mut h, coupled);
        self.h = h;
    }

    /// The rollout's `until_rest` criterion at the current state, with the filtered goal settled.
    #[inline(always)]
    fn rest(&self) -> bool {
        let tol = self.rest_tol;
        self.forcing_spent()
            && (0..self.n).all(|d| rests_at(self.g_target[d], self.y[d], self.z[d], tol))
    }

    /// Whether the current state, whose `tau dz/dt` is `self.h`, has stopped for good without a
    /// new goal or coupling: the forcing term spent, the goal filter settled, every scaled
    /// velocity within `rest_tol` and every net pull too small to move the rest point by
    /// `rest_tol` (`|h| <= alpha_z beta_z rest_tol`; a turning point has a large one).
    #[inline(always)]
    fn stalled(&self) -> bool {
        let cfg = self.dmp.config();
        let (n, tol) = (self.n, self.rest_tol);
        let spring = cfg.alpha_z * cfg.beta_z;
        self.forcing_spent()
            && self.z[..n].iter().all(|z| z.abs() <= tol)
            && self.h[..n].iter().all(|h| h.abs() <= spring * tol)
    }

    /// Whether the forcing term can no longer move the state by more than `rest_tol`, the goal
    /// filter settled (the part of [`Stepper::rest`] that is not per coordinate).
    #[inline(always)]
    fn forcing_spent(&self) -> bool {
        let cfg = self.dmp.config();
        !self.goal_moving
            && self.final_velocity.is_none()
            && self.x * self.max_w / (cfg.alpha_z * cfg.beta_z) <= self.rest_tol
    }

    #[inline(always)]
    fn check_finite(&self) -> Result<()> {
        let state = [&self.y[..], &self.z, &self.out_ydd];
        check_state("DMP stepper", self.x, &state, self.steps)
    }

    /// The phase `x` of the last command (1 before the first step).
    pub fn phase(&self) -> f64 {
        self.out_x
    }
    /// The time scale `tau_eff` of the last command's period (s).
    pub fn tau(&self) -> f64 {
        self.out_tau
    }
    /// The nominal tau (s), as set by [`Stepper::set_tau`].
    pub fn nominal_tau(&self) -> f64 {
        self.clock.nominal
    }
    /// Whether the last command was at rest at the goal: the rollout's `until_rest` criterion
    /// (within `rest_tol` of the goal, `|tau yd| <= rest_tol`, the forcing term unable to move
    /// it by more than `rest_tol`) with the goal filter settled. False before the first step.
    pub fn done(&self) -> bool {
        self.at_rest
    }
    /// Whether the last command's acceleration exceeds `acceleration_max` (by more than 1e-12
    /// relative). Temporal coupling meets the limits whenever the next command's lower bounds on
    /// the time scale leave room (docs/method.md §2.5.4); where they do not (the paper's
    /// feasibility condition fails, or `step` was given a coupling term that jumps), the
    /// velocity limits win and this says so. False without acceleration limits.
    pub fn over_limit(&self) -> bool {
        self.over_limit
    }
    /// Whether the last command came to rest away from its goal: it stopped (every scaled
    /// velocity within `rest_tol`, the net pull `|tau dz/dt|` within `alpha_z beta_z rest_tol`,
    /// the forcing term spent, the goal filter settled) but is not [`Stepper::done`]. Something
    /// holds it (a position limit before the goal, a coupling term): further steps repeat it
    /// until the goal or the coupling change. False before the first step and while moving.
    pub fn blocked(&self) -> bool {
        self.blocked
    }
    /// Calls of `step` since the start or the last reset; the last command is at
    /// `t = (steps - 1) dt` of the stepper's clock.
    pub fn steps(&self) -> u64 {
        self.steps
    }
    /// The goal the spring currently pulls towards (moving while filtered).
    pub fn goal(&self) -> &[f64] {
        &self.g[..self.n]
    }
    pub fn goal_target(&self) -> &[f64] {
        &self.g_target[..self.n]
    }
    pub fn dt(&self) -> f64 {
        self.clock.dt
    }
    pub fn substeps(&self) -> usize {
        self.clock.substeps
    }
    pub fn n_dof(&self) -> usize {
        self.n
    }
    pub fn dmp(&self) -> &Dmp {
        &self.dmp
    }
    pub fn position_limits(&self) -> Option<&PositionLimits> {
        self.limits.as_ref()
    }
    pub fn temporal_coupling(&self) -> Option<&TemporalCoupling> {
        self.clock.coupling.as_ref()
    }
    /// The last command, `(y, yd, ydd)`.
    pub fn output(&self) -> (&[f64], &[f64], &[f64]) {
        let n = self.n;
        (&self.out_y[..n], &self.out_yd[..n], &self.out_ydd[..n])
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::{DMatrix, DVector};

    use super::*;

    #[test]
    fn the_vector_period_gives_the_scalar_ones_bits() {
        if !crate::linalg::has_avx2_fma() {
            return; // only the scalar code runs on this CPU
        }
        // One vector of coordinates, part of one, and more than one.
        for n in [1, 3, 4, 7, 9] {
            let w = DMatrix::from_fn(30, n, |k, d| 60.0 * ((k * n + d) as f64 * 0.53).sin());
            let start = DVector::from_fn(n, |d, _| 0.3 * d as f64 - 0.5);
            let goal = DVector::from_fn(n, |d, _| 1.0 - 0.2 * d as f64);
            let cfg = DmpConfig {
                n_basis: 30,
                ..DmpConfig::default()
            };
            let dmp = Dmp::new(cfg, w, goal, start, 0.8).unwrap();
            let opts = StepperOptions {
                goal_filter: None,
                ..StepperOptions::new(2e-3)
            };
            let mut scalar = Stepper::new(&dmp, &opts).unwrap();
            let mut vector = scalar.clone();
            for k in 0..2500 {
                if k == 300 {
                    let goal: Vec<f64> = (0..n).map(|d| 0.5 - 0.1 * d as f64).collect();
                    for s in [&mut scalar, &mut vector] {
                        s.set_goal(&goal).unwrap();
                    }
                }
                // A robot that lags behind the command for a while: phase stopping.
                let lag = if (500..700).contains(&k) { 0.02 } else { 0.0 };
                let measured: Vec<f64> = scalar.output().0.iter().map(|y| y - lag).collect();
                let m = (k % 2 == 0).then_some(measured.as_slice());
                let bits = |v: &[f64]| v.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
                let a = scalar.period_inner::<false>(m, None, None).unwrap();
                // SAFETY: the CPU supports the enabled features (checked above).
                let b = unsafe { vector.period_avx2(m, None, None) }.unwrap();
                assert_eq!(a, b, "n={n} step {k}");
                let (a, b) = (scalar.output(), vector.output());
                let a = (bits(a.0), bits(a.1), bits(a.2));
                assert_eq!(a, (bits(b.0), bits(b.1), bits(b.2)), "n={n} step {k}");
                assert_eq!(scalar.phase().to_bits(), vector.phase().to_bits());
                assert_eq!(scalar.done(), vector.done(), "n={n} step {k}");
            }
            assert!(vector.done(), "n={n}");
        }
    }
}
