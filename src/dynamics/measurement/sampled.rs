//! The sampled modal model (impulse invariance): modal impulse responses at
//! t = nΔt in displacement, velocity or acceleration, and their exact FRFs
//! (Δt times the discrete-time Fourier transform), which a noise-free
//! simulated impact test reproduces to rounding error.
//!
//! Per mode r (unit residue), with σ = ζ_r ω_r, ω_d = ω_r√(1−ζ_r²) (seed
//! section 2.3.1) and the modal equation q̈ + 2σq̇ + ω_r²q = f:
//! - displacement g(t) = e^{−σt} sin(ω_d t)/ω_d,
//! - velocity ġ(t) = e^{−σt}(cos ω_d t − (σ/ω_d) sin ω_d t), which jumps from
//!   0 to 1 at t = 0; the sample at n = 0 takes the midpoint 1/2, the value
//!   for which the DTFT equals the sum of aliased copies of jω·α (Poisson),
//! - acceleration g̈ = δ(t) − 2σġ − ω_r²g: the δ becomes the force sample
//!   itself (feedthrough, added by the caller), the rest is sampled as above.
//!
//! With z⁻¹ = e^{−jωΔt}, a = e^{−σΔt}, D = 1 − 2a cos(ω_dΔt) z⁻¹ + a² z⁻²,
//! S = a sin(ω_dΔt) z⁻¹/D and C = (1 − a cos(ω_dΔt) z⁻¹)/D (the z-transforms
//! of the sampled e^{−σt} sin and cos):
//! G = Δt S/ω_d, V = Δt (C − ½ − (σ/ω_d) S), A = 1 − 2σV − ω_r²G.
//! They share the poles of eq. 2.45 and differ from its (jω)^p·α by the
//! aliased copies of the continuous FRF: relative order 4ζ_r (f_r/fs)² for
//! receptance at a resonance, larger for mobility/accelerance and near
//! anti-resonances.

use crate::frf::FrfQuantity;
use crate::modal::ModalModel;
use num_complex::Complex64;
use std::f64::consts::PI;

/// Decay rate σ = ζω_r (1/s) and damped angular frequency ω_d = ω_r√(1−ζ²)
/// (rad/s) of a viscously damped mode (seed section 2.3.1, ω̃ = ω̄√(1−ξ²)).
pub fn decay_and_damped_frequency(frequency_hz: f64, damping_ratio: f64) -> (f64, f64) {
    let wr = 2.0 * PI * frequency_hz;
    (
        damping_ratio * wr,
        wr * (1.0 - damping_ratio * damping_ratio).sqrt(),
    )
}

/// Unit-residue modal impulse response in `quantity` at t = nΔt, n = 0..len
/// (see module docs; for accelerance without the δ feedthrough). Units per
/// unit modal mass: s/kg, 1/kg, 1/(kg·s).
pub fn modal_impulse_response(
    frequency_hz: f64,
    damping_ratio: f64,
    dt: f64,
    len: usize,
    quantity: FrfQuantity,
) -> Vec<f64> {
    let (sigma, wd) = decay_and_damped_frequency(frequency_hz, damping_ratio);
    let wr2 = (2.0 * PI * frequency_hz).powi(2);
    (0..len)
        .map(|n| {
            let t = n as f64 * dt;
            let (s, c) = (wd * t).sin_cos();
            let decay = (-sigma * t).exp();
            let g = decay * s / wd;
            let g_dot = if n == 0 {
                0.5
            } else {
                decay * (c - sigma / wd * s)
            };
            match quantity {
                FrfQuantity::Receptance => g,
                FrfQuantity::Mobility => g_dot,
                FrfQuantity::Accelerance => -2.0 * sigma * g_dot - wr2 * g,
            }
        })
        .collect()
}

/// FRF of the sampled modal model in `quantity` at `f_hz` for sample rate
/// `sample_rate_hz` (module docs): Σ_r φ_jr φ_kr·{G, V, A}_r. Requires
/// ζ_r < 1; indices as in [`super::receptance`].
pub fn frf_sampled(
    model: &ModalModel,
    response: usize,
    reference: usize,
    f_hz: f64,
    sample_rate_hz: f64,
    quantity: FrfQuantity,
) -> Complex64 {
    let dt = 1.0 / sample_rate_hz;
    let zinv = Complex64::from_polar(1.0, -2.0 * PI * f_hz * dt);
    model
        .modes
        .iter()
        .map(|mode| {
            let (sigma, wd) = decay_and_damped_frequency(mode.frequency_hz, mode.damping_ratio);
            let a = (-sigma * dt).exp();
            let (s, c) = (wd * dt).sin_cos();
            let den = 1.0 - zinv * (2.0 * a * c) + zinv * zinv * (a * a);
            let sin_z = zinv * (a * s) / den;
            let cos_z = (1.0 - zinv * (a * c)) / den;
            let g = sin_z * (dt / wd);
            let v = (cos_z - 0.5 - sin_z * (sigma / wd)) * dt;
            let value = match quantity {
                FrfQuantity::Receptance => g,
                FrfQuantity::Mobility => v,
                FrfQuantity::Accelerance => {
                    1.0 - v * (2.0 * sigma) - g * (2.0 * PI * mode.frequency_hz).powi(2)
                }
            };
            value * (mode.shape[response].re * mode.shape[reference].re)
        })
        .sum()
}

/// Receptance of the sampled modal model, [`frf_sampled`] for displacement.
pub fn receptance_sampled(
    model: &ModalModel,
    response: usize,
    reference: usize,
    f_hz: f64,
    sample_rate_hz: f64,
) -> Complex64 {
    frf_sampled(
        model,
        response,
        reference,
        f_hz,
        sample_rate_hz,
        FrfQuantity::Receptance,
    )
}

#[cfg(test)]
mod tests {
    use super::super::superposition::tests::three_mode_model;
    use super::super::superposition::{convert_quantity, receptance};
    use super::*;

    const QUANTITIES: [FrfQuantity; 3] = [
        FrfQuantity::Receptance,
        FrfQuantity::Mobility,
        FrfQuantity::Accelerance,
    ];

    #[test]
    fn sampled_frf_equals_dtft_of_impulse_response() {
        let m = three_mode_model();
        let fs = 1024.0;
        let dt = 1.0 / fs;
        // Long enough for e^{-σt} < 1e-17 for the slowest-decaying mode.
        let n = 40 * 1024;
        for q in QUANTITIES {
            let g: Vec<Vec<f64>> = m
                .modes
                .iter()
                .map(|md| modal_impulse_response(md.frequency_hz, md.damping_ratio, dt, n, q))
                .collect();
            for f in [3.0, 62.0, 100.0, 151.0, 400.0] {
                let mut dtft = Complex64::new(0.0, 0.0);
                for i in 0..n {
                    let h: f64 = m
                        .modes
                        .iter()
                        .zip(&g)
                        .map(|(md, gr)| md.shape[0].re * md.shape[1].re * gr[i])
                        .sum();
                    dtft += Complex64::from_polar(h * dt, -2.0 * PI * f * i as f64 * dt);
                }
                if q == FrfQuantity::Accelerance {
                    // δ feedthrough: Σ_r φ_jr φ_kr · 1.
                    dtft += m
                        .modes
                        .iter()
                        .map(|md| md.shape[0].re * md.shape[1].re)
                        .sum::<f64>();
                }
                let exact = frf_sampled(&m, 0, 1, f, fs, q);
                assert!(
                    (dtft - exact).norm() < 1e-9 * exact.norm(),
                    "{q:?} f={f}: {dtft} vs {exact}"
                );
            }
        }
    }

    #[test]
    fn sampled_frf_converges_to_continuous_as_fs_grows() {
        let m = three_mode_model();
        for q in QUANTITIES {
            let err = |fs: f64| {
                let a = convert_quantity(receptance(&m, 0, 0, 151.0), 151.0, q);
                (frf_sampled(&m, 0, 0, 151.0, fs, q) - a).norm() / a.norm()
            };
            let (e1, e2) = (err(4096.0), err(8192.0));
            assert!(e1 < 1e-3, "{q:?} {e1}");
            // Aliasing error ∝ 1/fs²: doubling fs divides it by about four.
            assert!((e1 / e2 - 4.0).abs() < 0.3, "{q:?} {e1} {e2}");
        }
    }
}
