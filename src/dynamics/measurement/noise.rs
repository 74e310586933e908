//! Seeded Gaussian noise: a standard-normal stream per channel (ChaCha8 with
//! the channel index as stream number, Box–Muller transform) and relative
//! complex noise on synthetic FRFs.
//!
//! Each channel draws from its own ChaCha8 stream of the user's seed, so the
//! noise of a channel depends only on (seed, channel index): never on the
//! order in which channels are processed or on the number of threads.

use super::{invalid, MeasurementError};
use crate::frf::FrfSet;
use num_complex::Complex64;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::f64::consts::PI;

/// Standard-normal numbers from ChaCha8 stream `stream` of `seed`
/// (Box–Muller, Box & Muller 1958, both outputs of each pair used).
pub struct GaussianStream {
    rng: ChaCha8Rng,
    spare: Option<f64>,
}

impl GaussianStream {
    pub fn new(seed: u64, stream: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        rng.set_stream(stream);
        GaussianStream { rng, spare: None }
    }

    /// Uniform in (0, 1]: 53 random bits, never 0 so that ln(u) is finite.
    fn uniform_open0(&mut self) -> f64 {
        ((self.rng.next_u64() >> 11) + 1) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Two independent N(0, 1) numbers.
    fn pair(&mut self) -> (f64, f64) {
        let r = (-2.0 * self.uniform_open0().ln()).sqrt();
        let (s, c) = (2.0 * PI * self.uniform_open0()).sin_cos();
        (r * c, r * s)
    }

    /// One N(0, 1) number.
    pub fn standard(&mut self) -> f64 {
        if let Some(x) = self.spare.take() {
            return x;
        }
        let (a, b) = self.pair();
        self.spare = Some(b);
        a
    }

    /// Circular complex Gaussian with E|z|² = σ²: real and imaginary parts
    /// each N(0, σ²/2).
    pub fn complex(&mut self, sigma: f64) -> Complex64 {
        let (a, b) = self.pair();
        Complex64::new(a, b) * (sigma * std::f64::consts::FRAC_1_SQRT_2)
    }
}

/// Root mean square of |H| over a channel's lines.
pub(crate) fn rms_magnitude(values: &[Complex64]) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    (values.iter().map(|v| v.norm_sqr()).sum::<f64>() / values.len() as f64).sqrt()
}

/// Adds complex Gaussian noise to every channel: on each line, a circular
/// complex normal number with standard deviation σ_c = `relative` ·
/// RMS(|H_c|) of that channel (real and imaginary parts σ_c/√2 each).
/// Channel c uses stream c of `seed` (see module docs), so equal seeds give
/// bitwise equal results. Coherence (if any) is kept unchanged.
///
/// Errors if `relative` is negative or not finite (field `noise.relative`).
pub fn add_relative_noise(
    set: &FrfSet,
    relative: f64,
    seed: u64,
) -> Result<FrfSet, MeasurementError> {
    if !(relative.is_finite() && relative >= 0.0) {
        return Err(invalid(
            "noise.relative",
            format!("must be a finite number ≥ 0 (fraction of each FRF's RMS), got {relative}"),
        ));
    }
    let mut out = set.clone();
    for (index, channel) in out.channels.iter_mut().enumerate() {
        let sigma = relative * rms_magnitude(&channel.values);
        let mut stream = GaussianStream::new(seed, index as u64);
        for v in channel.values.iter_mut() {
            *v += stream.complex(sigma);
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frf::{Dof, FrfChannel};

    fn long_set() -> FrfSet {
        let n = 20_000;
        let freqs: Vec<f64> = (0..n).map(|i| i as f64 * 0.05).collect();
        let channel = |node: u32, scale: f64| FrfChannel {
            response: Dof::new(node, 3),
            reference: Dof::new(1, 3),
            values: freqs
                .iter()
                .map(|f| {
                    Complex64::new(1.0, 0.0) / Complex64::new(100.0 - f * f * 0.01, 0.3 * f) * scale
                })
                .collect(),
            coherence: None,
        };
        FrfSet {
            frequencies_hz: freqs.clone(),
            channels: vec![channel(1, 1.0), channel(2, 1e-6)],
            ..Default::default()
        }
    }

    #[test]
    fn standard_normal_moments() {
        let mut g = GaussianStream::new(7, 0);
        let n = 200_000;
        let xs: Vec<f64> = (0..n).map(|_| g.standard()).collect();
        let mean = xs.iter().sum::<f64>() / n as f64;
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n as f64;
        // Standard errors: 1/√n ≈ 0.0022 for the mean, √(2/n) ≈ 0.0032 for the variance.
        assert!(mean.abs() < 0.01, "{mean}");
        assert!((var - 1.0).abs() < 0.015, "{var}");
        let within_1sigma = xs.iter().filter(|x| x.abs() < 1.0).count() as f64 / n as f64;
        assert!((within_1sigma - 0.6827).abs() < 0.005, "{within_1sigma}");
    }

    #[test]
    fn relative_noise_level_matches_request() {
        let clean = long_set();
        for relative in [0.01, 0.1] {
            let noisy = add_relative_noise(&clean, relative, 3).unwrap();
            for (c, n) in clean.channels.iter().zip(&noisy.channels) {
                let diff: Vec<Complex64> =
                    c.values.iter().zip(&n.values).map(|(a, b)| b - a).collect();
                let measured = rms_magnitude(&diff) / rms_magnitude(&c.values);
                assert!(
                    (measured / relative - 1.0).abs() < 0.03,
                    "{measured} vs {relative}"
                );
                // Real and imaginary parts carry equal shares.
                let re: f64 = diff.iter().map(|d| d.re * d.re).sum();
                let im: f64 = diff.iter().map(|d| d.im * d.im).sum();
                assert!((re / im - 1.0).abs() < 0.05, "{re} {im}");
            }
        }
    }

    #[test]
    fn seeded_and_per_channel() {
        let clean = long_set();
        let a = add_relative_noise(&clean, 0.05, 11).unwrap();
        let b = add_relative_noise(&clean, 0.05, 11).unwrap();
        let c = add_relative_noise(&clean, 0.05, 12).unwrap();
        assert_eq!(a, b);
        assert_ne!(a.channels[0].values, c.channels[0].values);
        // Channel order independence: channel 1 alone in a set at index 1
        // gets the same noise whatever channel 0 holds.
        let mut other = clean.clone();
        other.channels[0].values.truncate(10);
        let d = add_relative_noise(&other, 0.05, 11).unwrap();
        assert_eq!(a.channels[1], d.channels[1]);
        // Zero noise leaves the data bitwise unchanged.
        assert_eq!(add_relative_noise(&clean, 0.0, 11).unwrap(), clean);
    }

    #[test]
    fn rejects_bad_level() {
        let clean = long_set();
        for bad in [-0.1, f64::NAN, f64::INFINITY] {
            let err = add_relative_noise(&clean, bad, 1).unwrap_err();
            assert!(err.to_string().contains("noise.relative"), "{err}");
        }
    }
}
