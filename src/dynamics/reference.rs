//! Matching a reference modal model (measured or synthesized modes) to a
//! prepared model: which configuration its position is, and which sensor
//! row (with which sign) each of its DOFs corresponds to. GSA outputs and
//! the identification objective compare model and reference shapes on these
//! shared DOFs.

use super::PreparedModel;
use crate::modal::ModalModel;

/// How a reference's DOFs map onto a configuration's sensors.
#[derive(Clone, Debug, PartialEq)]
pub struct ReferenceMatch {
    /// Configuration index of the reference's position.
    pub config: usize,
    /// Per shared DOF: the model's sensor row and the sign (−1 when the
    /// reference measured the opposite direction).
    pub rows: Vec<(usize, f64)>,
    /// Index into the reference's DOFs of each shared DOF, parallel to `rows`.
    pub keep: Vec<usize>,
}

impl PreparedModel {
    /// Match `reference` to this model; an error says what does not fit.
    pub fn match_reference(&self, reference: &ModalModel) -> Result<ReferenceMatch, String> {
        let r = reference;
        let config = self
            .configurations
            .iter()
            .position(|c| c.position.index == r.position.index)
            .ok_or_else(|| {
                format!(
                    "reference position {} ({}) is not a configuration of the model, which has {}",
                    r.position.index,
                    r.position.label,
                    self.configurations.len()
                )
            })?;
        let mut rows = Vec::new();
        let mut keep = Vec::new();
        for (k, d) in r.dofs.iter().enumerate() {
            let found = self
                .sensors
                .iter()
                .position(|(_, s)| s.node == d.node && s.direction.abs() == d.direction.abs());
            if let Some(i) = found {
                let sign = if self.sensors[i].1.direction == d.direction {
                    1.0
                } else {
                    -1.0
                };
                rows.push((i, sign));
                keep.push(k);
            }
        }
        if rows.is_empty() {
            return Err(format!(
                "reference position {} shares no DOF with the model's sensors; check node numbers and directions",
                r.position.index
            ));
        }
        Ok(ReferenceMatch { config, rows, keep })
    }
}
