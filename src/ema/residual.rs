//! The check of a final fit against the noise floor: where does the
//! residual H − Ĥ still stand above the noise, i.e. where is a mode the data
//! show missing from the modal model?
//!
//! Per channel c and line f, ρ_{c,f} = mean over lines f−1..f+1 of
//! |H_c − Ĥ_c|²/σ_c² (σ_c² from [`super::noise::noise_variance`]); pure
//! noise gives ρ ≈ 1 (a mean of three unit exponentials: P(ρ > 25) ≈ 10⁻²⁹).
//! The per-line maximum over channels is scanned for local maxima (±5 lines)
//! with amplitude ratio √ρ ≥ 3; each is reported with the channel where it
//! is largest. A ratio of 10 is the visibility limit of the acceptance
//! criteria (a peak 10× above the noise at its best sensor).

use super::FrfData;

/// Structure left in the residual at one frequency.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ResidualPeak {
    pub frequency_hz: f64,
    /// "response/reference" of the channel where it is largest.
    pub channel: String,
    /// Amplitude ratio √ρ of residual to noise.
    pub ratio: f64,
}

impl ResidualPeak {
    pub fn warning(&self) -> String {
        format!(
            "the fit leaves a residual {:.1}× above the noise at {:.2} Hz (channel {}): a mode the data show may be missing",
            self.ratio, self.frequency_hz, self.channel
        )
    }
}

/// Local maxima of the residual-to-noise ratio (most prominent first, at
/// most 20).
pub fn residual_peaks(
    data: &FrfData,
    reconstructed: &[num_complex::Complex64],
    noise: &[f64],
) -> Vec<ResidualPeak> {
    let nf = data.n_lines();
    let n_ch = data.n_out() * data.n_ref();
    let mut top = vec![(0.0f64, 0usize); nf];
    for c in 0..n_ch {
        let s2 = noise[c].max(1e-300);
        let r: Vec<f64> = (0..nf)
            .map(|f| (data.h[c * nf + f] - reconstructed[c * nf + f]).norm_sqr() / s2)
            .collect();
        for (f, t) in top.iter_mut().enumerate() {
            let lo = f.saturating_sub(1);
            let hi = (f + 2).min(nf);
            let m = r[lo..hi].iter().sum::<f64>() / (hi - lo) as f64;
            if m > t.0 {
                *t = (m, c);
            }
        }
    }
    let mut out: Vec<ResidualPeak> = (0..nf)
        .filter(|&f| {
            let lo = f.saturating_sub(5);
            let hi = (f + 6).min(nf);
            top[f].0 >= 9.0
                && (lo..hi).all(|g| top[g].0 < top[f].0 || (top[g].0 == top[f].0 && g >= f))
        })
        .map(|f| {
            let c = top[f].1;
            let (o, i) = (c / data.n_ref(), c % data.n_ref());
            ResidualPeak {
                frequency_hz: data.frequencies_hz[f],
                channel: format!("{}/{}", data.responses[o], data.references[i]),
                ratio: top[f].0.sqrt(),
            }
        })
        .collect();
    out.sort_by(|a, b| {
        b.ratio
            .total_cmp(&a.ratio)
            .then(a.frequency_hz.total_cmp(&b.frequency_hz))
    });
    out.truncate(20);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ema::lsfd::lsfd;
    use crate::ema::noise::noise_variance;
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
        let all: Vec<_> = modes
            .iter()
            .map(|m| pole(m.frequency_hz, m.damping_ratio))
            .collect();
        let fit = lsfd(&d, &all).unwrap();
        assert!(residual_peaks(&d, &fit.reconstructed, &noise).is_empty());
        let three: Vec<_> = all
            .iter()
            .enumerate()
            .filter(|(k, _)| *k != 2)
            .map(|(_, l)| *l)
            .collect();
        let fit = lsfd(&d, &three).unwrap();
        let p = residual_peaks(&d, &fit.reconstructed, &noise);
        assert!(!p.is_empty());
        assert!(
            (p[0].frequency_hz - 140.0).abs() < 1.0 && p[0].ratio > 10.0,
            "{p:?}"
        );
        assert!(p[0].warning().contains("140"));
    }
}
