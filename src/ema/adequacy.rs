//! Whether the identified modes describe the FRFs at all: the check that
//! keeps a poor modal model from passing as a result.
//!
//! The residual check ([`super::residual`]) looks for *missing modes*: data
//! peaks the fit leaves standing above the noise σ_c² + ε²|H|². On real
//! data ε is the larger of the data's own relative error and the fit's
//! median relative misfit at the resonances, so that a modal model that is
//! only so exact (leakage, a roving hammer's small inconsistencies) is not
//! called incomplete at every peak it holds. The price: a fit that misses
//! the data everywhere raises its own yardstick and passes silently. The
//! pyCFS PSV line scan did (mean FRAC 0.71, misfit 20 % of |H| at the
//! resonances where the data's own error is 3 %: no warning, `goal_reached`
//! true, 13 of 19 modes not among the peers' 13).
//!
//! **The rule.** A perfect modal model of FRFs with additive noise σ_c²
//! reaches E[FRAC_c] ≈ 1/(1 + σ_c²/P_c), P_c = mean |H_c|² over the band
//! (eq. 2.66 with ĥ the noise-free FRF: |ĥ|⁴/(|ĥ|²(|ĥ|² + n σ²))). When the
//! mean FRAC of the fit falls below [`MIN_FRAC_SHARE`] of that, more than a
//! tenth of the FRFs' correlation is left unexplained by anything the noise
//! accounts for, and the result says so. The two machines' simulated impact
//! tests reach 0.955–1.000 (80 positions; the test bench's hysteretic
//! damping the lowest), the quickstart 0.9999; the measured sets of
//! `benchmarks/real_sets` 0.90–1.00, except the PSV line scan (0.71) and
//! vibration-toolbox case 2 (0.43, one mode far narrower than a line).
//!
//! **Resolution.** A mode whose half-power band 2ζf is narrower than one
//! line spacing Δf has a peak the lines cannot show: its shape on the lines
//! is set by the record length (leakage) and the line spacing, not the
//! structure, and its damping is biased by about (Δf/B_r)²/3 (Bendat &
//! Piersol, *Random Data*, eq. 8.141). Each mode reports 2ζf/Δf
//! ([`bandwidth_lines`]); the warning names the modes below one line, as
//! the likely cause and what resolves them.

use super::FrfData;
use num_complex::Complex64;

/// Share of the noise-limited FRAC below which the fit is called poor.
pub const MIN_FRAC_SHARE: f64 = 0.9;

/// Half-power bandwidth 2ζf of a mode, in line spacings `step_hz`
/// (infinite without a line spacing).
pub fn bandwidth_lines(frequency_hz: f64, damping_ratio: f64, step_hz: f64) -> f64 {
    if step_hz > 0.0 {
        2.0 * damping_ratio * frequency_hz / step_hz
    } else {
        f64::INFINITY
    }
}

/// Mean over the channels of the FRAC a noise-free modal model reaches
/// against `h` (channel-major, `n_lines` per channel) with additive noise
/// variance `noise[c]`: 1/(1 + σ_c²/P_c). Channels without power count 1.
pub fn noise_limited_frac(h: &[Complex64], n_lines: usize, noise: &[f64]) -> f64 {
    if n_lines == 0 || noise.is_empty() {
        return 1.0;
    }
    let per_channel = noise.iter().enumerate().map(|(c, &s2)| {
        let power = h.get(c * n_lines..(c + 1) * n_lines).map_or(0.0, |ch| {
            ch.iter().map(Complex64::norm_sqr).sum::<f64>() / n_lines as f64
        });
        if power > 0.0 && s2.is_finite() {
            1.0 / (1.0 + s2.max(0.0) / power)
        } else {
            1.0
        }
    });
    per_channel.sum::<f64>() / noise.len() as f64
}

/// The warning for a fit of `data` (as analysed: whitened when they are,
/// with their noise variance per channel `noise`) whose mean FRAC is
/// `mean_frac`, its identified `modes` (frequency Hz, damping ratio)
/// ([`warning`] against [`noise_limited_frac`]).
pub fn check(
    data: &FrfData,
    noise: &[f64],
    mean_frac: f64,
    modes: &[(f64, f64)],
) -> Option<String> {
    let noise_frac = noise_limited_frac(&data.h, data.n_lines(), noise);
    warning(mean_frac, noise_frac, modes, data.line_spacing_hz())
}

/// The warning for a fit whose `mean_frac` lies below [`MIN_FRAC_SHARE`]
/// of `noise_frac` ([`noise_limited_frac`]), naming the identified `modes`
/// (frequency Hz, damping ratio) narrower than one line spacing `step_hz`;
/// `None` for an adequate fit.
pub fn warning(
    mean_frac: f64,
    noise_frac: f64,
    modes: &[(f64, f64)],
    step_hz: f64,
) -> Option<String> {
    let bar = MIN_FRAC_SHARE * noise_frac;
    if mean_frac >= bar || !mean_frac.is_finite() {
        return None;
    }
    let narrow: Vec<String> = modes
        .iter()
        .map(|&(f, z)| (f, bandwidth_lines(f, z, step_hz)))
        .filter(|(_, b)| *b < 1.0)
        .map(|(f, b)| format!("{f:.2} Hz: {b:.2} lines"))
        .collect();
    let mut text = format!(
        "the identified modes reproduce the FRFs poorly (mean FRAC {mean_frac:.2}, where the noise allows {noise_frac:.2}): modes are missing, spurious or misfitted, or the data are not those of one linear system; compare `frf_fit.uff` with the data and look at the stabilization diagram before using these modes"
    );
    if !narrow.is_empty() {
        text.push_str(&format!(
            "; {} of them {} a half-power band 2ζf narrower than one line spacing ({}), so the lines cannot show {} peak: a longer record (finer lines) or a zoom band resolves {}",
            narrow.len(),
            if narrow.len() == 1 { "has" } else { "have" },
            narrow.join(", "),
            if narrow.len() == 1 { "its" } else { "their" },
            if narrow.len() == 1 { "it" } else { "them" },
        ));
    }
    Some(text)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn noise_limited_frac_is_one_over_one_plus_the_noise_to_power_ratio() {
        // Channel 0: |H| = 3 on every line, σ² = 1 → 1/(1 + 1/9) = 0.9;
        // channel 1: |H| = 1, σ² = 1 → 0.5. Mean 0.7.
        let mut h = vec![Complex64::new(0.0, 3.0); 4];
        h.extend(vec![Complex64::new(1.0, 0.0); 4]);
        let f = noise_limited_frac(&h, 4, &[1.0, 1.0]);
        assert!((f - 0.7).abs() < 1e-15, "{f}");
        // Without noise a perfect model reaches 1; a silent channel counts 1.
        assert_eq!(noise_limited_frac(&h, 4, &[0.0, 0.0]), 1.0);
        assert_eq!(
            noise_limited_frac(&[Complex64::new(0.0, 0.0); 4], 4, &[1.0]),
            1.0
        );
    }

    #[test]
    fn bandwidth_in_lines() {
        // 2 · 0.0003 · 192.5 Hz / 0.3125 Hz = 0.3696 lines (vibration-toolbox case 2).
        let b = bandwidth_lines(192.5, 0.0003, 0.3125);
        assert!((b - 0.3696).abs() < 1e-12, "{b}");
        assert!(bandwidth_lines(100.0, 0.01, 0.0).is_infinite());
    }

    #[test]
    fn a_fit_within_the_bar_is_not_warned_about() {
        assert_eq!(warning(0.95, 1.0, &[(100.0, 0.0001)], 1.0), None);
        // Noisy data lower the bar: 0.8 against 0.9 · 0.85 = 0.765.
        assert_eq!(warning(0.8, 0.85, &[], 1.0), None);
    }

    #[test]
    fn a_poor_fit_is_warned_about_and_names_the_unresolved_modes() {
        let w = warning(0.71, 1.0, &[(925.0, 0.019), (192.4, 0.0003)], 0.3125).unwrap();
        assert!(w.contains("mean FRAC 0.71"), "{w}");
        assert!(w.contains("1 of them has a half-power band"), "{w}");
        assert!(w.contains("192.40 Hz: 0.37 lines"), "{w}");
        assert!(!w.contains("925.00"), "{w}");
        let plain = warning(0.5, 0.99, &[(925.0, 0.019)], 15.625).unwrap();
        assert!(!plain.contains("half-power"), "{plain}");
        // Just below the bar warns, just above does not.
        assert!(warning(0.8999, 1.0, &[], 1.0).is_some());
        assert!(warning(0.9001, 1.0, &[], 1.0).is_none());
    }
}
