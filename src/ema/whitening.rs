//! Whitening of FRF noise that varies along the frequency axis.
//!
//! Every statistical step of AutoEMA — PolyMAX's least-squares equation
//! error, the LSFD fit, the significance of a root (χ² of ΔRSS over one
//! σ_c² per channel), the residual check — assumes noise of one variance
//! per channel over the whole band. Measured FRFs break that: the H1/H2
//! random error is proportional to |H| (Bendat & Piersol, *Random Data*,
//! eq. 9.90), and a receptance falls by 1/ω² above its first modes. On the
//! PSV surface scan of issue 31 (receptance, 100–8900 Hz) the noise
//! standard deviation falls 55× from the first blocks to the middle of the
//! spectrum; one σ_c per channel, set by the low band, then calls every
//! mode above 1.5 kHz insignificant.
//!
//! **Profile.** The normalized fourth divided differences of every channel
//! ([`super::noise`]: noise almost everywhere, exponential with mean σ²(f))
//! are divided by their channel's median, pooled over the channels by the
//! median per line (a peak of one channel does not move it), and their
//! median is taken over [`BLOCKS`] consecutive blocks of lines; v(f) is the
//! log-linear interpolation of the block medians between block centres
//! (flat beyond the outer centres). A median over ≥ 32 lines ignores the
//! few lines where a lightly damped peak bends faster than a cubic.
//!
//! **When** ([`NoiseModel`]). By default (`Auto`) the profile is applied
//! only when its block medians span more than [`AUTO_DYNAMIC_RANGE`] in
//! variance (30, 5.5× in standard deviation): white noise (the synthetic
//! families' relative and impact-test noise) and measured data without a
//! trend stay below it — on the UFSC beam's hammer test (accelerance,
//! 5–800 Hz at 1 Hz) the blocks holding lightly damped peaks scatter the
//! medians up to 27× — and are analysed exactly as without whitening.
//!
//! **Whitened problem.** The analysis then works on u(f)·H(f) with
//! u = 1/√v (normalized to a median of 1): every model column is multiplied
//! by u too ([`FrfData::line_weight`]), so the least-squares fits are the
//! weighted fits Σ_f u²|H − model|² of the same rational model, and residues,
//! poles and shapes keep their physical units. PolyMAX works on H itself
//! with u in its equation-error weight (Peeters et al. 2004, eq. 6).

use super::noise::{fourth_differences, median};
use super::FrfData;

/// Number of blocks the profile is estimated on (fewer when a block would
/// hold fewer than [`MIN_BLOCK_LINES`] lines).
pub const BLOCKS: usize = 12;

/// Fewest lines per block.
pub const MIN_BLOCK_LINES: usize = 32;

/// Ratio of the largest to the smallest block median of the noise variance
/// above which `Auto` applies the profile.
pub const AUTO_DYNAMIC_RANGE: f64 = 30.0;

/// Largest ratio of the profile's values: v is floored at its largest
/// value over this (line weights within 100× of each other), so a few
/// quiet blocks cannot take over the least squares.
pub const MAX_DYNAMIC_RANGE: f64 = 1e4;

/// Which noise model the analysis assumes along the band.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum NoiseModel {
    /// The profile where it spans more than [`AUTO_DYNAMIC_RANGE`], white
    /// noise otherwise.
    #[default]
    Auto,
    /// One noise variance per channel over the whole band.
    White,
    /// The profile whatever its range.
    Profile,
}

impl NoiseModel {
    /// The line weights of `data` under this model, or `None` for white
    /// noise ([`noise_profile`], [`line_weights`]).
    pub fn line_weights(self, data: &FrfData) -> Option<Vec<f64>> {
        let min_range = match self {
            NoiseModel::White => return None,
            NoiseModel::Auto => AUTO_DYNAMIC_RANGE,
            NoiseModel::Profile => 1.0,
        };
        noise_profile(data, min_range).map(|v| line_weights(&v))
    }

    /// `data` whitened by its line weights, or `None` for white noise.
    pub fn whitened(self, data: &FrfData) -> Option<FrfData> {
        let u = self.line_weights(data)?;
        let mut white = data.clone();
        white.whiten(u);
        Some(white)
    }
}

/// Ratio of the largest to the smallest line weight: how far the noise's
/// standard deviation varies along the band.
pub fn range(u: &[f64]) -> f64 {
    let top = u.iter().cloned().fold(0.0, f64::max);
    let bottom = u.iter().cloned().fold(f64::INFINITY, f64::min);
    top / bottom
}

/// The relative noise variance v(f) per line (module docs), or `None` when
/// its block medians span less than `min_range` or the band is too short
/// for two blocks.
pub fn noise_profile(data: &FrfData, min_range: f64) -> Option<Vec<f64>> {
    let nf = data.n_lines();
    let n_blocks = BLOCKS.min(nf / MIN_BLOCK_LINES);
    if n_blocks < 2 {
        return None;
    }
    let n_ch = data.n_out() * data.n_ref();
    // Per line k (2 ≤ k < nf − 2): the channels' normalized fourth differences.
    let mut per_line: Vec<Vec<f64>> = vec![Vec::with_capacity(n_ch); nf];
    for c in 0..n_ch {
        let h = &data.h[c * nf..(c + 1) * nf];
        let e: Vec<(usize, f64)> = fourth_differences(&data.frequencies_hz, h).collect();
        let mut values: Vec<f64> = e.iter().map(|&(_, v)| v).collect();
        let m = median(&mut values);
        if !(m > 0.0 && m.is_finite()) {
            continue;
        }
        for (k, v) in e {
            per_line[k].push(v / m);
        }
    }
    let pooled: Vec<(usize, f64)> = per_line
        .iter_mut()
        .enumerate()
        .filter(|(_, v)| !v.is_empty())
        .map(|(k, v)| (k, median(v)))
        .collect();
    if pooled.len() < n_blocks * MIN_BLOCK_LINES / 2 {
        return None;
    }
    // Block medians at their centre lines.
    let knots: Vec<(f64, f64)> = (0..n_blocks)
        .filter_map(|b| {
            let lo = b * pooled.len() / n_blocks;
            let hi = (b + 1) * pooled.len() / n_blocks;
            let block = &pooled[lo..hi];
            let centre = 0.5 * (block[0].0 + block[block.len() - 1].0) as f64;
            let mut v: Vec<f64> = block.iter().map(|&(_, e)| e).collect();
            let m = median(&mut v);
            (m > 0.0).then_some((centre, m))
        })
        .collect();
    if knots.len() < 2 {
        return None;
    }
    let top = knots.iter().map(|k| k.1).fold(0.0, f64::max);
    let bottom = knots.iter().map(|k| k.1).fold(f64::INFINITY, f64::min);
    if top < min_range * bottom {
        return None;
    }
    let floor = top / MAX_DYNAMIC_RANGE;
    Some(
        (0..nf)
            .map(|k| log_linear(&knots, k as f64).max(floor))
            .collect(),
    )
}

/// Log-linear interpolation of `knots` (x ascending, y > 0) at `x`, flat
/// beyond the ends.
fn log_linear(knots: &[(f64, f64)], x: f64) -> f64 {
    let last = knots.len() - 1;
    if x <= knots[0].0 {
        return knots[0].1;
    }
    if x >= knots[last].0 {
        return knots[last].1;
    }
    let i = knots.partition_point(|k| k.0 <= x).min(last) - 1;
    let (x0, y0) = knots[i];
    let (x1, y1) = knots[i + 1];
    let t = (x - x0) / (x1 - x0);
    (y0.ln() + t * (y1.ln() - y0.ln())).exp()
}

/// The line weights u = 1/√v of a profile, scaled to a median of 1.
pub fn line_weights(profile: &[f64]) -> Vec<f64> {
    let u: Vec<f64> = profile.iter().map(|v| 1.0 / v.sqrt()).collect();
    let mut sorted = u.clone();
    let m = median(&mut sorted);
    u.iter().map(|x| x / m).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ema::synthetic::{gauss, lines, modal_superposition, SyntheticMode};
    use crate::ema::Weighting;
    use num_complex::Complex64;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    fn beam_like(noise: f64) -> FrfData {
        let m = |f, z, s: [f64; 4]| SyntheticMode {
            frequency_hz: f,
            damping_ratio: z,
            shape: s.to_vec(),
        };
        let modes = [
            m(300.0, 0.01, [1.0, 0.6, -0.4, 0.8]),
            m(1900.0, 0.008, [0.5, -0.9, 0.7, 0.3]),
            m(5200.0, 0.006, [-0.7, 0.4, 0.9, -0.5]),
        ];
        let set = modal_superposition(&modes, &[0], &lines(100.0, 8090.0, 10.0), noise, 7);
        FrfData::from_set(&set, None, Weighting::Uniform).unwrap()
    }

    #[test]
    fn white_noise_has_no_profile() {
        // Relative noise is white per channel: the data are analysed as before.
        let d = beam_like(0.02);
        assert_eq!(NoiseModel::Auto.line_weights(&d), None);
        assert_eq!(NoiseModel::White.line_weights(&d), None);
        // Forced, the profile is nearly flat.
        let u = NoiseModel::Profile.line_weights(&d).unwrap();
        let (lo, hi) = u
            .iter()
            .fold((f64::INFINITY, 0f64), |(a, b), &x| (a.min(x), b.max(x)));
        assert!(hi < 2.0 * lo, "{lo} .. {hi}");
    }

    #[test]
    fn noise_proportional_to_the_trend_is_whitened() {
        // Noise whose standard deviation falls 30× over the band (as an H1
        // error ∝ |H| on a receptance): the profile follows it within a
        // factor of two, and u·n is white.
        let mut d = beam_like(0.0);
        let nf = d.n_lines();
        let sd = |k: usize| 1e-3 * 30f64.powf(-(k as f64) / nf as f64);
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        for c in 0..d.n_out() * d.n_ref() {
            for k in 0..nf {
                let (a, b) = (gauss(&mut rng), gauss(&mut rng));
                d.h[c * nf + k] += Complex64::new(a, b) * (sd(k) / 2f64.sqrt());
            }
        }
        let v =
            noise_profile(&d, AUTO_DYNAMIC_RANGE).expect("a 900× range of variance is whitened");
        let ratio = |k: usize| v[k] / sd(k).powi(2);
        let reference = ratio(nf / 2);
        for k in (0..nf).step_by(50) {
            let r = ratio(k) / reference;
            assert!((0.5..2.0).contains(&r), "line {k}: {r}");
        }
        let u = line_weights(&v);
        let mut sorted = u.clone();
        assert!((median(&mut sorted) - 1.0).abs() < 1e-12);
        assert!(u[nf - 1] > 10.0 * u[0], "{} vs {}", u[nf - 1], u[0]);
    }

    /// A receptance over 100–8090 Hz with an H1-like error, 3 % of |H| at
    /// every line, and a weak, 2 % damped fourth mode at 6800 Hz.
    fn proportional_noise() -> (FrfData, Vec<f64>) {
        let mut d = beam_like(0.0);
        let weak = SyntheticMode {
            frequency_hz: 6800.0,
            damping_ratio: 0.02,
            shape: vec![0.12, 0.1, -0.15, 0.08],
        };
        let extra = modal_superposition(&[weak], &[0], &d.frequencies_hz, 0.0, 1);
        let nf = d.n_lines();
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        for (c, ch) in extra.channels.iter().enumerate() {
            for k in 0..nf {
                let h = d.h[c * nf + k] + ch.values[k];
                let n = Complex64::new(gauss(&mut rng), gauss(&mut rng)) * (0.03 * h.norm());
                d.h[c * nf + k] = h + n / 2f64.sqrt();
            }
        }
        (d, vec![300.0, 1900.0, 5200.0, 6800.0])
    }

    #[test]
    fn whitened_analysis_finds_a_weak_mode_above_a_falling_receptance() {
        use crate::ema::{auto_ema, AutoEmaParams};
        let (d, truth) = proportional_noise();
        let run = |noise| {
            let p = AutoEmaParams {
                noise,
                ..AutoEmaParams::default()
            };
            auto_ema(&d, &p, &|| {}).unwrap()
        };
        let found = |r: &crate::ema::AutoEmaResult| -> Vec<f64> {
            let mut f: Vec<f64> = r
                .best
                .roots
                .iter()
                .map(|x| x.pole(&r.orders).frequency_hz)
                .collect();
            f.sort_by(f64::total_cmp);
            f
        };
        let r = run(NoiseModel::Auto);
        let range = r.summary.noise_profile_range.expect("whitened");
        assert!(range > 10.0, "{range}");
        let f = found(&r);
        assert_eq!(f.len(), truth.len(), "{f:?}");
        for (a, b) in f.iter().zip(&truth) {
            assert!((a - b).abs() < 0.01 * b, "{f:?}");
        }
        // The reconstruction is returned in the data's units.
        assert!(r.fit.mean_frac(&d) > 0.99, "{}", r.fit.mean_frac(&d));
        assert!((r.best.mean_frac - r.fit.mean_frac(&d)).abs() < 1e-12);
        // Taken as white (one σ_c per channel, set by the low band), the
        // same data lose the weak mode.
        let white = found(&run(NoiseModel::White));
        assert_eq!(white.len(), 3, "{white:?}");
        assert!(white.iter().all(|f| (f - 6800.0).abs() > 68.0), "{white:?}");
    }

    #[test]
    fn interpolation_is_log_linear_and_flat_beyond_the_ends() {
        let knots = [(10.0, 1.0), (20.0, 100.0)];
        assert_eq!(log_linear(&knots, 0.0), 1.0);
        assert_eq!(log_linear(&knots, 30.0), 100.0);
        assert!((log_linear(&knots, 15.0) - 10.0).abs() < 1e-9);
    }
}
