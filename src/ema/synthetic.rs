//! Known-answer FRFs for testing and benchmarking the estimators: receptances
//! of a viscously damped system by modal superposition (seed eq. 2.45),
//! H_jk(ω) = Σ_r φ_jr φ_kr / (ω_r² − ω² + 2jζ_r ω_r ω), with optional complex
//! Gaussian noise relative to each channel's RMS.

use crate::frf::{Dof, FrfChannel, FrfQuantity, FrfSet, Position};
use num_complex::Complex64;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::f64::consts::PI;

/// One mode of the synthetic system: real (mass-normalized) shape over all DOFs.
#[derive(Clone, Debug, PartialEq)]
pub struct SyntheticMode {
    pub frequency_hz: f64,
    pub damping_ratio: f64,
    pub shape: Vec<f64>,
}

/// The DOF of synthetic output `j`: node j+1, direction +Z.
pub fn dof(j: usize) -> Dof {
    Dof::new(j as u32 + 1, 3)
}

/// Receptance FRFs at every DOF of the shapes for the given reference DOF
/// indices, on `frequencies_hz`; `noise` is the relative standard deviation
/// of complex Gaussian noise (0 for clean data), drawn from `seed`.
pub fn modal_superposition(
    modes: &[SyntheticMode],
    references: &[usize],
    frequencies_hz: &[f64],
    noise: f64,
    seed: u64,
) -> FrfSet {
    let n_dof = modes.first().map_or(0, |m| m.shape.len());
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut channels = Vec::new();
    for j in 0..n_dof {
        for &k in references {
            let mut values: Vec<Complex64> = frequencies_hz
                .iter()
                .map(|&f| receptance(modes, j, k, f))
                .collect();
            if noise > 0.0 {
                let rms = (values.iter().map(Complex64::norm_sqr).sum::<f64>()
                    / values.len() as f64)
                    .sqrt();
                let sd = noise * rms / 2f64.sqrt();
                for v in &mut values {
                    *v += Complex64::new(gauss(&mut rng), gauss(&mut rng)) * sd;
                }
            }
            channels.push(FrfChannel {
                response: dof(j),
                reference: dof(k),
                values,
                coherence: None,
            });
        }
    }
    FrfSet {
        position: Position::default(),
        quantity: FrfQuantity::Receptance,
        frequencies_hz: frequencies_hz.to_vec(),
        channels,
    }
}

/// The noise-free receptance of DOF `j` to a force at DOF `k` at `f_hz`,
/// Σ_r φ_jr φ_kr / (ω_r² − ω² + 2jζ_r ω_r ω) (eq. 2.45, unit modal masses).
pub fn receptance(modes: &[SyntheticMode], j: usize, k: usize, f_hz: f64) -> Complex64 {
    let w = 2.0 * PI * f_hz;
    modes
        .iter()
        .map(|m| {
            let wr = 2.0 * PI * m.frequency_hz;
            m.shape[j] * m.shape[k]
                / Complex64::new(wr * wr - w * w, 2.0 * m.damping_ratio * wr * w)
        })
        .sum()
}

/// Standard normal draw by Box–Muller.
pub(crate) fn gauss(rng: &mut ChaCha8Rng) -> f64 {
    let u = |r: &mut ChaCha8Rng| ((r.next_u64() >> 11) + 1) as f64 / (1u64 << 53) as f64;
    let (a, b) = (u(rng), u(rng));
    (-2.0 * a.ln()).sqrt() * (2.0 * PI * b).cos()
}

/// A 4-mode test system on 5 DOFs (60, 95, 140, 210 Hz; damping 1–2 %) with
/// distinct, non-orthogonal shapes, driven at DOFs 0 and 3.
pub fn four_mode_system() -> Vec<SyntheticMode> {
    let m = |f, z, s: [f64; 5]| SyntheticMode {
        frequency_hz: f,
        damping_ratio: z,
        shape: s.to_vec(),
    };
    vec![
        m(60.0, 0.010, [0.3, 0.5, 0.7, 0.8, 0.9]),
        m(95.0, 0.015, [0.7, 0.6, 0.1, -0.5, -0.8]),
        m(140.0, 0.012, [0.8, -0.2, -0.7, 0.1, 0.6]),
        m(210.0, 0.020, [0.5, -0.8, 0.6, -0.4, 0.2]),
    ]
}

/// Evenly spaced lines from `lo` to `hi` Hz inclusive.
pub fn lines(lo: f64, hi: f64, step: f64) -> Vec<f64> {
    let n = ((hi - lo) / step).round() as usize;
    (0..=n).map(|k| lo + k as f64 * step).collect()
}
