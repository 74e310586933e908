//! Frequency-domain processing of an impact test: the exponential and force
//! (transient) windows, averaged auto/cross power spectra, the H1/H2
//! estimators and the ordinary coherence (seed section 2.3.3, eq. 2.55–2.58).
//!
//! Conventions (eq. 2.57): s_yτ = y·τ* per average, so S_yτ = Σ y τ*,
//! S_ττ = Σ |τ|², S_yy = Σ |y|² (the 1/N_av factors cancel in every ratio).
//! H2 divides by S_τy = conj(S_yτ): eq. 2.56 as printed divides by s_yτ,
//! which would return the complex conjugate of H; the standard form
//! (Bendat & Piersol, *Random Data*, 4th ed., eq. 9.61) is used.

use crate::modal::Mode;
use num_complex::Complex64;
use std::f64::consts::PI;

/// H1 = S_yτ / S_ττ (eq. 2.55): unbiased by noise on the response, biased
/// low in magnitude by noise on the force. 0 where S_ττ = 0.
pub fn h1(s_yt: Complex64, s_tt: f64) -> Complex64 {
    if s_tt > 0.0 {
        s_yt / s_tt
    } else {
        Complex64::new(0.0, 0.0)
    }
}

/// H2 = S_yy / S_τy with S_τy = conj(S_yτ) (eq. 2.56, see module docs):
/// unbiased by noise on the force, biased high in magnitude by noise on the
/// response. 0 where S_yτ = 0.
pub fn h2(s_yy: f64, s_yt: Complex64) -> Complex64 {
    if s_yt.norm_sqr() > 0.0 {
        s_yy / s_yt.conj()
    } else {
        Complex64::new(0.0, 0.0)
    }
}

/// Ordinary coherence γ² = |S_yτ|² / (S_yy S_ττ) ∈ [0, 1] (square of eq. 2.58
/// without the percent scaling, as stored in `FrfChannel::coherence`).
/// 0 where either auto-spectrum vanishes.
pub fn coherence(s_yt: Complex64, s_yy: f64, s_tt: f64) -> f64 {
    let den = s_yy * s_tt;
    if den > 0.0 {
        (s_yt.norm_sqr() / den).min(1.0)
    } else {
        0.0
    }
}

/// Averaged spectra of one force channel and several response channels.
#[derive(Clone, Debug)]
pub struct SpectralAverages {
    /// S_ττ per line.
    pub s_tt: Vec<f64>,
    /// S_yy per response channel and line.
    pub s_yy: Vec<Vec<f64>>,
    /// S_yτ per response channel and line.
    pub s_yt: Vec<Vec<Complex64>>,
}

impl SpectralAverages {
    pub fn new(channels: usize, lines: usize) -> Self {
        SpectralAverages {
            s_tt: vec![0.0; lines],
            s_yy: vec![vec![0.0; lines]; channels],
            s_yt: vec![vec![Complex64::new(0.0, 0.0); lines]; channels],
        }
    }

    /// Adds one average: the force spectrum and one spectrum per response
    /// channel (eq. 2.57), on the first `lines` FFT bins.
    pub fn add(&mut self, force: &[Complex64], responses: &[Vec<Complex64>]) {
        for (s, t) in self.s_tt.iter_mut().zip(force) {
            *s += t.norm_sqr();
        }
        for ((s_yy, s_yt), y) in self
            .s_yy
            .iter_mut()
            .zip(self.s_yt.iter_mut())
            .zip(responses)
        {
            for (k, (syy, syt)) in s_yy.iter_mut().zip(s_yt.iter_mut()).enumerate() {
                *syy += y[k].norm_sqr();
                *syt += y[k] * force[k].conj();
            }
        }
    }
}

/// Exponential window w(t) = e^{−(t − t₀)/τ} for t ≥ t₀ (trigger time t₀),
/// 1 before the trigger.
///
/// Multiplying an impulse response by e^{−t/τ} raises each mode's decay rate
/// from σ_r = ζ_r ω_r to σ_r + 1/τ at unchanged damped frequency ω_dr, so
/// the windowed FRF shows the apparent mode of [`Self::apparent_mode`].
/// The simulation does not undo this: identified damping ratios can be
/// corrected with [`Self::corrected_damping`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ExponentialWindow {
    /// Time constant τ in s.
    pub tau_s: f64,
}

impl ExponentialWindow {
    /// The window that decays to `end_value` ∈ (0, 1] over `duration_s`
    /// seconds after the trigger: τ = duration / ln(1/end_value).
    /// `end_value` = 1 gives τ = ∞ (rectangular).
    pub fn from_end_value(end_value: f64, duration_s: f64) -> Self {
        ExponentialWindow {
            tau_s: duration_s / (1.0 / end_value).ln(),
        }
    }

    /// Window values for `len` samples of step `dt`, trigger at sample `start`.
    pub fn samples(&self, len: usize, start: usize, dt: f64) -> Vec<f64> {
        (0..len)
            .map(|n| {
                if n < start {
                    1.0
                } else {
                    (-((n - start) as f64) * dt / self.tau_s).exp()
                }
            })
            .collect()
    }

    /// The mode an exponentially windowed impulse response shows: σ' = σ + 1/τ,
    /// same ω_d, so ω' = √(ω_d² + σ'²) and ζ' = σ'/ω'.
    pub fn apparent_mode(&self, mode: &Mode) -> Mode {
        let wr = 2.0 * PI * mode.frequency_hz;
        let sigma = mode.damping_ratio * wr + 1.0 / self.tau_s;
        let wd = wr * (1.0 - mode.damping_ratio * mode.damping_ratio).sqrt();
        let w_apparent = wd.hypot(sigma);
        Mode {
            frequency_hz: w_apparent / (2.0 * PI),
            damping_ratio: sigma / w_apparent,
            shape: mode.shape.clone(),
        }
    }

    /// Removes the window's added damping from an identified mode
    /// (inverse of [`Self::apparent_mode`]): σ = σ' − 1/τ at the same ω_d.
    pub fn corrected_damping(
        &self,
        identified_frequency_hz: f64,
        identified_damping: f64,
    ) -> (f64, f64) {
        let w = 2.0 * PI * identified_frequency_hz;
        let wd = w * (1.0 - identified_damping * identified_damping).sqrt();
        let sigma = identified_damping * w - 1.0 / self.tau_s;
        let w_true = wd.hypot(sigma);
        (w_true / (2.0 * PI), sigma / w_true)
    }
}

/// Force (transient) window: 1 up to sample `end` (exclusive), 0 after.
/// Suppresses force-channel noise outside the pulse.
pub fn force_window(len: usize, end: usize) -> Vec<f64> {
    (0..len).map(|n| if n < end { 1.0 } else { 0.0 }).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn estimators_without_noise_agree() {
        // One average of y = H τ: H1 = H2 = H, γ² = 1.
        let h = Complex64::new(0.3, -1.7);
        let t = Complex64::new(2.0, 0.5);
        let y = h * t;
        let (s_tt, s_yy, s_yt) = (t.norm_sqr(), y.norm_sqr(), y * t.conj());
        assert!((h1(s_yt, s_tt) - h).norm() < 1e-15);
        assert!((h2(s_yy, s_yt) - h).norm() < 1e-15);
        assert!((coherence(s_yt, s_yy, s_tt) - 1.0).abs() < 1e-15);
        assert_eq!(h1(s_yt, 0.0), Complex64::new(0.0, 0.0));
        assert_eq!(coherence(s_yt, 0.0, s_tt), 0.0);
    }

    #[test]
    fn unrelated_signals_have_low_coherence() {
        let mut avg = SpectralAverages::new(1, 1);
        // Two averages whose cross terms cancel: γ² = 0.
        avg.add(
            &[Complex64::new(1.0, 0.0)],
            &[vec![Complex64::new(1.0, 0.0)]],
        );
        avg.add(
            &[Complex64::new(1.0, 0.0)],
            &[vec![Complex64::new(-1.0, 0.0)]],
        );
        assert_eq!(coherence(avg.s_yt[0][0], avg.s_yy[0][0], avg.s_tt[0]), 0.0);
    }

    #[test]
    fn exponential_window_damping_roundtrip() {
        let w = ExponentialWindow::from_end_value(0.01, 2.0);
        assert!((w.samples(3, 1, 2.0)[2] - 0.01).abs() < 1e-15);
        let mode = Mode {
            frequency_hz: 40.0,
            damping_ratio: 0.01,
            shape: vec![],
        };
        let apparent = w.apparent_mode(&mode);
        // Added damping Δζ ≈ 1/(τ ω_r) for light damping.
        let added = apparent.damping_ratio - mode.damping_ratio;
        assert!(
            (added * w.tau_s * 2.0 * PI * 40.0 - 1.0).abs() < 0.01,
            "{added}"
        );
        let (f, z) = w.corrected_damping(apparent.frequency_hz, apparent.damping_ratio);
        assert!((f - 40.0).abs() < 1e-12 && (z - 0.01).abs() < 1e-14);
    }
}
