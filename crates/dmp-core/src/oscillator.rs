//! The frequency, phase and waveform of a measured periodic signal, followed online: an adaptive
//! frequency oscillator with an adaptive Fourier series in its loop (Petrič, Gams, Ijspeert and
//! Žlajpah 2011), docs/method.md §12.5.
//!
//! One oscillator (phase `phi`, frequency `Omega`) drives a truncated Fourier series per
//! coordinate, `y_hat = sum_{c=0}^{M} a_c cos(c phi) + b_c sin(c phi)`; the series' error
//! `e = y - y_hat` of the driving coordinate pulls the phase and the frequency, and every
//! coordinate's error adapts its coefficients:
//!
//! ```text
//! phi'   = Omega - K_phi Omega e_n u
//! Omega' =       - K_Omega Omega^2 e_n u
//! u      = (a_1 sin(phi) - b_1 cos(phi)) / sqrt(a_1^2 + b_1^2)
//! a_c'   = eta Omega e cos(c phi),   b_c' = eta Omega e sin(c phi)
//! ```
//!
//! Petrič et al. (and Righetti et al. 2006 before them) pull along `u = sin(phi)`; here `u` is
//! minus the phase derivative of the driving coordinate's learned fundamental at unit amplitude
//! (the same when that fundamental is `a_1 cos(phi)`), so the frequency is pulled as hard at
//! whatever phase offset the series learned the signal at, and a rhythm is acquired alike from
//! every starting phase. Petrič et al. use constant gains; here each gain is multiplied by the
//! power of `Omega` that makes the equations the same in the oscillator's own phase, and the
//! error that moves the oscillator is normalized, `e_n = (e - e_mean) / s` with `s^2` the running
//! mean square of the driving coordinate about its baseline `a_0` and `e_mean` the error's running
//! mean (the offset `a_0` is still learning, which must not pull the phase). So a rhythm
//! converges in the same number of periods whatever its frequency, amplitude or unit. Because the
//! series represents every harmonic of `phi`, a signal's harmonics are absorbed by `a_c, b_c` for
//! `c >= 2` instead of pulling the oscillator: it locks onto the fundamental.

use std::f64::consts::{PI, TAU};

use crate::dmp::check_n_dof;
use crate::error::{Error, Result, check_scalar, fmt_g};
use crate::periodic::check_per_dof;

/// The most terms a coordinate's Fourier series may have besides its baseline.
pub const MAX_HARMONICS: usize = 1000;

/// The oscillator's gains, each per radian of its own phase (dimensionless).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OscillatorGains {
    /// `K_phi`: how strongly the error shifts the phase.
    pub phase: f64,
    /// `K_Omega`: how strongly the error changes the frequency.
    pub frequency: f64,
    /// `eta`: the Fourier coefficients' learning rate.
    pub fourier: f64,
}

impl Default for OscillatorGains {
    /// Chosen on noisy sines of 0.5, 1, 2 and 3 Hz at six phases from guesses 0.7-1.6 times the
    /// true frequency, and judged on other frequencies, phases and noise (tests/test_oscillator.py,
    /// docs/method.md §12.5).
    fn default() -> Self {
        Self {
            phase: 0.5,
            frequency: 0.1,
            fourier: 0.3,
        }
    }
}

/// An adaptive frequency oscillator with an adaptive Fourier series per coordinate.
#[derive(Debug, Clone)]
pub struct AdaptiveOscillator {
    gains: OscillatorGains,
    harmonics: usize,
    drive: usize,
    omega_range: (f64, f64),
    phase: f64,
    omega: f64,
    /// Per coordinate, `a_0..a_M` then `b_0..b_M` (`b_0` stays 0).
    coefficients: Vec<f64>,
    mean_square: f64,
    mean_error: f64,
    samples: u64,
    cos: Vec<f64>,
    sin: Vec<f64>,
    /// The coefficients before the sample being taken, put back if it is refused.
    saved: Vec<f64>,
}

impl AdaptiveOscillator {
    /// Starts at phase 0 and `frequency` (Hz, the guess), its frequency kept within
    /// `frequency_range` (Hz), `harmonics` terms in each coordinate's series, coordinate `drive`
    /// moving the oscillator.
    pub fn new(
        frequency: f64,
        n_dof: usize,
        harmonics: usize,
        drive: usize,
        frequency_range: (f64, f64),
        gains: OscillatorGains,
    ) -> Result<Self> {
        check_scalar("frequency", frequency, true)?;
        for (name, v) in [
            ("phase_gain", gains.phase),
            ("frequency_gain", gains.frequency),
            ("fourier_gain", gains.fourier),
        ] {
            check_scalar(name, v, true)?;
        }
        check_scalar("frequency_range", frequency_range.0, true)?;
        check_scalar("frequency_range", frequency_range.1, true)?;
        if !(frequency_range.0 <= frequency && frequency <= frequency_range.1) {
            return Err(Error::InvalidParameter {
                name: "frequency_range",
                value: format!(
                    "({}, {})",
                    fmt_g(frequency_range.0),
                    fmt_g(frequency_range.1)
                ),
                requirement: "must hold the initial frequency: (low, high) with low <= frequency <= high",
            });
        }
        check_n_dof(n_dof)?;
        if !(1..=MAX_HARMONICS).contains(&harmonics) {
            return Err(Error::InvalidParameter {
                name: "harmonics",
                value: harmonics.to_string(),
                requirement: "must be from 1 (the fundamental) to 1000: a 0.5 Hz rhythm sampled \
                              at 1 kHz has no more below its Nyquist frequency",
            });
        }
        if drive >= n_dof {
            return Err(Error::InvalidParameter {
                name: "drive",
                value: drive.to_string(),
                requirement: "must be the index of one of the coordinates (0 <= drive < n_dof)",
            });
        }
        Ok(Self {
            gains,
            harmonics,
            drive,
            omega_range: (TAU * frequency_range.0, TAU * frequency_range.1),
            phase: 0.0,
            omega: TAU * frequency,
            coefficients: vec![0.0; n_dof * 2 * (harmonics + 1)],
            mean_square: 0.0,
            mean_error: 0.0,
            samples: 0,
            cos: vec![0.0; harmonics + 1],
            sin: vec![0.0; harmonics + 1],
            saved: vec![0.0; n_dof * 2 * (harmonics + 1)],
        })
    }

    pub fn n_dof(&self) -> usize {
        self.coefficients.len() / self.stride()
    }
    pub fn harmonics(&self) -> usize {
        self.harmonics
    }
    /// rad, in `[0, 2 pi)`.
    pub fn phase(&self) -> f64 {
        self.phase
    }
    /// rad/s.
    pub fn omega(&self) -> f64 {
        self.omega
    }
    pub fn samples(&self) -> u64 {
        self.samples
    }
    /// Coordinate `d`'s `a_0..a_M`.
    pub fn cosine_coefficients(&self, d: usize) -> &[f64] {
        let s = d * self.stride();
        &self.coefficients[s..s + self.harmonics + 1]
    }
    /// Coordinate `d`'s `b_0..b_M` (`b_0 = 0`).
    pub fn sine_coefficients(&self, d: usize) -> &[f64] {
        let s = d * self.stride() + self.harmonics + 1;
        &self.coefficients[s..s + self.harmonics + 1]
    }

    fn stride(&self) -> usize {
        2 * (self.harmonics + 1)
    }

    /// `cos(c phi)`, `sin(c phi)` for `c = 0..M` by the angle-addition recurrence from one
    /// `cos`/`sin` (libm's: the same bits on every machine).
    fn harmonics_at(&mut self, phi: f64) {
        let (c1, s1) = (libm::cos(phi), libm::sin(phi));
        self.cos[0] = 1.0;
        self.sin[0] = 0.0;
        for c in 1..=self.harmonics {
            let (cp, sp) = (self.cos[c - 1], self.sin[c - 1]);
            self.cos[c] = cp * c1 - sp * s1;
            self.sin[c] = sp * c1 + cp * s1;
        }
    }

    fn series(&self, d: usize) -> f64 {
        let (a, b) = (self.cosine_coefficients(d), self.sine_coefficients(d));
        (0..=self.harmonics)
            .map(|c| a[c] * self.cos[c] + b[c] * self.sin[c])
            .sum()
    }

    /// Takes the sample `y` (one value per coordinate) measured `dt` seconds after the previous
    /// one, and advances the oscillator and the series by one explicit Euler step. A sample that
    /// is not finite, a `dt` at which the highest harmonic would alias, or a sample so large
    /// that the state or [`Self::estimate`] would no longer be finite, is refused and changes
    /// nothing.
    pub fn update(&mut self, dt: f64, y: &[f64]) -> Result<()> {
        let before = (self.phase, self.omega, self.mean_square, self.mean_error);
        self.saved.copy_from_slice(&self.coefficients);
        let taken = self.take(dt, y);
        if taken.is_ok() && !self.bounded() {
            (self.phase, self.omega, self.mean_square, self.mean_error) = before;
            self.coefficients.copy_from_slice(&self.saved);
            self.samples -= 1;
            return Err(Error::Numerical {
                context: "adaptive oscillator",
                detail: "the sample would make the series or its derivatives non-finite; it was \
                         not taken (the signal is too large for f64)"
                    .into(),
            });
        }
        taken
    }

    /// Whether the state is finite and bounds every value [`Self::estimate`] can give: each
    /// term of the series and of its derivatives is at most `(|a_c| + |b_c|) max(1, c Omega)^2`.
    fn bounded(&self) -> bool {
        let scale = (self.harmonics as f64 * self.omega).max(1.0).powi(2);
        let largest = self.coefficients.iter().fold(0.0f64, |m, c| m.max(c.abs()));
        let bound = largest * 2.0 * (self.harmonics + 1) as f64 * scale;
        // (a margin of 4 for the sums' rounding; NaN compares false)
        [self.phase, self.mean_square, self.mean_error]
            .iter()
            .all(|v| v.is_finite())
            && bound < f64::MAX / 4.0
    }

    /// [`Self::update`]'s step, the state's check aside.
    fn take(&mut self, dt: f64, y: &[f64]) -> Result<()> {
        check_scalar("dt", dt, true)?;
        check_per_dof("y", y, self.n_dof())?;
        if self.harmonics as f64 * self.omega_range.1 * dt >= PI {
            return Err(Error::InvalidParameter {
                name: "dt",
                value: fmt_g(dt),
                requirement: "must sample the highest harmonic at the highest frequency at least \
                              twice a period: harmonics * 2 pi * frequency_range[1] * dt < pi",
            });
        }
        if self.samples == 0 {
            // the baseline starts at the first sample, so the error is about the rhythm from the
            // first step, not its offset
            for (d, &v) in y.iter().enumerate() {
                let s = d * self.stride();
                self.coefficients[s] = v;
            }
        }
        self.harmonics_at(self.phase);
        let drive = self.drive;
        let offset = y[drive] - self.cosine_coefficients(drive)[0];
        // the running mean square: the plain mean over the first samples, then an exponential
        // one over about two radians of phase
        let rate = (0.5 * self.omega * dt).max(1.0 / (self.samples as f64 + 1.0));
        self.mean_square += rate * (offset * offset - self.mean_square);
        let learn = self.gains.fourier * self.omega * dt;
        let mut error_drive = 0.0;
        for (d, &v) in y.iter().enumerate() {
            let e = v - self.series(d);
            if d == drive {
                error_drive = e;
            }
            let (s, m) = (d * self.stride(), self.harmonics + 1);
            for c in 0..m {
                self.coefficients[s + c] += learn * e * self.cos[c];
                self.coefficients[s + m + c] += learn * e * self.sin[c];
            }
        }
        self.mean_error += rate * (error_drive - self.mean_error);
        let e_n = if self.mean_square > 0.0 {
            (error_drive - self.mean_error) / self.mean_square.sqrt()
        } else {
            0.0
        };
        // The direction the error pulls along: minus the phase derivative of the driving
        // coordinate's learned fundamental at unit amplitude,
        // u = -d/dphi (a_1 cos phi + b_1 sin phi) / R_1 with R_1 = sqrt(a_1^2 + b_1^2), where
        // Petrič et al. (2011) and Righetti et al. (2006) use sin(phi). The two agree when the
        // fundamental is learned as R_1 cos(phi), where the plain oscillator locks. With sin(phi)
        // the frequency is corrected with a gain proportional to sin of the phase offset at which
        // the series learned the fundamental, which is wherever the start left it while the phase
        // was still settling: from some starting phases the frequency took a long detour. Along
        // u, a phase lag d of the signal gives e ~ -R_1 d u, so e u averages to -R_1 d / 2 at
        // any offset (a gradient step on e^2 in phi through the fundamental): the loop is the
        // same whatever phase the signal starts at. Only the fundamental steers, so harmonics
        // still go into the higher terms. No fundamental learned yet (the first sample, a
        // constant signal): no pull. (sqrt, not hypot: IEEE-exact, the same bits everywhere.)
        let a1 = self.cosine_coefficients(drive)[1];
        let b1 = self.sine_coefficients(drive)[1];
        let r1 = (a1 * a1 + b1 * b1).sqrt();
        let pull = if r1 > 0.0 {
            e_n * (a1 * self.sin[1] - b1 * self.cos[1]) / r1
        } else {
            0.0
        };
        let dphi = self.omega * (1.0 - self.gains.phase * pull);
        let domega = -self.gains.frequency * self.omega * self.omega * pull;
        self.phase = (self.phase + dt * dphi).rem_euclid(TAU);
        // (rem_euclid may round a tiny negative up to 2 pi itself)
        if self.phase >= TAU {
            self.phase = 0.0;
        }
        self.omega = (self.omega + dt * domega).clamp(self.omega_range.0, self.omega_range.1);
        self.samples += 1;
        Ok(())
    }

    /// The series' value and its first two time derivatives at the current phase and
    /// frequency, per coordinate: `Omega` times the phase derivative, `Omega^2` the second.
    pub fn estimate(&mut self) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        self.harmonics_at(self.phase);
        let n = self.n_dof();
        let (mut y, mut yd, mut ydd) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        for d in 0..n {
            let (a, b) = (self.cosine_coefficients(d), self.sine_coefficients(d));
            for c in 0..=self.harmonics {
                let k = c as f64;
                y[d] += a[c] * self.cos[c] + b[c] * self.sin[c];
                yd[d] += k * (b[c] * self.cos[c] - a[c] * self.sin[c]);
                ydd[d] -= k * k * (a[c] * self.cos[c] + b[c] * self.sin[c]);
            }
            yd[d] *= self.omega;
            ydd[d] *= self.omega * self.omega;
        }
        (y, yd, ydd)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn follow(frequency: f64, guess: f64, periods: f64) -> AdaptiveOscillator {
        let mut osc = AdaptiveOscillator::new(
            guess,
            1,
            10,
            0,
            (guess / 4.0, guess * 4.0),
            OscillatorGains::default(),
        )
        .unwrap();
        let dt = 1e-3;
        let n = (periods / frequency / dt) as usize;
        for k in 0..n {
            let t = k as f64 * dt;
            osc.update(dt, &[0.3 + 2.0 * (TAU * frequency * t).sin()])
                .unwrap();
        }
        osc
    }

    #[test]
    fn a_sine_gives_its_frequency_amplitude_and_baseline() {
        let osc = follow(1.3, 1.0, 20.0);
        assert!(
            (osc.omega() / (TAU * 1.3) - 1.0).abs() < 1e-3,
            "{}",
            osc.omega()
        );
        let (a, b) = (osc.cosine_coefficients(0), osc.sine_coefficients(0));
        assert!((a[1].hypot(b[1]) - 2.0).abs() < 1e-2);
        assert!((a[0] - 0.3).abs() < 1e-2);
    }

    #[test]
    fn the_estimates_derivatives_are_the_series_derivatives() {
        let mut osc = follow(0.8, 0.9, 10.0);
        let (y0, yd, ydd) = osc.estimate();
        // the series' own finite difference along its phase at the frozen coefficients
        let h = 1e-5;
        let phase = osc.phase;
        let mut at = |p: f64| {
            osc.phase = p;
            osc.estimate().0[0]
        };
        let (yp, ym) = (at(phase + h), at(phase - h));
        let w = osc.omega;
        assert!(((yp - ym) / (2.0 * h) * w - yd[0]).abs() < 1e-6 * (1.0 + yd[0].abs()));
        assert!(
            ((yp - 2.0 * y0[0] + ym) / (h * h) * w * w - ydd[0]).abs()
                < 1e-3 * (1.0 + ydd[0].abs())
        );
    }

    #[test]
    fn bad_samples_change_nothing() {
        let mut osc = follow(1.0, 1.0, 2.0);
        let before = (osc.phase, osc.omega, osc.coefficients.clone(), osc.samples);
        assert!(osc.update(1e-3, &[f64::NAN]).is_err());
        assert!(osc.update(1e-3, &[1.0, 2.0]).is_err());
        assert!(osc.update(0.1, &[1.0]).is_err()); // 10 harmonics at 4 Hz alias at 10 Hz
        assert_eq!(
            before,
            (osc.phase, osc.omega, osc.coefficients.clone(), osc.samples)
        );
    }
}
