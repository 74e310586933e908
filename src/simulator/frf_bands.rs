//! FRF conformity per frequency band (PUB2, seed section 5.2.1): for every
//! axis position and band, the FRAC (eq. 2.66) and CSF (eq. 2.67) of the
//! model's FRFs against reference FRFs, averaged over the channels the two
//! share. PUB2 ran its GSAs on exactly such outcomes (2 criteria × 3 positions
//! × 10 bands × 9 FRFs); averaging over channels keeps one output per
//! criterion, position and band.
//!
//! The reference is either measured/synthesized FRFs (an `frf` artifact:
//! lines inside each band are used as they are, channels matched to the
//! model's sensor × excitation pairs by node and axis; FRAC and CSF are
//! blind to a channel's sign, so a DOF measured in the opposite direction
//! needs no flip) or the model's own FRFs at its true parameter values on
//! an even grid. The model side is computed by modal superposition of the
//! evaluated modes ([`crate::dynamics::frf::superposition`]), so a band costs
//! lines × channels × modes complex products on top of the eigensolution.

use super::EvalError;
use crate::dynamics::reference::dof_row;
use crate::dynamics::{frf::superposition, ModalSolution, PreparedModel};
use crate::frf::{FrfQuantity, FrfSet};
use crate::metrics::{csf, frac};
use num_complex::Complex64;

/// Which bands, and where the reference FRFs come from.
#[derive(Clone, Debug, PartialEq)]
pub struct BandOptions {
    /// Frequency bands (low, high) in Hz, low < high, lines with low ≤ f ≤ high.
    pub bands: Vec<(f64, f64)>,
    /// Line spacing of the model's own reference FRFs (Hz), used when no
    /// reference FRFs are given.
    pub step: f64,
}

/// One band of one position: the lines and the reference values per channel.
struct Band {
    lines: Vec<f64>,
    /// Per matched channel: reference values on `lines`.
    reference: Vec<Vec<Complex64>>,
}

/// The reference FRFs of one position reduced to the channels and lines used.
struct PositionBands {
    position: u32,
    config: usize,
    quantity: FrfQuantity,
    /// Per matched channel: (sensor row, excitation row).
    pairs: Vec<(usize, usize)>,
    bands: Vec<Band>,
}

/// FRAC and CSF per position and band; outputs
/// `p{position}.band{b}.frac` and `p{position}.band{b}.csf` (b 1-based).
pub struct FrfBands {
    positions: Vec<PositionBands>,
}

fn check_bands(options: &BandOptions) -> Result<(), EvalError> {
    if options.bands.is_empty() {
        return Err(EvalError::Domain("no frequency bands given".into()));
    }
    for (i, &(lo, hi)) in options.bands.iter().enumerate() {
        if !(lo.is_finite() && hi.is_finite() && lo >= 0.0 && lo < hi) {
            return Err(EvalError::Domain(format!(
                "band {} [{lo}, {hi}] Hz: give 0 <= low < high, e.g. [10, 50]",
                i + 1
            )));
        }
    }
    Ok(())
}

impl FrfBands {
    /// Bands against the model's own FRFs at `true_values` (receptance, all
    /// sensor × excitation channels), for every configuration that
    /// `configs` names.
    pub fn from_model(
        prepared: &PreparedModel,
        true_values: &[f64],
        configs: &[usize],
        modes: usize,
        options: &BandOptions,
    ) -> Result<FrfBands, EvalError> {
        check_bands(options)?;
        if !(options.step > 0.0 && options.step.is_finite()) {
            return Err(EvalError::Domain(format!(
                "band line spacing {} Hz must be positive",
                options.step
            )));
        }
        let ne = prepared.excitations.len();
        let pairs: Vec<(usize, usize)> = (0..prepared.sensors.len())
            .flat_map(|j| (0..ne).map(move |k| (j, k)))
            .collect();
        let mut positions = Vec::new();
        for &config in configs {
            let sol = prepared
                .evaluate(config, true_values, modes)
                .map_err(|e| EvalError::Domain(e.to_string()))?;
            let bands = options
                .bands
                .iter()
                .map(|&(lo, hi)| {
                    let count = ((hi - lo) / options.step).floor() as usize + 1;
                    let lines: Vec<f64> =
                        (0..count).map(|i| lo + i as f64 * options.step).collect();
                    let reference =
                        superposition(&sol, FrfQuantity::Receptance, &lines, &pairs, None);
                    Band { lines, reference }
                })
                .collect();
            positions.push(PositionBands {
                position: prepared
                    .config(config)
                    .map_err(|e| EvalError::Domain(e.to_string()))?
                    .position
                    .index,
                config,
                quantity: FrfQuantity::Receptance,
                pairs: pairs.clone(),
                bands,
            });
        }
        Ok(FrfBands { positions })
    }

    /// Bands against reference FRF sets (one per position, matched to the
    /// model's configurations by position index).
    pub fn from_reference(
        prepared: &PreparedModel,
        reference: &[FrfSet],
        options: &BandOptions,
    ) -> Result<FrfBands, EvalError> {
        check_bands(options)?;
        let mut positions = Vec::new();
        for set in reference {
            let index = set.position.index;
            let config = prepared.config_of_position(index).ok_or_else(|| {
                EvalError::Domain(format!(
                    "reference FRFs of position {index} have no model configuration"
                ))
            })?;
            // FRAC and CSF compare magnitudes of correlations: the sign of a
            // channel does not enter, so only the rows are kept.
            let row = |dofs, d| dof_row(dofs, d).map(|(i, _)| i);
            let mut pairs = Vec::new();
            let mut channels = Vec::new();
            for (c, ch) in set.channels.iter().enumerate() {
                if let (Some(j), Some(k)) = (
                    row(&prepared.sensors, ch.response),
                    row(&prepared.excitations, ch.reference),
                ) {
                    pairs.push((j, k));
                    channels.push(c);
                }
            }
            if pairs.is_empty() {
                return Err(EvalError::Domain(format!(
                    "reference FRFs of position {index} share no channel with the model's sensors and excitations; check node numbers and directions"
                )));
            }
            let mut bands = Vec::new();
            for (b, &(lo, hi)) in options.bands.iter().enumerate() {
                let idx: Vec<usize> = (0..set.frequencies_hz.len())
                    .filter(|&i| (lo..=hi).contains(&set.frequencies_hz[i]))
                    .collect();
                if idx.len() < 2 {
                    return Err(EvalError::Domain(format!(
                        "band {} [{lo}, {hi}] Hz holds {} line(s) of the reference FRFs of position {index} ({} to {} Hz); widen the band",
                        b + 1,
                        idx.len(),
                        set.frequencies_hz.first().copied().unwrap_or(f64::NAN),
                        set.frequencies_hz.last().copied().unwrap_or(f64::NAN)
                    )));
                }
                bands.push(Band {
                    lines: idx.iter().map(|&i| set.frequencies_hz[i]).collect(),
                    reference: channels
                        .iter()
                        .map(|&c| idx.iter().map(|&i| set.channels[c].values[i]).collect())
                        .collect(),
                });
            }
            positions.push(PositionBands {
                position: index,
                config,
                quantity: set.quantity,
                pairs,
                bands,
            });
        }
        Ok(FrfBands { positions })
    }

    /// Output names, in the order [`FrfBands::criteria`] appends values.
    pub fn outputs(&self) -> Vec<String> {
        let mut out = Vec::new();
        for p in &self.positions {
            for b in 1..=p.bands.len() {
                out.push(format!("p{}.band{b}.frac", p.position));
                out.push(format!("p{}.band{b}.csf", p.position));
            }
        }
        out
    }

    /// Configurations to solve, one per position in output order.
    pub fn configs(&self) -> impl Iterator<Item = usize> + '_ {
        self.positions.iter().map(|p| p.config)
    }

    /// Append FRAC and CSF (channel means) of every band of position slot
    /// `slot` for the solution `sol` of its configuration.
    pub fn criteria(&self, slot: usize, sol: &ModalSolution, out: &mut Vec<f64>) {
        let p = &self.positions[slot];
        for band in &p.bands {
            let model = superposition(sol, p.quantity, &band.lines, &p.pairs, None);
            let n = model.len() as f64;
            let (mut fr, mut cs) = (0.0, 0.0);
            for (h, r) in model.iter().zip(&band.reference) {
                fr += frac(r, h);
                cs += csf(r, h);
            }
            out.push(fr / n);
            out.push(cs / n);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dynamics::Model as Dynamics;

    const TWO_MASS: &str = include_str!("../../tests/fixtures/models/two_mass.yaml");

    fn prepared() -> (PreparedModel, Vec<f64>) {
        let read = |p: &str| std::fs::read(p);
        let m = Dynamics::from_yaml(TWO_MASS, "two_mass.yaml", &read).expect("model");
        (PreparedModel::new(&m).expect("prepared"), m.true_values())
    }

    fn options() -> BandOptions {
        BandOptions {
            bands: vec![(50.0, 150.0), (150.0, 400.0)],
            step: 1.0,
        }
    }

    fn criteria(b: &FrfBands, p: &PreparedModel, x: &[f64]) -> Vec<f64> {
        let sol = p.evaluate(0, x, 2).expect("modes");
        let mut out = Vec::new();
        b.criteria(0, &sol, &mut out);
        out
    }

    #[test]
    fn own_reference_is_matched_exactly_and_a_stiffer_model_is_not() {
        let (p, x) = prepared();
        let b = FrfBands::from_model(&p, &x, &[0], 2, &options()).expect("bands");
        assert_eq!(
            b.outputs(),
            [
                "p0.band1.frac",
                "p0.band1.csf",
                "p0.band2.frac",
                "p0.band2.csf"
            ]
        );
        for v in criteria(&b, &p, &x) {
            assert!((v - 1.0).abs() < 1e-12, "{v}");
        }
        // Resonances move by √1.3: the bands that hold them lose conformity.
        let stiff: Vec<f64> = vec![1.3e6, 1.3e6, 20.0];
        let c = criteria(&b, &p, &stiff);
        assert!(c.iter().all(|v| *v < 0.9 && *v > 0.0), "{c:?}");
    }

    #[test]
    fn reference_sets_match_channels_by_dof_and_csf_sees_amplitude() {
        let (p, x) = prepared();
        let sol = p.evaluate(0, &x, 2).expect("modes");
        let lines: Vec<f64> = (0..=350).map(|i| 50.0 + i as f64).collect();
        let mut set = p
            .frf_superposition(&sol, FrfQuantity::Accelerance, &lines)
            .expect("frf");
        // Twice the amplitude, and the second sensor measured in −x (matched by
        // axis; FRAC and CSF do not see the sign).
        for ch in &mut set.channels {
            let flip = if ch.response.node == 2 { -1.0 } else { 1.0 };
            ch.response.direction *= flip as i8;
            for v in &mut ch.values {
                *v *= 2.0 * flip;
            }
        }
        let b = FrfBands::from_reference(&p, &[set], &options()).expect("bands");
        let c = criteria(&b, &p, &x);
        // FRAC ignores scale; CSF = 2·2/(1 + 4) = 0.8 (eq. 2.67).
        assert!(
            (c[0] - 1.0).abs() < 1e-12 && (c[2] - 1.0).abs() < 1e-12,
            "{c:?}"
        );
        assert!(
            (c[1] - 0.8).abs() < 1e-12 && (c[3] - 0.8).abs() < 1e-12,
            "{c:?}"
        );
    }

    #[test]
    fn bad_bands_are_named() {
        let (p, x) = prepared();
        let bad = BandOptions {
            bands: vec![(100.0, 50.0)],
            step: 1.0,
        };
        let e = FrfBands::from_model(&p, &x, &[0], 2, &bad)
            .err()
            .expect("error");
        assert!(e.to_string().contains("band 1"), "{e}");
    }
}
