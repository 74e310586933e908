//! The FRF matrix an estimator works on: the complete response × reference
//! channel matrix of one [`FrfSet`] inside a frequency band, with one weight
//! per output and line (the weighting of the PolyMAX equation error, Peeters
//! et al. 2004, eq. 6).

use super::EmaError;
use crate::frf::{Dof, FrfChannel, FrfSet};
use num_complex::Complex64;

/// How the equation error of each output and line is weighted.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Weighting {
    /// Every output scaled to unit mean power over the band, so outputs with
    /// small amplitudes count as much as the driving points.
    #[default]
    Uniform,
    /// As `Uniform`, times the inverse standard deviation implied by the
    /// coherence, σ²(H) ∝ |H|²(1 − γ²)/γ² (Bendat & Piersol); lines with poor
    /// coherence count less. Falls back to `Uniform` without coherence.
    Coherence,
}

/// FRFs of one configuration as a dense `outputs × references × lines` array.
#[derive(Clone, Debug, PartialEq)]
pub struct FrfData {
    pub frequencies_hz: Vec<f64>,
    pub responses: Vec<Dof>,
    pub references: Vec<Dof>,
    /// H[(o · n_ref + i) · n_lines + f].
    pub h: Vec<Complex64>,
    /// Weight per output and line, w[o · n_lines + f].
    pub weight: Vec<f64>,
    /// Whitening weight u(f) per line, common to all channels
    /// ([`super::whitening`]): when not all ones, `h` holds u·H and every
    /// model column must be multiplied by u as well.
    pub line_weight: Vec<f64>,
    /// Ordinary coherence γ² per channel and line, laid out as `h`; empty
    /// unless every channel carries it.
    pub coherence: Vec<f64>,
}

impl FrfData {
    pub fn n_out(&self) -> usize {
        self.responses.len()
    }
    pub fn n_ref(&self) -> usize {
        self.references.len()
    }
    pub fn n_lines(&self) -> usize {
        self.frequencies_hz.len()
    }

    /// The median spacing of the lines, Hz (0 with fewer than two lines).
    pub fn line_spacing_hz(&self) -> f64 {
        let mut steps: Vec<f64> = self
            .frequencies_hz
            .windows(2)
            .map(|w| w[1] - w[0])
            .collect();
        steps.sort_by(f64::total_cmp);
        steps.get(steps.len() / 2).copied().unwrap_or(0.0)
    }

    /// The FRF of output `o` and reference `i` over all lines.
    pub fn channel(&self, o: usize, i: usize) -> &[Complex64] {
        let nf = self.n_lines();
        let k = (o * self.n_ref() + i) * nf;
        &self.h[k..k + nf]
    }

    /// Build from arrays (`h` as documented on the field); weights uniform.
    pub fn from_parts(
        frequencies_hz: Vec<f64>,
        responses: Vec<Dof>,
        references: Vec<Dof>,
        h: Vec<Complex64>,
    ) -> Result<FrfData, EmaError> {
        let nf = frequencies_hz.len();
        if h.len() != responses.len() * references.len() * nf {
            return Err(EmaError::InvalidData(format!(
                "FRF array has {} values, expected {} outputs × {} references × {} lines",
                h.len(),
                responses.len(),
                references.len(),
                nf
            )));
        }
        let mut d = FrfData {
            frequencies_hz,
            responses,
            references,
            h,
            weight: Vec::new(),
            line_weight: vec![1.0; nf],
            coherence: Vec::new(),
        };
        d.weight = d.uniform_weights();
        d.check()?;
        Ok(d)
    }

    /// The channels of `set` with lines inside `band_hz` (inclusive; all
    /// lines when `None`). Every response must be measured for every
    /// reference; [`super::layout::frf_data`] also takes partial matrices
    /// and fits by reciprocity.
    pub fn from_set(
        set: &FrfSet,
        band_hz: Option<(f64, f64)>,
        weighting: Weighting,
    ) -> Result<FrfData, EmaError> {
        let responses = set.responses();
        let references = set.references();
        let mut channels = Vec::with_capacity(responses.len() * references.len());
        for &r in &responses {
            for &q in &references {
                channels.push(set.channel(r, q).ok_or_else(|| {
                    EmaError::InvalidData(format!(
                        "position {}: channel {r}/{q} is missing; PolyMAX needs every response measured for every reference (select a complete set with the import stage's `select`)",
                        set.position.index
                    ))
                })?);
            }
        }
        FrfData::from_channels(
            &set.frequencies_hz,
            band_hz,
            responses,
            references,
            &channels,
            weighting,
        )
    }

    /// Build from `channels[o · n_ref + i]`, the FRF of output `o` for
    /// reference `i`, keeping the lines inside `band_hz` (inclusive; all
    /// lines when `None`).
    pub(crate) fn from_channels(
        frequencies_hz: &[f64],
        band_hz: Option<(f64, f64)>,
        responses: Vec<Dof>,
        references: Vec<Dof>,
        channels: &[&FrfChannel],
        weighting: Weighting,
    ) -> Result<FrfData, EmaError> {
        let (lo, hi) = band_hz.unwrap_or((f64::NEG_INFINITY, f64::INFINITY));
        let lines: Vec<usize> = (0..frequencies_hz.len())
            .filter(|&f| (lo..=hi).contains(&frequencies_hz[f]))
            .collect();
        let nf = lines.len();
        let mut h = Vec::with_capacity(channels.len() * nf);
        for c in channels {
            h.extend(lines.iter().map(|&f| c.values[f]));
        }
        let mut d = FrfData {
            frequencies_hz: lines.iter().map(|&f| frequencies_hz[f]).collect(),
            responses,
            references,
            h,
            weight: Vec::new(),
            line_weight: vec![1.0; nf],
            coherence: Vec::new(),
        };
        if channels.len() != d.n_out() * d.n_ref() {
            return Err(EmaError::InvalidData(format!(
                "{} channels for {} outputs × {} references",
                channels.len(),
                d.n_out(),
                d.n_ref()
            )));
        }
        d.check()?;
        d.weight = d.uniform_weights();
        let coherence: Vec<&Vec<f64>> = channels
            .iter()
            .filter_map(|c| c.coherence.as_ref())
            .collect();
        if coherence.len() == channels.len() {
            d.coherence = coherence
                .iter()
                .flat_map(|g| lines.iter().map(move |&f| g[f]))
                .collect();
        }
        if weighting == Weighting::Coherence && coherence.len() == channels.len() {
            let n_ref = d.n_ref();
            for o in 0..d.n_out() {
                for (f, &line) in lines.iter().enumerate() {
                    // Mean relative variance over the references of this output.
                    let var: f64 = (0..n_ref)
                        .map(|i| {
                            let g = coherence[o * n_ref + i][line].clamp(1e-3, 1.0);
                            (1.0 - g) / g + 1e-4
                        })
                        .sum::<f64>()
                        / n_ref as f64;
                    d.weight[o * nf + f] /= var.sqrt();
                }
            }
        }
        Ok(d)
    }

    fn check(&self) -> Result<(), EmaError> {
        if self.n_out() == 0 || self.n_ref() == 0 {
            return Err(EmaError::InvalidData("no FRF channels to analyse".into()));
        }
        if self.n_lines() < 4 {
            return Err(EmaError::InvalidData(format!(
                "only {} frequency lines in the band; PolyMAX needs many more than the model order",
                self.n_lines()
            )));
        }
        if let Some(k) = self
            .h
            .iter()
            .position(|v| !v.re.is_finite() || !v.im.is_finite())
        {
            let nf = self.n_lines();
            return Err(EmaError::InvalidData(format!(
                "non-finite FRF value at {} Hz, channel {}/{}",
                self.frequencies_hz[k % nf],
                self.responses[k / nf / self.n_ref()],
                self.references[(k / nf) % self.n_ref()]
            )));
        }
        Ok(())
    }

    /// Whether `h` is whitened ([`FrfData::whiten`]).
    pub fn is_whitened(&self) -> bool {
        self.line_weight.iter().any(|&u| u != 1.0)
    }

    /// Whiten by the line weights `u` ([`super::whitening`]): h ← u·h, the
    /// per-output weights recomputed on the whitened data (the coherence
    /// weighting, a noise model of its own, is not combined with it).
    pub fn whiten(&mut self, u: Vec<f64>) {
        let nf = self.n_lines();
        assert_eq!(u.len(), nf, "one weight per line");
        for (k, v) in self.h.iter_mut().enumerate() {
            *v *= u[k % nf];
        }
        self.line_weight = u;
        self.weight = self.uniform_weights();
    }

    /// Undo the whitening on values laid out as `h` (a reconstruction).
    pub fn unwhiten(&self, values: &mut [Complex64]) {
        let nf = self.n_lines();
        for (k, v) in values.iter_mut().enumerate() {
            *v /= self.line_weight[k % nf];
        }
    }

    /// Undo the whitening on one value per line (a CMIF curve).
    pub fn unwhiten_lines(&self, values: &mut [f64]) {
        for (v, u) in values.iter_mut().zip(&self.line_weight) {
            *v /= u;
        }
    }

    /// Per-output weight 1/√(mean |H_o|²) over references and lines.
    fn uniform_weights(&self) -> Vec<f64> {
        let (nf, n_ref) = (self.n_lines(), self.n_ref());
        let mut w = Vec::with_capacity(self.n_out() * nf);
        for o in 0..self.n_out() {
            let p: f64 = (0..n_ref)
                .flat_map(|i| self.channel(o, i).iter())
                .map(Complex64::norm_sqr)
                .sum::<f64>()
                / (nf * n_ref) as f64;
            let s = if p > 0.0 { 1.0 / p.sqrt() } else { 1.0 };
            w.extend(std::iter::repeat_n(s, nf));
        }
        w
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ema::synthetic::{four_mode_system, lines, modal_superposition};

    #[test]
    fn uniform_weights_equalize_outputs_and_coherence_downweights_poor_lines() {
        let mut set = modal_superposition(
            &four_mode_system(),
            &[0, 3],
            &lines(20.0, 60.0, 1.0),
            0.0,
            1,
        );
        let nf = set.frequencies_hz.len();
        let d = FrfData::from_set(&set, Some((30.0, 50.0)), Weighting::Uniform).unwrap();
        assert_eq!(d.n_lines(), 21);
        assert_eq!((d.n_out(), d.n_ref()), (5, 2));
        for o in 0..d.n_out() {
            let w = d.weight[o * d.n_lines()];
            let p: f64 = (0..2)
                .flat_map(|i| d.channel(o, i))
                .map(|h| (h * w).norm_sqr())
                .sum::<f64>()
                / (2 * d.n_lines()) as f64;
            assert!(
                (p - 1.0).abs() < 1e-12,
                "output {o}: mean weighted power {p}"
            );
        }
        // Coherence 0.5 at the first line of every channel, 1 elsewhere.
        for c in &mut set.channels {
            let mut g = vec![1.0; nf];
            g[0] = 0.5;
            c.coherence = Some(g);
        }
        let u = FrfData::from_set(&set, None, Weighting::Uniform).unwrap();
        let w = FrfData::from_set(&set, None, Weighting::Coherence).unwrap();
        // (1 − γ²)/γ² = 1 at the poor line versus 1e-4 elsewhere: 100× weaker relative to its neighbours.
        let ratio = |d: &FrfData| d.weight[0] / d.weight[1];
        assert!((ratio(&u) - 1.0).abs() < 1e-15);
        assert!(
            (ratio(&w) - (1e-4f64 / (1.0 + 1e-4)).sqrt()).abs() < 1e-12,
            "{}",
            ratio(&w)
        );
    }
}
