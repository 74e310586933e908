//! Noise floor of measured FRFs and the complex mode indicator function.
//!
//! **Noise floor.** FRFs are smooth on the scale of a line spacing except
//! within a few half-power bandwidths of a lightly damped peak, so the fourth
//! divided difference of a channel over five consecutive lines,
//!
//! d_f = Σ_{i=f−2}^{f+2} w_i H_i,   w_i = 1 / Π_{j≠i} (ω_i − ω_j),
//!
//! which annihilates every cubic in ω (Lagrange; any line spacing), is noise
//! almost everywhere. For complex noise of variance σ² = E|n|²,
//! |d_f|²/Σ w_i² is exponential with mean σ², whose median is σ² ln 2; the
//! median over the lines ignores the few lines where the curve itself bends
//! faster than a cubic. A floor of 10⁻¹² of the channel's mean power (120 dB, the
//! dynamic range of measurement hardware) keeps clean synthetic data from a
//! zero variance.
//!
//! **CMIF** (Shih et al. 1988, "Complex mode indication function and its
//! applications to spatial domain parameter estimation", MSSP 2(4),
//! doi:10.1016/0888-3270(88)90058-4): the singular values of the
//! outputs × references FRF matrix at every line, σ_k(H(ω_f)); a peak of the
//! k-th curve marks a mode, and two curves peaking at one frequency mark a
//! repeated root.

use super::hermitian::hermitian_eigen;
use super::FrfData;
use num_complex::Complex64;

/// Dynamic-range floor of the noise variance relative to a channel's mean power.
pub const NOISE_FLOOR_RELATIVE: f64 = 1e-12;

/// Noise variance σ_c² = E|n|² of every channel (`o · n_ref + i`), from the
/// median of the normalized second differences.
pub fn noise_variance(data: &FrfData) -> Vec<f64> {
    let nf = data.n_lines();
    let n_ch = data.n_out() * data.n_ref();
    (0..n_ch)
        .map(|c| channel_noise_variance(&data.frequencies_hz, &data.h[c * nf..(c + 1) * nf]))
        .collect()
}

/// Noise variance σ² = E|n|² of one channel `h` on the lines `f` (module
/// docs): the median of the normalized fourth divided differences over ln 2,
/// floored at [`NOISE_FLOOR_RELATIVE`] of the channel's mean power.
pub fn channel_noise_variance(f: &[f64], h: &[Complex64]) -> f64 {
    let nf = h.len().min(f.len());
    let power = h.iter().map(Complex64::norm_sqr).sum::<f64>() / nf.max(1) as f64;
    let mut r: Vec<f64> = fourth_differences(f, h).map(|(_, e)| e).collect();
    let med = median(&mut r);
    (med / std::f64::consts::LN_2).max(NOISE_FLOOR_RELATIVE * power)
}

/// |d_k|²/Σ w_i² of the fourth divided difference centred on every line k
/// with two neighbours each side (module docs), with k.
pub(crate) fn fourth_differences<'a>(
    f: &'a [f64],
    h: &'a [Complex64],
) -> impl Iterator<Item = (usize, f64)> + 'a {
    let nf = h.len().min(f.len());
    (2..nf.saturating_sub(2)).filter_map(move |k| {
        let mut w = [0.0f64; 5];
        for (i, wi) in w.iter_mut().enumerate() {
            let p: f64 = (0..5)
                .filter(|&j| j != i)
                .map(|j| f[k + i - 2] - f[k + j - 2])
                .product();
            *wi = 1.0 / p;
        }
        let norm: f64 = w.iter().map(|v| v * v).sum();
        let d: Complex64 = (0..5).map(|i| h[k + i - 2] * w[i]).sum();
        (norm.is_finite() && norm > 0.0).then(|| (k, d.norm_sqr() / norm))
    })
}

/// Relative error ε² of the data at their resonances: the median, over the
/// lines where |H|² ≥ max(100 σ_c², mean |H_c|²) of every channel, of the
/// normalized fourth divided difference over |H|², over ln 2 (0 without
/// such lines).
///
/// Where a resonance is finely resolved the fourth difference there is the
/// relative random error of the estimate (the H1 error ∝ |H|, Bendat &
/// Piersol, *Random Data*, eq. 9.90); where it is not (a half-power band of
/// one or two lines, as at 17 Hz on the UFSC beam), the peak bends faster
/// than a cubic and the statistic grows with the resolution bias (Δf/B_r)²
/// (ibid. eq. 8.141) — the error a modal fit of those lines is left with
/// too. Taken from the data alone, it does not depend on a fit (a fit that
/// misses the strongest mode cannot raise it).
pub fn relative_noise(data: &FrfData, noise: &[f64]) -> f64 {
    let nf = data.n_lines();
    let f = &data.frequencies_hz;
    let mut r: Vec<f64> = (0..data.n_out() * data.n_ref())
        .flat_map(|c| {
            let h = &data.h[c * nf..(c + 1) * nf];
            let mean = h.iter().map(Complex64::norm_sqr).sum::<f64>() / nf.max(1) as f64;
            let strong = (100.0 * noise.get(c).copied().unwrap_or(0.0)).max(mean);
            fourth_differences(f, h).filter_map(move |(k, e)| {
                let p = h[k].norm_sqr();
                (p >= strong && p > 0.0).then_some(e / p)
            })
        })
        .collect();
    median(&mut r) / std::f64::consts::LN_2
}

/// Number of averages n_d assumed for the H1 error from coherence. UFF 58
/// and most exports do not carry it; 1 is the fewest a coherence can come
/// with, so the error below is the largest the coherence allows: it can
/// only widen the noise where the coherence is poor (antiresonances, weak
/// excitation), never narrow it where it is good.
pub const ASSUMED_AVERAGES: f64 = 1.0;

/// Relative variance of each measured H1 value from its coherence,
/// E|Ĥ − H|²/|H|² ≈ (1 − γ²)/(n_d γ²): the random error of |Ĥ|,
/// var|Ĥ|/|H|² ≈ (1 − γ²)/(2 n_d γ²) (Bendat & Piersol, *Random Data*,
/// eq. 9.90), and an equal one in phase (ibid. eq. 9.91, in radians),
/// laid out as `data.h`; empty without coherence. γ² is clamped to
/// [10⁻³, 1] (a zero coherence would give an infinite error).
pub fn coherence_relative_error(data: &FrfData, n_averages: f64) -> Vec<f64> {
    data.coherence
        .iter()
        .map(|&g| {
            let g = g.clamp(1e-3, 1.0);
            (1.0 - g) / (n_averages.max(1.0) * g)
        })
        .collect()
}

pub(crate) fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// CMIF curves: `cmif[k][f]` is the k-th largest singular value of the FRF
/// matrix at line f, for k < min(n_out, n_ref): the matrix's rank. Beyond
/// it the Gram matrix's eigenvalues are round-off, and their wiggles passed
/// as peaks — as many as 230 on pyuff's 1 response × 3 hammer points fitted
/// as measured (`reciprocity: never`), each "a further curve peaking" that
/// kept a second root beside a sharp mode (278.6/279.9, 687.2/687.7 Hz).
pub fn cmif(data: &FrfData) -> Vec<Vec<f64>> {
    let (nf, nr, no) = (data.n_lines(), data.n_ref(), data.n_out());
    let m = nr.min(no);
    let h = |o: usize, i: usize, f: usize| data.h[(o * nr + i) * nf + f];
    let mut curves = vec![vec![0.0; nf]; m];
    let mut g = vec![Complex64::new(0.0, 0.0); m * m];
    for f in 0..nf {
        g.iter_mut().for_each(|v| *v = Complex64::new(0.0, 0.0));
        // The Gram matrix of the smaller side: HᴴH (references) or HHᴴ
        // (outputs); their nonzero eigenvalues are the same.
        for o in 0..no {
            for i in 0..nr {
                let (a, x) = if nr <= no {
                    (i, h(o, i, f).conj())
                } else {
                    (o, h(o, i, f))
                };
                for b in 0..m {
                    let y = if nr <= no {
                        h(o, b, f)
                    } else {
                        h(b, i, f).conj()
                    };
                    g[a * m + b] += x * y;
                }
            }
        }
        let (values, _) = hermitian_eigen(&g, m);
        for (curve, v) in curves.iter_mut().zip(&values) {
            curve[f] = v.max(0.0).sqrt();
        }
    }
    curves
}

/// Lines where `curve` has a local maximum over ±3 lines that stands at
/// least `prominence` times above the lowest value within ±`reach` lines on
/// both sides.
pub fn peaks(curve: &[f64], prominence: f64, reach: usize) -> Vec<usize> {
    let n = curve.len();
    (0..n)
        .filter(|&k| {
            let lo = k.saturating_sub(3);
            let hi = (k + 4).min(n);
            let is_max = curve[lo..hi]
                .iter()
                .enumerate()
                .all(|(j, &v)| v < curve[k] || (v == curve[k] && lo + j >= k));
            if !is_max || k == 0 || k + 1 == n {
                return false;
            }
            let left = curve[k.saturating_sub(reach)..k]
                .iter()
                .cloned()
                .fold(f64::INFINITY, f64::min);
            let right = curve[k + 1..(k + 1 + reach).min(n)]
                .iter()
                .cloned()
                .fold(f64::INFINITY, f64::min);
            curve[k] >= prominence * left && curve[k] >= prominence * right
        })
        .collect()
}

/// Prominence ratio a peak of the first CMIF curve needs to count as a mode
/// in [`cmif_mode_peaks`] (≈ 3.5 dB).
pub const MODE_PROMINENCE: f64 = 1.5;

/// Lines where the first CMIF curve `sigma1` shows a mode: local maxima
/// (over ±2 lines) whose topographic prominence stands at least
/// [`MODE_PROMINENCE`] times above the higher of the two lowest values
/// between the peak and the nearest higher value on either side (the band
/// edge when there is none) — the "key col" of topography, as in
/// `scipy.signal.find_peaks` — on the curve smoothed by a 3-line moving
/// geometric mean, and that stand above the noise: σ₁² ≥ 10 `noise_power`
/// (the noise power summed over the channels of one reference column).
///
/// Unlike a fixed ±reach window, a key col follows each peak to where the
/// curve rises again, so a mode between two stronger ones counts as long
/// as it stands out of the valley between them, and a broad noisy plateau
/// does not: a plateau's wiggles have no prominence. The smoothing keeps
/// single-line noise spikes of finely resolved spectra from splitting a
/// peak; a lightly damped mode two lines wide keeps ~⅔ of its height.
pub fn cmif_mode_peaks(sigma1: &[f64], noise_power: f64) -> Vec<usize> {
    let n = sigma1.len();
    if n < 3 {
        return Vec::new();
    }
    // 3-line geometric mean of σ₁ (log domain: multiplicative noise).
    let log: Vec<f64> = sigma1.iter().map(|v| v.max(1e-300).ln()).collect();
    let y: Vec<f64> = (0..n)
        .map(|k| {
            let (lo, hi) = (k.saturating_sub(1), (k + 2).min(n));
            log[lo..hi].iter().sum::<f64>() / (hi - lo) as f64
        })
        .collect();
    let floor = 0.5 * (10.0 * noise_power).max(1e-300).ln();
    let threshold = MODE_PROMINENCE.ln();
    (0..n)
        .filter(|&k| {
            let (lo, hi) = (k.saturating_sub(2), (k + 3).min(n));
            let is_max = (lo..hi).all(|j| y[j] < y[k] || (y[j] == y[k] && j >= k));
            if !is_max || log[k] < floor {
                return false;
            }
            // Lowest value on each side before the curve exceeds the peak.
            let col = |it: &mut dyn Iterator<Item = usize>| {
                let mut low = y[k];
                for j in it {
                    if y[j] > y[k] {
                        break;
                    }
                    low = low.min(y[j]);
                }
                low
            };
            let left = col(&mut (0..k).rev());
            let right = col(&mut (k + 1..n));
            y[k] - left.max(right) >= threshold
        })
        .collect()
}

/// Whether `curve` (over `freqs`) peaks within ±`hw` Hz of `f`: its largest
/// value there is the largest within ±3·hw and at least twice the lowest
/// value on either side within ±8·hw.
pub fn peak_at(curve: &[f64], freqs: &[f64], f: f64, hw: f64) -> bool {
    let range = |a: f64, b: f64| {
        let lo = freqs.partition_point(|&x| x < a);
        let hi = freqs.partition_point(|&x| x <= b);
        (lo, hi.max(lo))
    };
    let max_in = |(lo, hi): (usize, usize)| {
        curve[lo..hi]
            .iter()
            .cloned()
            .fold(f64::NEG_INFINITY, f64::max)
    };
    let min_in =
        |(lo, hi): (usize, usize)| curve[lo..hi].iter().cloned().fold(f64::INFINITY, f64::min);
    let (lo, hi) = range(f - hw, f + hw);
    if lo >= hi {
        return false;
    }
    let v = max_in((lo, hi));
    let near = max_in(range(f - 3.0 * hw, f + 3.0 * hw));
    let left = min_in(range(f - 8.0 * hw, f - hw));
    let right = min_in(range(f + hw, f + 8.0 * hw));
    v >= near && left.is_finite() && right.is_finite() && v >= 2.0 * left.max(right)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ema::synthetic::{four_mode_system, lines, modal_superposition, SyntheticMode};
    use crate::ema::Weighting;
    use rand::SeedableRng;

    /// The synthetic noise is complex Gaussian with E|n|² = (r · RMS)²: the
    /// estimate recovers it within the sampling error of a median over ~1000
    /// lines (a few percent), on channels with four sharp peaks.
    #[test]
    fn noise_variance_recovers_the_added_noise() {
        for (r, seed) in [(0.01, 1), (0.05, 2)] {
            let set = modal_superposition(
                &four_mode_system(),
                &[0, 3],
                &lines(20.0, 260.0, 0.25),
                r,
                seed,
            );
            let clean = modal_superposition(
                &four_mode_system(),
                &[0, 3],
                &lines(20.0, 260.0, 0.25),
                0.0,
                seed,
            );
            let d = FrfData::from_set(&set, None, Weighting::Uniform).unwrap();
            let c = FrfData::from_set(&clean, None, Weighting::Uniform).unwrap();
            let nf = d.n_lines();
            for (ch, v) in noise_variance(&d).iter().enumerate() {
                let rms2 = c.h[ch * nf..(ch + 1) * nf]
                    .iter()
                    .map(Complex64::norm_sqr)
                    .sum::<f64>()
                    / nf as f64;
                let want = r * r * rms2;
                assert!(
                    (v / want - 1.0).abs() < 0.15,
                    "noise {r}, channel {ch}: {v} vs {want}"
                );
            }
            // Clean data: far below any measurement noise.
            for (ch, v) in noise_variance(&c).iter().enumerate() {
                let rms2 = c.h[ch * nf..(ch + 1) * nf]
                    .iter()
                    .map(Complex64::norm_sqr)
                    .sum::<f64>()
                    / nf as f64;
                assert!(
                    v / rms2 < 1e-8,
                    "clean data, channel {ch}: noise {}",
                    v / rms2
                );
            }
        }
    }

    /// The mode count of the first CMIF curve finds the four modes at
    /// every noise level, and nothing in a curve of noise alone, whether
    /// its wiggles stand above the noise floor or not.
    #[test]
    fn cmif_mode_peaks_count_modes_not_wiggles() {
        let modes = four_mode_system();
        for (r, seed) in [(0.0, 1), (0.02, 2), (0.05, 3)] {
            let set = modal_superposition(&modes, &[0, 3], &lines(20.0, 260.0, 0.25), r, seed);
            let d = FrfData::from_set(&set, None, Weighting::Uniform).unwrap();
            let power = noise_variance(&d).iter().sum::<f64>() / 2.0;
            let found: Vec<f64> = cmif_mode_peaks(&cmif(&d)[0], power)
                .iter()
                .map(|&k| d.frequencies_hz[k])
                .collect();
            assert_eq!(found.len(), 4, "noise {r}: {found:?}");
            for (f, m) in found.iter().zip(&modes) {
                assert!((f - m.frequency_hz).abs() <= 1.0, "noise {r}: {found:?}");
            }
        }
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(4);
        let wiggles: Vec<f64> = (0..800)
            .map(|_| 1.0 + 0.2 * crate::ema::synthetic::gauss(&mut rng).clamp(-1.0, 1.0))
            .collect();
        assert!(cmif_mode_peaks(&wiggles, 1e-6).is_empty());
        assert!(cmif_mode_peaks(&wiggles, 1.0).is_empty());
    }

    /// A matrix with fewer outputs than references has as many CMIF curves
    /// as outputs (its rank), the same as its transpose's.
    #[test]
    fn cmif_has_as_many_curves_as_the_matrix_rank() {
        let set = modal_superposition(
            &four_mode_system(),
            &[0, 3],
            &lines(20.0, 260.0, 0.5),
            0.01,
            5,
        );
        let mut hammer = set.clone();
        for c in &mut hammer.channels {
            std::mem::swap(&mut c.response, &mut c.reference);
        }
        let d = FrfData::from_set(&set, None, Weighting::Uniform).unwrap();
        let t = FrfData::from_set(&hammer, None, Weighting::Uniform).unwrap();
        assert_eq!((d.n_out(), d.n_ref(), t.n_out(), t.n_ref()), (5, 2, 2, 5));
        let (a, b) = (cmif(&d), cmif(&t));
        assert_eq!((a.len(), b.len()), (2, 2));
        for (x, y) in a.iter().flatten().zip(b.iter().flatten()) {
            assert!((x - y).abs() <= 1e-9 * x.max(1e-300), "{x} {y}");
        }
    }

    /// CMIF of a repeated root driven from two references: two curves peak
    /// at the root; a simple mode peaks only in the first.
    #[test]
    fn cmif_shows_a_repeated_root_in_two_curves() {
        let m = |f, s: [f64; 4]| SyntheticMode {
            frequency_hz: f,
            damping_ratio: 0.01,
            shape: s.to_vec(),
        };
        let modes = vec![
            m(50.0, [1.0, 0.5, -0.3, 0.2]),
            m(100.0, [1.0, 0.0, 0.5, -0.5]),
            m(100.0, [0.0, 1.0, -0.5, -0.5]),
        ];
        let set = modal_superposition(&modes, &[0, 1], &lines(20.0, 150.0, 0.25), 0.0, 1);
        let d = FrfData::from_set(&set, None, Weighting::Uniform).unwrap();
        let c = cmif(&d);
        let at = |f: f64| {
            d.frequencies_hz
                .iter()
                .position(|&x| (x - f).abs() < 1e-9)
                .unwrap()
        };
        let p1 = peaks(&c[0], 2.0, 40);
        let p2 = peaks(&c[1], 2.0, 40);
        assert!(p1.contains(&at(50.0)) && p1.contains(&at(100.0)), "{p1:?}");
        assert_eq!(
            p2,
            vec![at(100.0)],
            "second curve peaks only at the repeated root"
        );
        let f = &d.frequencies_hz;
        assert!(peak_at(&c[1], f, 100.0, 1.0) && !peak_at(&c[1], f, 50.0, 0.5));
        assert!(peak_at(&c[0], f, 50.0, 0.5) && !peak_at(&c[0], f, 75.0, 0.75));
    }
}
