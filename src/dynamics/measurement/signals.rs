//! Time signals of a simulated impact test: the half-sine hammer pulse, the
//! structural response by exact modal superposition of the sampled analytic
//! impulse responses, and the anti-aliasing decimation from the internal
//! (oversampled) rate to the analyzer's sample rate.
//!
//! Discretization (documented choice): the pulse is sampled at the internal
//! rate f_int = R·fs and each sample acts as an impulse of area `f[m]·Δt`, so
//! the response is the discrete convolution
//! `y_j[n] = Δt Σ_m f[m] Σ_r φ_jr φ_kr g_r((n − m)Δt)`,
//! g_r(t) = e^{−ζ_r ω_r t} sin(ω_dr t)/ω_dr (seed section 2.3.1, viscous modes).
//! The response is computed directly in the sensor's quantity (displacement,
//! velocity or acceleration, [`super::sampled`] kernels), so the measurement
//! noise is white in that quantity. Its exact FRF is [`super::frf_sampled`]
//! at f_int, which shares the poles of eq. 2.45.
//! Decimation by R keeps the FFT bins below fs/2 of the internal block (an
//! ideal anti-aliasing low-pass, the same for force and response, so it
//! cancels in H1/H2); the remaining deviation from the continuous receptance
//! is the aliasing of f_int, of relative order 4ζ_r (f_r / f_int)² at resonances.

use super::sampled::modal_impulse_response;
use crate::frf::FrfQuantity;
use num_complex::Complex64;
use rustfft::FftPlanner;
use std::f64::consts::PI;

/// Half-sine pulse f(t) = F̂ sin(πt/T) sampled at t = m·dt for 0 ≤ t ≤ T.
pub fn half_sine_pulse(peak_force_n: f64, duration_s: f64, dt: f64) -> Vec<f64> {
    let count = (duration_s / dt).floor() as usize + 1;
    (0..count)
        .map(|m| peak_force_n * (PI * m as f64 * dt / duration_s).sin().max(0.0))
        .collect()
}

/// Modal responses in the sensor's `quantity` (unit residues) of a block of
/// `len` samples, pulse starting at sample `start`:
/// `q_r[n] = Δt Σ_m pulse[m] k_r((n − start − m)Δt)` with the kernel k_r of
/// [`modal_impulse_response`], plus the force itself for accelerance (the
/// δ feedthrough of g̈, see [`super::sampled`]).
pub fn modal_responses(
    modes: &[(f64, f64)],
    pulse: &[f64],
    start: usize,
    dt: f64,
    len: usize,
    quantity: FrfQuantity,
) -> Vec<Vec<f64>> {
    modes
        .iter()
        .map(|&(frequency_hz, damping_ratio)| {
            let kernel = modal_impulse_response(
                frequency_hz,
                damping_ratio,
                dt,
                len.saturating_sub(start),
                quantity,
            );
            let mut q = vec![0.0; len];
            for (m, &p) in pulse.iter().enumerate() {
                let offset = start + m;
                if offset >= len || p == 0.0 {
                    continue;
                }
                for (qn, kn) in q[offset..].iter_mut().zip(&kernel) {
                    *qn += p * dt * kn;
                }
                if quantity == FrfQuantity::Accelerance {
                    q[offset] += p;
                }
            }
            q
        })
        .collect()
}

/// Decimates a block by `factor` with an ideal low-pass: keeps the DFT bins
/// |k| < len/(2·factor) of the `len`-sample block (Nyquist bin of the output
/// as the real part of the input bin), divides by `factor`, returns
/// len/factor samples. The output's DFT equals the input's DFT/`factor` on
/// every kept bin, so ratios of spectra are preserved exactly.
pub fn decimate(signal: &[f64], factor: usize, planner: &mut FftPlanner<f64>) -> Vec<f64> {
    if factor == 1 {
        return signal.to_vec();
    }
    let len = signal.len();
    let out_len = len / factor;
    let mut spectrum: Vec<Complex64> = signal.iter().map(|&x| Complex64::new(x, 0.0)).collect();
    planner.plan_fft_forward(len).process(&mut spectrum);
    let half = out_len / 2;
    let mut reduced = vec![Complex64::new(0.0, 0.0); out_len];
    reduced[..half].copy_from_slice(&spectrum[..half]);
    reduced[half] = Complex64::new(spectrum[half].re, 0.0);
    for k in 1..half {
        reduced[out_len - k] = spectrum[len - k];
    }
    planner.plan_fft_inverse(out_len).process(&mut reduced);
    // rustfft's inverse is unnormalized (factor out_len); the DFT of the
    // R-times shorter block is R times smaller for the same amplitudes.
    let scale = 1.0 / (out_len as f64 * factor as f64);
    reduced.iter().map(|z| z.re * scale).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pulse_shape_and_area() {
        let dt = 1e-5;
        let p = half_sine_pulse(100.0, 1e-3, dt);
        assert_eq!(p.len(), 101);
        assert!((p[50] - 100.0).abs() < 1e-12);
        // Impulse ∫ f dt = 2 F̂ T / π.
        let area: f64 = p.iter().sum::<f64>() * dt;
        assert!(
            (area / (2.0 * 100.0 * 1e-3 / PI) - 1.0).abs() < 1e-4,
            "{area}"
        );
    }

    #[test]
    fn decimation_preserves_low_bins() {
        let mut planner = FftPlanner::new();
        let len = 64;
        let x: Vec<f64> = (0..len).map(|n| ((n * 7919) % 31) as f64 - 15.0).collect();
        let y = decimate(&x, 4, &mut planner);
        assert_eq!(y.len(), 16);
        let dft = |s: &[f64], k: usize| -> Complex64 {
            s.iter()
                .enumerate()
                .map(|(n, &v)| {
                    Complex64::from_polar(v, -2.0 * PI * (k * n) as f64 / s.len() as f64)
                })
                .sum()
        };
        for k in 0..8 {
            let expected = dft(&x, k) / 4.0;
            assert!(
                (dft(&y, k) - expected).norm() < 1e-12 * (1.0 + expected.norm()),
                "bin {k}"
            );
        }
        assert_eq!(decimate(&x, 1, &mut planner), x);
    }
}
