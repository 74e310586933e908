//! One position's measured FRFs matched to the model ([`FrfSlot`]): its
//! channels paired with the model's sensor and excitation rows and signed,
//! the lines in the band, and each line's noise σ (from coherence where
//! the test gives it, module docs of [`super`]).

use super::{FrfNoise, FrfSlot};
use crate::dynamics::reference::dof_row;
use crate::dynamics::PreparedModel;
use crate::ema::noise::channel_noise_variance;
use crate::frf::FrfSet;
use crate::identify::IdentifyError;
use num_complex::Complex64;

/// One position's FRFs matched to the model.
pub(super) fn slot(
    model: &PreparedModel,
    set: &FrfSet,
    band: (f64, f64),
    noise: FrfNoise,
) -> Result<FrfSlot, IdentifyError> {
    let index = set.position.index;
    let config = model.config_of_position(index).ok_or_else(|| {
        IdentifyError::Invalid(format!(
            "frf: position {index} is not a configuration of the model, which has {}",
            model.configurations.len()
        ))
    })?;
    let lines: Vec<usize> = (0..set.frequencies_hz.len())
        .filter(|&f| (band.0..=band.1).contains(&set.frequencies_hz[f]))
        .collect();
    if lines.len() < 8 {
        return Err(IdentifyError::Invalid(format!(
            "frf: position {index} has {} lines in the band [{}, {}] Hz; at least 8 are needed",
            lines.len(),
            band.0,
            band.1
        )));
    }
    let lines_hz: Vec<f64> = lines.iter().map(|&f| set.frequencies_hz[f]).collect();
    let record_s = if let Some(t0) = noise.truncation {
        let t = record_length(&set.frequencies_hz).ok_or_else(|| {
            IdentifyError::Invalid(format!(
                "frf: position {index}'s lines are not evenly spaced, so they are no DFT's and `frf_truncated` cannot know the record length; leave `frf_truncated` off for these FRFs"
            ))
        })?;
        if t0 >= t {
            return Err(IdentifyError::Invalid(format!(
                "frf: `frf_pre_trigger_s` {t0} s is not shorter than position {index}'s record of {t} s (1/Δf); give the time from the record's start to the hit"
            )));
        }
        Some(t)
    } else {
        None
    };
    let (mut pairs, mut signs, mut measured, mut sigma) = (vec![], vec![], vec![], vec![]);
    let (mut from_coherence, mut coherence_unused) = (0, 0);
    for c in &set.channels {
        let (Some((j, sj)), Some((k, sk))) = (
            dof_row(&model.sensors, c.response),
            dof_row(&model.excitations, c.reference),
        ) else {
            continue;
        };
        let values: Vec<Complex64> = lines.iter().map(|&f| c.values[f]).collect();
        if values
            .iter()
            .any(|v| !v.re.is_finite() || !v.im.is_finite())
        {
            return Err(IdentifyError::Invalid(format!(
                "frf: position {index}, channel {}/{} has non-finite values",
                c.response, c.reference
            )));
        }
        // Noise-free data (synthesized without noise) estimate σ ≈ 0: a floor
        // of 1e-9 of the channel's RMS keeps the residuals finite; an
        // all-zero channel carries nothing and is left out.
        let power = values.iter().map(|v| v.norm_sqr()).sum::<f64>() / values.len() as f64;
        if power == 0.0 {
            continue;
        }
        let white = channel_noise_variance(&lines_hz, &values)
            .max(1e-18 * power)
            .sqrt();
        let coherence: Option<Vec<f64>> = c.coherence.as_ref().map(|g| {
            lines
                .iter()
                .map(|&f| g.get(f).copied().unwrap_or(f64::NAN))
                .collect()
        });
        let line_sigma = match (coherence, noise.averages) {
            (Some(g), Some(n)) => {
                from_coherence += 1;
                values
                    .iter()
                    .zip(&g)
                    .map(|(h, &g)| coherence_sigma(h.norm(), g, n).max(white))
                    .collect()
            }
            (g, _) => {
                coherence_unused += usize::from(g.is_some());
                vec![white; values.len()]
            }
        };
        pairs.push((j, k));
        signs.push(sj * sk);
        sigma.push(line_sigma);
        measured.push(values);
    }
    if pairs.is_empty() {
        return Err(IdentifyError::Invalid(format!(
            "frf: position {index} shares no channel (response and reference node and axis) with the model's sensors and excitations"
        )));
    }
    Ok(FrfSlot {
        position: index,
        config,
        quantity: set.quantity,
        lines_hz,
        pairs,
        signs,
        measured,
        sigma,
        from_coherence,
        coherence_unused,
        expected_modes: 14,
        record_s,
    })
}

/// The record length T = 1/Δf of FRFs on the DFT lines `frequencies_hz`:
/// `None` unless they are evenly spaced (to 10⁻⁶ of the spacing).
fn record_length(frequencies_hz: &[f64]) -> Option<f64> {
    let (first, last) = (frequencies_hz.first()?, frequencies_hz.last()?);
    let n = frequencies_hz.len();
    if n < 2 {
        return None;
    }
    let step = (last - first) / (n - 1) as f64;
    let even = step > 0.0
        && frequencies_hz
            .windows(2)
            .all(|w| ((w[1] - w[0]) - step).abs() <= 1e-6 * step);
    even.then(|| 1.0 / step)
}

/// Random error σ of an FRF estimate |H| from n averages with coherence γ²
/// (module docs; Bendat & Piersol eq. 9.73/9.90): √((1 − γ²)/(nγ²))·|H|.
/// A coherence at or below 0 (no signal) or not finite gives an infinite σ,
/// so the line does not count.
pub fn coherence_sigma(h_abs: f64, gamma2: f64, averages: usize) -> f64 {
    if !(gamma2.is_finite() && gamma2 > 0.0) {
        return f64::INFINITY;
    }
    let g = gamma2.min(1.0);
    h_abs * ((1.0 - g) / (averages as f64 * g)).sqrt()
}
