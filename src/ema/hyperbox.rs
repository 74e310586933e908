//! The search box of the AutoEMA hyperparameters, fitted to the data, and
//! the check of a result that ends at one of its bounds.
//!
//! | hyperparameter | range | from the data |
//! |---|---|---|
//! | frequency_tol | [2·10⁻³, 0.03] (log) | — |
//! | damping_tol | [0.05, 0.5] (log) | — |
//! | mac_tol | [5·10⁻³, 0.2] (log) | fixed at 0.2 with one reference (no vector to compare) |
//! | max_damping | [0.05, ζ_top] | ζ_top = clamp((f_hi − f_lo)/(4 f_hi), 0.08, 0.3): a half-power band 2ζf wider than half the band cannot be a mode of it |
//! | cluster_distance | [3·10⁻³, 0.05] (log) | — |
//! | min_cluster_fraction | [0.1, 0.6] | (a cluster needs ≥ 5 orders in any case, [`super::clustering::MIN_COLUMN`]) |
//!
//! The lower ends of the tolerances are loose on purpose: a tolerance
//! tighter than the scatter of a mode's poles across orders only loses
//! modes, while a loose one costs nothing since every root is validated
//! against the noise afterwards (duplicates, significance). Tight corners
//! of a box with three tolerances that must all pass would otherwise fill
//! most of a 40-point search with empty selections.
//! | damping_weight | [0, 1] | — |
//! | mac_weight | [0, 1] | fixed at 0 with one reference |
//! | max_order | [n_lo, n_hi] | from the number N of CMIF peaks and n_ref: n_lo = clamp(⌈2 N/n_ref⌉ + 4, 8, 60), n_hi = min(max(n_lo + 24, ⌈6 N/n_ref⌉ + 30), 100, n_f − 2). N counts the prominent peaks of the first CMIF curve above the noise ([`super::noise::cmif_mode_peaks`]) and the peaks of the further curves: a lower bound of the modes (a close pair shares a peak, heavily damped modes merge), hence the margins; a wide band needs several poles per mode before the low modes converge, and the second pole of a repeated root often stabilizes only at high orders. With ≤ [`FEW_REFERENCES`] references the FRF peaks are counted too and reported ([`frf_peak_count`]), not used (see [`DataSummary::frf_peaks`]) |
//!
//! A chosen value within 2 % (of the searched range) of a bound is "at the
//! bound"; the search then evaluates the selection a quarter of the range
//! beyond that bound and reports whether the result would change there.

use super::noise::{cmif_mode_peaks, peaks};
use super::FrfData;

/// Searched on a log scale (tolerances spanning decades).
pub const LOG_SCALE: [bool; 9] = [true, true, true, false, true, false, false, false, false];

/// What the box is fitted to.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct DataSummary {
    pub band_hz: (f64, f64),
    /// Median line spacing.
    pub line_spacing_hz: f64,
    pub n_ref: usize,
    pub n_lines: usize,
    /// Peaks of the CMIF curves (a first estimate of the number of modes):
    /// prominent peaks of the first curve above the noise, and peaks of
    /// the further ones (repeated roots).
    pub cmif_peaks: usize,
    /// With ≤ [`FEW_REFERENCES`] references: the peaks of the individual
    /// FRFs, clustered across channels ([`frf_peak_count`]); 0 otherwise.
    /// Reported beside `cmif_peaks` (which alone sizes the order range):
    /// sizing the range from the larger count (tried in issue 31: PSV
    /// surface scan 14 FRF peaks against 3 CMIF peaks) found one more mode
    /// there and lost modes on the UFSC beam hammer test (707 Hz) and the
    /// PSV line scan (920, 6924, 7582 Hz), the order rising to 100: a higher
    /// order feeds the significance test more spurious columns, and that
    /// test, not the order, rejects the modes missed on these sets.
    pub frf_peaks: usize,
    /// When the noise varies along the band beyond
    /// the limit of [`super::whitening::NoiseModel`]: the ratio of its largest to
    /// its smallest standard deviation, and the analysis weights the lines
    /// by it ([`super::whitening`]); `None` for white noise.
    pub noise_profile_range: Option<f64>,
}

/// Reference count up to which the FRF peaks are counted as well: with one
/// reference the first CMIF curve is the root-sum-square of the responses,
/// σ₁(f) = (Σ_o |H_o(f)|²)^½, where a mode strong at a few points is lost
/// under the flanks of modes strong at most of them (the PSV surface scan
/// of issue 31: 3 CMIF peaks, a dozen in its 25 FRFs); with two the same
/// holds for the modes neither reference excites well.
pub const FEW_REFERENCES: usize = 2;

/// Peaks of the individual FRFs, clustered across channels: the prominent
/// peaks of every |H_c| above its noise floor
/// ([`cmif_mode_peaks`] with the channel's noise variance) are sorted by
/// frequency and chained while neighbours lie within two line spacings (a
/// mode's peak moves by a line between channels with leakage and noise);
/// a chain counts when at least two channels (one, if there is only one)
/// hold it, so a spike of one channel does not. A lower bound of the
/// modes, like the CMIF count (close modes share a peak).
pub fn frf_peak_count(data: &FrfData, noise: &[f64], step_hz: f64) -> usize {
    let nf = data.n_lines();
    let n_ch = data.n_out() * data.n_ref();
    let mut peaks: Vec<(f64, usize)> = (0..n_ch)
        .flat_map(|c| {
            let mag: Vec<f64> = data.h[c * nf..(c + 1) * nf]
                .iter()
                .map(|v| v.norm())
                .collect();
            let noise_c = noise.get(c).copied().unwrap_or(0.0);
            cmif_mode_peaks(&mag, noise_c)
                .into_iter()
                .map(move |k| (data.frequencies_hz[k], c))
        })
        .collect();
    peaks.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    let support = 2.min(n_ch.max(1));
    let mut count = 0;
    let mut chain: Vec<usize> = Vec::new();
    let mut last = f64::NEG_INFINITY;
    for &(f, c) in &peaks {
        if f - last > 2.0 * step_hz + 1e-9 * f.abs() {
            count += usize::from(distinct(&mut chain) >= support);
            chain.clear();
        }
        chain.push(c);
        last = f;
    }
    count + usize::from(distinct(&mut chain) >= support)
}

fn distinct(v: &mut Vec<usize>) -> usize {
    v.sort_unstable();
    v.dedup();
    v.len()
}

impl DataSummary {
    /// The summary of `data` with its CMIF curves and per-channel noise
    /// variances ([`super::noise`]).
    pub fn of(data: &FrfData, cmif: &[Vec<f64>], noise: &[f64]) -> DataSummary {
        let f = &data.frequencies_hz;
        let reach = (data.n_lines() / 50).max(5);
        // First curve: every mode, by prominence above the noise
        // ([`cmif_mode_peaks`]); further curves: repeated roots.
        let noise_power = noise.iter().sum::<f64>() / data.n_ref().max(1) as f64;
        let cmif_peaks = cmif
            .iter()
            .enumerate()
            .map(|(k, c)| {
                if k == 0 {
                    cmif_mode_peaks(c, noise_power).len()
                } else {
                    peaks(c, 3.0, reach).len()
                }
            })
            .sum();
        let line_spacing_hz = data.line_spacing_hz();
        let frf_peaks = if data.n_ref() <= FEW_REFERENCES {
            frf_peak_count(data, noise, line_spacing_hz)
        } else {
            0
        };
        DataSummary {
            band_hz: (
                f.first().copied().unwrap_or(0.0),
                f.last().copied().unwrap_or(0.0),
            ),
            line_spacing_hz,
            n_ref: data.n_ref(),
            n_lines: data.n_lines(),
            cmif_peaks,
            frf_peaks,
            noise_profile_range: None,
        }
    }

    /// Default range of the maximum model order.
    pub fn max_order_range(&self) -> (usize, usize) {
        let per_ref =
            |k: f64| (k * self.cmif_peaks as f64 / self.n_ref.max(1) as f64).ceil() as usize;
        let cap = self.n_lines.saturating_sub(2).max(1);
        let lo = (per_ref(2.0) + 4).clamp(8, 60).min(cap);
        let hi = (lo + 24).max(per_ref(6.0) + 30).min(100).min(cap).max(lo);
        (lo, hi)
    }

    /// Search bounds of every hyperparameter, for a maximum-order range.
    pub fn bounds(&self, max_order: (usize, usize)) -> [(f64, f64); 9] {
        let (lo, hi) = self.band_hz;
        let z_top = if hi > 0.0 {
            ((hi - lo) / (4.0 * hi)).clamp(0.08, 0.3)
        } else {
            0.2
        };
        [
            (2e-3, 0.03),
            (0.05, 0.5),
            (5e-3, 0.2),
            (0.05, z_top),
            (3e-3, 0.05),
            (0.1, 0.6),
            (0.0, 1.0),
            (0.0, 1.0),
            (max_order.0 as f64, max_order.1 as f64),
        ]
    }

    /// Hyperparameters without meaning for these data, with their value.
    pub fn implied(&self) -> Vec<(usize, f64)> {
        if self.n_ref < 2 {
            vec![(2, 0.2), (7, 0.0)]
        } else {
            Vec::new()
        }
    }
}

/// A hyperparameter of the result at the edge of its search range.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct AtBound {
    pub name: String,
    pub value: f64,
    pub bound: f64,
    /// "lower" or "upper".
    pub side: &'static str,
    /// The value tried beyond the bound (None when it cannot be tried).
    pub beyond: Option<f64>,
    /// Modes and objective at the chosen point and beyond the bound.
    pub modes_at: usize,
    pub modes_beyond: Option<usize>,
    pub objective_at: f64,
    pub objective_beyond: Option<f64>,
    /// Whether modes of the result depend on the box: beyond the bound the
    /// screening's objective is better by more than the search's tie
    /// tolerance, with other modes ([`same_modes`]), and refined, that
    /// selection lacks modes of the result (`only_here_hz`).
    pub sensitive: bool,
    /// Modes (Hz) of the refined selection beyond the bound that the result
    /// lacks, and modes of the result it lacks, one to one within
    /// [`FOUND_WITHIN`]; empty unless the screening there was better.
    pub only_beyond_hz: Vec<f64>,
    pub only_here_hz: Vec<f64>,
}

/// The warning for the result's modes that a better-fitting selection
/// beyond a bound lacks (the sensitive bounds' `only_here_hz`), if any.
/// Modes such a selection adds are not named: on the vertical mill's family
/// (autoema 21) 6 of 71 were true modes the result missed, while 9 of the
/// 14 modes named here were spurious (docs/stage-kinds.md).
pub fn box_warning(bounds: &[AtBound]) -> Option<String> {
    let sensitive: Vec<&AtBound> = bounds.iter().filter(|b| b.sensitive).collect();
    if sensitive.is_empty() {
        return None;
    }
    let mut modes: Vec<f64> = Vec::new();
    for f in sensitive.iter().flat_map(|b| &b.only_here_hz) {
        if !modes.contains(f) {
            modes.push(*f);
        }
    }
    modes.sort_by(f64::total_cmp);
    let hz: Vec<String> = modes.iter().map(|f| format!("{f:.2}")).collect();
    let hz = hz.join(", ");
    let beyond: Vec<String> = sensitive
        .iter()
        .map(|b| {
            format!(
                "`{}` beyond its {} bound ({}, objective {:.6} against {:.6})",
                b.name,
                b.side,
                b.beyond.map_or("?".into(), |v| format!("{v:.4}")),
                b.objective_beyond.unwrap_or(f64::NAN),
                b.objective_at
            )
        })
        .collect();
    let beyond = beyond.join(" or ");
    Some(format!(
        "the mode(s) at {hz} Hz depend on the search box: with {beyond}, a selection that fits the FRFs better lacks them (`at_bound` in metrics.json); check them in the stabilization diagram and frf_fit.uff before you use them"
    ))
}

/// Relative frequency within which a mode of one selection is the same
/// mode as one of another for [`differing_modes`] (the "found" tolerance
/// of issue 31).
pub const FOUND_WITHIN: f64 = 0.01;

/// The frequencies of `a` and of `b` left unpaired (each sorted) when they
/// are paired one to one within `tol` ([`crate::pairing::pair_frequencies`]).
pub fn differing_modes(a: &[f64], b: &[f64], tol: f64) -> (Vec<f64>, Vec<f64>) {
    let pairs = crate::pairing::pair_frequencies(a, b, tol);
    let left = |v: &[f64], paired: &dyn Fn(usize) -> bool| -> Vec<f64> {
        let mut out: Vec<f64> = (0..v.len()).filter(|&i| !paired(i)).map(|i| v[i]).collect();
        out.sort_by(f64::total_cmp);
        out
    };
    (
        left(a, &|i| pairs.iter().any(|p| p.0 == i)),
        left(b, &|j| pairs.iter().any(|p| p.1 == j)),
    )
}

/// Whether two selections' modes (frequency, damping) are the same: none
/// left unpaired when paired one to one within [`SAME_MODE`]
/// ([`differing_modes`]).
pub fn same_modes(a: &[(f64, f64)], b: &[(f64, f64)]) -> bool {
    let f = |v: &[(f64, f64)]| v.iter().map(|m| m.0).collect::<Vec<f64>>();
    let (only_a, only_b) = differing_modes(&f(a), &f(b), SAME_MODE);
    only_a.is_empty() && only_b.is_empty()
}

/// Relative frequency within which two selections hold the same mode (the
/// seed-invariance tolerance of issue 31).
const SAME_MODE: f64 = 1e-3;

#[cfg(test)]
mod tests {
    use super::*;

    /// Two selections hold the same modes when they pair one to one within
    /// 0.1 % in frequency, whatever their order and damping.
    #[test]
    fn same_modes_pairs_frequencies_within_a_tenth_of_a_percent() {
        let a = [(100.0, 0.01), (250.0, 0.02)];
        assert!(super::same_modes(&a, &[(250.2, 0.05), (100.05, 0.01)]));
        assert!(!super::same_modes(&a, &[(100.0, 0.01), (250.3, 0.02)]));
        assert!(!super::same_modes(&a, &[(100.0, 0.01)]));
    }

    /// Unpaired modes are those left when as many pairs as possible within
    /// the tolerance are formed, the least shifted; one mode pairs with one
    /// mode only.
    #[test]
    fn differing_modes_pair_one_to_one_within_the_tolerance() {
        let (only_a, only_b) =
            differing_modes(&[100.0, 101.5, 300.0], &[100.4, 250.0, 301.0, 302.0], 0.01);
        assert_eq!(only_a, vec![101.5]);
        assert_eq!(only_b, vec![250.0, 302.0]);
        let (none_a, none_b) = differing_modes(&[50.0], &[50.2], 0.01);
        assert!(none_a.is_empty() && none_b.is_empty());
    }

    /// Only sensitive bounds warn, once for all of them, naming each mode
    /// of the result they lack once and never the modes they add.
    #[test]
    fn box_warning_names_the_modes_a_better_selection_lacks() {
        let bound = |name: &str, sensitive: bool, here: Vec<f64>| AtBound {
            name: name.into(),
            value: 0.05,
            bound: 0.05,
            side: "upper",
            beyond: Some(0.1),
            modes_at: 7,
            modes_beyond: Some(9),
            objective_at: 0.97,
            objective_beyond: Some(0.98),
            sensitive,
            only_beyond_hz: vec![777.0],
            only_here_hz: here,
        };
        assert_eq!(box_warning(&[bound("mac_tol", false, vec![])]), None);
        let w = box_warning(&[
            bound("cluster_distance", true, vec![4236.0, 120.5]),
            bound("frequency_tol", true, vec![120.5]),
            bound("mac_tol", false, vec![]),
        ])
        .unwrap();
        assert!(
            w.starts_with("the mode(s) at 120.50, 4236.00 Hz depend"),
            "{w}"
        );
        assert!(w.contains("`cluster_distance` beyond") && w.contains("`frequency_tol` beyond"));
        assert!(!w.contains("mac_tol") && !w.contains("777"), "{w}");
    }

    #[test]
    fn bounds_follow_the_data() {
        let s = DataSummary {
            band_hz: (20.0, 260.0),
            line_spacing_hz: 0.25,
            n_ref: 2,
            n_lines: 961,
            cmif_peaks: 8,
            frf_peaks: 0,
            noise_profile_range: None,
        };
        assert_eq!(s.max_order_range(), (12, 54));
        let b = s.bounds((12, 54));
        assert!((b[3].1 - 240.0 / 1040.0).abs() < 1e-12);
        assert!(s.implied().is_empty());
        let one = DataSummary {
            n_ref: 1,
            cmif_peaks: 40,
            ..s.clone()
        };
        assert_eq!(one.max_order_range(), (60, 100));
        assert_eq!(one.implied(), vec![(2, 0.2), (7, 0.0)]);
        let short = DataSummary { n_lines: 30, ..one };
        assert_eq!(short.max_order_range(), (28, 28));
    }

    /// One reference, `n_out` responses: H_o(f) = Σ_k a_ko / (ω_k² − ω² + 2jζ_k ω_k ω).
    fn one_reference(freqs: &[f64], n_out: usize, modes: &[(f64, f64, Vec<f64>)]) -> FrfData {
        use num_complex::Complex64;
        let nf = freqs.len();
        let mut h = Vec::with_capacity(n_out * nf);
        for o in 0..n_out {
            h.extend(freqs.iter().map(|&f| {
                let w = 2.0 * std::f64::consts::PI * f;
                modes
                    .iter()
                    .map(|(fr, z, a)| {
                        let wr = 2.0 * std::f64::consts::PI * fr;
                        a[o] / Complex64::new(wr * wr - w * w, 2.0 * z * wr * w)
                    })
                    .sum::<Complex64>()
            }));
        }
        FrfData {
            frequencies_hz: freqs.to_vec(),
            responses: (0..n_out).map(crate::ema::synthetic::dof).collect(),
            references: vec![crate::ema::synthetic::dof(99)],
            h,
            weight: vec![1.0; n_out * nf],
            line_weight: vec![1.0; nf],
            coherence: Vec::new(),
        }
    }

    #[test]
    fn frf_peaks_count_modes_the_cmif_of_one_reference_hides() {
        use crate::ema::noise::cmif;
        // Ten responses; modes at 100, 130 and 160 Hz (ζ 0.5 %) each seen
        // at two responses only, under a broad mode at 115 Hz (ζ 5 %) ten
        // times stronger at all ten: σ₁, the root-sum-square over the
        // responses, hides the local modes; the FRFs show all four.
        let freqs: Vec<f64> = (0..=800).map(|k| 60.0 + 0.2 * k as f64).collect();
        let local = |a: usize| (0..10).map(|o| f64::from(o / 2 == a)).collect::<Vec<f64>>();
        let modes = [
            (100.0, 0.005, local(0)),
            (130.0, 0.005, local(1)),
            (160.0, 0.005, local(2)),
            (115.0, 0.05, vec![10.0; 10]),
        ];
        let data = one_reference(&freqs, 10, &modes);
        let noise = vec![1e-30; 10];
        let s = DataSummary::of(&data, &cmif(&data), &noise);
        assert_eq!(s.frf_peaks, 4, "{s:?}");
        assert!(s.cmif_peaks < s.frf_peaks, "{s:?}");
        // A peak at one response alone does not count (two channels needed).
        let lone = [
            (100.0, 0.005, (0..10).map(|o| f64::from(o == 0)).collect()),
            (160.0, 0.005, vec![1.0; 10]),
        ];
        let data = one_reference(&freqs, 10, &lone);
        assert_eq!(frf_peak_count(&data, &noise, 0.2), 1);
    }
}
