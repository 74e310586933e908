//! Is the sample size of a Sobol screening adequate? (issue 26; PUB2, seed
//! section 5.2.1.)
//!
//! The split of PUB2 compares each parameter's combined total index c_i
//! (the weighted mean of eq. 2.12's ST over the outputs, or their maximum;
//! [`super::aggregate`]) with a threshold t. The estimate c_i carries the
//! sampling error of N base rows: its confidence interval is taken from the
//! same bootstrap as `ST_conf` ([`super::sobol::analyze()`]): resample k
//! draws the same base rows for every output, so the combination is formed
//! per resample, c_i^(k), and
//!
//!   h_i = z · std_k(c_i^(k)),  z = Φ⁻¹(½ + confidence/2),
//!
//! the interval c_i ± h_i, as `ST_conf` is for one output. A parameter is
//! **undecided** when its interval straddles the threshold,
//! |c_i − t| < h_i: at this N the data cannot say on which side it lies.
//!
//! The half-width of a Monte Carlo estimate shrinks as 1/√N (the bootstrap
//! standard error of a mean over N rows), so h_i(N′) ≈ h_i · √(N/N′), and
//! the interval clears the threshold once
//!
//!   N′ > N · (h_i / |c_i − t|)²,
//!
//! rounded up to a power of two (Sobol sequences balance there). A
//! parameter with c_i = t exactly, or one needing more than
//! [`super::sobol::MAX_SAMPLES`], has no suggested size.

use super::aggregate::{combine, Combine};
use super::sobol::MAX_SAMPLES;
use super::SensitivityError;
use serde::Serialize;
use statrs::distribution::{ContinuousCDF, Normal};

/// The combined index of one parameter with its bootstrap interval.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ScoreInterval {
    pub parameter: String,
    /// Combined total index c_i (point estimate, all N rows).
    pub score: f64,
    /// Half-width h_i of the interval c_i ± h_i.
    pub half_width: f64,
    /// The interval straddles the threshold: |c_i − t| < h_i.
    pub undecided: bool,
    /// Base sample size N′ at which the interval would clear the threshold
    /// (undecided parameters; `None` when no size up to the maximum would).
    pub samples_needed: Option<usize>,
}

/// Interval of every parameter's combined index and the verdict on N.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Adequacy {
    /// Base sample size N of the study.
    pub samples: usize,
    pub threshold: f64,
    pub confidence: f64,
    /// Per parameter, in parameter order.
    pub intervals: Vec<ScoreInterval>,
    /// Undecided parameters, in parameter order.
    pub undecided: Vec<String>,
    /// The power of two N′ that decides every undecided parameter that
    /// some size up to the maximum decides; `None` if none is undecided or
    /// none can be.
    pub suggested_samples: Option<usize>,
}

/// Intervals of the combined indices `scores` (in `parameters` order, as
/// [`super::aggregate`] computed them) from the bootstrap resamples of every
/// output's ST (`resamples[o][k][i]`, the same resamples k for every output),
/// combined with `weights` by `rule`; undecided parameters with respect to
/// `threshold`, for a study of `samples` base rows.
#[allow(clippy::too_many_arguments)]
pub fn score_intervals(
    parameters: &[String],
    scores: &[f64],
    resamples: &[&[Vec<f64>]],
    weights: &[f64],
    rule: Combine,
    threshold: f64,
    confidence: f64,
    samples: usize,
) -> Result<Adequacy, SensitivityError> {
    let d = parameters.len();
    if scores.len() != d || resamples.len() != weights.len() {
        return Err(SensitivityError::Invalid(format!(
            "{} scores for {d} parameters, {} resample sets for {} weights",
            scores.len(),
            resamples.len(),
            weights.len()
        )));
    }
    let count = resamples.first().map_or(0, |r| r.len());
    if resamples
        .iter()
        .any(|r| r.len() != count || r.iter().any(|row| row.len() != d))
    {
        return Err(SensitivityError::Invalid(
            "every output needs the same number of bootstrap resamples of all parameters".into(),
        ));
    }
    if !(confidence > 0.0 && confidence < 1.0) {
        return Err(SensitivityError::Invalid(format!(
            "confidence level {confidence} must lie strictly between 0 and 1"
        )));
    }
    let z = Normal::new(0.0, 1.0)
        .map_err(|e| SensitivityError::Invalid(e.to_string()))?
        .inverse_cdf(0.5 + confidence / 2.0);
    // c_i^(k): the combination formed within each resample k.
    let combined: Vec<Vec<f64>> = (0..count)
        .map(|k| {
            let st: Vec<&[f64]> = resamples.iter().map(|r| r[k].as_slice()).collect();
            combine(d, &st, weights, rule)
        })
        .collect();
    let intervals: Vec<ScoreInterval> = (0..d)
        .map(|i| {
            let half_width = z * std_dev(combined.iter().map(|c| c[i]));
            let score = scores[i];
            let gap = (score - threshold).abs();
            let undecided = gap < half_width;
            ScoreInterval {
                parameter: parameters[i].clone(),
                score,
                half_width,
                undecided,
                samples_needed: if undecided {
                    samples_needed(samples, half_width, gap)
                } else {
                    None
                },
            }
        })
        .collect();
    let undecided: Vec<String> = intervals
        .iter()
        .filter(|s| s.undecided)
        .map(|s| s.parameter.clone())
        .collect();
    let suggested_samples = intervals.iter().filter_map(|s| s.samples_needed).max();
    Ok(Adequacy {
        samples,
        threshold,
        confidence,
        intervals,
        undecided,
        suggested_samples,
    })
}

/// N′ > N (h/gap)², the interval's half-width scaling as 1/√N, as the
/// next power of two; `None` when gap = 0 or N′ exceeds the maximum.
pub fn samples_needed(samples: usize, half_width: f64, gap: f64) -> Option<usize> {
    if gap.is_nan() || gap <= 0.0 || !half_width.is_finite() {
        return None;
    }
    let needed = samples as f64 * (half_width / gap).powi(2);
    if needed.is_nan() || needed > MAX_SAMPLES as f64 {
        return None;
    }
    // Strictly more than `needed`, so the interval clears the threshold.
    let n = (needed.floor() as usize + 1).max(samples + 1);
    Some(n.next_power_of_two()).filter(|&n| n <= MAX_SAMPLES)
}

/// Sample standard deviation (ddof 1), 0 for fewer than two values.
fn std_dev(values: impl Iterator<Item = f64> + Clone) -> f64 {
    let n = values.clone().count();
    if n < 2 {
        return 0.0;
    }
    let mean = values.clone().sum::<f64>() / n as f64;
    (values.map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn needed_size_follows_the_inverse_square_root() {
        // h = 0.04 at N = 128, 0.01 from the threshold: N′ > 128 · 16 = 2048 → 4096.
        assert_eq!(samples_needed(128, 0.04, 0.01), Some(4096));
        // h just above the gap: N′ > 128 · 1.21 = 154.9 → 256.
        assert_eq!(samples_needed(128, 0.011, 0.01), Some(256));
        assert_eq!(samples_needed(128, 0.04, 0.0), None);
        assert_eq!(samples_needed(128, 1.0, 1e-9), None);
    }

    #[test]
    fn intervals_from_resamples_combined_per_resample() {
        let p: Vec<String> = ["a", "b"].iter().map(|s| s.to_string()).collect();
        // Two outputs, three resamples; output 2 mirrors output 1's spread
        // for `a`, so the mean of the two is constant in `a`: h = 0.
        let o1 = vec![vec![0.1, 0.02], vec![0.2, 0.04], vec![0.3, 0.06]];
        let o2 = vec![vec![0.3, 0.02], vec![0.2, 0.04], vec![0.1, 0.06]];
        let a = score_intervals(
            &p,
            &[0.2, 0.04],
            &[&o1, &o2],
            &[1.0, 1.0],
            Combine::Mean,
            0.05,
            0.95,
            64,
        )
        .expect("valid");
        assert!(a.intervals[0].half_width < 1e-15);
        assert!(!a.intervals[0].undecided);
        // b: resampled 0.02, 0.04, 0.06 → std 0.02, h = 1.96 · 0.02 > |0.04 − 0.05|.
        let h = a.intervals[1].half_width;
        assert!((h - 1.959_963_984_540_054 * 0.02).abs() < 1e-12, "{h}");
        assert_eq!(a.undecided, ["b"]);
        // N′ > 64 · (0.0392 / 0.01)² = 983.5 → 1024.
        assert_eq!(a.suggested_samples, Some(1024));
    }
}
