//! The check of a final fit against the noise floor: where does the
//! residual H − Ĥ still stand above the noise, i.e. where is a mode the data
//! show missing from the modal model?
//!
//! **Noise of measured FRFs.** The error of a measured FRF is not only an
//! additive floor σ_c² (from [`super::noise::noise_variance`], the line to
//! line scatter where the spectrum is smooth): the random error of the H1
//! estimate is relative, σ²(H) ≈ |H|²(1 − γ²)/(n_d γ²) (Bendat & Piersol,
//! *Random Data*, eq. 9.90), and so are the bias errors of leakage and of a
//! line spacing coarse against a half-power bandwidth, (Δf/B_r)²/3 (ibid.,
//! eq. 8.141). Near a resonance these are orders of magnitude above the
//! floor, so a floor-only test calls every well-fitted peak of a real
//! measurement "a mode missing" (the UFSC beam: 20 such warnings at the
//! modes the fit holds). The check therefore uses
//!
//! σ²_{c,f} = σ_c² + ε² |H_{c,f}|²,
//!
//! with ε² the larger of the relative error of the data at their
//! resonances ([`super::noise::relative_noise`]: the line-to-line scatter
//! relative to |H| where the data stand far above the floor, which grows
//! with the resolution bias where a peak is only a line or two wide) and
//! the fit's median relative misfit there ([`relative_misfit`]); synthetic
//! data with additive noise give ε ≈ 0. With coherence, ε² of each line is
//! at least that line's H1 error (1 − γ²)/(n_d γ²)
//! ([`super::noise::coherence_relative_error`], n_d assumed 1, the fewest
//! averages: coherence only widens the noise where it is poor).
//!
//! Per channel c and line f, ρ_{c,f} = mean over lines f−1..f+1 of
//! |H_c − Ĥ_c|²/σ²_{c,f}; pure noise gives ρ ≈ 1 (a mean of three unit
//! exponentials: P(ρ > 25) ≈ 10⁻²⁹).
//! The per-line maximum over channels is scanned for local maxima (±5 lines)
//! with amplitude ratio √ρ ≥ 3; each is reported with the channel where it
//! is largest. It is a missing mode when that channel's data peak there and
//! the ratio reaches 10, the visibility limit of the acceptance criteria (a
//! peak 10× above the noise at its best sensor); misfit on a flank or in a
//! valley (antiresonances, where the H1 error grows as the coherence drops)
//! is listed, not warned about.

use super::noise::{coherence_relative_error, relative_noise, ASSUMED_AVERAGES};
use super::FrfData;
use num_complex::Complex64;

/// Residual-to-noise amplitude ratio from which a residual peak is a mode
/// the data show and the fit misses (the visibility limit of the acceptance
/// criteria: a peak 10× above the noise at its best sensor).
pub const VISIBLE: f64 = 10.0;

/// Structure left in the residual at one frequency.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ResidualPeak {
    pub frequency_hz: f64,
    /// "response/reference" of the channel where it is largest.
    pub channel: String,
    /// Amplitude ratio √ρ of residual to noise.
    pub ratio: f64,
    /// Whether that channel's data peak nearby where the fit does not
    /// ([`ChannelPeaks::unfitted`]): a mode the data show. Without it the misfit sits
    /// at a fitted peak, on a flank or in a valley (an antiresonance, where
    /// the H1 error grows as the coherence drops, or the out-of-band
    /// residuals) and is no missing mode.
    pub data_peak: bool,
    /// An identified mode whose peak window holds this data peak
    /// ([`mark_identified`]): the mode is there, its shape fits this
    /// channel poorly (e.g. a channel near a node of it, or a reference
    /// that moved the mode a little); no mode is missing.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub at_mode_hz: Option<f64>,
}

impl ResidualPeak {
    /// Whether this is a mode the data show and the fit misses.
    pub fn missing_mode(&self) -> bool {
        self.data_peak && self.at_mode_hz.is_none() && self.ratio >= VISIBLE
    }

    pub fn warning(&self) -> String {
        format!(
            "the data peak at {1:.2} Hz (channel {2}) and the fit leaves a residual {0:.1}× above the noise there: a mode may be missing; look at that band, or narrow `band` to it",
            self.ratio, self.frequency_hz, self.channel
        )
    }
}

/// Lines around a residual peak searched for the data's own peak, at
/// least; the search reaches ±[`SEARCH_RELATIVE`] of the frequency too.
/// With a relative error ε the residual-to-noise ratio of a mode the fit
/// lacks is a plateau ≈ 1/ε over its band and peaks on a flank, where
/// ε²|H|² meets the floor, rather than at the data's peak.
const SEARCH_LINES: usize = 12;
const SEARCH_RELATIVE: f64 = 0.03;

/// How far (Hz) from a residual peak at `f_hz` the check looks for the
/// data's own peak: ±max([`SEARCH_LINES`] lines of `step_hz`,
/// [`SEARCH_RELATIVE`] f).
pub fn search_reach(f_hz: f64, step_hz: f64) -> f64 {
    (SEARCH_LINES as f64 * step_hz).max(SEARCH_RELATIVE * f_hz)
}

/// Whether line `k` of `a` is the largest within ±`w` lines (and no end).
fn local_max(a: &dyn Fn(usize) -> f64, n: usize, k: usize, w: usize) -> bool {
    k > 0 && k + 1 < n && (k.saturating_sub(w)..(k + w + 1).min(n)).all(|j| a(j) <= a(k))
}

/// Where one channel's data and fit peak, found once per channel (a
/// residual check on 51,201 lines asks about thousands of lines).
struct ChannelPeaks {
    /// Line spacing, Hz (mean over the band).
    step: f64,
    /// Prominent data peaks: the largest within ±6 lines and twice the
    /// power (3 dB) of the lowest line on each side within ±max(6 lines,
    /// 5 % of the frequency) — a peak, not a noise wiggle or a ripple on a
    /// slope, with reach enough for the valley beside a damped peak on fine
    /// lines.
    data_peak: Vec<bool>,
    /// Local maxima of the fit, |Ĥ|², within ±3 lines.
    model_max: Vec<bool>,
}

impl ChannelPeaks {
    fn new(h: &[Complex64], fit: &[Complex64], freqs: &[f64]) -> ChannelPeaks {
        let n = h.len().min(fit.len()).min(freqs.len());
        let step = if n < 2 {
            f64::MIN_POSITIVE
        } else {
            ((freqs[n - 1] - freqs[0]) / (n - 1) as f64).max(f64::MIN_POSITIVE)
        };
        let data = |k: usize| h[k].norm_sqr();
        let model = |k: usize| fit[k].norm_sqr();
        let prominent = |k: usize| {
            let w = ((0.05 * freqs[k] / step).ceil() as usize).max(6);
            let low = |r: std::ops::Range<usize>| r.map(data).fold(f64::INFINITY, f64::min);
            let (left, right) = (low(k.saturating_sub(w)..k), low(k + 1..(k + w + 1).min(n)));
            data(k) >= 2.0 * left.max(right)
        };
        ChannelPeaks {
            step,
            data_peak: (0..n)
                .map(|k| local_max(&data, n, k, 6) && prominent(k))
                .collect(),
            model_max: (0..n).map(|k| local_max(&model, n, k, 3)).collect(),
        }
    }

    /// The data's peak near line `f` (the nearest [`Self::data_peak`]
    /// within ±max([`SEARCH_LINES`], [`SEARCH_RELATIVE`] f), the lower one
    /// on a tie) where the fit does not peak (no local maximum of |Ĥ| within
    /// ±3 lines of it): a mode the data show and the model lacks (its
    /// line). Misfit at a fitted peak, on a flank or in a valley is not.
    fn unfitted(&self, freqs: &[f64], f: usize) -> Option<usize> {
        let n = self.data_peak.len();
        if n < 2 {
            return None;
        }
        let reach =
            ((SEARCH_RELATIVE * freqs[f.min(n - 1)] / self.step).ceil() as usize).max(SEARCH_LINES);
        let (lo, hi) = (f.saturating_sub(reach), (f + reach + 1).min(n));
        let near = (0..=reach).find_map(|d| {
            [f.checked_sub(d), f.checked_add(d)]
                .into_iter()
                .flatten()
                .find(|&k| k >= lo && k < hi && self.data_peak[k])
        })?;
        let fitted = (near.saturating_sub(3)..(near + 4).min(n)).any(|j| self.model_max[j]);
        (!fitted).then_some(near)
    }
}

/// Relative misfit ε² of a fit at the resonances: the median of
/// |H − Ĥ|²/|H|² over the lines where |H|² ≥ max(100 σ_c², mean |H_c|²) of
/// every channel, over ln 2 (0 without such lines). The residual check
/// uses the larger of this and the data's own relative error
/// ([`super::noise::relative_noise`]): a real structure's modal model is
/// only so exact (leakage, slight non-linearity, a time-variant test), and
/// that misfit at every fitted peak is not a missing mode.
pub fn relative_misfit(data: &FrfData, reconstructed: &[Complex64], noise: &[f64]) -> f64 {
    let nf = data.n_lines();
    let mut r: Vec<f64> = (0..data.n_out() * data.n_ref())
        .flat_map(|c| {
            let h = &data.h[c * nf..(c + 1) * nf];
            let fit = &reconstructed[c * nf..(c + 1) * nf];
            let mean = h.iter().map(Complex64::norm_sqr).sum::<f64>() / nf.max(1) as f64;
            let strong = (100.0 * noise.get(c).copied().unwrap_or(0.0)).max(mean);
            h.iter().zip(fit).filter_map(move |(h, g)| {
                let p = h.norm_sqr();
                (p >= strong && p > 0.0).then(|| (h - g).norm_sqr() / p)
            })
        })
        .collect();
    if r.is_empty() {
        return 0.0;
    }
    let mid = r.len() / 2;
    let (_, m, _) = r.select_nth_unstable_by(mid, f64::total_cmp);
    *m / std::f64::consts::LN_2
}

/// Marks the residual peaks that lie at an identified mode: within
/// max(2 Δf, ζ f) of a mode (f, ζ) in `modes`, the window in which
/// [`super::peak_evidence`] assigns a data peak to a root. The residual
/// there is that mode's misfit on one channel, not a mode the fit lacks,
/// and asks the user for nothing (the 118.9 Hz mode of the UFSC beam's
/// shaker test, fitted at 118.7 Hz, was warned about as "missing" at
/// 119 Hz).
pub fn mark_identified(peaks: &mut [ResidualPeak], modes: &[(f64, f64)], step_hz: f64) {
    for p in peaks.iter_mut() {
        p.at_mode_hz = modes
            .iter()
            .filter(|(f, z)| (p.frequency_hz - f).abs() <= (2.0 * step_hz).max(z.abs() * f))
            .min_by(|a, b| {
                (a.0 - p.frequency_hz)
                    .abs()
                    .total_cmp(&(b.0 - p.frequency_hz).abs())
            })
            .map(|m| m.0);
    }
}

/// The missing-mode warnings of `peaks`, one per stretch of the band
/// between two identified modes (`modes`: frequency, damping ratio, as
/// [`mark_identified`] takes them): peaks with no mode between
/// them are one region the fit leaves unexplained (a mode above the span
/// whose flank rises to the band's end gives a data "peak" every few lines
/// of it: vibration-toolbox case 1, nine warnings for 395–489 Hz), so the
/// user is asked once per region; every peak stays in metrics.json.
pub fn missing_mode_warnings(peaks: &[ResidualPeak], modes: &[(f64, f64)]) -> Vec<String> {
    let mut missing: Vec<&ResidualPeak> = peaks.iter().filter(|p| p.missing_mode()).collect();
    missing.sort_by(|a, b| a.frequency_hz.total_cmp(&b.frequency_hz));
    let region = |f: f64| modes.iter().filter(|m| m.0 < f).count();
    let mut out = Vec::new();
    let mut k = 0;
    while k < missing.len() {
        let r = region(missing[k].frequency_hz);
        let n = missing[k..]
            .iter()
            .take_while(|p| region(p.frequency_hz) == r)
            .count()
            .max(1);
        // n ≥ 1: the group starts with missing[k] itself.
        let group = &missing[k..k + n];
        let worst = group
            .iter()
            .fold(group[0], |w, p| if p.ratio > w.ratio { p } else { w });
        out.push(if n == 1 {
            worst.warning()
        } else {
            format!(
                "the data peak at {n} frequencies in {:.2}–{:.2} Hz with no identified mode among them, and the fit leaves residuals up to {:.1}× above the noise there (at {:.2} Hz, channel {}): modes may be missing, or a mode outside the band shows its flank; look at that band, or narrow `band` (residual_peaks in metrics.json lists each)",
                group[0].frequency_hz,
                group[n - 1].frequency_hz,
                worst.ratio,
                worst.frequency_hz,
                worst.channel
            )
        });
        k += n;
    }
    out
}

/// The check of a fit (`reconstructed`, of the identified `modes`:
/// frequency, damping ratio) against the noise: the relative error ε²
/// (power ratio; the larger of the data's noise and the fit's misfit) and
/// the residual peaks, those at an identified mode marked.
pub fn check(
    data: &FrfData,
    noise: &[f64],
    reconstructed: &[Complex64],
    modes: &[(f64, f64)],
) -> (f64, Vec<ResidualPeak>) {
    let relative = relative_noise(data, noise).max(relative_misfit(data, reconstructed, noise));
    let mut peaks = residual_peaks(
        data,
        reconstructed,
        noise,
        relative,
        &coherence_relative_error(data, ASSUMED_AVERAGES),
    );
    mark_identified(&mut peaks, modes, data.line_spacing_hz());
    (relative, peaks)
}

/// Local maxima of the residual-to-noise ratio (most prominent first, at
/// most 20), with the noise σ_c² + ε²|H|² (module docs; `relative` = ε²),
/// where ε² per line is the larger of `relative` and, with coherence, that
/// line's H1 error `coherence_error` ([`super::noise::coherence_relative_error`],
/// laid out as `data.h`; empty without coherence).
pub fn residual_peaks(
    data: &FrfData,
    reconstructed: &[Complex64],
    noise: &[f64],
    relative: f64,
    coherence_error: &[f64],
) -> Vec<ResidualPeak> {
    let nf = data.n_lines();
    let n_ch = data.n_out() * data.n_ref();
    // ρ_{c,f}: the ratio averaged over lines f−1..f+1.
    let rho = |c: usize, f: usize| {
        let (lo, hi) = (f.saturating_sub(1), (f + 2).min(nf));
        (lo..hi)
            .map(|g| {
                let h = data.h[c * nf + g];
                let eps2 = coherence_error
                    .get(c * nf + g)
                    .map_or(relative, |&e| e.max(relative));
                let s2 = (noise[c] + eps2 * h.norm_sqr()).max(1e-300);
                (h - reconstructed[c * nf + g]).norm_sqr() / s2
            })
            .sum::<f64>()
            / (hi - lo) as f64
    };
    let rhos: Vec<f64> = (0..n_ch)
        .flat_map(|c| (0..nf).map(move |f| (c, f)))
        .map(|(c, f)| rho(c, f))
        .collect();
    let top: Vec<(f64, usize)> = (0..nf)
        .map(|f| {
            (0..n_ch).fold((0.0, 0), |t, c| {
                let m = rhos[c * nf + f];
                if m > t.0 {
                    (m, c)
                } else {
                    t
                }
            })
        })
        .collect();
    let peaks: Vec<std::cell::OnceCell<ChannelPeaks>> =
        (0..n_ch).map(|_| std::cell::OnceCell::new()).collect();
    let unfitted = |c: usize, f: usize| {
        peaks[c]
            .get_or_init(|| {
                ChannelPeaks::new(
                    &data.h[c * nf..(c + 1) * nf],
                    &reconstructed[c * nf..(c + 1) * nf],
                    &data.frequencies_hz,
                )
            })
            .unfitted(&data.frequencies_hz, f)
    };
    let mut out: Vec<ResidualPeak> = (0..nf)
        .filter(|&f| {
            let lo = f.saturating_sub(5);
            let hi = (f + 6).min(nf);
            top[f].0 >= 9.0
                && (lo..hi).all(|g| top[g].0 < top[f].0 || (top[g].0 == top[f].0 && g >= f))
        })
        .map(|f| {
            // Report the channel where the data show an unfitted peak and
            // the residual is visible, if any; else where it is largest.
            let visible = VISIBLE * VISIBLE;
            let peak_channel = (0..n_ch)
                .filter(|&c| rhos[c * nf + f] >= visible)
                .filter_map(|c| unfitted(c, f).map(|k| (c, k)))
                .max_by(|a, b| rhos[a.0 * nf + f].total_cmp(&rhos[b.0 * nf + f]));
            let (c, peak) = match peak_channel {
                Some((c, k)) => (c, Some(k)),
                None => (top[f].1, unfitted(top[f].1, f)),
            };
            let (o, i) = (c / data.n_ref(), c % data.n_ref());
            ResidualPeak {
                // The data's peak when there is one: where the mode is.
                frequency_hz: data.frequencies_hz[peak.unwrap_or(f)],
                channel: format!("{}/{}", data.responses[o], data.references[i]),
                ratio: rhos[c * nf + f].sqrt(),
                data_peak: peak.is_some(),
                at_mode_hz: None,
            }
        })
        .collect();
    out.sort_by(|a, b| {
        b.ratio
            .total_cmp(&a.ratio)
            .then(a.frequency_hz.total_cmp(&b.frequency_hz))
    });
    // One entry per data peak: the strongest residual that found it.
    let mut seen = Vec::new();
    out.retain(|p| {
        let fresh = !(p.data_peak && seen.contains(&p.frequency_hz.to_bits()));
        if p.data_peak {
            seen.push(p.frequency_hz.to_bits());
        }
        fresh
    });
    out.truncate(20);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ema::lsfd::lsfd;
    use crate::ema::noise::{noise_variance, relative_noise};
    use crate::ema::synthetic::{four_mode_system, lines, modal_superposition};
    use crate::ema::Weighting;
    use crate::metrics::pole;

    /// A fit with all four modes leaves noise only; leaving out the 140 Hz
    /// mode leaves a peak there, far above 10× the noise.
    #[test]
    fn a_missing_mode_shows_in_the_residual() {
        let modes = four_mode_system();
        let set = modal_superposition(&modes, &[0, 3], &lines(20.0, 260.0, 0.25), 0.01, 5);
        let d = FrfData::from_set(&set, None, Weighting::Uniform).unwrap();
        let noise = noise_variance(&d);
        let all = poles(&modes);
        let fit = lsfd(&d, &all).unwrap();
        // Additive noise only: the relative error is small (ε ≪ 1 %).
        let eps2 = relative_noise(&d, &noise);
        assert!(eps2 < 1e-4, "{eps2}");
        assert!(residual_peaks(&d, &fit.reconstructed, &noise, eps2, &[]).is_empty());
        let missing = missing_without_140_hz(&d, &all, &noise, eps2);
        assert!(missing.contains("Hz"));
    }

    #[test]
    fn missing_peaks_between_two_modes_are_one_warning() {
        let peak = |f: f64, ratio: f64| ResidualPeak {
            frequency_hz: f,
            channel: "2+Z/1+Z".into(),
            ratio,
            data_peak: true,
            at_mode_hz: None,
        };
        let peaks = [
            peak(464.06, 20.4),
            peak(395.31, 10.1),
            peak(489.06, 25.9),
            peak(420.94, 14.7),
            peak(300.0, 4.0), // below the visibility limit: no warning
        ];
        let w = missing_mode_warnings(&peaks, &[(212.1, 0.001), (410.1, 0.01), (431.8, 0.02)]);
        assert_eq!(w.len(), 3, "{w:?}");
        assert!(w[0].starts_with("the data peak at 395.31 Hz"), "{w:?}");
        assert!(w[1].starts_with("the data peak at 420.94 Hz"), "{w:?}");
        assert!(
            w[2].starts_with("the data peak at 2 frequencies in 464.06–489.06 Hz")
                && w[2].contains("25.9× above the noise there (at 489.06 Hz"),
            "{w:?}"
        );
        assert!(missing_mode_warnings(&peaks[4..], &[]).is_empty());
    }

    /// The poles λ of the synthetic modes.
    fn poles(modes: &[crate::ema::synthetic::SyntheticMode]) -> Vec<Complex64> {
        modes
            .iter()
            .map(|m| pole(m.frequency_hz, m.damping_ratio))
            .collect()
    }

    /// Fits all poles but the 140 Hz one and returns the one missing-mode
    /// warning, which must be at 140 Hz.
    fn missing_without_140_hz(d: &FrfData, all: &[Complex64], noise: &[f64], eps2: f64) -> String {
        let three: Vec<_> = all
            .iter()
            .enumerate()
            .filter(|(k, _)| *k != 2)
            .map(|(_, l)| *l)
            .collect();
        let fit = lsfd(d, &three).unwrap();
        let p = residual_peaks(d, &fit.reconstructed, noise, eps2, &[]);
        let missing: Vec<_> = p.iter().filter(|p| p.missing_mode()).collect();
        assert_eq!(missing.len(), 1, "{p:?}");
        assert!((missing[0].frequency_hz - 140.0).abs() < 3.0, "{p:?}");
        missing[0].warning()
    }

    /// Data with a relative error (5 % of |H| per line, as the H1 estimate
    /// and leakage leave near resonances) and all modes fitted: the floor
    /// alone flags the peaks, σ² + ε²|H|² does not; a missing mode still
    /// stands out.
    #[test]
    fn a_relative_error_is_not_a_missing_mode() {
        use rand::{RngExt, SeedableRng};
        let modes = four_mode_system();
        let set = modal_superposition(&modes, &[0, 3], &lines(20.0, 260.0, 0.25), 0.001, 7);
        let mut d = FrfData::from_set(&set, None, Weighting::Uniform).unwrap();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        for h in d.h.iter_mut() {
            let e = Complex64::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0));
            *h *= Complex64::new(1.0, 0.0) + 0.05 * e;
        }
        let noise = noise_variance(&d);
        let all = poles(&modes);
        let fit = lsfd(&d, &all).unwrap();
        assert!(
            residual_peaks(&d, &fit.reconstructed, &noise, 0.0, &[])
                .iter()
                .any(|p| p.ratio >= 10.0),
            "the floor alone must flag the relative error"
        );
        // Complex uniform error of ±5 % per part: E|e|² = 2 · 0.05²/3.
        let eps2 = relative_noise(&d, &noise);
        assert!(eps2 > 5e-4 && eps2 < 5e-3, "{eps2}");
        let p = residual_peaks(&d, &fit.reconstructed, &noise, eps2, &[]);
        assert!(p.iter().all(|p| !p.missing_mode()), "{p:?}");
        missing_without_140_hz(&d, &all, &noise, eps2);
    }

    /// Synthetic coherence: a band of poorly coherent lines (γ² = 0.9 on
    /// 80–110 Hz, around the 95 Hz mode, whose H1 values carry a ±20 %
    /// relative error on 88–102 Hz, E|e|² = 2 · 0.2²/3 ≈ 0.027 < (1 − 0.9)/0.9) and γ² = 1
    /// elsewhere. The scatter-based ε² (a median over all strong lines)
    /// misses the local error and flags the band; the coherence-based
    /// error does not, and the 140 Hz mode, where the coherence is good,
    /// is still found missing when left out.
    #[test]
    fn coherence_widens_the_noise_only_where_it_is_poor() {
        use crate::ema::noise::coherence_relative_error;
        use rand::{RngExt, SeedableRng};
        let modes = four_mode_system();
        let set = modal_superposition(&modes, &[0, 3], &lines(20.0, 260.0, 0.25), 0.001, 7);
        let mut d = FrfData::from_set(&set, None, Weighting::Uniform).unwrap();
        let nf = d.n_lines();
        let within = |k: usize, lo: f64, hi: f64| (lo..=hi).contains(&d.frequencies_hz[k % nf]);
        let poor: Vec<bool> = (0..d.h.len()).map(|k| within(k, 88.0, 102.0)).collect();
        // The coherence band is wider than the corrupted one: the LSFD fit
        // of the corrupted lines smears their error onto the lines beside.
        let low: Vec<bool> = (0..d.h.len()).map(|k| within(k, 80.0, 110.0)).collect();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        for (h, &p) in d.h.iter_mut().zip(&poor) {
            let e = Complex64::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0));
            if p {
                *h *= Complex64::new(1.0, 0.0) + 0.2 * e;
            }
        }
        d.coherence = low.iter().map(|&p| if p { 0.9 } else { 1.0 }).collect();
        let coh = coherence_relative_error(&d, 1.0);
        assert!((coh[0] - 0.0).abs() < 1e-15);
        let k = poor.iter().position(|&p| p).unwrap();
        assert!((coh[k] - 0.1 / 0.9).abs() < 1e-12, "{}", coh[k]);
        // With n_d = 4 averages the error is a quarter.
        assert!((coherence_relative_error(&d, 4.0)[k] - 0.1 / 3.6).abs() < 1e-12);
        let noise = noise_variance(&d);
        let eps2 = relative_noise(&d, &noise);
        let all = poles(&modes);
        let fit = lsfd(&d, &all).unwrap();
        let without = residual_peaks(&d, &fit.reconstructed, &noise, eps2, &[]);
        assert!(
            without
                .iter()
                .any(|p| p.ratio >= VISIBLE && (p.frequency_hz - 95.0).abs() < 8.0),
            "the scatter-based ε must miss the local error: {without:?}"
        );
        let with = residual_peaks(&d, &fit.reconstructed, &noise, eps2, &coh);
        assert!(with.iter().all(|p| p.ratio < VISIBLE), "{with:?}");
        let three: Vec<_> = all
            .iter()
            .enumerate()
            .filter(|(k, _)| *k != 2)
            .map(|(_, l)| *l)
            .collect();
        let fit = lsfd(&d, &three).unwrap();
        // The strongest missing mode is 140 Hz (the 210 Hz one, refitted
        // without it, may follow: ε here is the additive noise's only).
        let p = residual_peaks(&d, &fit.reconstructed, &noise, eps2, &coh);
        let missing: Vec<_> = p.iter().filter(|p| p.missing_mode()).collect();
        assert!(!missing.is_empty(), "{p:?}");
        assert!((missing[0].frequency_hz - 140.0).abs() < 3.0, "{p:?}");
    }

    /// A data peak the fit misses on one channel is no missing mode when an
    /// identified mode's window (max(2 Δf, ζ f)) holds it; one outside
    /// every window still is.
    #[test]
    fn a_peak_at_an_identified_mode_is_no_missing_mode() {
        let at = |f: f64| ResidualPeak {
            frequency_hz: f,
            channel: "11+Z/2+Z".into(),
            ratio: 34.0,
            data_peak: true,
            at_mode_hz: None,
        };
        let mut p = vec![at(119.0), at(42.0), at(130.0)];
        // 118.7 Hz at ζ 0.6 %: window max(2 · 1, 0.71) = 2 Hz; 125 Hz at
        // ζ 3 %: 3.75 Hz, which reaches 128.75 but not 130.
        mark_identified(&mut p, &[(118.7, 0.006), (125.0, 0.03)], 1.0);
        assert_eq!(p[0].at_mode_hz, Some(118.7));
        assert!(!p[0].missing_mode());
        assert!(p[1].missing_mode() && p[2].missing_mode(), "{p:?}");
    }
}
