//! Explicit Euler on the transformation system (eqs. 1-2), shared by every integrator: the step
//! within which it is stable, and the spring towards a goal that moves with a final velocity.

use crate::dmp::DmpConfig;

/// Euler sub-steps per sample beyond which a rollout is refused: that many mean a `dt` far too
/// coarse for the DMP's stiffness, and the work would grow without bound.
pub const MAX_SUBSTEPS: usize = 1000;
/// Fraction of the explicit-Euler stability limit a (sub-)step may use: a quarter keeps
/// `h |lambda| <= 0.5` on a critically damped spring, where Euler is not only stable but does
/// not overshoot (the default dt = 1 ms with tau >= 0.1 s is far inside).
pub(crate) const STABILITY_MARGIN: f64 = 0.25;

/// The largest step `h = dt / tau` (in units of tau) for which explicit Euler on eqs. 1-3 decays
/// instead of blowing up. The spring `(y, z)` has the eigenvalues `lambda` of
/// `[[0, 1], [-alpha_z beta_z, -alpha_z]]` (times 1/tau) and Euler is stable iff
/// `|1 + h lambda| < 1`, i.e. `h < -2 Re(lambda) / |lambda|^2`: `4 / (alpha_z + sqrt(alpha_z^2 -
/// 4 alpha_z beta_z))` for real eigenvalues, `1 / beta_z` for complex ones. The phase eq. 3 stays
/// positive iff `h < 1 / alpha_x`.
pub fn stable_step(alpha_z: f64, beta_z: f64, alpha_x: f64) -> f64 {
    spring_stable_step(alpha_z, beta_z).min(STABILITY_MARGIN / alpha_x)
}

/// The spring's part of [`stable_step`], with its margin: the bound of a system whose phase
/// needs none (the periodic DMP's advances linearly).
pub(crate) fn spring_stable_step(alpha_z: f64, beta_z: f64) -> f64 {
    let disc = alpha_z * alpha_z - 4.0 * alpha_z * beta_z;
    let spring = if disc >= 0.0 {
        4.0 / (alpha_z + disc.sqrt())
    } else {
        1.0 / beta_z
    };
    STABILITY_MARGIN * spring
}

/// The spring of eq. 1 towards a goal moving with the final velocity `gd` (docs/method.md
/// §2.8): `alpha_z (beta_z (g - gd (tau - t) - y) + tau gd - z)`, written with the goal's
/// velocity per unit of scaled time, `v = tau gd`, and the scaled time to go, `s = (tau - t) /
/// tau`: `alpha_z (beta_z (g - v s - y) + v - z)`. So written it depends on time only through
/// the phase, and a stepper whose time scale changes keeps the path.
#[inline(always)]
pub(crate) fn moving_spring(cfg: &DmpConfig, g: f64, v: f64, s: f64, y: f64, z: f64) -> f64 {
    cfg.alpha_z * (cfg.beta_z * (g - v * s - y) + v - z)
}

/// The fewest equal Euler sub-steps of a period `dt` at time scale `tau` that are stable (1 when
/// `dt` already is; NaN for a NaN `dt`); the callers refuse counts beyond [`MAX_SUBSTEPS`].
pub(crate) fn substeps_needed(cfg: &DmpConfig, tau: f64, dt: f64) -> f64 {
    let limit = stable_step(cfg.alpha_z, cfg.beta_z, cfg.alpha_x) * tau;
    if dt <= limit {
        1.0
    } else {
        (dt / limit).ceil()
    }
}
