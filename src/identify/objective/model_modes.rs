//! The model's modes at the reference's DOFs: what the objective pairs
//! (the lowest modes, as many as the reference has plus spares) and what an
//! update reports (those, and with measured FRFs every mode up to the top of
//! their band).

use super::visibility::mask_invisible;
use super::{IdentifyError, ModalObjective};
use crate::dynamics::solve::ModeSelection;
use crate::modal::{ModalModel, Mode};
use num_complex::Complex64;

impl ModalObjective {
    /// Model modes of each reference position at `x`, at the shared DOFs in
    /// the reference's orientation.
    pub fn model_modes(&self, x: &[f64]) -> Result<Vec<ModalModel>, IdentifyError> {
        (0..self.references.len())
            .map(|p| self.model_modes_at(p, x))
            .collect()
    }

    /// Model modes of each reference position at `x` as [`Self::model_modes`]
    /// gives them, and beyond them every mode up to `top_hz` (the measured
    /// band's top): the updated model's prediction of modes the reference
    /// lacks, as a user reads it.
    pub fn model_modes_through(
        &self,
        x: &[f64],
        top_hz: f64,
    ) -> Result<Vec<ModalModel>, IdentifyError> {
        (0..self.references.len())
            .map(|p| {
                let below = self.modes_selected(p, x, ModeSelection::Below(top_hz))?;
                if below.modes.len() >= self.modes {
                    Ok(below)
                } else {
                    self.model_modes_at(p, x)
                }
            })
            .collect()
    }

    /// Model modes of position slot `p` alone (one eigensolution).
    pub fn model_modes_at(&self, p: usize, x: &[f64]) -> Result<ModalModel, IdentifyError> {
        self.modes_selected(p, x, ModeSelection::Lowest(self.modes))
    }

    fn modes_selected(
        &self,
        p: usize,
        x: &[f64],
        selection: ModeSelection,
    ) -> Result<ModalModel, IdentifyError> {
        let r = &self.references[p];
        let sol = self
            .prepared
            .evaluate_modes(r.config, x, selection)
            .map_err(|e| IdentifyError::Model(e.to_string()))?;
        let f = sol.frequencies_hz();
        let z = sol.damping_ratios();
        let mut modes: Vec<Mode> = (0..f.len())
            .map(|m| Mode {
                frequency_hz: f[m],
                damping_ratio: z[m],
                shape: r
                    .rows
                    .iter()
                    .map(|&(i, s, _)| Complex64::new(s * sol.sensor_shapes[(i, m)], 0.0))
                    .collect(),
            })
            .collect();
        mask_invisible(&mut modes);
        Ok(ModalModel {
            position: r.position.clone(),
            dofs: r.rows.iter().map(|row| row.2).collect(),
            modes,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dynamics::{Model, PreparedModel};
    use crate::identify::objective::Weights;
    use crate::pairing::Pairing;

    const BEAM: &str = include_str!("../../../pipelines/models/ufsc_beam.yaml");

    #[test]
    fn modes_through_a_band_add_the_modes_above_the_paired_ones() {
        let model = Model::from_yaml(BEAM, "ufsc_beam.yaml", &|p: &str| std::fs::read(p)).unwrap();
        let prepared = PreparedModel::new(&model).unwrap();
        let x: Vec<f64> = model.parameters.iter().map(|p| p.value).collect();
        // A reference of the model's own first two modes.
        let mut reference = prepared
            .modal_model(&prepared.evaluate(0, &x, 2).unwrap())
            .unwrap();
        reference.modes.truncate(2);
        let o = ModalObjective::new(
            &model,
            &[reference],
            None,
            Weights::default(),
            Pairing::within(0.3),
        )
        .unwrap();
        let paired = o.model_modes(&x).unwrap();
        let f: Vec<f64> = paired[0].modes.iter().map(|m| m.frequency_hz).collect();
        assert_eq!(f.len(), 2 + 4, "{f:?}");
        // Below the paired modes' top: the same modes.
        let same = o.model_modes_through(&x, f[5] * 0.99).unwrap();
        assert_eq!(same[0].modes.len(), f.len());
        // Through 790 Hz: every mode there, the paired ones first and equal.
        let band = o.model_modes_through(&x, 790.0).unwrap();
        let g: Vec<f64> = band[0].modes.iter().map(|m| m.frequency_hz).collect();
        assert!(g.len() > f.len() && *g.last().unwrap() <= 790.0, "{g:?}");
        for (a, b) in g.iter().zip(&f) {
            assert!((a / b - 1.0).abs() < 1e-9, "{a} {b}");
        }
    }
}
